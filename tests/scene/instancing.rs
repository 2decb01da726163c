//! Meshes shared by many placements are stored once and traced through the two-level BVH
//! (src/tlas.rs): scenes/instances.gltf (tools/gen_scenes.py) places two meshes 1000 times —
//! 600 nodes and one EXT_mesh_gpu_instancing node with 400 instances — with rotations,
//! non-uniform scales and mirroring. Its memory grows with the placements, not placements ×
//! triangles; its instanced render has the expectation of the same scene baked into world
//! space (an independent path: the baked loader swaps mirrored winding, the instanced one
//! transforms normals), and the GPU agrees with the CPU on it.

use crate::common::{assert_agree_at, gpu_agrees_with_cpu, render_cpu, scene_path};
use glam::Vec3;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{Budget, LoadOptions, Scene};

fn load(instancing: bool, budget: u64) -> anyhow::Result<Scene> {
    Scene::load_with(
        &scene_path("instances.gltf"),
        &LoadOptions {
            allow_paths: Vec::new(),
            budget: Budget::new(budget),
            instancing,
        },
    )
}

fn settings(seed: u32) -> RenderSettings {
    RenderSettings {
        width: 48,
        height: 32,
        spp: 64,
        max_depth: 4,
        seed,
        environment: Vec3::splat(0.2),
        ..RenderSettings::default()
    }
}

#[test]
fn a_thousand_placements_are_stored_once() {
    let scene = load(true, 1 << 30).unwrap();
    assert_eq!(scene.meshes.len(), 2);
    assert_eq!(scene.instances.len(), 1000);
    // Floor and light are baked (the light emits; each is used once).
    assert_eq!(scene.triangles.len(), 4);
    assert_eq!(
        scene
            .meshes
            .iter()
            .map(|m| m.triangles.len())
            .sum::<usize>(),
        1280 + 12
    );
    assert_eq!(scene.rendered_triangles(), 4 + 600 * 1280 + 400 * 12);
    assert!(scene.notes.is_empty(), "{:?}", scene.notes);
}

/// The budget the loader reserves is what the scene and its preparation will take: 16 MiB
/// holds the instanced scene, while baking its 772,804 triangles needs several times more.
#[test]
fn memory_grows_with_placements_not_placements_times_triangles() {
    const BUDGET: u64 = 16 << 20;
    let scene = load(true, BUDGET).unwrap_or_else(|e| panic!("{e:#}"));
    let prepared = PreparedScene::new(&scene);
    assert_eq!(prepared.instances.len(), 1001);
    let baked = load(false, BUDGET).expect_err("baking 772,804 triangles fits in 16 MiB");
    assert!(format!("{baked:#}").contains("memory budget"), "{baked:#}");
}

#[test]
fn instanced_render_has_the_expectation_of_the_baked_scene() {
    let instanced = PreparedScene::new(&load(true, 1 << 30).unwrap());
    let baked_scene = load(false, 4 << 30).unwrap();
    assert!(baked_scene.meshes.is_empty() && baked_scene.instances.is_empty());
    let baked = PreparedScene::new(&baked_scene);
    let a = render_cpu(&instanced, &settings(1));
    let b = render_cpu(&baked, &settings(2));
    assert_eq!(a.film.dropped + b.film.dropped, 0);
    assert_agree_at(&a.film, &b.film, 0.01, "instanced vs baked (CPU)");
}

#[test]
fn gpu_agrees_with_cpu_on_instances() {
    let scene = PreparedScene::new(&load(true, 1 << 30).unwrap());
    gpu_agrees_with_cpu(&scene, &settings(3), &settings(4), "instances.gltf");
}

/// The CPU integrators' 4-wide walk of both levels (`bvh::wide`) and the GPU's walk of both
/// levels in the same nodes quantised (`qbvh.glsl`, `tlas.glsl`; here the CPU's walk of those
/// nodes, its twin) find the hits of the binary walk (`bvh.glsl`, the GPU's where a level has no
/// quantised nodes): the same distance, and the same triangle, instance and (u, v) unless two
/// surfaces lie at exactly that distance. Rays from a grid of origins around the scene towards
/// points inside it, and shadow-ray ranges around each hit.
#[test]
fn wide_and_binary_walks_find_the_same_hits() {
    use wavetrace::bvh::{Hierarchy, Hit, Ray};
    use wavetrace::tlas::{scene_intersect_any, scene_intersect_closest};
    fn closest<H: Hierarchy + ?Sized>(
        tree: &H,
        p: &PreparedScene,
        ray: &Ray,
    ) -> Option<(Hit, u32)> {
        let (instances, triangles) = (&p.instances, &p.triangles);
        scene_intersect_closest(
            tree,
            p.tlas_root,
            instances,
            triangles,
            ray,
            0.0,
            f32::MAX,
            |_, _, _, _, _| true,
        )
    }
    fn any<H: Hierarchy + ?Sized>(tree: &H, p: &PreparedScene, ray: &Ray, t_max: f32) -> bool {
        let (instances, triangles) = (&p.instances, &p.triangles);
        scene_intersect_any(
            tree,
            p.tlas_root,
            instances,
            triangles,
            ray,
            0.0,
            t_max,
            |_, _, _, _, _| true,
        )
    }
    let scene = load(true, 1 << 30).unwrap();
    let p = PreparedScene::new(&scene);
    let (lo, hi) = p.bounds();
    let (binary, wide) = (p.bvh.nodes.as_slice(), p.wide_bvh());
    let quant = wavetrace::bvh::wide::WideBvh::collapse(binary, &p.level_roots()).quantized();
    // The GPU walks both levels of this scene in their quantised nodes.
    let gpu = p.gpu_bvh();
    assert_ne!(gpu.tlas_wide_root, wavetrace::layout::NO_WIDE_ROOT);
    assert!(gpu
        .instances
        .iter()
        .all(|i| i.wide_root != wavetrace::layout::NO_WIDE_ROOT));
    let (mut hits, mut ties) = (0, 0);
    let steps = 24;
    for i in 0..steps * steps * steps {
        let f = |k: u32| (k as f32 + 0.5) / steps as f32;
        let g = Vec3::new(f(i % steps), f(i / steps % steps), f(i / (steps * steps)));
        let origin = lo - (hi - lo) * 0.25 + (hi - lo) * 1.5 * g;
        let target = lo + (hi - lo) * Vec3::new(g.z, g.x, g.y);
        let ray = Ray {
            origin,
            dir: target - origin,
        };
        let a = closest(binary, &p, &ray);
        for (b, walk) in [
            (closest(wide, &p, &ray), "wide"),
            (closest(&quant, &p, &ray), "quantised"),
        ] {
            match (a, b) {
                (Some(x), Some(y)) if (x.0.triangle, x.1) != (y.0.triangle, y.1) => {
                    assert_eq!(x.0.t, y.0.t, "{walk}: {ray:?}");
                    ties += 1;
                }
                _ => assert_eq!(a, b, "{walk}: {ray:?}"),
            }
        }
        hits += a.is_some() as u32;
        let t = a.map_or(1.0, |h| h.0.t);
        for t_max in [t * 0.999, t * 1.001] {
            let expected = any(binary, &p, &ray, t_max);
            assert_eq!(
                expected,
                any(wide, &p, &ray, t_max),
                "wide: {ray:?} t_max {t_max}"
            );
            assert_eq!(
                expected,
                any(&quant, &p, &ray, t_max),
                "quantised: {ray:?} t_max {t_max}"
            );
        }
    }
    assert!(hits > 5000, "{hits} hits: the test is too weak");
    assert!(ties < hits / 50, "{ties} ties in {hits} hits of two walks");
}

/// The kernels' two deferred arrays are made for their own levels
/// (`PreparedScene::gpu_features`): the top level's walk holds its array while an instance's walk
/// holds the bottom levels' one, so each takes its own levels' largest deferred bound
/// (`WideBvh::deferred_bound`) less the two slots kept in registers — here a top level over 1 000
/// placements and bottom levels over two meshes, whose bounds differ. A scene without a top level
/// makes the smallest top-level array (its walk is compiled out).
#[test]
fn the_top_level_and_the_bottom_levels_have_deferred_arrays_of_their_own() {
    use wavetrace::bvh::quantized::GPU_DEFERRED_REGISTERS;
    use wavetrace::bvh::WideBvh;
    use wavetrace::layout::{qbvh_stack_size, tlas_stack_size, FEATURE_TOP_LEVEL};
    let scene = PreparedScene::new(&load(true, 1 << 30).unwrap());
    let quant = WideBvh::collapse(&scene.bvh.nodes, &scene.level_roots()).quantized();
    let bound = |binary: u32| quant.root(binary).map_or(0, |w| quant.deferred_bound(w));
    let top = bound(scene.tlas_root);
    let bottom = scene
        .instances
        .iter()
        .map(|i| bound(i.blas_root))
        .max()
        .unwrap();
    assert_ne!(top, bottom, "the test needs levels of different bounds");
    let features = scene.gpu_features(&settings(1));
    assert_ne!(features & FEATURE_TOP_LEVEL, 0);
    assert_eq!(tlas_stack_size(features), top - GPU_DEFERRED_REGISTERS);
    assert_eq!(qbvh_stack_size(features), bottom - GPU_DEFERRED_REGISTERS);
    let baked = PreparedScene::new(&load(false, 1 << 30).unwrap());
    let features = baked.gpu_features(&settings(1));
    assert_eq!(features & FEATURE_TOP_LEVEL, 0);
    assert_eq!(tlas_stack_size(features), 1);
}
