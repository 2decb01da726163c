//! The GPU wavefront integrator against the CPU reference on the Cornell box (DESIGN.md,
//! Verification 3 and 4): per-tile Welch tests at family-wise α = 0.01 (Šidák over tiles ×
//! channels); a deliberately biased GPU render must fail the same test; same seed ⇒ the same
//! bits, whatever the batch size; orthographic and thin-lens cameras agree too.

use crate::common;

use crate::common::{
    assert_agree, gpu_agrees_with_cpu, prepared, render_cpu, render_gpu, render_gpu_banded,
};
use wavetrace::film::Film;
use wavetrace::layout::{DEBUG_NO_NEE, SAMPLER_INDEPENDENT, SAMPLER_SOBOL};
use wavetrace::mis::Heuristic;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{Camera, Projection, Scene};
use wavetrace::stats::{compare_films, film_mean, Comparison};

const TILE: u32 = 8;
const ALPHA: f64 = 0.01;

/// The per-tile comparison of a GPU and a CPU film, printed.
fn compare(gpu: &Film, cpu: &Film) -> Comparison {
    let cmp = compare_films(gpu, cpu, TILE, ALPHA).unwrap();
    println!("{cmp}");
    cmp
}

/// The smaller configuration of the other comparisons: 32×32 at 128 spp.
fn small(seed: u32) -> RenderSettings {
    RenderSettings {
        width: 32,
        height: 32,
        spp: 128,
        ..settings(seed)
    }
}

/// The acceptance render: `--width 64 --height 64 --spp 512 --max-depth 7`.
fn settings(seed: u32) -> RenderSettings {
    RenderSettings {
        width: 64,
        height: 64,
        spp: 512,
        max_depth: 7,
        seed,
        ..RenderSettings::default()
    }
}

#[test]
fn gpu_matches_cpu_reference_on_cornell_box() {
    let scene = prepared("cornell-box.gltf");
    gpu_agrees_with_cpu(&scene, &settings(1), &settings(2), "GPU and CPU disagree");
}

#[test]
fn comparison_detects_a_dropped_nee_term() {
    let scene = prepared("cornell-box.gltf");
    let short = |seed| RenderSettings {
        spp: 64,
        ..small(seed)
    };
    let biased = RenderSettings {
        debug_flags: DEBUG_NO_NEE,
        ..short(1)
    };
    let Some(gpu) = render_gpu(&scene, &biased, None) else {
        return;
    };
    let cpu = render_cpu(&scene, &short(2));
    let cmp = compare(&gpu.film, &cpu.film);
    assert!(
        !cmp.passed(),
        "a GPU render without next event estimation passed the comparison"
    );
}

#[test]
fn same_seed_gives_identical_bits_whatever_the_batch_and_band_size() {
    let scene = prepared("cornell-box.gltf");
    let s = RenderSettings {
        width: 32,
        height: 32,
        spp: 16,
        ..settings(9)
    };
    let Some(a) = render_gpu(&scene, &s, None) else {
        return;
    };
    let b = render_gpu(&scene, &s, None).unwrap();
    let c = render_gpu(&scene, &s, Some(1000)).unwrap();
    // Bands of 9 rows (at most 300 pixels): four bands, the last one of 5 rows.
    let d = render_gpu_banded(&scene, &s, 300).unwrap();
    for (i, pd) in d.film.pixels.iter().enumerate() {
        let pa = &a.film.pixels[i];
        assert_eq!(
            bytemuck::bytes_of(pa),
            bytemuck::bytes_of(pd),
            "pixel {i} differs in bands"
        );
    }
    for (i, ((pa, pb), pc)) in a
        .film
        .pixels
        .iter()
        .zip(&b.film.pixels)
        .zip(&c.film.pixels)
        .enumerate()
    {
        assert_eq!(
            bytemuck::bytes_of(pa),
            bytemuck::bytes_of(pb),
            "pixel {i} differs between two runs"
        );
        assert_eq!(
            bytemuck::bytes_of(pa),
            bytemuck::bytes_of(pc),
            "pixel {i} differs with --wavefront 1000"
        );
    }
    assert_eq!(a.stats.extension_rays, c.stats.extension_rays);
}

#[test]
fn cpu_is_deterministic() {
    let scene = prepared("cornell-box.gltf");
    let s = RenderSettings {
        width: 32,
        height: 32,
        spp: 8,
        ..settings(4)
    };
    let a = render_cpu(&scene, &s);
    let b = render_cpu(&scene, &s);
    assert!(
        a.film.pixels == b.film.pixels,
        "two CPU renders with the same seed differ"
    );
}

#[test]
fn gpu_matches_cpu_with_an_environment() {
    // Rays leaving the box through its open front see a uniform environment.
    let scene = prepared("cornell-box.gltf");
    let lit = |seed| RenderSettings {
        environment: glam::Vec3::new(0.5, 0.7, 1.0),
        ..small(seed)
    };
    gpu_agrees_with_cpu(
        &scene,
        &lit(5),
        &lit(6),
        "GPU and CPU disagree with an environment",
    );
}

/// The GPU with each of the seed's weightings against the CPU with the power heuristic: every
/// combination has the same expectation.
#[test]
fn every_mis_heuristic_agrees_with_the_reference() {
    let scene = prepared("cornell-box.gltf");
    let cpu = render_cpu(&scene, &small(8));
    for mis in [
        Heuristic::Average,
        Heuristic::Maximum,
        Heuristic::Balance,
        Heuristic::Power(3.0),
    ] {
        let Some(gpu) = render_gpu(&scene, &RenderSettings { mis, ..small(7) }, None) else {
            return;
        };
        assert_agree(
            &gpu.film,
            &cpu.film,
            &format!("GPU with {mis:?} disagrees with the CPU reference"),
        );
    }
}

/// The independent sampler against the (default) stratified one: same expectation.
#[test]
fn independent_and_stratified_samplers_agree() {
    let scene = prepared("cornell-box.gltf");
    let independent = RenderSettings {
        sampler: SAMPLER_INDEPENDENT,
        ..small(11)
    };
    gpu_agrees_with_cpu(
        &scene,
        &independent,
        &small(12),
        "independent (GPU) and stratified (CPU) samplers disagree",
    );
}

/// The Sobol sampler on the GPU against the (default) stratified one on the CPU: same expectation.
#[test]
fn sobol_and_stratified_samplers_agree() {
    let scene = prepared("cornell-box.gltf");
    let sobol = RenderSettings {
        sampler: SAMPLER_SOBOL,
        ..small(16)
    };
    gpu_agrees_with_cpu(
        &scene,
        &sobol,
        &small(17),
        "Sobol (GPU) and stratified (CPU) samplers disagree",
    );
}

/// A validation-layer error fails the render that follows it (DESIGN.md, Verification 6).
#[test]
fn validation_errors_fail_the_render() {
    let scene = prepared("cornell-box.gltf");
    let Some(gpu) = common::gpu() else { return };
    if !gpu
        .context()
        .report_validation_error_for_test(c"test: a deliberate validation error")
    {
        eprintln!("skipping: the validation layer is not installed");
        return;
    }
    let s = RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        ..settings(1)
    };
    let result = gpu.render(&scene, &s, None);
    let errors = gpu.context().take_validation_errors();
    let message = format!(
        "{:#}",
        result
            .err()
            .expect("the render succeeded despite a validation error")
    );
    assert!(message.contains("deliberate validation error"), "{message}");
    assert_eq!(errors.len(), 1);
}

/// A double-sided light (its back lights the ceiling just above it): emission from both faces,
/// twice the power in the emitter table, |cos| in the light pdf, on both integrators.
#[test]
fn double_sided_emitters_agree() {
    let mut scene = Scene::load(&common::scene_path("cornell-box.gltf")).unwrap();
    for m in scene
        .materials
        .iter_mut()
        .filter(|m| m.emission.max_element() > 0.0)
    {
        m.double_sided = true;
    }
    let scene = PreparedScene::new(&scene);
    let Some(cpu) = gpu_agrees_with_cpu(
        &scene,
        &small(13),
        &small(14),
        "GPU and CPU disagree with a double-sided light",
    ) else {
        return;
    };
    // The back face adds light to the box: the image mean must exceed the one-sided one by more
    // than 4 standard errors of the difference (independent seeds).
    let one_sided = render_cpu(&prepared("cornell-box.gltf"), &small(15));
    let ((m2, e2), (m1, e1)) = (film_mean(&cpu), film_mean(&one_sided.film));
    // The standard error of a sum of correlated channels is at most the sum of theirs.
    let z = (m2.element_sum() - m1.element_sum()) / e2.element_sum().hypot(e1.element_sum());
    println!(
        "double-sided light: image mean {} vs {} one-sided, z = {z:.1}",
        m2, m1
    );
    assert!(z > 4.0, "the light's back face added no light: z = {z:.2}");
}

/// The Cornell box seen by another camera at the file camera's place (0, 0, 3.9), looking down −Z.
fn cornell_box_with(projection: Projection, znear: f32) -> PreparedScene {
    let mut scene = Scene::load(&common::scene_path("cornell-box.gltf")).unwrap();
    scene.camera = Camera {
        projection,
        znear,
        ..scene.camera
    };
    PreparedScene::new(&scene)
}

/// An orthographic camera whose near plane (z = 0.5) cuts through the two boxes: parallel rays,
/// some starting inside a box, on both integrators.
#[test]
fn orthographic_camera_agrees() {
    let scene = cornell_box_with(
        Projection::Orthographic {
            xmag: 1.1,
            ymag: 1.1,
        },
        3.4,
    );
    gpu_agrees_with_cpu(
        &scene,
        &small(21),
        &small(22),
        "GPU and CPU disagree with an orthographic camera",
    );
}

/// A thin lens of diameter 1 focused 1.0 in front of the camera, 3 to 5 before the box's walls:
/// every part of the box blurs by a wide circle, so the lens's effect on the tiles is far above
/// the noise of 128 spp (focused mid-box at 3.4 the blur reached few tiles, and once the BVH
/// renumbered the triangles the pinhole comparison below missed it: p = 3.6e-3 against
/// α = 2.1e-4). Rays through one film point spread over the lens, drawn from the camera block's
/// spare pair on both integrators; a pinhole render must fail the same comparison.
#[test]
fn thin_lens_agrees() {
    let scene = prepared("cornell-box.gltf");
    let lens = |seed| RenderSettings {
        aperture: 1.0,
        focus_distance: Some(1.0),
        ..small(seed)
    };
    assert_eq!(scene.thin_lens(&lens(0)).unwrap().radius, 0.5);
    let Some(cpu) = gpu_agrees_with_cpu(
        &scene,
        &lens(23),
        &lens(24),
        "GPU and CPU disagree with a thin lens",
    ) else {
        return;
    };
    let pinhole = render_cpu(&scene, &small(25));
    assert!(
        !compare(&cpu, &pinhole.film).passed(),
        "the thin lens renders what a pinhole does"
    );
}

/// `render --stats`'s cost model: counting each kernel's scene-image fetches changes no bit of
/// the image, the counts are the same on every run, the kernels that read no scene data count
/// none, and every extension ray fetches at least the BVH root (two texels), every shadow ray
/// too (the Cornell box is not one instance, so the root is read per ray).
#[test]
fn fetch_counts_are_deterministic_and_change_nothing() {
    let scene = prepared("cornell-box.gltf");
    let settings = small(11);
    let Some(mut gpu) = common::gpu() else { return };
    let plain = gpu.render(&scene, &settings, None).unwrap();
    gpu.set_count_fetches(true);
    let counted = gpu.render(&scene, &settings, None);
    let again = gpu.render(&scene, &settings, None);
    gpu.set_count_fetches(false);
    drop(gpu);
    let (counted, again) = (counted.unwrap(), again.unwrap());
    common::assert_same_bits(&plain.film, &counted.film, "with fetch counts");
    assert!(plain.stats.kernel_fetches.is_empty());
    assert_eq!(counted.stats.kernel_fetches, again.stats.kernel_fetches);
    let fetches = |k: &str| {
        counted
            .stats
            .kernel_fetches
            .iter()
            .find(|(name, _)| name == k)
            .map_or(0, |(_, n)| *n)
    };
    println!("{:?}", counted.stats.kernel_fetches);
    for quiet in ["accumulate", "dispatch_args"] {
        assert_eq!(fetches(quiet), 0, "{quiet} reads no scene data");
    }
    assert!(fetches("extend") >= 2 * counted.stats.extension_rays);
    assert!(fetches("connect") >= 2 * counted.stats.shadow_rays);
    // shade reads a triangle, its vertices and its material per hit.
    assert!(fetches("shade") >= counted.stats.extension_rays);
}

/// The GPU's walks are the CPU reference's twins: `extend`, the render's kernel made for each
/// scene's features, finds for every one of 4096 random rays (uniform points of the scene's
/// box, uniform directions) the hit `PreparedScene::intersect_closest` finds with the same alpha
/// key — a plain tree (Cornell box), a top level over instances, a two-sided leaf over a floor,
/// and where the samples are present AlphaBlendModeTest's masked and blended materials (whose
/// stochastic alpha test reads the key). On a device whose
/// arithmetic is IEEE single precision without fused operations (llvmpipe) the same triangle
/// at the same t, bit for bit; on another (a GPU may fuse a multiply and an add) the same
/// triangle on all but rays through an edge, at a t within 1e-5 relative. And `connect` finds
/// the same rays, cut at random lengths, blocked where `PreparedScene::intersect_any` does.
#[test]
fn the_gpu_walk_finds_the_cpu_references_hits() {
    use wavetrace::layout::NO_HIT;
    let samples = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples/valid/AlphaBlendModeTest.glb");
    let mut scenes: Vec<(String, PreparedScene)> =
        ["cornell-box.gltf", "instances.gltf", "leaf.gltf"]
            .iter()
            .map(|name| (name.to_string(), prepared(name)))
            .collect();
    match Scene::load(&samples) {
        Ok(scene) => scenes.push(("AlphaBlendModeTest.glb".into(), PreparedScene::new(&scene))),
        Err(_) => eprintln!("skipping AlphaBlendModeTest: ../shared/gltf-samples not found"),
    }
    let Some(gpu) = common::gpu() else { return };
    let exact = gpu.device().name.contains("llvmpipe");
    for (name, scene) in &scenes {
        let (lo, hi) = scene.bounds();
        let rays: Vec<(glam::Vec3, glam::Vec3)> = (0..4096u32)
            .map(|i| {
                let u = wavetrace::sampling::rng_uniform4(5, i, 0, 0);
                let o = wavetrace::sampling::rng_uniform4(5, i, 0, 1);
                let dir = wavetrace::sampling::sample_uniform_cone(glam::Vec2::new(u.x, u.y), -1.0);
                (lo + (hi - lo) * o.truncate(), dir)
            })
            .collect();
        let traced = gpu.trace_closest(scene, &rays, 7, 1).unwrap();
        assert_eq!(traced.hits.len(), rays.len(), "{name}");
        let (mut hits, mut edges) = (0, 0);
        for (i, ((origin, dir), g)) in rays.iter().zip(&traced.hits).enumerate() {
            let key = wavetrace::surface::alpha_key(7, i as u32, 0, 0, false);
            let ray = wavetrace::bvh::Ray {
                origin: *origin,
                dir: *dir,
            };
            let c = scene
                .intersect_closest(&ray, 0.0, f32::MAX, key)
                .map(|(h, _)| h);
            let where_ = format!("{name}, ray {i} from {origin} along {dir}: GPU {g:?}, CPU {c:?}");
            match c {
                None => assert_eq!(g.triangle, NO_HIT, "{where_}"),
                Some(c) => {
                    hits += 1;
                    assert_ne!(g.triangle, NO_HIT, "{where_}");
                    if exact {
                        assert_eq!(
                            (g.triangle, g.t.to_bits()),
                            (c.triangle, c.t.to_bits()),
                            "{where_}"
                        );
                    } else if g.triangle != c.triangle {
                        edges += 1;
                    } else {
                        assert!((g.t - c.t).abs() <= 1e-5 * c.t.abs(), "{where_}");
                    }
                }
            }
        }
        println!(
            "{name}: {hits} of {} rays hit; {edges} on another triangle",
            rays.len()
        );
        assert!(hits > 0, "{name}: no ray hit anything");
        assert!(
            edges * 1000 <= hits,
            "{name}: {edges} of {hits} hits on another triangle"
        );
        // The same rays as shadow rays (`connect`), cut at lengths up to the box's diagonal.
        let shadows: Vec<(glam::Vec3, glam::Vec3, f32)> = rays
            .iter()
            .enumerate()
            .map(|(i, &(o, d))| {
                (
                    o,
                    d,
                    (hi - lo).length() * wavetrace::sampling::rng_uniform4(5, i as u32, 0, 2).x,
                )
            })
            .collect();
        let blocked = gpu.trace_any(scene, &shadows, 7, 1).unwrap();
        let (mut agree, mut occluded) = (0, 0);
        for (i, (&(origin, dir, t_max), &g)) in shadows.iter().zip(&blocked.blocked).enumerate() {
            let key = wavetrace::surface::alpha_key(7, i as u32, 0, 0, true);
            let ray = wavetrace::bvh::Ray { origin, dir };
            let c = scene.intersect_any(&ray, 0.0, t_max, key);
            occluded += c as usize;
            agree += (c == g) as usize;
        }
        println!(
            "{name}: {occluded} of {} shadow rays blocked; the GPU agrees on {agree}",
            rays.len()
        );
        assert!(
            occluded > 0 && occluded < rays.len(),
            "{name}: {occluded} blocked"
        );
        match exact {
            true => assert_eq!(agree, rays.len(), "{name}: shadow rays"),
            false => assert!(
                (rays.len() - agree) * 1000 <= rays.len(),
                "{name}: shadow rays"
            ),
        }
    }
}

/// A render reports how many kernels it made before its first sample: a second render with
/// the same features makes none (the renderer keeps its pipelines), and no render makes more
/// than its integrator dispatches.
#[test]
fn a_render_reports_the_kernels_it_made_and_a_second_makes_none() {
    let scene = prepared("cornell-box.gltf");
    let Some(gpu) = common::gpu() else { return };
    let first = gpu.render(&scene, &small(14), None).unwrap();
    let second = gpu.render(&scene, &small(15), None).unwrap();
    drop(gpu);
    let kernels = wavetrace::gpu::wavefront::kernels(wavetrace::render::Integrator::Path).len();
    let (made, seconds) = first
        .stats
        .kernels_made
        .expect("a GPU render reports its kernels");
    assert!(made <= kernels, "{made} of {kernels} kernels made");
    assert!(
        seconds >= 0.0 && (made == 0 || seconds > 0.0),
        "{made} made in {seconds} s"
    );
    assert_eq!(second.stats.kernels_made.map(|(n, _)| n), Some(0));
}

/// `render --stats` and `bench` show what the driver made of each kernel where the device
/// reports it (`VK_KHR_pipeline_executable_properties`: NVIDIA's registers and local memory,
/// for instance): then every kernel the path tracer dispatches has statistics, each named and
/// each the same on a second render. lavapipe and SwiftShader report none; the test says so.
#[test]
fn kernel_statistics_cover_every_dispatched_kernel_where_the_driver_reports_them() {
    let scene = prepared("cornell-box.gltf");
    let Some(gpu) = common::gpu() else { return };
    let offered = gpu.context().executable_properties.is_some();
    let first = gpu.render(&scene, &small(12), None).unwrap();
    let second = gpu.render(&scene, &small(13), None).unwrap();
    let name = gpu.device().name.clone();
    drop(gpu);
    if !offered {
        assert!(first.stats.kernel_statistics.is_empty());
        println!("notice: {name} reports no kernel statistics; nothing to check");
        return;
    }
    let kernels = wavetrace::gpu::wavefront::kernels(wavetrace::render::Integrator::Path);
    let listed: Vec<&str> = first
        .stats
        .kernel_statistics
        .iter()
        .map(|(k, _)| k.as_str())
        .collect();
    assert_eq!(listed, kernels, "kernels with statistics");
    for (kernel, statistics) in &first.stats.kernel_statistics {
        println!(
            "{kernel}: {}",
            wavetrace::render::statistics_line(statistics)
        );
        assert!(!statistics.is_empty(), "{kernel} has no statistics");
        assert!(
            statistics.iter().all(|s| !s.name.is_empty()),
            "{kernel}: an unnamed statistic"
        );
    }
    assert_eq!(
        first.stats.kernel_statistics,
        second.stats.kernel_statistics
    );
}
