//! (Over 900 lines: the vertex, its subpaths and the MIS weights read side by side with bdpt.glsl.)
//! Bidirectional path tracing (Veach 1997, ch. 10) on the CPU: subpaths of [`Vertex`]es from
//! the camera and from the emitters, every (s, t) connection and its MIS weight over all the
//! strategies that can make the path. Twin of `shaders/inc/bdpt.glsl`, same names.

// `!(x > 0.0)` rejects NaN along with the non-positive, on purpose, as the GLSL twin does.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use crate::bsdf::volume::{transmittance, volume_sigma};
use crate::bsdf::{ShadingFrame, TransportMode, VertexBsdf};
use crate::bvh::Ray;
use crate::cpu::path::emitted_radiance;
use crate::cpu::path::{sample_pair, RayCounts};
use crate::layout::{
    dim, FrameParams, GpuMaterial, ALPHA_CONNECT, ALPHA_LIGHT_WALK, LIGHT_DIRECTIONAL,
    LIGHT_ENTRY_PUNCTUAL, LIGHT_SPOT, MATERIAL_DOUBLE_SIDED, RR_ALBEDO, RR_OFF,
};
use crate::lights::{punctual_intensity, punctual_window, sample_light, spot_cos_outer};
use crate::mc::roulette_f32;
use crate::mis::Heuristic;
use crate::paths::{PathExpr, SYM_D, SYM_E, SYM_L, SYM_S};
use crate::render::Integrator;
use crate::render::PreparedScene;
use crate::sampling::{
    build_frame, offset_ray_origin, rng_uniform4, sample_cosine_hemisphere, sample_uniform_cone,
    sample_uniform_triangle, uniform_cone_pdf, ONE_MINUS_EPSILON,
};
use crate::spectrum::{material_at_wavelength, sample_wavelength_of, wavelength_weight};
use crate::surface::{alpha_key, surface_material, surface_normal, towards_eye, LOD_MAGNIFY};
use crate::texture::TextureData;
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// What a vertex is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// The pinhole (z₀).
    Camera,
    /// A point on an emitting triangle chosen as a light subpath's origin (y₀).
    AreaLight,
    /// A point or spot light (y₀): a delta in position.
    PointLight,
    /// A surface the subpath hit.
    Surface,
}

/// One vertex of a subpath, with what MIS needs: the area-measure densities of generating it
/// from its predecessor (`pdf_fwd`) and from its successor by the other subpath (`pdf_rev`).
#[derive(Clone, Copy, Debug)]
pub struct Vertex {
    pub kind: Kind,
    pub p: Vec3,
    /// Geometric normal of the front face (the view axis at the camera, the spot axis at a
    /// punctual light).
    pub ng: Vec3,
    pub ns: Vec3,
    /// The material with its textures resolved (the emission factor at light origins).
    pub mat: GpuMaterial,
    /// Unit direction towards the previous vertex of its subpath (zero at y₀ and z₀).
    pub wo: Vec3,
    /// Throughput of the subpath up to this vertex, its own scattering left out.
    pub beta: Vec3,
    pub pdf_fwd: f32,
    pub pdf_rev: f32,
    /// The subpath left this vertex along a delta lobe ("S").
    pub delta: bool,
    /// Triangle (surfaces, area lights) or punctual light index.
    pub index: u32,
}

impl Vertex {
    pub(crate) fn endpoint(
        kind: Kind,
        p: Vec3,
        ng: Vec3,
        beta: Vec3,
        pdf_fwd: f32,
        index: u32,
    ) -> Vertex {
        Vertex {
            kind,
            p,
            ng,
            ns: ng,
            mat: GpuMaterial::default(),
            wo: Vec3::ZERO,
            beta,
            pdf_fwd,
            pdf_rev: 0.0,
            delta: false,
            index,
        }
    }
    pub(crate) fn on_surface(&self) -> bool {
        matches!(self.kind, Kind::Surface | Kind::AreaLight)
    }
    /// |cos| of the vertex's side of an edge along `w` (the G term).
    pub(crate) fn cos(&self, w: Vec3) -> f32 {
        match self.kind {
            Kind::PointLight => 1.0,
            _ => self.ng.dot(w).abs(),
        }
    }
}

/// Path tracer-independent state of one render with `--integrator light|bdpt`.
pub struct Bidir<'a> {
    pub scene: &'a PreparedScene,
    pub frame: &'a FrameParams,
    pub(crate) textures: TextureData<'a>,
    pub integrator: Integrator,
    pub heuristic: Heuristic,
    pub paths: Option<&'a PathExpr>,
    /// A = 4 tan²(fov/2)·aspect.
    pub(crate) film_area: f32,
}

/// One path's contributions: to its own pixel, and splats (pixel, value) elsewhere.
#[derive(Default)]
pub struct Contributions {
    pub own: Vec3,
    pub splats: Vec<(u32, Vec3)>,
}

impl<'a> Bidir<'a> {
    /// The integrator, weighting and path expression `settings` ask for.
    pub fn from_settings(
        scene: &'a PreparedScene,
        frame: &'a FrameParams,
        settings: &'a crate::render::RenderSettings,
    ) -> Bidir<'a> {
        Bidir::new(
            scene,
            frame,
            settings.integrator,
            settings.mis,
            settings.paths.as_deref(),
        )
    }

    pub fn new(
        scene: &'a PreparedScene,
        frame: &'a FrameParams,
        integrator: Integrator,
        heuristic: Heuristic,
        paths: Option<&'a PathExpr>,
    ) -> Bidir<'a> {
        let t = frame.tan_half_fov_y;
        Bidir {
            scene,
            frame,
            textures: scene.texture_data(),
            integrator,
            heuristic,
            paths,
            film_area: 4.0 * t * t * frame.aspect,
        }
    }

    // --- the camera -------------------------------------------------------------------------

    /// Emitter table entry for `u`, its probability (the environment's share out), then a
    /// light vertex on it for `u_point` (and, double-sided, `u_side`): y₀ with β = 1/p(y₀).
    pub(crate) fn sample_light_vertex(
        &self,
        (pixel, sample): (u32, u32),
        u: f32,
        u_point: Vec2,
    ) -> Option<Vertex> {
        let scene = self.scene;
        let f = self.frame;
        if f.light_count == 0 {
            return None;
        }
        let keep = 1.0 - f.env_pmf;
        let entry = &scene.lights[sample_light(&scene.lights, u.min(ONE_MINUS_EPSILON))];
        let pmf = entry.pmf * keep;
        if !(pmf > 0.0) {
            return None;
        }
        if entry.triangle & LIGHT_ENTRY_PUNCTUAL != 0 {
            let index = entry.triangle & !LIGHT_ENTRY_PUNCTUAL;
            let light = &scene.punctual[index as usize];
            if light.kind == LIGHT_DIRECTIONAL {
                return None;
            }
            return Some(Vertex::endpoint(
                Kind::PointLight,
                Vec3::from(light.position),
                Vec3::from(light.direction),
                Vec3::splat(1.0 / pmf),
                pmf,
                index,
            ));
        }
        let tri = &scene.triangles[entry.triangle as usize];
        let b = sample_uniform_triangle(u_point);
        let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
        let y = Vec3::from(tri.p0) + b.x * e1 + b.y * e2;
        let n = e1.cross(e2).normalize();
        let key = alpha_key(f.seed, pixel, sample, ALPHA_CONNECT - 1, true);
        if !scene.present(&self.textures, entry.triangle, b.x, b.y, key, Vec3::ZERO) {
            return None;
        }
        let mat = scene
            .emitter_at(&self.textures, entry.triangle, b.x, b.y)
            .into_owned();
        let p_a = pmf / tri.area;
        let mut v = Vertex::endpoint(
            Kind::AreaLight,
            y,
            n,
            Vec3::splat(1.0 / p_a),
            p_a,
            entry.triangle,
        );
        v.mat = mat;
        Some(v)
    }

    /// Radiance (or intensity) leaving light vertex `v` along `w`, over a distance `dist` (the
    /// range window of punctual lights).
    pub(crate) fn emission(&self, v: &Vertex, w: Vec3, dist: f32) -> Vec3 {
        match v.kind {
            Kind::PointLight => {
                let light = &self.scene.punctual[v.index as usize];
                punctual_intensity(light, w) * punctual_window(light, dist)
            }
            _ => emitted_radiance(&v.mat, v.ng.dot(w)),
        }
    }

    /// Solid-angle pdf of the emission direction `w` from light vertex `v` (an emitting
    /// surface for s = 0: cosine-weighted on its emitting side, or both halves).
    pub(crate) fn emission_pdf(&self, v: &Vertex, w: Vec3) -> f32 {
        match v.kind {
            Kind::PointLight => {
                let light = &self.scene.punctual[v.index as usize];
                if light.kind == LIGHT_SPOT {
                    let cos_outer = spot_cos_outer(light);
                    if v.ng.dot(w) >= cos_outer {
                        uniform_cone_pdf(cos_outer)
                    } else {
                        0.0
                    }
                } else {
                    0.25 * FRAC_1_PI
                }
            }
            _ => {
                let cos = v.ng.dot(w);
                if v.mat.flags & MATERIAL_DOUBLE_SIDED != 0 {
                    0.5 * cos.abs() * FRAC_1_PI
                } else {
                    cos.max(0.0) * FRAC_1_PI
                }
            }
        }
    }

    /// The area density with which light subpaths start at surface vertex `v` (emitter hit by
    /// a camera subpath): the triangle's power share over its area.
    pub(crate) fn light_origin_pdf(&self, v: &Vertex) -> f32 {
        let tri = &self.scene.triangles[v.index as usize];
        (1.0 - self.frame.env_pmf) * tri.light_pmf / tri.area
    }

    // --- densities --------------------------------------------------------------------------

    /// A solid-angle pdf at `from` of the direction to `to`, as an area density at `to`.
    pub(crate) fn to_area(&self, pdf_dir: f32, from: Vec3, to: &Vertex) -> f32 {
        let d = to.p - from;
        let r2 = d.dot(d);
        if !(r2 > 0.0) {
            return 0.0;
        }
        let mut pdf = pdf_dir / r2;
        if to.on_surface() {
            pdf *= to.ng.dot(d).abs() / r2.sqrt();
        }
        pdf
    }

    /// Area density of sampling `next` from `v`, `v` having been reached from `prev` (surfaces:
    /// the BSDF seen from `prev`; endpoints: the camera's or the light's direction pdf).
    pub(crate) fn pdf(&self, v: &Vertex, prev: Option<&Vertex>, next: &Vertex) -> f32 {
        let w = (next.p - v.p).normalize();
        let pdf_dir = match v.kind {
            Kind::Camera => self.camera_importance(w).map_or(0.0, |(_, _, pdf)| pdf),
            Kind::AreaLight | Kind::PointLight => self.emission_pdf(v, w),
            Kind::Surface => {
                let Some(prev) = prev else { return 0.0 };
                match self.bsdf(v, (prev.p - v.p).normalize()) {
                    Some(frame) => frame.pdf(w),
                    None => 0.0,
                }
            }
        };
        self.to_area(pdf_dir, v.p, next)
    }

    pub(crate) fn bsdf(&self, v: &Vertex, w_cam: Vec3) -> Option<ShadingFrame> {
        ShadingFrame::new_shading(&v.mat, v.ng, v.ns, w_cam)
    }

    /// The surface the subpath's ray hits: its vertex with textures at level 0.
    pub(crate) fn surface_vertex(
        &self,
        hit: crate::bvh::Hit,
        instance: u32,
        ray: &Ray,
        beta: Vec3,
        lambda: f32,
    ) -> Vertex {
        let (sp, tri) = self.scene.hit_surface(&hit, instance);
        let raw = &self.scene.materials[tri.material_index() as usize];
        let mut mat = surface_material(&self.textures, raw, &sp, LOD_MAGNIFY);
        // KHR_materials_dispersion: n(λ) of the sample's wavelength (0: none).
        material_at_wavelength(&mut mat, lambda);
        Vertex {
            kind: Kind::Surface,
            p: sp.p,
            ng: sp.ng,
            ns: surface_normal(&self.textures, raw, &sp, LOD_MAGNIFY),
            mat,
            wo: -ray.dir,
            beta,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
            delta: false,
            index: hit.triangle,
        }
    }

    /// Extends `path` (whose last vertex emitted `ray` with solid-angle pdf `pdf_dir`, or a
    /// delta: `pdf_dir` < 0) until it has `max_vertices` vertices, leaves the scene or is
    /// stopped by Russian roulette. Camera subpaths (radiance) draw the path tracer's numbers.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn walk(
        &self,
        (pixel, sample): (u32, u32),
        mode: TransportMode,
        mut ray: Ray,
        mut beta: Vec3,
        mut pdf_dir: f32,
        path: &mut Vec<Vertex>,
        max_vertices: usize,
        counts: &mut RayCounts,
    ) {
        let f = self.frame;
        let beta_ref = beta.max_element();
        let camera = mode == TransportMode::Radiance;
        let lambda = self.wavelength(pixel, sample);
        while path.len() < max_vertices {
            let i = path.len() as u32;
            let bounce = i - 1;
            let alpha_depth = if camera {
                bounce
            } else {
                ALPHA_LIGHT_WALK + bounce
            };
            counts.extension += 1;
            let key = alpha_key(f.seed, pixel, sample, alpha_depth, false);
            let Some((hit, instance)) = self.scene.intersect_closest(&ray, 0.0, f32::MAX, key)
            else {
                return;
            };
            let prev = path[path.len() - 1];
            if i == 1 && prev.kind == Kind::PointLight {
                // The range window of a punctual light, now that the distance is known.
                beta *= punctual_window(&self.scene.punctual[prev.index as usize], hit.t);
            }
            let mut v = self.surface_vertex(hit, instance, &ray, beta, lambda);
            // KHR_materials_volume: the segment's attenuation, its medium read from either end.
            beta *= transmittance(
                vertex_sigma(&prev, ray.dir).max(vertex_sigma(&v, -ray.dir)),
                hit.t,
            );
            v.beta = beta;
            v.pdf_fwd = if pdf_dir < 0.0 {
                1.0
            } else {
                self.to_area(pdf_dir, prev.p, &v)
            };
            path.push(v);
            if path.len() >= max_vertices {
                return;
            }
            let Some(frame) = self.bsdf(&v, v.wo) else {
                return;
            };
            let (block, u_rr) = if camera {
                let b = dim::bounce_block(bounce) + 1;
                (
                    b,
                    rng_uniform4(f.seed, pixel, sample, dim::bounce_block(bounce)).w,
                )
            } else {
                let b = dim::light_block(i);
                (b, rng_uniform4(f.seed, pixel, sample, b).w)
            };
            let u = rng_uniform4(f.seed, pixel, sample, block);
            let u_dir = sample_pair(f, pixel, sample, 4 * block, Vec2::new(u.x, u.y));
            let Some(s) = frame.sample(u_dir.extend(u.z), mode) else {
                return;
            };
            let wi = s.wi;
            let last = path.len() - 1;
            if camera {
                beta *= s.weight;
            } else {
                // The adjoint with the shading-normal correction (module docs).
                let (cos_gi, cos_go) = (v.ng.dot(wi).abs(), v.ng.dot(v.wo).abs());
                if s.delta {
                    beta *=
                        s.weight * frame.cos_theta(v.wo) * cos_gi / (cos_go * frame.cos_theta(wi));
                } else {
                    beta *= self.phi(&v, wi, v.wo) * cos_gi / s.pdf;
                }
            }
            if s.delta {
                path[last].delta = true;
                path[last - 1].pdf_rev = 1.0;
                pdf_dir = -1.0;
            } else {
                pdf_dir = s.pdf;
                let back = self.bsdf(&v, wi).map_or(0.0, |fr| fr.pdf(v.wo));
                path[last - 1].pdf_rev = self.to_area(back, v.p, &path[last - 1]);
            }
            if !(beta.max_element() > 0.0) || !beta.is_finite() {
                return;
            }
            if bounce + 1 >= f.rr_start_depth && f.rr_mode != RR_OFF {
                let survive = if camera && f.rr_mode == RR_ALBEDO {
                    frame.albedo_estimate().min(1.0)
                } else if camera {
                    beta.max_element().min(1.0)
                } else {
                    (beta.max_element() / beta_ref).min(1.0)
                };
                match roulette_f32(u_rr, survive) {
                    Some(w) => beta *= w,
                    None => return,
                }
            }
            ray = Ray {
                origin: offset_ray_origin(v.p, if v.ng.dot(wi) > 0.0 { v.ng } else { -v.ng }),
                dir: wi,
            };
        }
    }

    /// The camera subpath of (pixel, sample): z₀ and up to `max_vertices` − 1 surfaces.
    pub(crate) fn camera_subpath(
        &self,
        key: (u32, u32),
        max_vertices: usize,
        path: &mut Vec<Vertex>,
        counts: &mut RayCounts,
    ) {
        let ray = crate::cpu::path::primary_ray(self.frame, key.0, key.1);
        path.clear();
        path.push(self.camera_vertex());
        let pdf_dir = self.camera_importance(ray.dir).map_or(0.0, |(_, _, p)| p);
        self.walk(
            key,
            TransportMode::Radiance,
            ray,
            Vec3::ONE,
            pdf_dir,
            path,
            max_vertices,
            counts,
        );
    }

    /// The light subpath of (pixel, sample): y₀ and up to `max_vertices` − 1 surfaces.
    pub(crate) fn light_subpath(
        &self,
        key: (u32, u32),
        max_vertices: usize,
        path: &mut Vec<Vertex>,
        counts: &mut RayCounts,
    ) {
        let f = self.frame;
        let (pixel, sample) = key;
        path.clear();
        let block = dim::light_block(0);
        let u = rng_uniform4(f.seed, pixel, sample, block);
        let u_point = sample_pair(f, pixel, sample, 4 * block + 1, Vec2::new(u.y, u.z));
        let Some(y0) = self.sample_light_vertex(key, u.x, u_point) else {
            return;
        };
        path.push(y0);
        if max_vertices <= 1 {
            return;
        }
        let ud = rng_uniform4(f.seed, pixel, sample, block + 1);
        let u_dir = sample_pair(f, pixel, sample, 4 * (block + 1), Vec2::new(ud.x, ud.y));
        // The emission direction: a uniform direction in a punctual light's cone, or
        // cosine-weighted on the emitting side (either side with probability ½ if both emit).
        let (dir, origin) = match y0.kind {
            Kind::PointLight => {
                let light = &self.scene.punctual[y0.index as usize];
                let cos_max = if light.kind == LIGHT_SPOT {
                    spot_cos_outer(light)
                } else {
                    -1.0
                };
                let local = sample_uniform_cone(u_dir, cos_max);
                let (t, b) = build_frame(y0.ng);
                (t * local.x + b * local.y + y0.ng * local.z, y0.p)
            }
            _ => {
                let side = if y0.mat.flags & MATERIAL_DOUBLE_SIDED != 0 && u.w < 0.5 {
                    -y0.ng
                } else {
                    y0.ng
                };
                let local = sample_cosine_hemisphere(u_dir);
                let (t, b) = build_frame(side);
                (
                    t * local.x + b * local.y + side * local.z,
                    offset_ray_origin(y0.p, side),
                )
            }
        };
        let pdf_dir = self.emission_pdf(&y0, dir);
        if !(pdf_dir > 0.0) {
            return;
        }
        // (A punctual light's range window waits for the first hit's distance: `walk`.)
        let le = match y0.kind {
            Kind::PointLight => punctual_intensity(&self.scene.punctual[y0.index as usize], dir),
            _ => self.emission(&y0, dir, 0.0),
        };
        let beta = y0.beta * le * (y0.cos(dir) / pdf_dir);
        if !(beta.max_element() > 0.0) {
            return;
        }
        self.walk(
            key,
            TransportMode::Importance,
            Ray { origin, dir },
            beta,
            pdf_dir,
            path,
            max_vertices,
            counts,
        );
    }

    // --- connections ------------------------------------------------------------------------

    /// KHR_materials_volume: the transmittance of the segment between two vertices, its medium
    /// read from either end (`volume::volume_sigma` of a surface or emitter's material; the
    /// camera and punctual lights lie in no volume).
    pub(crate) fn segment_transmittance(&self, a: &Vertex, b: &Vertex) -> Vec3 {
        let d = b.p - a.p;
        let dist = d.length();
        let w = d / dist;
        transmittance(vertex_sigma(a, w).max(vertex_sigma(b, -w)), dist)
    }

    /// Whether the segment between two vertices is free (the camera's near plane respected).
    pub(crate) fn visible(
        &self,
        a: &Vertex,
        b: &Vertex,
        key: (u32, u32, u32),
        counts: &mut RayCounts,
    ) -> bool {
        let f = self.frame;
        counts.shadow += 1;
        let d = b.p - a.p;
        let dist = d.length();
        let dir = d / dist;
        let origin = if a.kind == Kind::Surface || a.kind == Kind::AreaLight {
            offset_ray_origin(a.p, if a.ng.dot(dir) > 0.0 { a.ng } else { -a.ng })
        } else {
            a.p
        };
        let target = if b.kind == Kind::Surface || b.kind == Kind::AreaLight {
            offset_ray_origin(b.p, if b.ng.dot(-dir) > 0.0 { b.ng } else { -b.ng })
        } else if b.kind == Kind::Camera {
            // Camera rays start on the near plane.
            let cos = (-dir).dot(b.ng);
            b.p + (-dir) * (f.cam_znear / cos)
        } else {
            b.p
        };
        let seg = target - origin;
        let t_max = seg.length();
        if b.kind == Kind::Camera && (-dir).dot(b.ng) * dist <= f.cam_znear {
            return false;
        }
        let alpha = alpha_key(f.seed, key.0, key.1, ALPHA_CONNECT + key.2, true);
        // A join to the camera runs from the light vertex: towards the eye.
        let alpha = if b.kind == Kind::Camera {
            towards_eye(alpha)
        } else {
            alpha
        };
        !self.scene.intersect_any(
            &Ray {
                origin,
                dir: seg / t_max,
            },
            0.0,
            t_max,
            alpha,
        )
    }

    /// The path string of strategy (s, t), emitter-first, through the forward automaton.
    pub(crate) fn path_matches(
        &self,
        light: &[Vertex],
        camera: &[Vertex],
        s: usize,
        t: usize,
    ) -> bool {
        let Some(expr) = self.paths else {
            return true;
        };
        let dfa = &expr.forward;
        let sym = |v: &Vertex, connection: bool| {
            if !connection && v.delta {
                SYM_S
            } else {
                SYM_D
            }
        };
        let mut st = dfa.step(0, SYM_L);
        for (i, v) in light.iter().enumerate().take(s).skip(1) {
            st = dfa.step(st, sym(v, i == s - 1));
        }
        let first_camera = if s == 0 { t - 2 } else { t - 1 };
        for i in (1..=first_camera).rev() {
            st = dfa.step(st, sym(&camera[i], i == t - 1));
        }
        dfa.accepts(dfa.step(st, SYM_E))
    }

    /// The MIS weight of strategy (s, t) over all strategies that make the same path (Veach
    /// 1997, §10.2; the ratio recurrence of eq. 10.9), `sampled` standing in for y₀ when s = 1.
    pub fn mis_weight(
        &self,
        light: &[Vertex],
        camera: &[Vertex],
        sampled: Option<&Vertex>,
        s: usize,
        t: usize,
    ) -> f32 {
        if s + t == 2 {
            return 1.0;
        }
        let lv = |i: usize| -> &Vertex {
            match sampled {
                Some(v) if s == 1 && i == 0 => v,
                _ => &light[i],
            }
        };
        // The reverse densities of the four vertices beside the connection, for this path.
        let qs = (s > 0).then(|| lv(s - 1));
        let pt = (t > 0).then(|| &camera[t - 1]);
        let qs_minus = (s > 1).then(|| lv(s - 2));
        let pt_minus = (t > 1).then(|| &camera[t - 2]);
        let pt_rev = match (qs, pt) {
            (Some(qs), Some(pt)) => self.pdf(qs, qs_minus, pt),
            (None, Some(pt)) => self.light_origin_pdf(pt),
            _ => 0.0,
        };
        let pt_minus_rev = match (qs, pt, pt_minus) {
            (Some(qs), Some(pt), Some(ptm)) => self.pdf(pt, Some(qs), ptm),
            (None, Some(pt), Some(ptm)) => {
                let w = (ptm.p - pt.p).normalize();
                let light = Vertex {
                    kind: Kind::AreaLight,
                    ..*pt
                };
                self.to_area(self.emission_pdf(&light, w), pt.p, ptm)
            }
            _ => 0.0,
        };
        let qs_rev = match (qs, pt) {
            (Some(qs), Some(pt)) => self.pdf(pt, pt_minus, qs),
            _ => 0.0,
        };
        let qs_minus_rev = match (qs, pt, qs_minus) {
            (Some(qs), Some(pt), Some(qsm)) => self.pdf(qs, Some(pt), qsm),
            _ => 0.0,
        };

        let mut sum = 0.0f32;
        let mut others = 0u32;
        let mut beaten = false;
        let mut add = |r: f32, more_light_vertices: bool| match self.heuristic {
            Heuristic::Power(beta) => sum += r.powf(beta),
            Heuristic::Balance => sum += r,
            Heuristic::Average => others += u32::from(r > 0.0),
            Heuristic::Maximum => {
                // Ties go to the strategy with fewer light vertices.
                beaten |= if more_light_vertices {
                    r > 1.0
                } else {
                    r >= 1.0
                }
            }
            Heuristic::LightOnly | Heuristic::BsdfOnly => {}
        };
        let ratio = |rev: f32, fwd: f32| if fwd > 0.0 { rev / fwd } else { 0.0 };
        // Strategies with more light vertices: move the connection towards the camera.
        let mut r = 1.0;
        for i in (1..t).rev() {
            let rev = if i == t - 1 {
                pt_rev
            } else if i + 2 == t {
                pt_minus_rev
            } else {
                camera[i].pdf_rev
            };
            r *= ratio(rev, camera[i].pdf_fwd);
            let delta_here = i != t - 1 && camera[i].delta;
            let delta_before = i - 1 != t - 1 && camera[i - 1].delta;
            if !delta_here && !delta_before {
                add(r, true);
            }
        }
        // Strategies with fewer light vertices.
        let mut r = 1.0;
        for i in (0..s).rev() {
            let v = lv(i);
            let rev = if i == s - 1 {
                qs_rev
            } else if i + 2 == s {
                qs_minus_rev
            } else {
                v.pdf_rev
            };
            r *= ratio(rev, v.pdf_fwd);
            let delta_here = i != s - 1 && v.delta;
            let delta_before = if i > 0 {
                i - 1 != s - 1 && lv(i - 1).delta
            } else {
                lv(0).kind == Kind::PointLight
            };
            if !delta_here && !delta_before {
                add(r, false);
            }
        }
        match self.heuristic {
            Heuristic::Power(_) | Heuristic::Balance => 1.0 / (1.0 + sum),
            Heuristic::Average => 1.0 / (1.0 + others as f32),
            Heuristic::Maximum => {
                if beaten {
                    0.0
                } else {
                    1.0
                }
            }
            Heuristic::LightOnly | Heuristic::BsdfOnly => 1.0,
        }
    }

    /// The unweighted contribution of strategy (s, t) and, for t = 1, the pixel it lands in;
    /// for s = 1 the light vertex sampled afresh at the camera vertex.
    pub(crate) fn connect(
        &self,
        key: (u32, u32),
        light: &[Vertex],
        camera: &[Vertex],
        s: usize,
        t: usize,
        counts: &mut RayCounts,
    ) -> Option<(Vec3, Option<u32>, Option<Vertex>)> {
        let f = self.frame;
        let conn = (key.0, key.1, (s * 64 + t) as u32);
        if s == 0 {
            // The camera subpath found an emitter.
            let pt = &camera[t - 1];
            let le = emitted_radiance(&pt.mat, pt.ng.dot(pt.wo));
            return Some((pt.beta * le, None, None));
        }
        if t == 1 {
            let qs = &light[s - 1];
            if qs.kind == Kind::Surface && !self.connectible(qs) {
                return None;
            }
            let z0 = &camera[0];
            let d = z0.p - qs.p;
            let dist = d.length();
            let w = d / dist;
            let (pixel, we, _) = self.camera_importance(-w)?;
            if qs.kind == Kind::Surface && !self.camera_sees(qs, w) {
                return None;
            }
            let value = if qs.kind == Kind::Surface {
                self.phi(qs, w, qs.wo)
            } else {
                self.emission(qs, w, dist)
            };
            let g = qs.cos(w) * z0.cos(w) / (dist * dist);
            let c = qs.beta * value * (g * we) * self.segment_transmittance(qs, z0);
            if !(c.max_element() > 0.0) || !self.visible(qs, z0, conn, counts) {
                return None;
            }
            return Some((c, Some(pixel), None));
        }
        let pt = &camera[t - 1];
        if !self.connectible(pt) {
            return None;
        }
        let (qs, sampled) = if s == 1 {
            // A fresh light vertex for this camera vertex (next event estimation).
            let block = dim::bounce_block(t as u32 - 2);
            let u = rng_uniform4(f.seed, key.0, key.1, block);
            let u_point = sample_pair(f, key.0, key.1, 4 * block + 1, Vec2::new(u.y, u.z));
            let y = self.sample_light_vertex(key, u.x, u_point)?;
            (y, Some(y))
        } else {
            let qs = light[s - 1];
            if !self.connectible(&qs) {
                return None;
            }
            (qs, None)
        };
        let d = qs.p - pt.p;
        let dist = d.length();
        let w = d / dist;
        let at_light = if qs.kind == Kind::Surface {
            self.phi(&qs, -w, qs.wo)
        } else {
            self.emission(&qs, -w, dist)
        };
        let g = qs.cos(w) * pt.cos(w) / (dist * dist);
        let c = qs.beta
            * at_light
            * self.phi(pt, pt.wo, w)
            * pt.beta
            * g
            * self.segment_transmittance(pt, &qs);
        if !(c.max_element() > 0.0) || !c.is_finite() || !self.visible(pt, &qs, conn, counts) {
            return None;
        }
        Some((c, None, sampled))
    }

    /// The wavelength sample (`pixel`, `sample`) carries where the scene has a dispersive
    /// material (`FrameParams::spectral`), else 0: one for both subpaths (`spectrum`'s module
    /// docs).
    pub(crate) fn wavelength(&self, pixel: u32, sample: u32) -> f32 {
        if self.frame.spectral != 0 {
            sample_wavelength_of(self.frame.seed, pixel, sample)
        } else {
            0.0
        }
    }

    /// Every contribution of sample `sample` of `pixel`: its light subpath's splats and, for
    /// BDPT, its camera subpath's strategies. `strategies` receives (s, t, weighted, pixel) of
    /// each nonzero strategy when given. A spectral sample's contributions carry its
    /// wavelength's weight r(λ)/p(λ) once.
    pub fn sample(
        &self,
        pixel: u32,
        sample: u32,
        scratch: &mut (Vec<Vertex>, Vec<Vertex>),
        counts: &mut RayCounts,
        mut strategies: Option<&mut Vec<Strategy>>,
    ) -> Contributions {
        let first = strategies.as_deref().map_or(0, Vec::len);
        let mut out = self.sample_rgb(pixel, sample, scratch, counts, strategies.as_deref_mut());
        let lambda = self.wavelength(pixel, sample);
        if lambda > 0.0 {
            let w = wavelength_weight(lambda);
            out.own *= w;
            for (_, c) in &mut out.splats {
                *c *= w;
            }
            if let Some(list) = strategies {
                for entry in &mut list[first..] {
                    entry.2 *= w;
                    entry.3 *= w;
                }
            }
        }
        out
    }

    /// [`Bidir::sample`] before the wavelength's weight.
    pub(crate) fn sample_rgb(
        &self,
        pixel: u32,
        sample: u32,
        scratch: &mut (Vec<Vertex>, Vec<Vertex>),
        counts: &mut RayCounts,
        mut strategies: Option<&mut Vec<Strategy>>,
    ) -> Contributions {
        let f = self.frame;
        let key = (pixel, sample);
        let max_depth = f.max_depth as usize;
        let (light, camera) = scratch;
        let mut out = Contributions::default();
        self.light_subpath(key, max_depth + 1, light, counts);
        if self.integrator == Integrator::Light {
            camera.clear();
            camera.push(self.camera_vertex());
            for s in 1..=light.len() {
                // A point or spot light is not seen directly: camera rays cannot hit a point,
                // and no integrator may show what the path tracer cannot (BDPT leaves out
                // (1, 1) altogether).
                if s == 1 && light[0].kind == Kind::PointLight {
                    continue;
                }
                if !self.path_matches(light, camera, s, 1) {
                    continue;
                }
                if let Some((c, Some(p), _)) = self.connect(key, light, camera, s, 1, counts) {
                    out.splats.push((p, c));
                    if let Some(list) = strategies.as_deref_mut() {
                        list.push((s, 1, c, c, p));
                    }
                }
            }
            return out;
        }
        self.camera_subpath(key, max_depth + 2, camera, counts);
        for t in 1..=camera.len() {
            // (s = 1 samples its light vertex afresh, so it runs even without a light subpath.)
            for s in 0..=light.len().max(1) {
                let depth = s + t;
                // (1, 1) is left to (0, 2), emitters seen directly, as pbrt-v3 does: one
                // strategy for paths of no scattering, weight 1.
                if depth < 2 || depth - 2 > max_depth || (s == 0 && t < 2) || (s == 1 && t == 1) {
                    continue;
                }
                if s == 0 && Vec3::from(camera[t - 1].mat.emission).max_element() <= 0.0 {
                    continue;
                }
                if !self.path_matches(light, camera, s, t) {
                    continue;
                }
                let Some((c, splat, sampled)) = self.connect(key, light, camera, s, t, counts)
                else {
                    continue;
                };
                if !(c.max_element() > 0.0) {
                    continue;
                }
                let w = self.mis_weight(light, camera, sampled.as_ref(), s, t);
                let weighted = c * w;
                match splat {
                    Some(p) => out.splats.push((p, weighted)),
                    None => out.own += weighted,
                }
                if let Some(list) = strategies.as_deref_mut() {
                    list.push((s, t, weighted, c, splat.unwrap_or(pixel)));
                }
            }
        }
        out
    }
}

/// The attenuation coefficient of the medium direction `w` enters at vertex `v`
/// (`volume::volume_sigma` at a surface or an emitting triangle; 0 elsewhere).
fn vertex_sigma(v: &Vertex, w: Vec3) -> Vec3 {
    match v.kind {
        Kind::Surface | Kind::AreaLight => volume_sigma(&v.mat, v.ng, w),
        _ => Vec3::ZERO,
    }
}

/// One strategy's contribution: (s, t, weighted, unweighted, pixel).
pub type Strategy = (usize, usize, Vec3, Vec3, u32);
