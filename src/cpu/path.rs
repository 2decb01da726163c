//! One path, vertex by vertex: the twin of `generate.comp`, `shade.comp` and `connect.comp`
//! (and of the helpers in `shaders/inc/scene.glsl`), with the same names and the same order of
//! random numbers, so that a disagreement between the two integrators points at one stage.

use crate::bsdf::volume::{transmittance, volume_sigma};
use crate::bsdf::{fresnel_coat, ShadingFrame, TransportMode, VertexBsdf};
use crate::bvh::Ray;
use crate::layout::LIGHT_SAMPLER_BVH;
use crate::layout::{
    dim, FrameParams, GpuMaterial, PathState, AOV_ALPHA, AOV_BASE_COLOR, AOV_DEPTH, AOV_INSTANCE,
    AOV_MATERIAL, AOV_NORMAL, AOV_POSITION, AOV_RADIANCE, AOV_UV, DEBUG_NO_NEE, FLAG_PIXEL_CENTRE,
    FLAG_TRANSPARENT_BACKGROUND, LIGHT_ENTRY_PUNCTUAL, MATERIAL_DOUBLE_SIDED, MATERIAL_TEXTURED,
    MATERIAL_UNLIT, RR_ALBEDO, RR_OFF, SAMPLER_STRATIFIED,
};
use crate::lights::environment::{env_pdf, env_radiance, env_sample, EnvironmentMap};
use crate::lights::light_bvh::{light_bvh_pmf, light_bvh_sample};
use crate::lights::{punctual_incident, sample_light};
use crate::mc::roulette_f32;
use crate::mis::{mis_weight2, MIS_BSDF_ONLY};
use crate::paths::{Dfa, SYM_D, SYM_E, SYM_L, SYM_S};
use crate::render::PreparedScene;
use crate::sampling::{
    offset_ray_origin, rng_uniform4, sample_uniform_triangle, stratify2, ONE_MINUS_EPSILON,
};
use crate::scene::camera_ray;
use crate::spectrum::{
    is_dispersive, material_at_wavelength, sample_wavelength_of, wavelength_weight,
};
use crate::surface::{
    alpha_key, material_is_constant, sample_footprint_levels, surface_lod_base, surface_material,
    surface_normal,
};
use glam::{Vec2, Vec3};

/// Extension and shadow rays traced.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounts {
    pub extension: u64,
    pub shadow: u64,
}

impl RayCounts {
    pub fn merged(&self, other: &RayCounts) -> RayCounts {
        RayCounts {
            extension: self.extension + other.extension,
            shadow: self.shadow + other.shadow,
        }
    }
}

/// Pixel and sample of path `i` of a batch (`scene.glsl`; see `DispatchParams`). The batch's
/// paths go round the band's pixels in order or, in a pass of an adaptive render
/// (`frame.active_pixel_count` > 0), round the first `active_pixel_count` entries of
/// `active_pixels` (band-local pixel indices, every one of which has had the same number of
/// samples, so sample = the pass's first sample + the round).
pub fn path_pixel_sample(
    frame: &FrameParams,
    active_pixels: &[u32],
    first_sample: u32,
    first_pixel: u32,
    i: u32,
) -> (u32, u32) {
    let local_index = first_pixel + i;
    if frame.active_pixel_count == 0 {
        (
            frame.band_first_pixel + local_index % frame.band_pixel_count,
            first_sample + local_index / frame.band_pixel_count,
        )
    } else {
        (
            frame.band_first_pixel
                + active_pixels[(local_index % frame.active_pixel_count) as usize],
            first_sample + local_index / frame.active_pixel_count,
        )
    }
}

/// The pair (u.x, u.y) of dimension `dimension` (block · 4 + first component) of a path's
/// sample, as the frame's sampler places it over the pixel's samples: N-rooks stratified,
/// Owen-scrambled Sobol, or `u` itself (independent) (scene.glsl).
pub fn sample_pair(frame: &FrameParams, pixel: u32, sample: u32, dimension: u32, u: Vec2) -> Vec2 {
    match frame.sampler_mode {
        SAMPLER_STRATIFIED => stratify2(frame.seed, pixel, sample, frame.spp, dimension, u),
        crate::layout::SAMPLER_SOBOL => {
            crate::sobol::sobol_pair(frame.seed, pixel, sample, dimension)
        }
        _ => u,
    }
}

/// Radiance leaving material `m` towards a direction with cosine `cos_out` to the front-face
/// normal: one-sided unless the material is double-sided, darkened by a clear coat
/// ([`coat_emission_weight`]).
pub fn emitted_radiance(m: &GpuMaterial, cos_out: f32) -> Vec3 {
    let visible = cos_out > 0.0 || (m.flags & MATERIAL_DOUBLE_SIDED != 0 && cos_out < 0.0);
    if visible {
        Vec3::from(m.emission) * coat_emission_weight(m, cos_out)
    } else {
        Vec3::ZERO
    }
}

/// KHR_materials_clearcoat: "the emission is darkened by the Fresnel term" of the coat above it,
/// emission · (1 − clearcoat · F_c); F_c ([`fresnel_coat`]) is taken on the angle to the
/// front-face normal (emitters are sampled as flat triangles; the coat's normal map is not read
/// for them). 1 without a coat and for unlit materials.
pub fn coat_emission_weight(m: &GpuMaterial, cos_out: f32) -> f32 {
    if m.clearcoat <= 0.0 || m.flags & MATERIAL_UNLIT != 0 {
        return 1.0;
    }
    1.0 - m.clearcoat * fresnel_coat(cos_out)
}

/// Where a path stands in the `--paths` automaton (read eye-first); accepts everything
/// without one.
pub struct Classifier<'a> {
    dfa: Option<&'a Dfa>,
    state: u32,
}

impl Classifier<'_> {
    fn step(&mut self, symbol: u32) {
        if let Some(d) = self.dfa {
            self.state = d.step(self.state, symbol);
        }
    }
    /// Whether the path so far, then `symbols`, then an emitter (L), is accepted.
    fn ends_here(&self, symbols: &[u32]) -> bool {
        match self.dfa {
            None => true,
            Some(d) => {
                let s = symbols.iter().fold(self.state, |s, &x| d.step(s, x));
                d.accepts(d.step(s, SYM_L))
            }
        }
    }
}

/// A shadow ray and the contribution it carries if unoccluded.
struct ShadowRay {
    ray: Ray,
    t_max: f32,
    contribution: Vec3,
}

/// The camera ray of path (pixel, sample): the pixel jitter and lens point from the camera block
/// (generate.comp).
pub fn primary_ray(frame: &FrameParams, pixel: u32, sample: u32) -> Ray {
    let u = rng_uniform4(frame.seed, pixel, sample, dim::CAMERA_BLOCK);
    let jitter = sample_pair(
        frame,
        pixel,
        sample,
        4 * dim::CAMERA_BLOCK,
        Vec2::new(u.x, u.y),
    );
    // The lens's pair only where a thin lens reads it (`camera_ray`); a pinhole ignores it.
    let lens_u = if frame.lens_radius > 0.0 {
        sample_pair(
            frame,
            pixel,
            sample,
            4 * dim::CAMERA_BLOCK + 2,
            Vec2::new(u.z, u.w),
        )
    } else {
        Vec2::new(u.z, u.w)
    };
    // AOV layers that must not be averaged: the pixel's centre, the lens's centre.
    if frame.debug_flags & FLAG_PIXEL_CENTRE != 0 {
        return camera_ray(frame, pixel, Vec2::splat(0.5), Vec2::splat(0.5));
    }
    camera_ray(frame, pixel, jitter, lens_u)
}

/// The radiance estimate of one path (pixel, sample): generate, then extend → shade → connect
/// until the path ends.
pub fn trace_path(
    scene: &PreparedScene,
    frame: &FrameParams,
    env: &EnvironmentMap,
    pixel: u32,
    sample: u32,
    counts: &mut RayCounts,
) -> Vec3 {
    trace_path_matching(scene, frame, env, pixel, sample, counts, None)
}

/// [`trace_path`] keeping only the contributions of paths that `paths` accepts (`--paths`):
/// the automaton reads the path eye-first — E, then each vertex as D or S by the lobe that
/// left it, and L at the emitter (a vertex that samples an emitter is D).
pub fn trace_path_matching(
    scene: &PreparedScene,
    frame: &FrameParams,
    env: &EnvironmentMap,
    pixel: u32,
    sample: u32,
    counts: &mut RayCounts,
    paths: Option<&Dfa>,
) -> Vec3 {
    // generate
    let mut ray = primary_ray(frame, pixel, sample);
    let mut state = PathState {
        throughput: [1.0; 3],
        prev_specular: 1,
        cone_width: frame.cone_width,
        ..Default::default()
    };
    let mut class = Classifier {
        dfa: paths,
        state: paths.map_or(0, |d| d.step(0, SYM_E)),
    };
    let mut depth = 0;
    loop {
        // extend
        counts.extension += 1;
        let key = alpha_key(frame.seed, pixel, sample, depth, false);
        let hit = scene.intersect_closest(&ray, 0.0, f32::MAX, key);
        let (next, shadow) = shade(
            scene, frame, env, pixel, sample, depth, &ray, hit, &mut state, &mut class,
        );
        // connect
        if let Some(s) = shadow {
            counts.shadow += 1;
            let key = alpha_key(frame.seed, pixel, sample, depth, true);
            if !scene.intersect_any(&s.ray, 0.0, s.t_max, key) {
                state.radiance = (Vec3::from(state.radiance) + s.contribution).to_array();
            }
        }
        match next {
            Some(r) => ray = r,
            None => return Vec3::from(state.radiance),
        }
        depth += 1;
    }
}

/// One vertex of the path (shade.comp): MIS-weighted emission, one emitter sample, the BSDF
/// sample of the continuation ray, Russian roulette.
#[allow(clippy::too_many_arguments)]
fn shade(
    scene: &PreparedScene,
    frame: &FrameParams,
    env: &EnvironmentMap,
    pixel: u32,
    sample: u32,
    depth: u32,
    ray: &Ray,
    hit: Option<(crate::bvh::Hit, u32)>,
    state: &mut PathState,
    class: &mut Classifier,
) -> (Option<Ray>, Option<ShadowRay>) {
    let wo = -ray.dir;
    let mut throughput = Vec3::from(state.throughput);
    let mut radiance = Vec3::from(state.radiance);

    // Escaped: the environment's radiance, weighted against sampling the environment from the
    // previous vertex (a ray that leaves into a volume and escapes crossed an infinite medium).
    let Some((hit, instance)) = hit else {
        if scene.attenuates {
            throughput *= transmittance(Vec3::from(state.medium), f32::MAX);
        }
        // --transparent: a camera ray that escapes sees nothing (alpha 0 there).
        let hidden = depth == 0 && frame.debug_flags & FLAG_TRANSPARENT_BACKGROUND != 0;
        if frame.aov == AOV_RADIANCE && frame.env_width > 0 && !hidden && class.ends_here(&[]) {
            let le = env_radiance(env, frame, ray.dir);
            let mut w = 1.0;
            if state.prev_specular == 0 {
                let light_pdf = frame.env_pmf * env_pdf(env, frame, ray.dir);
                w = mis_weight2(
                    frame.mis_heuristic,
                    frame.mis_beta,
                    state.prev_bsdf_pdf,
                    light_pdf,
                    false,
                );
            }
            state.radiance = (radiance + throughput * w * le).to_array();
        }
        return (None, None);
    };
    let (sp, tri) = scene.hit_surface(&hit, instance);
    let textures = scene.texture_data();
    let (p, ng) = (sp.p, sp.ng);
    let cos_out = ng.dot(wo);
    // The ray cone's width at the hit sets the textures' level of detail.
    let cone_width = state.cone_width + frame.cone_spread * hit.t;
    state.cone_width = cone_width;
    let raw = &scene.materials[tri.material_index() as usize];
    // KHR_materials_volume: the segment's attenuation, its medium read from either end (1
    // where no material attenuates: the medium stays 0).
    if scene.attenuates {
        let sigma = Vec3::from(state.medium).max(volume_sigma(raw, ng, wo));
        throughput *= transmittance(sigma, hit.t);
    }
    state.throughput = throughput.to_array();
    let lod = if raw.flags & MATERIAL_TEXTURED != 0 {
        // The footprint of this sample's stratum of the pixel, not the whole pixel's.
        let finer = sample_footprint_levels(sample);
        surface_lod_base(&sp, cone_width, cos_out).map(|l| l - finer)
    } else {
        [0.0; 2]
    };
    // A material without textures, anisotropy or vertex colours here is its own factors
    // (`surface_material` would return a copy of them).
    let (surface, dispersed);
    let mut mat = if material_is_constant(raw, &sp) {
        raw
    } else {
        surface = surface_material(&textures, raw, &sp, lod);
        &surface
    };
    // --aov: a property of the first hit instead of radiance.
    if frame.aov != AOV_RADIANCE {
        let value = match frame.aov {
            AOV_BASE_COLOR => Vec3::from(mat.base_color),
            AOV_NORMAL => surface_normal(&textures, raw, &sp, lod),
            AOV_UV => sp.uv[0].extend(0.0),
            // The camera ray starts on the near plane: its distance from the eye (the lens
            // point; an orthographic camera's film plane) is added back.
            AOV_DEPTH => {
                Vec3::splat(hit.t + frame.cam_znear / ray.dir.dot(Vec3::from(frame.cam_forward)))
            }
            AOV_POSITION => p,
            AOV_MATERIAL => Vec3::splat((tri.material_index() + 1) as f32),
            AOV_INSTANCE => Vec3::splat((scene.instances[instance as usize].placement + 1) as f32),
            AOV_ALPHA => Vec3::ONE,
            _ => Vec3::from(mat.emission),
        };
        state.radiance = value.to_array();
        return (None, None);
    }

    // Direct emission, weighted against emitter sampling from the previous vertex.
    let le = emitted_radiance(mat, cos_out);
    if le.max_element() > 0.0 && class.ends_here(&[]) {
        let mut w = 1.0;
        if state.prev_specular == 0 {
            let pmf = triangle_light_pmf(scene, frame, tri, hit.triangle, state);
            let light_pdf =
                pmf * (1.0 - frame.env_pmf) * hit.t * hit.t / (cos_out.abs() * tri.area);
            w = mis_weight2(
                frame.mis_heuristic,
                frame.mis_beta,
                state.prev_bsdf_pdf,
                light_pdf,
                false,
            );
        }
        radiance += throughput * w * le;
    }
    state.radiance = radiance.to_array();
    if depth >= frame.max_depth {
        return (None, None);
    }
    // KHR_materials_dispersion: the path turns spectral at its first dispersive vertex, before
    // the vertex's emitter sample (`spectrum`'s module docs).
    if frame.spectral != 0 && is_dispersive(mat) {
        if state.wavelength == 0.0 {
            let lambda = sample_wavelength_of(frame.seed, pixel, sample);
            throughput *= wavelength_weight(lambda);
            state.wavelength = lambda;
        }
        let mut m = *mat;
        material_at_wavelength(&mut m, state.wavelength);
        dispersed = m;
        mat = &dispersed;
    }
    // The material seen from wo, once for every BSDF query of this vertex; none where wo grazes
    // the surface exactly (nothing scatters along it). A plain diffuse material's is a
    // LambertFrame, whose eval, pdf and sample give the general frame's floats.
    let ns = surface_normal(&textures, raw, &sp, lod);
    let vertex = Vertex {
        scene,
        frame,
        env,
        key: (pixel, sample, depth),
        p,
        ng,
        mat,
    };
    // One `scatter` per kind of frame, each with its frame's own calls; the frame borrowed where
    // it was built (moving the 280-byte general frame out of its Option copied it — callgrind: a
    // memcpy per vertex).
    match &ShadingFrame::new_shading(mat, ng, ns, wo) {
        Some(ShadingFrame::Lambert(bsdf)) => scatter(&vertex, bsdf, throughput, state, class),
        Some(ShadingFrame::General(bsdf)) => scatter(&vertex, bsdf, throughput, state, class),
        None => (None, None),
    }
}

/// A path vertex's surface as [`scatter`] reads it: the scene and render, the path's
/// (pixel, sample, depth), the hit point, its geometric normal and its material.
struct Vertex<'a> {
    scene: &'a PreparedScene,
    frame: &'a FrameParams,
    env: &'a EnvironmentMap,
    key: (u32, u32, u32),
    p: Vec3,
    ng: Vec3,
    mat: &'a GpuMaterial,
}

/// The rest of a vertex (shade.comp) once its BSDF is known: one emitter sample, the BSDF
/// sample of the continuation ray, Russian roulette.
fn scatter<B: VertexBsdf>(
    vertex: &Vertex,
    bsdf: &B,
    mut throughput: Vec3,
    state: &mut PathState,
    class: &mut Classifier,
) -> (Option<Ray>, Option<ShadowRay>) {
    let &Vertex {
        scene,
        frame,
        env,
        key: (pixel, sample, depth),
        p,
        ng,
        mat,
    } = vertex;
    // Emitter sampling: the environment with probability env_pmf, else one emitter of the table
    // chosen by power (one point on its triangle, or a punctual light). Delta lobes have no
    // part in it (bsdf_eval leaves them out); transmissive surfaces see lights on both sides.
    let u_light = rng_uniform4(frame.seed, pixel, sample, dim::bounce_block(depth));
    let mut shadow = None;
    if (frame.light_count > 0 || frame.env_pmf > 0.0)
        && class.ends_here(&[SYM_D])
        && frame.debug_flags & DEBUG_NO_NEE == 0
        && frame.mis_heuristic != MIS_BSDF_ONLY
    {
        let u_point = sample_pair(
            frame,
            pixel,
            sample,
            4 * dim::bounce_block(depth) + 1,
            Vec2::new(u_light.y, u_light.z),
        );
        let light = if u_light.x < frame.env_pmf {
            sample_environment(env, frame, u_point)
        } else {
            sample_emitter(
                scene,
                frame,
                (pixel, sample, depth),
                p,
                ng,
                u_light.x,
                u_point,
            )
        };
        if let Some(ls) = light {
            let f = bsdf.eval(ls.wi, TransportMode::Radiance);
            if f.max_element() > 0.0
                && ls.radiance.max_element() > 0.0
                && ls.pdf > 0.0
                && ls.pdf.is_finite()
            {
                // A delta light has no MIS partner (no BSDF sample can reach it): weight 1.
                let w = if ls.delta {
                    1.0
                } else {
                    mis_weight2(
                        frame.mis_heuristic,
                        frame.mis_beta,
                        ls.pdf,
                        bsdf.pdf(ls.wi),
                        true,
                    )
                };
                let origin = offset_ray_origin(p, if ng.dot(ls.wi) > 0.0 { ng } else { -ng });
                let (dir, t_max) = match ls.target {
                    Some(target) => {
                        let d = target - origin;
                        let t_max = d.length();
                        (d / t_max, t_max)
                    }
                    None => (ls.wi, f32::MAX),
                };
                // The shadow segment's attenuation, its medium read from either end.
                let attenuation = if scene.attenuates {
                    transmittance(volume_sigma(mat, ng, ls.wi).max(ls.medium), t_max)
                } else {
                    Vec3::ONE
                };
                shadow = Some(ShadowRay {
                    ray: Ray { origin, dir },
                    t_max,
                    contribution: throughput
                        * f
                        * bsdf.cos_theta(ls.wi)
                        * ls.radiance
                        * attenuation
                        * (w / ls.pdf),
                });
            }
        }
    }

    // BSDF sampling of the continuation ray: u.xy the direction, u.z the lobe.
    let u_bsdf = rng_uniform4(frame.seed, pixel, sample, dim::bounce_block(depth) + 1);
    let u_dir = sample_pair(
        frame,
        pixel,
        sample,
        4 * (dim::bounce_block(depth) + 1),
        Vec2::new(u_bsdf.x, u_bsdf.y),
    );
    let Some(s) = bsdf.sample(u_dir.extend(u_bsdf.z), TransportMode::Radiance) else {
        return (None, shadow);
    };
    throughput *= s.weight;
    class.step(if s.delta { SYM_S } else { SYM_D });
    state.prev_bsdf_pdf = s.pdf;
    state.prev_specular = u32::from(s.delta);
    state.prev_position = p.to_array();
    state.prev_normal = ng.to_array();
    if scene.attenuates {
        state.medium = volume_sigma(mat, ng, s.wi).to_array();
    }
    if throughput.max_element() <= 0.0 {
        return (None, shadow);
    }

    // Stopping criterion: Russian roulette, survivors divided by their survival probability
    // (lecture, "Russian roulette for integral equations"): by throughput, or by the surface's
    // albedo (the subcritical set-up P = ∫K).
    if depth + 1 >= frame.rr_start_depth && frame.rr_mode != RR_OFF {
        let survive = if frame.rr_mode == RR_ALBEDO {
            bsdf.albedo_estimate().min(1.0)
        } else {
            throughput.max_element().min(1.0)
        };
        match roulette_f32(u_light.w, survive) {
            Some(weight) => throughput *= weight,
            None => {
                state.throughput = throughput.to_array();
                return (None, shadow);
            }
        }
    }
    state.throughput = throughput.to_array();
    (
        Some(Ray {
            origin: offset_ray_origin(p, if ng.dot(s.wi) > 0.0 { ng } else { -ng }),
            dir: s.wi,
        }),
        shadow,
    )
}

/// The probability that next event estimation at the path's previous vertex picks emitting
/// triangle `index` from the table (the environment's share left out): through the light BVH
/// at that vertex, or its power share (shade.comp, `triangle_light_pmf`).
fn triangle_light_pmf(
    scene: &PreparedScene,
    frame: &FrameParams,
    tri: &crate::layout::GpuTriangle,
    index: u32,
    state: &PathState,
) -> f32 {
    if frame.light_sampler == LIGHT_SAMPLER_BVH {
        frame.light_bounded_cdf
            * light_bvh_pmf(
                &scene.light_nodes,
                &scene.light_trails,
                Vec3::from(state.prev_position),
                Vec3::from(state.prev_normal),
                index,
            )
    } else {
        tri.light_pmf
    }
}

/// One light sample seen from a shading point (shade.comp, `LightSample`): the direction to
/// the light, where the shadow ray ends (a point, or at infinity), the radiance arriving and
/// the solid-angle density of the sample (the pmf for a delta light, which has no MIS partner).
struct LightSample {
    wi: Vec3,
    target: Option<Vec3>,
    radiance: Vec3,
    pdf: f32,
    delta: bool,
    /// The attenuation coefficient behind the light's surface where the shading point lies
    /// there (`volume_sigma` at the light's end of the shadow segment).
    medium: Vec3,
}

/// Next event estimation towards the environment (shade.comp, `sample_environment`): a
/// direction from the map's distribution, with the environment's share of the choice.
fn sample_environment(env: &EnvironmentMap, frame: &FrameParams, u: Vec2) -> Option<LightSample> {
    let (wi, pdf) = env_sample(env, frame, u)?;
    Some(LightSample {
        wi,
        target: None,
        radiance: env_radiance(env, frame, wi),
        pdf: frame.env_pmf * pdf,
        delta: false,
        medium: Vec3::ZERO,
    })
}

/// Next event estimation towards the emitter table (shade.comp, `sample_emitter`): for `u_pick`
/// rescaled past the environment's share, a bounded emitter through the light BVH (its share
/// of the table, `light_bounded_cdf`) or an entry of the table by power, then the punctual
/// light it names, or a point on its triangle for `u_point`.
fn sample_emitter(
    scene: &PreparedScene,
    frame: &FrameParams,
    (pixel, sample, depth): (u32, u32, u32),
    p: Vec3,
    ng: Vec3,
    u_pick: f32,
    u_point: Vec2,
) -> Option<LightSample> {
    if frame.light_count == 0 {
        return None;
    }
    let keep = 1.0 - frame.env_pmf;
    let u_table = ((u_pick - frame.env_pmf) / keep).min(ONE_MINUS_EPSILON);
    let (entry, pmf) =
        if frame.light_sampler == LIGHT_SAMPLER_BVH && u_table < frame.light_bounded_cdf {
            // A bounded emitter, by its importance to (p, ng) through the light BVH.
            let u_bvh = (u_table / frame.light_bounded_cdf).min(ONE_MINUS_EPSILON);
            let (k, pmf) = light_bvh_sample(&scene.light_nodes, p, ng, u_bvh)?;
            (&scene.lights[k as usize], pmf * frame.light_bounded_cdf)
        } else {
            let entry = &scene.lights[sample_light(&scene.lights, u_table)];
            (entry, entry.pmf)
        };
    let pmf = pmf * keep;
    if entry.triangle & LIGHT_ENTRY_PUNCTUAL != 0 {
        let light = &scene.punctual[(entry.triangle & !LIGHT_ENTRY_PUNCTUAL) as usize];
        let (wi, dist, li) = punctual_incident(light, p);
        return Some(LightSample {
            wi,
            target: (dist >= 0.0).then(|| Vec3::from(light.position)),
            radiance: li,
            pdf: pmf,
            delta: true,
            medium: Vec3::ZERO,
        });
    }
    let light = &scene.triangles[entry.triangle as usize];
    let b = sample_uniform_triangle(u_point);
    let (l1, l2) = (Vec3::from(light.e1), Vec3::from(light.e2));
    let y = Vec3::from(light.p0) + b.x * l1 + b.y * l2;
    let light_n = l1.cross(l2).normalize();
    let to_light = y - p;
    let dist2 = to_light.dot(to_light);
    let wi = to_light / dist2.sqrt();
    let cos_light = light_n.dot(-wi);
    // The light point's emission and the medium behind it (`emitter_surface`); where no emitter
    // reads its surface or is alpha-tested, its material's as it is (`plain_emitters`).
    let (radiance, medium) = if scene.plain_emitters {
        let m = &scene.materials[light.material_index() as usize];
        let medium = if scene.attenuates {
            volume_sigma(m, light_n, -wi)
        } else {
            Vec3::ZERO
        };
        (emitted_radiance(m, cos_light), medium)
    } else {
        let key = alpha_key(frame.seed, pixel, sample, depth, true);
        emitter_surface(scene, entry.triangle, b, key, cos_light, light_n, wi)
    };
    Some(LightSample {
        wi,
        // The shadow ray ends just off the light's surface, on the side it leaves towards p.
        target: Some(offset_ray_origin(
            y,
            if cos_light > 0.0 { light_n } else { -light_n },
        )),
        radiance,
        // Solid-angle pdf: pmf · (1/area) · dist² / |cos at the light|.
        pdf: pmf * dist2 / (cos_light.abs() * light.area),
        delta: false,
        medium,
    })
}

/// The emission at point `b` (barycentric) of emitting triangle `index`, seen at cosine
/// `cos_light` to its normal `light_n` from direction −`wi`: its textures at level 0 where its
/// surface exists under alpha key `key`, and the medium behind it (`volume_sigma` at the
/// light's end of the shadow segment). Out of line: most scenes' emitters take the plain path.
#[inline(never)]
fn emitter_surface(
    scene: &PreparedScene,
    index: u32,
    b: Vec2,
    key: glam::UVec4,
    cos_light: f32,
    light_n: Vec3,
    wi: Vec3,
) -> (Vec3, Vec3) {
    let textures = scene.texture_data();
    let light_mat = scene.emitter_at(&textures, index, b.x, b.y);
    // (Culling does not apply: the light's own sidedness is its emission's.)
    let radiance = if scene.present(&textures, index, b.x, b.y, key, Vec3::ZERO) {
        emitted_radiance(&light_mat, cos_light)
    } else {
        Vec3::ZERO
    };
    (radiance, volume_sigma(&light_mat, light_n, -wi))
}
