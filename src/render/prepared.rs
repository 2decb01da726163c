//! The scene prepared for tracing, shared by both backends: the BVH (two levels with instances),
//! triangles in BVH order, materials as the GPU's table, the emitter table and its light BVH,
//! punctual lights, textures, and the per-render constants ([`PreparedScene::frame_params`]).

use super::settings::{Integrator, RenderSettings};
use crate::bvh::{gpu_triangles_with, Bvh, WideBvh};
use crate::bvh::{Hit, Ray};
use crate::layout::BvhNode;
use crate::layout::{
    FrameParams, GpuInstance, GpuMaterial, GpuPunctualLight, GpuTexture, GpuTextureRef,
    GpuTriangle, GpuVertex, LightEntry, MATERIAL_ALPHA_BLEND, MATERIAL_ALPHA_MASK,
    MATERIAL_DOUBLE_SIDED, MATERIAL_ENERGY_COMPENSATION, MATERIAL_TEXTURED, MATERIAL_UNLIT,
    NO_TEXTURE, TRIANGLE_ALPHA, TRIANGLE_FLAT, TRIANGLE_PLAIN, TRIANGLE_TEST_ALPHA,
    TRIANGLE_TEST_CULL,
};
use crate::layout::{LIGHT_DIRECTIONAL, LIGHT_ENTRY_PUNCTUAL, LIGHT_SAMPLER_POWER, LIGHT_SPOT};
use crate::lights::light_bvh::{GpuLightNode, LightBounds, LightBvh, NO_LIGHT_TRAIL};
use crate::lights::{build_light_table_with, luminance};
use crate::sampling::sample_uniform_triangle;
use crate::scene::{AlphaMode, Camera, Material, Scene, ThinLens, NO_VERTEX};
use crate::surface::triangle_present;
use crate::surface::{emitter_reads_surface, surface_emitter, surface_point, LOD_MAGNIFY};
use crate::texture::{sample_texture_ref, TextureData};
use crate::tlas::{
    append_blas, gpu_instance, instance_bounds, instance_key, scene_intersect_any,
    scene_intersect_closest,
};
use glam::{Mat4, UVec4, Vec3};
use rayon::prelude::*;

/// The BVH node and instance arrays a GPU renderer uploads ([`PreparedScene::gpu_bvh`]).
pub struct GpuBvh {
    pub nodes: Vec<BvhNode>,
    pub instances: Vec<GpuInstance>,
    /// The top level's quantised root in `nodes` (`FrameParams::tlas_wide_root`), or
    /// `NO_WIDE_ROOT` where it is walked in its binary nodes.
    pub tlas_wide_root: u32,
    /// The most slots a walk of any quantised bottom level can have deferred at once
    /// (`WideBvh::deferred_bound`; 0 where none is quantised).
    pub deferred_max: u32,
    /// The same for the top level (0 where it is walked in its binary nodes).
    pub tlas_deferred: u32,
}

/// The scene in the form both integrators trace: the two-level BVH (`tlas.rs`) and triangles
/// in BVH order, with their shading data (`surface.rs`).
pub struct PreparedScene {
    /// Every level's nodes: bottom levels first (the baked world-space triangles at root 0),
    /// the top level last; `order` and `stats` are the baked level's.
    pub bvh: Bvh,
    /// The top level's root node in `bvh.nodes`.
    pub tlas_root: u32,
    /// `bvh.nodes` collapsed to 4-wide nodes for the CPU integrators, made when one first
    /// traces a ray ([`PreparedScene::wide_bvh`]), so that a GPU render does not pay for it.
    pub wide: std::sync::OnceLock<WideBvh>,
    /// The node and instance arrays the GPU reads (`bvh::quantized::gpu_nodes`), made when a
    /// GPU renderer first uploads the scene ([`PreparedScene::gpu_bvh`]).
    pub gpu: std::sync::OnceLock<GpuBvh>,
    /// The top level's leaves, in its order.
    pub instances: Vec<GpuInstance>,
    /// KHR_lights_punctual lights (emitter entries with `LIGHT_ENTRY_PUNCTUAL` index them).
    pub punctual: Vec<GpuPunctualLight>,
    pub triangles: Vec<GpuTriangle>,
    pub materials: Vec<GpuMaterial>,
    pub lights: Vec<LightEntry>,
    /// Total selection power of the emitter table (luminance-weighted watts), against which
    /// the environment's share of next event estimation is set.
    pub light_power: f32,
    /// Radius of the scene's bounding sphere (half the diagonal of its bounds).
    pub radius: f32,
    /// The light BVH over the table's bounded entries (its leaves index the table), and per
    /// triangle the trail to its entry's leaf (empty when no triangle emits).
    pub light_nodes: Vec<GpuLightNode>,
    /// The light BVH cannot tell its lights apart (`LightBvh::power_alike`; false without
    /// one): renders sample emitters by power whichever light sampler they ask for
    /// (`frame_params`).
    pub light_power_alike: bool,
    pub light_trails: Vec<u32>,
    /// The table's CDF at its last bounded entry (`FrameParams::light_bounded_cdf`).
    pub light_bounded_cdf: f32,
    /// How long the light BVH took to build (`render` prints it beside the BVH's).
    pub light_bvh_time: std::time::Duration,
    /// Per BVH-ordered triangle: its vertices (xyz) and `TRIANGLE_*` flags (w).
    pub triangle_vertices: Vec<UVec4>,
    /// The scene's vertices and, last, one without attributes (`NO_VERTEX` corners).
    pub vertices: Vec<GpuVertex>,
    pub textures: Vec<GpuTexture>,
    pub texture_refs: Vec<GpuTextureRef>,
    /// Shared with the `Scene`, not copied.
    pub texels: std::sync::Arc<Vec<u32>>,
    pub camera: Camera,
    /// Some material attenuates the light inside it (KHR_materials_volume: attenuation > 0,
    /// the GPU kernels' `FEATURE_VOLUME`). Without one every segment's transmittance is 1,
    /// and the CPU path skips working it out.
    pub attenuates: bool,
    /// Every emitting triangle's emission is its material's factors wherever it is sampled:
    /// no emitter reads its surface (`surface::emitter_reads_surface`) or is alpha-tested. The
    /// CPU path's emitter sample then reads the material as it is.
    pub plain_emitters: bool,
}

/// The GPU form of a scene material.
pub fn gpu_material(m: &Material) -> GpuMaterial {
    let mut flags = if m.double_sided {
        MATERIAL_DOUBLE_SIDED
    } else {
        0
    };
    match m.alpha_mode {
        AlphaMode::Opaque => {}
        AlphaMode::Mask => flags |= MATERIAL_ALPHA_MASK,
        AlphaMode::Blend => flags |= MATERIAL_ALPHA_BLEND,
    }
    // Energy compensation on by default (DESIGN.md, Materials); `set_energy_compensation`.
    flags |= MATERIAL_ENERGY_COMPENSATION;
    if m.unlit {
        flags |= MATERIAL_UNLIT;
    }
    let t = &m.textures;
    if [
        t.base_color,
        t.metallic_roughness,
        t.emissive,
        t.normal,
        t.transmission,
        t.specular,
        t.specular_color,
        t.clearcoat,
        t.clearcoat_roughness,
        t.clearcoat_normal,
        t.sheen_color,
        t.sheen_roughness,
        t.anisotropy,
        t.iridescence,
        t.iridescence_thickness,
        t.diffuse_transmission,
        t.diffuse_transmission_color,
    ]
    .iter()
    .any(Option::is_some)
    {
        flags |= MATERIAL_TEXTURED;
    }
    let slot = |t: Option<u32>| t.unwrap_or(NO_TEXTURE);
    GpuMaterial {
        base_color: m.base_color.to_array(),
        flags,
        emission: m.emission.to_array(),
        metallic: m.metallic,
        roughness: m.roughness,
        ior: m.ior,
        transmission: m.transmission,
        specular: m.specular,
        alpha: m.alpha,
        alpha_cutoff: m.alpha_cutoff,
        normal_scale: m.normal_scale,
        base_color_texture: slot(m.textures.base_color),
        metallic_roughness_texture: slot(m.textures.metallic_roughness),
        emissive_texture: slot(m.textures.emissive),
        normal_texture: slot(m.textures.normal),
        transmission_texture: slot(m.textures.transmission),
        specular_color: m.specular_color.to_array(),
        specular_texture: slot(m.textures.specular),
        specular_color_texture: slot(m.textures.specular_color),
        clearcoat: m.clearcoat,
        clearcoat_roughness: m.clearcoat_roughness,
        clearcoat_texture: slot(m.textures.clearcoat),
        clearcoat_roughness_texture: slot(m.textures.clearcoat_roughness),
        clearcoat_normal_texture: slot(m.textures.clearcoat_normal),
        clearcoat_normal_scale: m.clearcoat_normal_scale,
        sheen_color: m.sheen_color.to_array(),
        sheen_roughness: m.sheen_roughness,
        sheen_color_texture: slot(m.textures.sheen_color),
        sheen_roughness_texture: slot(m.textures.sheen_roughness),
        anisotropy: m.anisotropy,
        anisotropy_rotation: m.anisotropy_rotation,
        anisotropy_texture: slot(m.textures.anisotropy),
        iridescence: m.iridescence,
        iridescence_ior: m.iridescence_ior,
        iridescence_thickness_min: m.iridescence_thickness_min,
        iridescence_thickness: m.iridescence_thickness_max,
        iridescence_texture: slot(m.textures.iridescence),
        iridescence_thickness_texture: slot(m.textures.iridescence_thickness),
        attenuation: crate::bsdf::volume::attenuation_coefficient(
            m.thickness,
            m.attenuation_color,
            m.attenuation_distance,
        )
        .to_array(),
        thickness: m.thickness,
        diffuse_transmission: m.diffuse_transmission,
        diffuse_transmission_color: m.diffuse_transmission_color.to_array(),
        diffuse_transmission_texture: slot(m.textures.diffuse_transmission),
        diffuse_transmission_color_texture: slot(m.textures.diffuse_transmission_color),
        dispersion: m.dispersion,
        ..GpuMaterial::default()
    }
}

/// The emitter-selection power of a triangle with an emissive texture, relative to the texture's
/// mean over the whole image: the luminance of the texture's mean over the triangle (16
/// stratified points, level 0) over that of the image's mean, at least 10⁻³ so that no triangle
/// that may emit is never chosen (the estimate stays unbiased whatever the scale). 1 for other
/// triangles.
fn emissive_texture_scale(
    data: &TextureData,
    materials: &[GpuMaterial],
    emitting: &[GpuMaterial],
    tri: &GpuTriangle,
    tv: UVec4,
    vertices: &[GpuVertex],
) -> f32 {
    let m = &materials[tri.material_index() as usize];
    if m.emissive_texture == NO_TEXTURE || luminance(Vec3::from(m.emission)) <= 0.0 {
        return 1.0;
    }
    let whole = luminance(Vec3::from(emitting[tri.material_index() as usize].emission));
    if whole <= 0.0 {
        return 1.0;
    }
    let mut sum = Vec3::ZERO;
    for k in 0..16 {
        let u = glam::Vec2::new(((k % 4) as f32 + 0.5) / 4.0, ((k / 4) as f32 + 0.5) / 4.0);
        let b = sample_uniform_triangle(u);
        let sp = surface_point(tri, tv, vertices, b.x, b.y);
        sum += sample_texture_ref(data, m.emissive_texture, sp.uv, LOD_MAGNIFY).truncate();
    }
    let over_triangle = luminance(Vec3::from(m.emission) * sum / 16.0);
    (over_triangle / whole).max(1e-3)
}

/// `src` after `dst`'s elements; an empty `dst` takes `src` itself instead of a copy of it (the
/// baked level is most of a scene's triangles).
fn append_moved<T>(dst: &mut Vec<T>, mut src: Vec<T>) {
    if dst.is_empty() {
        *dst = src;
    } else {
        dst.append(&mut src);
    }
}

/// The light BVH over the emitter table's bounded entries (emissive triangles, point and spot
/// lights: the entries before the directional ones), each with its selection power; per
/// triangle, the trail to its entry's leaf (empty when no triangle emits); and the table's CDF
/// at its last bounded entry.
fn build_light_bvh(
    lights: &[LightEntry],
    total_power: f32,
    triangles: &[GpuTriangle],
    materials: &[GpuMaterial],
    punctual: &[GpuPunctualLight],
) -> (LightBvh, Vec<u32>, f32) {
    let mut bounds = Vec::new();
    let mut bounded_cdf = 0.0;
    for entry in lights {
        let power = entry.pmf * total_power;
        if entry.triangle & LIGHT_ENTRY_PUNCTUAL != 0 {
            let l = &punctual[(entry.triangle & !LIGHT_ENTRY_PUNCTUAL) as usize];
            let p = Vec3::from(l.position);
            match l.kind {
                LIGHT_DIRECTIONAL => break,
                LIGHT_SPOT => {
                    // KHR_lights_punctual: scale = 1/(cos inner − cos outer), offset = −cos outer · scale.
                    let cos_outer = -l.spot_offset / l.spot_scale;
                    let cos_inner = cos_outer + 1.0 / l.spot_scale;
                    bounds.push(LightBounds::spot(
                        p,
                        Vec3::from(l.direction),
                        power,
                        cos_inner,
                        cos_outer,
                    ));
                }
                _ => bounds.push(LightBounds::point(p, power)),
            }
        } else {
            let t = &triangles[entry.triangle as usize];
            let p0 = Vec3::from(t.p0);
            let two_sided =
                materials[t.material_index() as usize].flags & MATERIAL_DOUBLE_SIDED != 0;
            bounds.push(LightBounds::triangle(
                p0,
                p0 + Vec3::from(t.e1),
                p0 + Vec3::from(t.e2),
                power,
                two_sided,
            ));
        }
        bounded_cdf = entry.cdf;
    }
    let bvh = LightBvh::build(&bounds);
    let mut per_triangle = Vec::new();
    if lights[..bounds.len()]
        .iter()
        .any(|e| e.triangle & LIGHT_ENTRY_PUNCTUAL == 0)
    {
        per_triangle = vec![NO_LIGHT_TRAIL; triangles.len()];
        for (entry, &trail) in lights.iter().zip(&bvh.trails) {
            if entry.triangle & LIGHT_ENTRY_PUNCTUAL == 0 {
                per_triangle[entry.triangle as usize] = trail;
            }
        }
    }
    (bvh, per_triangle, bounded_cdf)
}

impl PreparedScene {
    pub fn new(scene: &Scene) -> PreparedScene {
        let materials: Vec<GpuMaterial> = scene.materials.iter().map(gpu_material).collect();
        // Copied on every core (a million-vertex scene's 64 MiB are fresh memory, faulted in by
        // the writer), with room for the blank vertex.
        let mut vertices = Vec::with_capacity(scene.vertices.len() + 1);
        vertices.par_extend(scene.vertices.par_iter().copied());
        let blank = vertices.len() as u32;
        vertices.push(GpuVertex {
            color: [1.0; 4],
            ..Default::default()
        });
        // Bottom levels: the baked world-space triangles (root 0), then each instanced mesh.
        let mut triangles = Vec::new();
        let mut triangle_vertices = Vec::new();
        // glTF: doubleSided false enables back-face culling. Transmissive surfaces keep both
        // faces: their back face is how light leaves a solid of glass (or a translucent one).
        let cull: Vec<bool> = scene
            .materials
            .iter()
            .map(|m| {
                !m.double_sided
                    && m.transmission == 0.0
                    && m.textures.transmission.is_none()
                    && m.diffuse_transmission == 0.0
            })
            .collect();
        let mut add_blas = |nodes: &mut Vec<crate::layout::BvhNode>,
                            tris: &[crate::scene::Triangle]| {
            // Each pass over the triangles on every core, reading the scene's records in place.
            let mut bvh = Bvh::build_with(tris.len(), |i| tris[i].p);
            let root = append_blas(
                nodes,
                std::mem::take(&mut bvh.nodes),
                triangles.len() as u32,
            );
            // The any-hit tests ride in the material's top bits (`TRIANGLE_TEST_*`).
            let mut ordered = gpu_triangles_with(&bvh.order, |i| (tris[i].p, tris[i].material));
            ordered.par_iter_mut().zip(&bvh.order).for_each(|(g, &i)| {
                let t = &tris[i as usize];
                if t.flags & TRIANGLE_ALPHA != 0 {
                    g.material |= TRIANGLE_TEST_ALPHA;
                }
                if cull.get(t.material as usize).copied().unwrap_or(false) {
                    g.material |= TRIANGLE_TEST_CULL;
                }
            });
            append_moved(&mut triangles, ordered);
            let corners: Vec<UVec4> = bvh
                .order
                .par_iter()
                .map(|&i| {
                    let t = &tris[i as usize];
                    let [a, b, c] = t.vertices.map(|v| if v == NO_VERTEX { blank } else { v });
                    UVec4::new(a, b, c, t.flags & (TRIANGLE_FLAT | TRIANGLE_PLAIN))
                })
                .collect();
            append_moved(&mut triangle_vertices, corners);
            (root, bvh)
        };
        let mut nodes = Vec::new();
        let (_, baked) = add_blas(&mut nodes, &scene.triangles);
        let baked_triangles = scene.triangles.len();
        let mesh_roots: Vec<u32> = scene
            .meshes
            .iter()
            .map(|mesh| add_blas(&mut nodes, &mesh.triangles).0)
            .collect();
        // The top level over every placement: the baked geometry (identity), then the instances.
        let mut placed: Vec<GpuInstance> = Vec::new();
        if !scene.triangles.is_empty() {
            placed.push(gpu_instance(&Mat4::IDENTITY, 0));
        }
        placed.extend(
            scene
                .instances
                .iter()
                .enumerate()
                .map(|(k, i)| GpuInstance {
                    placement: k as u32 + 1,
                    ..gpu_instance(&i.transform, mesh_roots[i.mesh as usize])
                }),
        );
        let boxes: Vec<(Vec3, Vec3)> = placed
            .iter()
            .map(|i| instance_bounds(&nodes[i.blas_root as usize], i))
            .collect();
        let tlas = Bvh::build_boxes(&boxes);
        let instances: Vec<GpuInstance> = tlas.order.iter().map(|&k| placed[k as usize]).collect();
        let tlas_root = append_blas(&mut nodes, tlas.nodes, 0);
        // Emitters are chosen by power; an emissive texture scales it by its mean. Emitting
        // meshes are always baked (the loader never instances them), so the table covers the
        // bottom level at root 0 only.
        let emitting: Vec<GpuMaterial> = materials
            .iter()
            .map(|m| {
                let mut m = *m;
                if m.emissive_texture != NO_TEXTURE {
                    let r = &scene.textures.refs[m.emissive_texture as usize];
                    let mean = scene.textures.means[r.texture as usize];
                    for k in 0..3 {
                        m.emission[k] *= mean[k];
                    }
                }
                m
            })
            .collect();
        let root = &nodes[tlas_root as usize];
        let radius = if instances.is_empty() {
            0.0
        } else {
            0.5 * (Vec3::from(root.bounds_max) - Vec3::from(root.bounds_min)).length()
        };
        let data = TextureData {
            textures: &scene.textures.textures,
            refs: &scene.textures.refs,
            texels: &scene.textures.texels,
        };
        // Per triangle, independent: on every core (16 texture taps each; a tenth of the
        // preparation of a million emitting triangles on one).
        let scales: Vec<f32> = triangles[..baked_triangles]
            .par_iter()
            .zip(&triangle_vertices[..baked_triangles])
            .map(|(tri, &tv)| {
                emissive_texture_scale(&data, &materials, &emitting, tri, tv, &vertices)
            })
            .collect();
        let (lights, light_power) = build_light_table_with(
            &mut triangles[..baked_triangles],
            &emitting,
            &scales,
            &scene.punctual,
            radius,
        );
        let light_bvh_start = std::time::Instant::now();
        let (light_bvh, light_trails, light_bounded_cdf) = build_light_bvh(
            &lights,
            light_power as f32,
            &triangles,
            &materials,
            &scene.punctual,
        );
        let attenuates = materials
            .iter()
            .any(|m| m.attenuation.iter().any(|&s| s > 0.0));
        let plain_emitters = lights.iter().all(|e| {
            e.triangle & LIGHT_ENTRY_PUNCTUAL != 0 || {
                let t = &triangles[e.triangle as usize];
                t.material & TRIANGLE_TEST_ALPHA == 0
                    && !crate::surface::emitter_reads_surface(
                        &materials[t.material_index() as usize],
                    )
            }
        });
        PreparedScene {
            bvh: Bvh {
                nodes,
                order: baked.order,
                stats: baked.stats,
            },
            tlas_root,
            wide: std::sync::OnceLock::new(),
            gpu: std::sync::OnceLock::new(),
            instances,
            triangles,
            materials,
            light_nodes: light_bvh.nodes,
            light_power_alike: light_bvh.power_alike,
            light_trails,
            light_bounded_cdf,
            light_bvh_time: light_bvh_start.elapsed(),
            lights,
            light_power: light_power as f32,
            radius,
            punctual: scene.punctual.clone(),
            triangle_vertices,
            vertices,
            textures: scene.textures.textures.clone(),
            texture_refs: scene.textures.refs.clone(),
            texels: std::sync::Arc::clone(&scene.textures.texels),
            camera: scene.camera,
            attenuates,
            plain_emitters,
        }
    }

    /// The textures as `texture.rs` samples them.
    pub fn texture_data(&self) -> TextureData<'_> {
        TextureData {
            textures: &self.textures,
            refs: &self.texture_refs,
            texels: &self.texels,
        }
    }

    /// Axis-aligned bounds (min, max) of the scene's triangles, from the top level's root;
    /// (0, 0) for an empty scene.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match self.bvh.nodes.get(self.tlas_root as usize) {
            Some(root) if !self.instances.is_empty() => {
                (Vec3::from(root.bounds_min), Vec3::from(root.bounds_max))
            }
            _ => (Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// Closest hit with t in (t_min, t_max) over every instance (`tlas.rs`) with its instance,
    /// honouring alpha for the ray with alpha key `key` (`surface::alpha_key`).
    pub fn intersect_closest(
        &self,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        key: UVec4,
    ) -> Option<(Hit, u32)> {
        scene_intersect_closest(
            self.wide_bvh(),
            self.tlas_root,
            &self.instances,
            &self.triangles,
            ray,
            t_min,
            t_max,
            self.any_hit(key),
        )
    }

    /// The CPU's 4-wide BVH over every level (`bvh::wide`), collapsed on first use.
    pub fn wide_bvh(&self) -> &WideBvh {
        self.wide
            .get_or_init(|| WideBvh::collapse(&self.bvh.nodes, &self.level_roots()))
    }

    /// The binary root of every level: the top level's, then each instance's bottom level.
    pub fn level_roots(&self) -> Vec<u32> {
        std::iter::once(self.tlas_root)
            .chain(self.instances.iter().map(|i| i.blas_root))
            .collect()
    }

    /// The GPU's node and instance arrays: the binary nodes followed by every level collapsed
    /// to quantised 4-wide nodes (`qbvh.glsl`), the instances with their bottom level's
    /// quantised root, and the top level's.
    pub fn gpu_bvh(&self) -> &GpuBvh {
        self.gpu.get_or_init(|| {
            let quant = WideBvh::collapse(&self.bvh.nodes, &self.level_roots()).quantized();
            let (nodes, base) = crate::bvh::quantized::gpu_nodes(&self.bvh.nodes, &quant);
            // A level of no primitives, or whose walk could defer more slots than the GPU
            // keeps, is walked in its binary nodes (`tlas.glsl`); the largest bound of the others
            // sizes the kernels' deferred array (`gpu_features`).
            // The bottom levels' bound and the top level's size two arrays apart
            // (`layout::FEATURE_TLAS_STACK_SHIFT`).
            let mut bounds = std::collections::HashMap::new();
            let mut wide_root = |binary: u32, deferred: &mut u32| {
                quant
                    .root(binary)
                    .filter(|&w| {
                        let bound = *bounds.entry(w).or_insert_with(|| quant.deferred_bound(w));
                        let walked = bound <= crate::bvh::quantized::GPU_DEFERRED_MAX;
                        if walked {
                            *deferred = (*deferred).max(bound);
                        }
                        walked
                    })
                    .map_or(crate::layout::NO_WIDE_ROOT, |w| {
                        crate::bvh::quantized::gpu_node_index(base, w)
                    })
            };
            let mut deferred_max = 0;
            let instances = self
                .instances
                .iter()
                .map(|inst| GpuInstance {
                    wide_root: wide_root(inst.blas_root, &mut deferred_max),
                    ..*inst
                })
                .collect();
            let mut tlas_deferred = 0;
            let tlas_wide_root = wide_root(self.tlas_root, &mut tlas_deferred);
            GpuBvh {
                nodes,
                instances,
                tlas_wide_root,
                deferred_max,
                tlas_deferred,
            }
        })
    }

    /// The any-hit test of a ray with alpha key `key`: (triangle, u, v, instance, direction in
    /// the instance's space) → whether the surface is there (`present`).
    fn any_hit(&self, key: UVec4) -> impl Fn(u32, f32, f32, u32, Vec3) -> bool + '_ {
        let data = self.texture_data();
        // Inlined into the walks: left to LLVM, the closest-hit walk called it per candidate hit
        // (about 60 instructions a call; Cornell box 8 563 -> 8 470 instructions per sample
        // sampling as Mitsuba does, tools/instructions.py).
        #[inline(always)]
        move |i, u, v, k, dir| self.present(&data, i, u, v, instance_key(key, k), dir)
    }

    /// True if anything is hit with t in (t_min, t_max) (alpha as in `intersect_closest`).
    pub fn intersect_any(&self, ray: &Ray, t_min: f32, t_max: f32, key: UVec4) -> bool {
        scene_intersect_any(
            self.wide_bvh(),
            self.tlas_root,
            &self.instances,
            &self.triangles,
            ray,
            t_min,
            t_max,
            self.any_hit(key),
        )
    }

    /// The any-hit test of both traversals (`surface::triangle_present`), inlined into them.
    #[inline(always)]
    pub fn present(
        &self,
        data: &TextureData,
        index: u32,
        u: f32,
        v: f32,
        key: UVec4,
        dir: Vec3,
    ) -> bool {
        triangle_present(
            data,
            &self.triangles,
            &self.triangle_vertices,
            &self.vertices,
            &self.materials,
            index,
            u,
            v,
            key,
            dir,
        )
    }

    /// Emitting triangle `index`'s material at barycentrics (u, v), textures at level 0, as
    /// `emitted_radiance` reads it: `surface_emitter` at the point, whose attributes are
    /// interpolated only where [`emitter_reads_surface`] says the emitter reads them; else the
    /// material itself, borrowed (shade.comp and bdpt.glsl: `emitter_at`). Inlined into next event estimation: out of line, building and
    /// reading the `Cow` cost about 100 instructions per Cornell box sample (callgrind).
    #[inline(always)]
    pub fn emitter_at(
        &self,
        data: &TextureData,
        index: u32,
        u: f32,
        v: f32,
    ) -> std::borrow::Cow<'_, GpuMaterial> {
        let tri = &self.triangles[index as usize];
        let raw = &self.materials[tri.material_index() as usize];
        if !emitter_reads_surface(raw) {
            return std::borrow::Cow::Borrowed(raw);
        }
        let tv = self.triangle_vertices[index as usize];
        let sp = surface_point(tri, tv, &self.vertices, u, v);
        std::borrow::Cow::Owned(surface_emitter(data, raw, &sp, LOD_MAGNIFY))
    }

    /// The world-space attributes of `hit` on placement `instance`, with its triangle
    /// (shade.comp and shade_light.comp: `surface_point`, then `surface_to_world`).
    pub fn hit_surface(
        &self,
        hit: &Hit,
        instance: u32,
    ) -> (crate::surface::SurfacePoint, &GpuTriangle) {
        let tri = &self.triangles[hit.triangle as usize];
        let mut sp = surface_point(
            tri,
            self.triangle_vertices[hit.triangle as usize],
            &self.vertices,
            hit.u,
            hit.v,
        );
        crate::surface::surface_to_world(&mut sp, tri, &self.instances[instance as usize]);
        (sp, tri)
    }

    /// The thin lens `settings` ask of this scene's camera (`Camera::thin_lens`); errors name
    /// the option at fault.
    pub fn thin_lens(&self, settings: &RenderSettings) -> anyhow::Result<ThinLens> {
        self.camera
            .thin_lens(settings.aperture, settings.focus_distance, self.bounds())
            .map_err(anyhow::Error::msg)
    }

    /// The constants of one render, as the GPU's uniform buffer holds them. Settings whose
    /// [`thin_lens`](PreparedScene::thin_lens) is an error render with a pinhole: check it
    /// first (the command line does).
    /// Whether every material is plain diffuse (`bsdf::material_is_plain`): the GPU then takes
    /// the plain frames' path through the BSDF everywhere (`layout::FEATURE_GENERAL_BSDF`).
    pub fn plain_diffuse(&self) -> bool {
        self.materials.iter().all(crate::bsdf::material_is_plain)
    }

    /// The features the GPU's kernels need for this scene rendered with `settings`
    /// (`layout::FEATURE_*`): its pipelines are specialised for them and compile without the
    /// others' code. Each is left out only where no ray can reach its code: one instance placed
    /// as it is (the top level skipped, `tlas.glsl`), every level with a quantised root, every
    /// material plain, no alpha-tested triangle, no texture, no environment, no punctual light,
    /// no dispersive material, no attenuation, no path expression, no thin film, and of the
    /// samplers and the light samplers all but the one chosen. The top byte is the bottom levels'
    /// quantised walks' array of deferred slots made for the scene (`layout::qbvh_stack_size`):
    /// their largest deferred bound less the two slots the walks keep in registers, at least 1;
    /// bits 16 to 21 the top level's, alike (`layout::tlas_stack_size`; 1 without a top level).
    pub fn gpu_features(&self, settings: &RenderSettings) -> u32 {
        use crate::layout::*;
        let frame = self.frame_params(settings);
        let bvh = self.gpu_bvh();
        let top_level =
            !matches!(&bvh.instances[..], [only] if only.flags & INSTANCE_IDENTITY != 0);
        let binary_walk = bvh.instances.iter().any(|i| i.wide_root == NO_WIDE_ROOT)
            || (top_level && bvh.tlas_wide_root == NO_WIDE_ROOT);
        let alpha = self
            .triangles
            .iter()
            .any(|t| t.material & TRIANGLE_TEST_ALPHA != 0);
        let volume = self.attenuates;
        // A deferred array for walks that defer at most `bound` slots: less the ones the walks
        // keep in registers, at least one.
        let slots = |bound: u32| {
            bound
                .saturating_sub(crate::bvh::quantized::GPU_DEFERRED_REGISTERS)
                .clamp(1, QBVH_STACK_MAX)
        };
        [
            (top_level, FEATURE_TOP_LEVEL),
            (binary_walk, FEATURE_BINARY_WALK),
            (!self.plain_diffuse(), FEATURE_GENERAL_BSDF),
            (alpha, FEATURE_ALPHA),
            (!self.textures.is_empty(), FEATURE_TEXTURES),
            (frame.env_width > 0, FEATURE_ENVIRONMENT),
            (!self.punctual.is_empty(), FEATURE_PUNCTUAL),
            (frame.spectral != 0, FEATURE_DISPERSION),
            (volume, FEATURE_VOLUME),
            (settings.paths.is_some(), FEATURE_PATHS),
            (frame.sampler_mode == SAMPLER_STRATIFIED, FEATURE_STRATIFIED),
            (frame.sampler_mode == SAMPLER_SOBOL, FEATURE_SOBOL),
            (frame.light_sampler == LIGHT_SAMPLER_BVH, FEATURE_LIGHT_BVH),
            (
                self.materials.iter().any(|m| m.iridescence > 0.0),
                FEATURE_IRIDESCENCE,
            ),
        ]
        .into_iter()
        .filter(|&(needed, _)| needed)
        .fold(0, |features, (_, f)| features | f)
            | slots(bvh.deferred_max) << FEATURE_STACK_SHIFT
            | slots(if top_level { bvh.tlas_deferred } else { 0 }) << FEATURE_TLAS_STACK_SHIFT
    }

    /// Energy compensation of the GGX lobes on every material (`bsdf::energy`; on when a scene
    /// is prepared), or off: the specification's single-scattering model exactly
    /// (`--energy-compensation off`, the reference scenes and the tests of its formulas).
    pub fn set_energy_compensation(&mut self, on: bool) {
        for m in &mut self.materials {
            if on {
                m.flags |= MATERIAL_ENERGY_COMPENSATION;
            } else {
                m.flags &= !MATERIAL_ENERGY_COMPENSATION;
            }
        }
    }

    /// Whether the file lights itself: a `KHR_lights_punctual` lamp, or an emitting surface
    /// whose emission is not textured (a lamp: an area light is written as emissiveFactor on a
    /// surface). Textured emission alone (screens, dials, the glowing parts of a model such as
    /// DamagedHelmet's visor) is a surface's look, not the scene's lighting: such a file, like
    /// one without emission, is lit by the built-in studio unless told otherwise
    /// (`lights::studio`, DESIGN.md "Lighting by default").
    pub fn has_own_lights(&self) -> bool {
        self.lights.iter().any(|entry| {
            entry.triangle & LIGHT_ENTRY_PUNCTUAL != 0
                || self
                    .triangles
                    .get(entry.triangle as usize)
                    .and_then(|t| self.materials.get(t.material_index() as usize))
                    .is_some_and(|m| m.emissive_texture == NO_TEXTURE)
        })
    }

    pub fn frame_params(&self, settings: &RenderSettings) -> FrameParams {
        let mut frame = FrameParams {
            aspect: settings.width as f32 / settings.height as f32,
            width: settings.width,
            height: settings.height,
            seed: settings.seed,
            max_depth: settings.max_depth,
            light_count: self.lights.len() as u32,
            rr_start_depth: settings.rr_start_depth,
            debug_flags: settings.debug_flags,
            aov: settings.aov,
            tlas_root: self.tlas_root,
            // The GPU renderer names the quantised top level (`gpu_bvh`); the CPU walks its own.
            tlas_wide_root: crate::layout::NO_WIDE_ROOT,
            band_first_pixel: 0,
            band_pixel_count: settings.width * settings.height,
            mis_heuristic: settings.mis.code_and_beta().0,
            mis_beta: settings.mis.code_and_beta().1,
            spp: settings.spp,
            sampler_mode: settings.sampler,
            rr_mode: settings.rr_mode,
            light_sampler: if self.light_nodes.is_empty() || self.light_power_alike {
                LIGHT_SAMPLER_POWER
            } else {
                settings.light_sampler
            },
            light_bounded_cdf: self.light_bounded_cdf,
            integrator: match settings.integrator {
                Integrator::Path => crate::layout::INTEGRATOR_PATH,
                Integrator::Light => crate::layout::INTEGRATOR_LIGHT,
                Integrator::Bdpt => crate::layout::INTEGRATOR_BDPT,
            },
            // KHR_materials_dispersion: light tracing and BDPT carry a wavelength per sample.
            spectral: u32::from(self.materials.iter().any(crate::spectrum::is_dispersive)),
            // The camera's fields: written below.
            ..FrameParams::default()
        };
        let lens = self.thin_lens(settings).unwrap_or_default();
        self.camera.write_frame_params(lens, &mut frame);
        if settings.finest_textures {
            // A cone of no width reads every texture at level 0 (`surface_lod_base`).
            frame.cone_width = 0.0;
            frame.cone_spread = 0.0;
        }
        if let Some((map, scale)) = settings.environment_map() {
            map.write_frame_params(scale, settings.env_rotate, &mut frame);
            // The environment's power through the scene's bounding disc, π·R²·∫L dω, against
            // the emitters' (as for a directional light, `punctual_power`).
            let env_power =
                std::f32::consts::PI * self.radius * self.radius * map.power * luminance(scale);
            frame.env_pmf = if self.light_power > 0.0 {
                let p = env_power / (env_power + self.light_power);
                if p.is_finite() {
                    p
                } else {
                    0.0
                }
            } else {
                1.0
            };
        }
        frame
    }
}
