//! Environment maps on both integrators (src/lights/environment.rs, shaders/inc/environment.glsl):
//!
//! - a map that is 1 above the horizon and 0 below lights an upward Lambertian plane with its
//!   albedo (less the map's own bilinear ramp at the horizon, integrated here exactly), and
//!   leaves its underside exactly black;
//! - sampled directions follow the density MIS uses (χ² against env_pdf integrated per bin);
//! - a constant map renders as `--environment` of that value;
//! - on a small bright "sun", environment sampling with MIS cuts the variance against BSDF
//!   sampling alone (the factor is printed), with the same mean;
//! - the GPU agrees with the CPU per tile, with a synthetic map turned by --env-rotate and with
//!   an HDR file from ../shared/gltf-samples/env/ (skipped where absent);
//! - the built-in studio (src/lights/studio.rs) lights an upward plane with ρ/π times its
//!   irradiance, integrated here from the lookup, on CPU and GPU; a file without lights is lit
//!   by it with a note, `--env none` and `--environment 0` keep it black, a file with lights
//!   keeps its own;
//! - `--sky` (src/lights/sky.rs): its map and sun light an upward plane with ρ/π times their
//!   irradiance, on CPU and GPU; its options out of range are refused by name.

use crate::common;

use crate::common::{assert_agree_at, render_cpu, render_gpu};
use glam::{Vec2, Vec3};
use std::f64::consts::PI;
use std::sync::Arc;
use wavetrace::layout::{FrameParams, GpuPunctualLight};
use wavetrace::lights::environment::{env_pdf, env_sample, EnvironmentMap};
use wavetrace::mis::Heuristic;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::sampling::rng_uniform4;
use wavetrace::scene::{Camera, Material, Projection, Scene, Triangle};
use wavetrace::stats::{chi_square_gof, compare_films, normal_quantile_upper, sidak};

const ALBEDO: f32 = 0.5;
const SIZE: u32 = 16;

/// The plane y = 0 over [-4, 4]², front face +Y, double-sided Lambertian, seen by an
/// orthographic camera from above (`from_below` false) or from below.
fn plane_scene(from_below: bool) -> PreparedScene {
    plane_scene_lit(from_below, Vec::new())
}

/// [`plane_scene`] with punctual lights.
fn plane_scene_lit(from_below: bool, punctual: Vec<GpuPunctualLight>) -> PreparedScene {
    let s = 4.0;
    let (a, b, c, d) = (
        Vec3::new(-s, 0.0, -s),
        Vec3::new(-s, 0.0, s),
        Vec3::new(s, 0.0, s),
        Vec3::new(s, 0.0, -s),
    );
    let material = Material {
        name: "plane".into(),
        base_color: Vec3::splat(ALBEDO),
        metallic: 0.0,
        roughness: 1.0,
        specular: 0.0,
        double_sided: true,
        ..Material::default_white()
    };
    let sign = if from_below { -1.0 } else { 1.0 };
    PreparedScene::new(&Scene {
        source: "test".into(),
        triangles: vec![Triangle::flat([a, b, c], 0), Triangle::flat([a, c, d], 0)],
        materials: vec![material],
        vertices: Vec::new(),
        textures: Default::default(),
        meshes: Vec::new(),
        instances: Vec::new(),
        punctual,
        camera: Camera {
            position: Vec3::new(0.0, 5.0 * sign, 0.0),
            forward: Vec3::new(0.0, -sign, 0.0),
            right: Vec3::X,
            up: Vec3::new(0.0, 0.0, -sign),
            projection: Projection::Orthographic {
                xmag: 2.0,
                ymag: 2.0,
            },
            znear: 0.0,
        },
        cameras: Vec::new(),
        dropped_degenerate: 0,
        skipped_primitives: 0,
        notes: Vec::new(),
    })
}

fn settings(map: &Arc<EnvironmentMap>, seed: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width: SIZE,
        height: SIZE,
        spp,
        max_depth: 1,
        seed,
        env_map: Some(Arc::clone(map)),
        ..RenderSettings::default()
    }
}

/// 1 above the horizon, 0 below: 2k + 1 rows, so the centre of row k (the first black one)
/// lies on the horizon and the bilinear lookup is exactly 0 for every direction below it.
fn horizon_map(k: u32) -> Arc<EnvironmentMap> {
    let (w, h) = (16, 2 * k + 1);
    let rgb: Vec<Vec3> = (0..w * h)
        .map(|t| if t / w < k { Vec3::ONE } else { Vec3::ZERO })
        .collect();
    Arc::new(EnvironmentMap::from_rgb(w, h, &rgb).unwrap())
}

/// Every pixel's mean within z standard errors of `want` (z at family-wise α = 0.01 over the
/// pixels and channels, Šidák), plus f32 rounding.
fn assert_pixels_near(film: &wavetrace::film::Film, want: Vec3, what: &str) {
    let z_max = normal_quantile_upper(sidak(0.01, film.pixels.len() * 3) / 2.0) as f32;
    for i in 0..film.pixels.len() {
        let got = film.mean(i);
        let se = film.variance_of_mean(i).to_array().map(f32::sqrt);
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() <= z_max * se[c] + 1e-5 * want[c] + 1e-6,
                "{what}: pixel {i} channel {c}: {} vs {} ± {}",
                got[c],
                want[c],
                se[c]
            );
        }
    }
}

#[test]
fn horizon_map_gives_the_albedo_above_and_nothing_below() {
    let k = 16u32;
    let map = horizon_map(k);
    // L(θ) is 1 down to the centre of row k − 1 (θ1 = π(k − ½)/(2k + 1)), then falls linearly
    // in θ to 0 at the horizon; a Lambertian plane returns ρ·(1 − 2∫(1 − L) cos θ sin θ dθ).
    let theta1 = PI * (k as f64 - 0.5) / (2 * k + 1) as f64;
    let n = 20000;
    let h = (PI / 2.0 - theta1) / n as f64;
    let mut lost = 0.0;
    for i in 0..n {
        let theta = theta1 + (i as f64 + 0.5) * h;
        let l = 1.0 - (theta - theta1) / (PI / 2.0 - theta1);
        lost += (1.0 - l) * theta.cos() * theta.sin() * h;
    }
    let want = ALBEDO as f64 * (1.0 - 2.0 * lost);
    println!("upward plane: expected {want} (albedo {ALBEDO} less the horizon ramp)");

    let above = plane_scene(false);
    let cpu = render_cpu(&above, &settings(&map, 3, 256));
    assert_eq!(cpu.film.dropped, 0);
    assert_pixels_near(&cpu.film, Vec3::splat(want as f32), "upward plane (CPU)");
    if let Some(gpu) = render_gpu(&above, &settings(&map, 4, 256), None) {
        assert_pixels_near(&gpu.film, Vec3::splat(want as f32), "upward plane (GPU)");
        assert_agree_at(&gpu.film, &cpu.film, 0.01, "upward plane");
    }

    let below = plane_scene(true);
    let cpu = render_cpu(&below, &settings(&map, 3, 64));
    let gpu = render_gpu(&below, &settings(&map, 4, 64), None);
    for (film, side) in
        std::iter::once((&cpu.film, "CPU")).chain(gpu.as_ref().map(|g| (&g.film, "GPU")))
    {
        assert_eq!(film.pixels[0].count, 64);
        for (i, p) in film.pixels.iter().enumerate() {
            assert_eq!(p.sum, [0.0; 3], "{side}: underside pixel {i} is lit");
        }
    }
}

/// A map with structure at every scale: smooth sky, random texels and a bright small sun.
fn sky_map(w: u32, h: u32, sun: (u32, u32), sun_radiance: f32) -> Arc<EnvironmentMap> {
    let rgb: Vec<Vec3> = (0..w * h)
        .map(|t| {
            let (i, j) = (t % w, t / w);
            if (i, j) == sun {
                return Vec3::new(1.0, 0.9, 0.7) * sun_radiance;
            }
            let u = rng_uniform4(31, t, 0, 0);
            let sky = if j < h / 2 { 0.6 } else { 0.1 };
            Vec3::new(sky * (0.5 + u.x), sky * (0.5 + u.y), sky * (0.6 + u.z))
        })
        .collect();
    Arc::new(EnvironmentMap::from_rgb(w, h, &rgb).unwrap())
}

fn frame_for(map: &EnvironmentMap, degrees: f32) -> FrameParams {
    let mut frame = FrameParams::default();
    map.write_frame_params(Vec3::ONE, degrees, &mut frame);
    frame
}

#[test]
fn sampled_directions_follow_the_density() {
    let map = sky_map(48, 24, (30, 7), 500.0);
    let frame = frame_for(&map, 57.0);
    // Bins uniform in (φ, θ) about the world's +Y, unrelated to the map's cells.
    let (nb_phi, nb_theta) = (24usize, 16usize);
    let bin = |d: Vec3| -> usize {
        let phi = (d.z.atan2(d.x) as f64 + PI) / (2.0 * PI);
        let theta = (d.y.clamp(-1.0, 1.0) as f64).acos() / PI;
        let a = ((phi * nb_phi as f64) as usize).min(nb_phi - 1);
        let b = ((theta * nb_theta as f64) as usize).min(nb_theta - 1);
        b * nb_phi + a
    };
    let samples = 400_000u32;
    let mut observed = vec![0f64; nb_phi * nb_theta];
    for k in 0..samples {
        let u = rng_uniform4(77, k, 0, 0);
        let (d, pdf) = env_sample(&map, &frame, Vec2::new(u.x, u.y)).expect("a direction");
        assert!(pdf > 0.0 && pdf.is_finite());
        observed[bin(d)] += 1.0;
    }
    // Expected counts: env_pdf integrated over each bin (dω = sin θ dθ dφ), 48 × 48 midpoints.
    let m = 48;
    let mut expected = vec![0f64; nb_phi * nb_theta];
    let (d_theta, d_phi) = (PI / (nb_theta * m) as f64, 2.0 * PI / (nb_phi * m) as f64);
    for b in 0..nb_theta {
        for a in 0..nb_phi {
            let mut sum = 0.0;
            for j in 0..m {
                let theta = (b * m + j) as f64 * d_theta + 0.5 * d_theta;
                for i in 0..m {
                    let phi = -PI + (a * m + i) as f64 * d_phi + 0.5 * d_phi;
                    let d = Vec3::new(
                        (theta.sin() * phi.cos()) as f32,
                        theta.cos() as f32,
                        (theta.sin() * phi.sin()) as f32,
                    );
                    sum += env_pdf(&map, &frame, d) as f64 * theta.sin();
                }
            }
            expected[b * nb_phi + a] = sum * d_theta * d_phi * samples as f64;
        }
    }
    let total: f64 = expected.iter().sum::<f64>() / samples as f64;
    assert!((total - 1.0).abs() < 2e-3, "∫ env_pdf dω = {total}");
    let (chi2, dof, p) = chi_square_gof(&observed, &expected);
    println!("environment sampling: χ² = {chi2:.1}, dof = {dof}, p = {p:.3}");
    assert!(
        p > 0.001,
        "sampled directions do not follow env_pdf: χ² = {chi2}, dof = {dof}, p = {p}"
    );
}

#[test]
fn constant_map_equals_the_constant_environment() {
    let value = Vec3::new(0.8, 0.5, 0.3);
    let (w, h) = (40, 20);
    let map = Arc::new(EnvironmentMap::from_rgb(w, h, &vec![value; (w * h) as usize]).unwrap());
    let scene = common::prepared("furnace.gltf");
    let base = RenderSettings {
        width: 24,
        height: 24,
        spp: 128,
        max_depth: 6,
        ..RenderSettings::default()
    };
    let with_map = render_cpu(
        &scene,
        &RenderSettings {
            env_map: Some(map),
            seed: 1,
            ..base.clone()
        },
    );
    let constant = render_cpu(
        &scene,
        &RenderSettings {
            environment: value,
            seed: 2,
            ..base
        },
    );
    assert_agree_at(
        &with_map.film,
        &constant.film,
        0.01,
        "constant map vs --environment",
    );
}

#[test]
fn environment_sampling_cuts_the_variance_of_a_sun() {
    // One texel of 64 × 32 carries a sun 4000 times brighter than the sky.
    let map = sky_map(64, 32, (20, 9), 4000.0);
    let scene = plane_scene(false);
    let run = |mis: Heuristic, seed: u32| {
        render_cpu(
            &scene,
            &RenderSettings {
                mis,
                ..settings(&map, seed, 256)
            },
        )
        .film
    };
    let mis = run(Heuristic::Power(2.0), 1);
    let bsdf = run(Heuristic::BsdfOnly, 2);
    let cmp = compare_films(&mis, &bsdf, 8, 0.01).unwrap();
    assert!(cmp.passed(), "MIS and BSDF sampling disagree:\n{cmp}");
    let variance = |film: &wavetrace::film::Film| -> f64 {
        (0..film.pixels.len())
            .map(|i| film.variance_of_mean_f64(i).iter().sum::<f64>() * film.pixels[i].count as f64)
            .sum::<f64>()
            / film.pixels.len() as f64
    };
    let factor = variance(&bsdf) / variance(&mis);
    println!("sun: per-sample variance with --mis bsdf-only / with environment sampling and MIS = {factor:.1}");
    assert!(
        factor > 1.0,
        "environment sampling did not reduce the variance ({factor})"
    );
}

#[test]
fn gpu_agrees_with_cpu_on_a_turned_map() {
    let map = sky_map(96, 48, (70, 12), 800.0);
    let scene = common::prepared("cornell-materials.gltf");
    let s = |seed| RenderSettings {
        width: 32,
        height: 32,
        spp: 64,
        max_depth: 4,
        seed,
        env_map: Some(Arc::clone(&map)),
        env_rotate: 70.0,
        env_scale: 0.7,
        ..RenderSettings::default()
    };
    common::gpu_agrees_with_cpu(&scene, &s(1), &s(2), "turned sky map");
}

#[test]
fn hdr_file_loads_exactly_and_renders_alike_on_gpu_and_cpu() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples");
    let hdr = dir.join("env/venice_sunset_1k.hdr");
    let helmet = dir.join("valid/DamagedHelmet.glb");
    if !hdr.exists() || !helmet.exists() {
        eprintln!("skipping: ../shared/gltf-samples not found");
        return;
    }
    let map = Arc::new(EnvironmentMap::load(&hdr, 1 << 32).unwrap_or_else(|e| panic!("{e:#}")));
    assert_eq!((map.width, map.height), (1024, 512));
    let scene = PreparedScene::new(&Scene::load(&helmet).unwrap_or_else(|e| panic!("{e:#}")));
    let s = |seed| RenderSettings {
        width: 32,
        height: 32,
        spp: 64,
        max_depth: 4,
        seed,
        env_map: Some(Arc::clone(&map)),
        ..RenderSettings::default()
    };
    common::gpu_agrees_with_cpu(
        &scene,
        &s(1),
        &s(2),
        "DamagedHelmet under venice_sunset_1k.hdr",
    );
}

#[test]
fn written_hdr_and_exr_files_load_as_written() {
    // Values a Radiance file holds exactly (8-bit mantissas) survive .hdr and .exr alike.
    let (w, h) = (6u32, 3u32);
    let rgb: Vec<[f32; 3]> = (0..w * h)
        .map(|t| {
            let e = (t % 5) as i32 - 2;
            [
                (128 + t) as f32 * 2f32.powi(e - 8),
                (t * 7 % 128) as f32 * 2f32.powi(e - 8),
                (t * 3 % 64) as f32 * 2f32.powi(e - 8),
            ]
        })
        .collect();
    let image =
        image::Rgb32FImage::from_raw(w, h, rgb.iter().flatten().copied().collect()).unwrap();
    for ext in ["hdr", "exr"] {
        let path = common::temp("environment", &format!("map.{ext}"));
        image::DynamicImage::ImageRgb32F(image.clone())
            .save(&path)
            .unwrap();
        let map = EnvironmentMap::load(&path, 1 << 30).unwrap_or_else(|e| panic!("{e:#}"));
        for (t, c) in rgb.iter().enumerate() {
            assert_eq!(
                wavetrace::lights::environment::rgbe_decode(map.texels[t]),
                Vec3::from(*c),
                ".{ext} texel {t}"
            );
        }
    }
}

#[test]
fn bad_environment_files_are_refused_by_name() {
    let text = common::temp("environment", "not-a-map.hdr");
    std::fs::write(&text, "hello").unwrap();
    let black = common::temp("environment", "black.hdr");
    image::DynamicImage::ImageRgb32F(image::Rgb32FImage::new(4, 2))
        .save(&black)
        .unwrap();
    let cases = [
        (text.display().to_string(), "cannot"),
        (black.display().to_string(), "black everywhere"),
        ("missing-map.hdr".to_owned(), "cannot open"),
        ("scenes/cornell-box.gltf".to_owned(), ".hdr or an OpenEXR"),
    ];
    for (file, says) in cases {
        let out = common::wavetrace(&[
            "render",
            "scenes/cornell-box.gltf",
            "--device",
            "cpu",
            "--width",
            "8",
            "--spp",
            "1",
            "--env",
            &file,
            "-o",
            common::temp("environment", "out.png").to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{file}: accepted");
        assert!(
            stderr.contains(&file) && stderr.contains(says) && !stderr.contains("panicked"),
            "{file}: {stderr}"
        );
    }
}

/// E = ∫ L(ω) cos θ dω over the upper hemisphere of the lookup the renderers use, per channel,
/// by the midpoint rule on 4096 × 1024 cells in (φ, θ) (the lookup is bilinear between texels,
/// at most 512 × 256 of them here, so each cell sees a smooth piece of it).
fn upward_irradiance(map: &EnvironmentMap) -> [f64; 3] {
    use wavetrace::lights::environment::env_radiance;
    let mut frame = FrameParams::default();
    map.write_frame_params(Vec3::ONE, 0.0, &mut frame);
    let (nphi, ntheta) = (4096, 1024);
    let mut e = [0.0f64; 3];
    for j in 0..ntheta {
        let theta = (j as f64 + 0.5) / ntheta as f64 * PI / 2.0;
        for i in 0..nphi {
            let phi = (i as f64 + 0.5) / nphi as f64 * 2.0 * PI;
            let d = Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                theta.cos() as f32,
                (theta.sin() * phi.sin()) as f32,
            );
            let l = env_radiance(map, &frame, d);
            for (c, e) in e.iter_mut().enumerate() {
                *e += l[c] as f64 * theta.cos() * theta.sin();
            }
        }
    }
    e.map(|e| e * (PI / 2.0 / ntheta as f64) * (2.0 * PI / nphi as f64))
}

#[test]
fn the_studio_lights_a_plane_with_its_irradiance() {
    let map = wavetrace::lights::studio();
    let e = upward_irradiance(&map)[0];
    let want = ALBEDO as f64 / PI * e;
    println!("studio: irradiance of an upward plane {e:.4}, its radiance {want:.4}");
    let above = plane_scene(false);
    let cpu = render_cpu(&above, &settings(&map, 5, 256));
    assert_eq!(cpu.film.dropped, 0);
    assert_pixels_near(&cpu.film, Vec3::splat(want as f32), "studio plane (CPU)");
    if let Some(gpu) = render_gpu(&above, &settings(&map, 6, 256), None) {
        assert_eq!(gpu.film.dropped, 0);
        assert_pixels_near(&gpu.film, Vec3::splat(want as f32), "studio plane (GPU)");
        assert_agree_at(&gpu.film, &cpu.film, 0.01, "studio plane");
    }
}

#[test]
fn a_file_without_lights_is_lit_by_the_studio_unless_told_otherwise() {
    // The Cornell box without its light (emission removed from every material).
    let mut doc: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(common::scene_path("cornell-box.gltf")).unwrap(),
    )
    .unwrap();
    for m in doc["materials"].as_array_mut().unwrap() {
        m.as_object_mut().unwrap().remove("emissiveFactor");
    }
    let dark = common::temp("environment", "unlit-box.gltf");
    std::fs::write(&dark, doc.to_string()).unwrap();
    let render = |file: &str, extra: &[&str]| {
        let out = common::temp("environment", "default-light.exr");
        let mut args = vec![
            "render", file, "--device", "cpu", "--width", "8", "--height", "8", "--spp", "4", "-o",
        ];
        args.push(out.to_str().unwrap());
        args.extend(extra);
        let run = common::wavetrace(&args);
        let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
        assert!(run.status.success(), "{args:?}: {stderr}");
        let film = common::read_exr_file(&out).film;
        let sum: f64 = (0..film.pixels.len())
            .map(|p| film.mean_f64(p).iter().sum::<f64>())
            .sum();
        (stderr, sum)
    };
    let dark = dark.to_str().unwrap();
    let (stderr, sum) = render(dark, &[]);
    assert!(stderr.contains("built-in studio"), "{stderr}");
    assert!(sum > 0.0, "the studio lights nothing");
    let (stderr, studio) = render(dark, &["--env", "studio"]);
    assert!(!stderr.contains("has no lights"), "{stderr}");
    assert_eq!(studio, sum, "--env studio is the default's studio");
    for told in [&["--env", "none"][..], &["--environment", "0"]] {
        let (stderr, sum) = render(dark, told);
        assert!(!stderr.contains("built-in studio"), "{told:?}: {stderr}");
        assert!(stderr.contains("nothing emits light"), "{told:?}: {stderr}");
        assert_eq!(sum, 0.0, "{told:?}");
    }
    // A file with a light keeps it alone.
    let (stderr, _) = render("scenes/cornell-box.gltf", &[]);
    assert!(!stderr.contains("studio"), "{stderr}");
    // Textured emission alone is no lamp: DamagedHelmet's glowing visor.
    let lit = |path: &std::path::Path| {
        PreparedScene::new(&Scene::load(path).unwrap_or_else(|e| panic!("{e:#}"))).has_own_lights()
    };
    assert!(lit(&common::scene_path("cornell-box.gltf")));
    let helmet = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/gltf-samples/valid/DamagedHelmet.glb");
    if helmet.exists() {
        let scene = Scene::load(&helmet).unwrap();
        assert!(
            !PreparedScene::new(&scene).lights.is_empty(),
            "the visor emits"
        );
        assert!(!lit(&helmet));
    } else {
        eprintln!("skipping DamagedHelmet: ../shared/gltf-samples not found");
    }
}

/// `--sky` (src/lights/sky.rs): an upward white-ish Lambertian plane under the sky map and the
/// sun (a directional light) shows ρ/π (E_sky + E_sun sin e), E_sky integrated here from the
/// map's lookup, on the CPU and the GPU.
#[test]
fn the_sky_and_sun_light_a_plane_with_their_irradiance() {
    use wavetrace::lights::{sky, SkyParams};
    let params = SkyParams {
        sun_elevation: 35.0,
        sun_azimuth: -60.0,
        turbidity: 4.0,
    };
    let (map, sun) = sky(&params).unwrap();
    let e = upward_irradiance(&map);
    let sin_e = (params.sun_elevation as f64).to_radians().sin();
    let want: [f64; 3] =
        std::array::from_fn(|c| ALBEDO as f64 / PI * (e[c] + sun.intensity[c] as f64 * sin_e));
    println!(
        "sky: sky irradiance {e:?}, sun {:?}, plane radiance {want:?}",
        sun.intensity
    );
    // The sun joins the plane's lights as `--sky` adds it to a file's.
    let plane = plane_scene_lit(false, vec![sun]);
    let want = Vec3::new(want[0] as f32, want[1] as f32, want[2] as f32);
    let cpu = render_cpu(&plane, &settings(&map, 7, 256));
    assert_eq!(cpu.film.dropped, 0);
    assert_pixels_near(&cpu.film, want, "sky plane (CPU)");
    if let Some(gpu) = render_gpu(&plane, &settings(&map, 8, 256), None) {
        assert_pixels_near(&gpu.film, want, "sky plane (GPU)");
        assert_agree_at(&gpu.film, &cpu.film, 0.01, "sky plane");
    }
}

#[test]
fn sky_options_are_checked_by_name() {
    for (args, needle) in [
        (&["--sky", "--sun-elevation", "95"][..], "--sun-elevation"),
        (&["--sky", "--turbidity", "1"], "--turbidity"),
        (&["--sun-elevation", "30"], "--sky"),
        (&["--sky", "--env", "studio"], "--env"),
    ] {
        let mut all = vec![
            "render",
            "scenes/cornell-box.gltf",
            "--device",
            "cpu",
            "--spp",
            "1",
        ];
        all.extend(args);
        let run = common::wavetrace(&all);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success(), "{all:?} succeeded");
        assert!(stderr.contains(needle), "{all:?}: {stderr}");
    }
    let out = common::temp("environment", "sky.exr");
    let run = common::wavetrace(&[
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "2",
        "--sky",
        "--sun-elevation",
        "20",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}
