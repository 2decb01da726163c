//! The glTF material model in whole renders (issue "materials"): a plane under a white
//! environment shows the directional albedo that quadrature of the BRDF gives; a smooth glass
//! sphere in a white environment is exactly 1; the material scenes agree between GPU and CPU in
//! every --mis, --rr and sampler mode, and every mode agrees with the default within noise.

use crate::common;

use crate::common::{assert_agree_at, prepared, render_cpu, render_gpu};
use glam::Vec3;
use std::f32::consts::PI;
use wavetrace::bsdf::microfacet::{dielectric_f0, fresnel_conductor, fresnel_dielectric};
use wavetrace::bsdf::{bsdf_eval, TransportMode};
use wavetrace::film::Film;
use wavetrace::layout::{GpuMaterial, RR_ALBEDO, RR_OFF, SAMPLER_INDEPENDENT, SAMPLER_STRATIFIED};
use wavetrace::mis::Heuristic;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{camera_ray, Camera, Material, Projection, Scene, Triangle};
use wavetrace::stats::{film_mean, normal_quantile_upper, sidak};

fn material(base: Vec3, metallic: f32, roughness: f32, transmission: f32) -> Material {
    Material {
        name: "test".into(),
        base_color: base,
        metallic,
        roughness,
        ior: 1.5,
        transmission,
        specular: 1.0,
        emission: Vec3::ZERO,
        double_sided: false,
        // Transmissive test materials are solid glass: the boundary of a volume
        // (KHR_materials_volume's thicknessFactor > 0), not glTF's thin-walled default.
        thickness: 1.0,
        ..Material::default_white()
    }
}

fn looking_at(position: Vec3, target: Vec3, yfov: f32) -> Camera {
    let forward = (target - position).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    Camera {
        position,
        forward,
        right,
        up: right.cross(forward),
        projection: Projection::Perspective {
            yfov,
            aspect_ratio: None,
        },
        znear: 0.0,
    }
}

fn scene(triangles: Vec<Triangle>, material: Material, camera: Camera) -> PreparedScene {
    PreparedScene::new(&Scene {
        source: "test".into(),
        triangles,
        materials: vec![material],
        vertices: Vec::new(),
        textures: Default::default(),
        meshes: Vec::new(),
        instances: Vec::new(),
        punctual: Vec::new(),
        camera,
        cameras: Vec::new(),
        dropped_degenerate: 0,
        skipped_primitives: 0,
        notes: Vec::new(),
    })
}

/// A unit-radius latitude–longitude sphere, counter-clockwise seen from outside.
fn sphere(rings: usize, segments: usize) -> Vec<Triangle> {
    let point = |i: usize, j: usize| {
        let theta = PI * i as f32 / rings as f32;
        let phi = 2.0 * PI * j as f32 / segments as f32;
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            -theta.sin() * phi.sin(),
        )
    };
    let mut triangles = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                point(i, j),
                point(i + 1, j),
                point(i + 1, j + 1),
                point(i, j + 1),
            );
            for p in [[a, b, c], [a, c, d]] {
                let t = Triangle::flat(p, 0);
                if t.area() > 1e-9 {
                    triangles.push(t);
                }
            }
        }
    }
    triangles
}

/// Every pixel's mean within z standard errors of `expected(pixel)`, z Šidák-corrected over the
/// pixels and channels at family-wise α = 0.01.
fn assert_pixels(film: &Film, expected: &dyn Fn(usize) -> Vec3, who: &str) {
    assert_eq!(film.dropped, 0, "{who}: NaN/Inf samples");
    let n = film.pixels.len();
    let z = normal_quantile_upper(0.5 * sidak(0.01, 3 * n));
    for i in 0..n {
        let (mean, var) = (film.mean_f64(i), film.variance_of_mean_f64(i));
        let e = expected(i);
        for c in 0..3 {
            // Where every sample is the same number the variance is 0 and only f32 rounding of
            // the weights and the sum remains: allow 1e-5 beside the statistical bound.
            let tol = z * var[c].sqrt() + 1e-5;
            assert!(
                (mean[c] - e[c] as f64).abs() <= tol,
                "{who}: pixel {i} channel {c}: {} vs {} (± {tol})",
                mean[c],
                e[c]
            );
        }
    }
}

/// ∫ f(wo, wi) cos θi dωi over the hemisphere above a plane with normal +Z, by the midpoint rule
/// in (cos θ, φ) on a fine grid (the BRDF is smooth for the roughness used here).
fn directional_albedo(m: &GpuMaterial, wo: Vec3) -> Vec3 {
    let (nz, np) = (512usize, 256usize);
    let mut sum = Vec3::ZERO;
    for i in 0..nz {
        let cos = (i as f32 + 0.5) / nz as f32;
        let sin = (1.0 - cos * cos).sqrt();
        for j in 0..np {
            let phi = 2.0 * PI * (j as f32 + 0.5) / np as f32;
            let wi = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
            sum += bsdf_eval(m, Vec3::Z, wo, wi, TransportMode::Radiance) * cos;
        }
    }
    sum * (2.0 * PI / (nz * np) as f32)
}

#[test]
fn plane_under_white_environment_shows_the_directional_albedo() {
    // A large plane z = 0 seen from above at about 50° with a narrow field of view; direct
    // lighting only (max depth 1) from --environment 1, no roulette: each pixel's expectation is
    // the directional albedo ∫ f cos dωi for its view direction, computed by quadrature.
    let quad = |a: Vec3, b: Vec3, c: Vec3, d: Vec3| {
        [Triangle::flat([a, b, c], 0), Triangle::flat([a, c, d], 0)]
    };
    let s = 50.0;
    let plane = quad(
        Vec3::new(-s, -s, 0.0),
        Vec3::new(s, -s, 0.0),
        Vec3::new(s, s, 0.0),
        Vec3::new(-s, s, 0.0),
    )
    .to_vec();
    let camera = looking_at(Vec3::new(0.0, -3.0, 2.5), Vec3::ZERO, 0.3);
    for m in [
        material(Vec3::splat(0.8), 0.0, 0.5, 0.0), // rough plastic
        material(Vec3::new(0.9, 0.6, 0.3), 1.0, 0.4, 0.0), // rough copper-like metal
        material(Vec3::new(0.2, 0.5, 0.9), 0.5, 0.7, 0.0), // half metal
        material(Vec3::splat(0.8), 0.0, 0.0, 0.0), // smooth plastic: delta + diffuse
        material(Vec3::new(0.9, 0.6, 0.3), 0.5, 0.0, 0.0), // smooth half metal
    ] {
        let prepared = scene(plane.clone(), m.clone(), camera);
        let settings = RenderSettings {
            width: 6,
            height: 6,
            spp: 4096,
            max_depth: 1,
            seed: 5,
            environment: Vec3::ONE,
            rr_mode: RR_OFF,
            ..RenderSettings::default()
        };
        let frame = prepared.frame_params(&settings);
        let gm = prepared.materials[0];
        // The view direction at each pixel's centre (the albedo varies slowly across a pixel).
        let expected: Vec<Vec3> = (0..36)
            .map(|i| {
                let d = camera_ray(&frame, i, glam::Vec2::splat(0.5), glam::Vec2::ZERO).dir;
                // The delta mirror lobe (roughness 0) adds its Fresnel weight at cos θo exactly.
                let cos = -d.z;
                let mirror = if gm.roughness == 0.0 {
                    (1.0 - gm.metallic)
                        * fresnel_dielectric(cos, dielectric_f0(gm.ior), 1.0, gm.ior)
                        + gm.metallic * fresnel_conductor(Vec3::from(gm.base_color), cos)
                } else {
                    Vec3::ZERO
                };
                directional_albedo(&gm, -d) + mirror
            })
            .collect();
        let who = format!(
            "{} metallic {} roughness {}",
            m.base_color, m.metallic, m.roughness
        );
        assert_pixels(
            &render_cpu(&prepared, &settings).film,
            &|i| expected[i],
            &format!("cpu {who}"),
        );
        if let Some(out) = render_gpu(&prepared, &settings, None) {
            assert_pixels(&out.film, &|i| expected[i], &format!("gpu {who}"));
        }
    }
}

#[test]
fn smooth_glass_sphere_in_white_environment_is_exactly_one() {
    // Every path either misses (radiance 1) or is reflected (weight 1) and refracted in and out
    // (1/η² · η² = 1) until it leaves: with roulette off, each sample is 1 up to rounding.
    // With roulette on, the mean is 1 within noise.
    let glass = material(Vec3::ONE, 0.0, 0.0, 1.0);
    let prepared = scene(
        sphere(24, 48),
        glass,
        looking_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8),
    );
    for rr_mode in [RR_OFF, wavetrace::layout::RR_THROUGHPUT, RR_ALBEDO] {
        let settings = RenderSettings {
            width: 12,
            height: 12,
            spp: 256,
            // Rays entering a faceted sphere near its silhouette can be trapped by total
            // internal reflection for hundreds of bounces (0.1 % of the paths at 200): without
            // roulette the depth must not truncate them.
            max_depth: 1000,
            seed: 9,
            environment: Vec3::ONE,
            rr_mode,
            ..RenderSettings::default()
        };
        let mut films = vec![("cpu", render_cpu(&prepared, &settings).film)];
        if let Some(out) = render_gpu(&prepared, &settings, None) {
            films.push(("gpu", out.film));
        }
        for (who, film) in films {
            assert_pixels(&film, &|_| Vec3::ONE, &format!("{who} --rr {rr_mode}"));
            let (mean, err) = film_mean(&film);
            println!("{who} --rr {rr_mode}: image mean {mean:?} ± {err:?}");
        }
    }
}

#[test]
fn seen_from_inside_glass_the_environment_is_eta_squared_brighter() {
    // Radiance over η² is invariant along a refracted ray, so from inside glass of index 1.5 a
    // white environment reads 2.25: every path is reflected inside (weight 1) until it leaves
    // (weight η² = 2.25). The closed-sphere test above cannot see a wrong exponent of η, since
    // entering and leaving cancel; this one can.
    let glass = material(Vec3::ONE, 0.0, 0.0, 1.0);
    let prepared = scene(
        sphere(24, 48),
        glass,
        looking_at(Vec3::ZERO, Vec3::NEG_Z, 1.0),
    );
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 64,
        max_depth: 200,
        seed: 4,
        environment: Vec3::ONE,
        rr_mode: RR_OFF,
        ..RenderSettings::default()
    };
    let expected = Vec3::splat(2.25);
    assert_pixels(&render_cpu(&prepared, &settings).film, &|_| expected, "cpu");
    if let Some(out) = render_gpu(&prepared, &settings, None) {
        assert_pixels(&out.film, &|_| expected, "gpu");
    }
}

/// Settings of the mode comparisons: 32×32 at 128 spp, default depth.
fn small(seed: u32) -> RenderSettings {
    RenderSettings {
        width: 32,
        height: 32,
        spp: 128,
        seed,
        ..RenderSettings::default()
    }
}

#[test]
fn material_scenes_agree_between_gpu_and_cpu_and_across_modes() {
    let modes: Vec<(&str, RenderSettings)> = vec![
        ("default (power, throughput roulette, sobol)", small(1)),
        (
            "--mis light-only",
            RenderSettings {
                mis: Heuristic::LightOnly,
                ..small(1)
            },
        ),
        (
            "--mis bsdf-only",
            RenderSettings {
                mis: Heuristic::BsdfOnly,
                ..small(1)
            },
        ),
        (
            "--mis balance",
            RenderSettings {
                mis: Heuristic::Balance,
                ..small(1)
            },
        ),
        (
            "--mis maximum",
            RenderSettings {
                mis: Heuristic::Maximum,
                ..small(1)
            },
        ),
        (
            "--mis average",
            RenderSettings {
                mis: Heuristic::Average,
                ..small(1)
            },
        ),
        (
            "--rr albedo",
            RenderSettings {
                rr_mode: RR_ALBEDO,
                ..small(1)
            },
        ),
        (
            "--rr off",
            RenderSettings {
                rr_mode: RR_OFF,
                ..small(1)
            },
        ),
        (
            "--sampler stratified",
            RenderSettings {
                sampler: SAMPLER_STRATIFIED,
                ..small(1)
            },
        ),
        (
            "--sampler independent",
            RenderSettings {
                sampler: SAMPLER_INDEPENDENT,
                ..small(1)
            },
        ),
    ];
    // On the Veach scene, emitter sampling alone (and the average weighting, half of whose
    // weight it carries) sees the smooth plates' reflections of the large lights only through
    // rare, huge samples: about one per tile at 128 spp. Such sample means are far from the
    // normal distribution the Welch test assumes (a typical tile sees none and reads 10–25×
    // low), so these two are compared with the default on the Cornell variant only; the strip
    // in tools/gallery shows their noise on the plates.
    let skewed_on_veach = ["--mis light-only", "--mis average"];
    let scenes = ["veach-mis.gltf", "cornell-materials.gltf"];
    // Two comparisons per mode and scene (GPU = CPU in the mode; the mode = the default on the
    // CPU), family-wise α = 0.01 over all of them.
    let alpha = sidak(0.01, 2 * modes.len() * scenes.len());
    for name in scenes {
        let scene = prepared(name);
        let reference = render_cpu(&scene, &small(3)).film;
        assert_eq!(reference.dropped, 0);
        for (what, settings) in &modes {
            let cpu = render_cpu(
                &scene,
                &RenderSettings {
                    seed: 2,
                    ..settings.clone()
                },
            )
            .film;
            assert_eq!(cpu.dropped, 0, "{name} {what}: CPU dropped samples");
            if !(name == "veach-mis.gltf" && skewed_on_veach.contains(what)) {
                assert_agree_at(
                    &cpu,
                    &reference,
                    alpha,
                    &format!("{name}, {what}: CPU against the CPU default"),
                );
            }
            if let Some(gpu) = render_gpu(&scene, settings, None) {
                assert_eq!(gpu.film.dropped, 0, "{name} {what}: GPU dropped samples");
                assert_agree_at(
                    &gpu.film,
                    &cpu,
                    alpha,
                    &format!("{name}, {what}: GPU against CPU"),
                );
            }
        }
    }
}

#[test]
fn khronos_material_samples_render_alike_on_gpu_and_cpu() {
    // Factor-only glTF files from ../shared/gltf-samples (skipped where that folder is absent):
    // their metallic, roughness and transmission factors are read, and the GPU render of each
    // under a white environment agrees with the CPU reference.
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples/valid");
    if !dir.is_dir() {
        eprintln!("skipping: ../shared/gltf-samples not found");
        return;
    }
    let metal = Scene::load(&dir.join("MetalRoughSpheresNoTextures.glb")).unwrap();
    let values = |f: &dyn Fn(&Material) -> f32| {
        let mut v: Vec<f32> = metal.materials.iter().map(f).collect();
        v.sort_by(f32::total_cmp);
        v.dedup();
        v
    };
    assert!(
        values(&|m| m.metallic).len() >= 5,
        "metallic factors: {:?}",
        values(&|m| m.metallic)
    );
    assert!(
        values(&|m| m.roughness).len() >= 5,
        "roughness factors: {:?}",
        values(&|m| m.roughness)
    );
    let glass = Scene::load(&dir.join("TransmissionTest.glb")).unwrap();
    assert!(glass.materials.iter().any(|m| m.transmission > 0.0));
    let settings = |seed| RenderSettings {
        width: 24,
        height: 24,
        spp: 64,
        seed,
        environment: Vec3::ONE,
        ..RenderSettings::default()
    };
    for (name, scene) in [
        ("MetalRoughSpheresNoTextures", metal),
        ("TransmissionTest", glass),
    ] {
        let prepared = PreparedScene::new(&scene);
        let cpu = render_cpu(&prepared, &settings(2)).film;
        assert_eq!(cpu.dropped, 0, "{name}: CPU dropped samples");
        if let Some(gpu) = render_gpu(&prepared, &settings(1), None) {
            assert_eq!(gpu.film.dropped, 0, "{name}: GPU dropped samples");
            assert_agree_at(
                &gpu.film,
                &cpu,
                sidak(0.01, 2),
                &format!("{name}: GPU against CPU"),
            );
        }
    }
}

/// The CPU path's scene-wide shortcuts (`PreparedScene::attenuates`, `plain_emitters`) skip
/// only work whose result they know: a transmittance of exactly 1 where no material attenuates,
/// and an emitter's material as it is where no emitter reads its surface or is alpha-tested.
/// Forcing the general path on scenes that take the shortcuts gives the same bits; the flags
/// are set where a scene needs the general path (an attenuating model, an emissive texture).
#[test]
fn the_cpu_paths_scene_shortcuts_change_no_bit() {
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 4,
        max_depth: 5,
        ..RenderSettings::default()
    };
    let mut scenes: Vec<(String, Scene)> = ["cornell-box.gltf", "furnace.gltf", "veach-mis.gltf"]
        .iter()
        .map(|&n| (n.to_string(), Scene::load(&common::scene_path(n)).unwrap()))
        .collect();
    let samples = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples");
    if samples.is_dir() {
        for (name, attenuates, plain_emitters) in [
            ("valid/DamagedHelmet.glb", false, false),
            ("valid/extensions/AttenuationTest.glb", true, true),
        ] {
            let scene = Scene::load(&samples.join(name)).unwrap();
            let p = PreparedScene::new(&scene);
            assert_eq!(
                (p.attenuates, p.plain_emitters),
                (attenuates, plain_emitters),
                "{name}: (attenuates, plain_emitters)"
            );
            scenes.push((name.to_string(), scene));
        }
    } else {
        eprintln!("../shared/gltf-samples not found: the committed scenes only");
    }
    for (name, scene) in &scenes {
        let fast = PreparedScene::new(scene);
        if name.ends_with(".gltf") {
            assert!(!fast.attenuates && fast.plain_emitters, "{name}'s flags");
        }
        let mut general = PreparedScene::new(scene);
        general.attenuates = true;
        general.plain_emitters = false;
        common::assert_same_bits(
            &render_cpu(&fast, &settings).film,
            &render_cpu(&general, &settings).film,
            &format!("{name}: shortcuts against the general path"),
        );
    }
}

#[test]
fn rough_white_spheres_in_a_white_furnace_reflect_one_with_energy_compensation() {
    // A white metal of roughness 1 and a white dielectric of roughness 0.8 (Lambertian base
    // under a white specular layer) under a white environment: with energy compensation (on
    // when a scene is prepared) every pixel is 1 within noise, on CPU and GPU; without it the
    // single-scattering lobes lose light (the image means are printed).
    for (name, m) in [
        ("metal", material(Vec3::ONE, 1.0, 1.0, 0.0)),
        ("dielectric", material(Vec3::ONE, 0.0, 0.8, 0.0)),
    ] {
        let mut prepared = scene(
            sphere(24, 48),
            m,
            looking_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 0.8),
        );
        let settings = RenderSettings {
            width: 12,
            height: 12,
            spp: 256,
            max_depth: 64,
            seed: 5,
            environment: Vec3::ONE,
            ..RenderSettings::default()
        };
        let mut films = vec![("cpu", render_cpu(&prepared, &settings).film)];
        if let Some(out) = render_gpu(&prepared, &settings, None) {
            films.push(("gpu", out.film));
        }
        for (who, film) in films {
            assert_pixels(&film, &|_| Vec3::ONE, &format!("{who} compensated {name}"));
            let (mean, err) = film_mean(&film);
            println!("{who} compensated {name}: image mean {mean:?} ± {err:?}");
        }
        prepared.set_energy_compensation(false);
        let film = render_cpu(&prepared, &settings).film;
        let (mean, err) = film_mean(&film);
        println!("cpu single-scattering {name}: image mean {mean:?} ± {err:?}");
        if name == "metal" {
            assert!(mean[0] < 1.0 - 10.0 * err[0], "{mean:?} ± {err:?}: no loss");
        }
    }
}
