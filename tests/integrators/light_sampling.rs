//! Choosing the emitter for next event estimation (issue 9, "many lights"): through the light
//! BVH (`--light-sampler bvh`, src/lights/light_bvh/mod.rs) or by power (`--light-sampler power`).
//!
//! - Both samplers estimate the same image (per-tile Welch tests) on the 10 240-emitter scene
//!   and on a scene mixing emissive triangles, point, spot and directional lights and an
//!   environment map, where the BVH covers the bounded lights and the table the directional
//!   one.
//! - The GPU agrees with the CPU with the light BVH on the many-light scene.
//! - On the many-light scene the BVH's per-sample variance is lower (the factor is printed).

use crate::common;

use crate::common::{assert_agree_at, render_cpu, render_gpu};
use glam::Vec3;
use std::sync::Arc;
use wavetrace::layout::*;
use wavetrace::lights::environment::EnvironmentMap;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::Scene;

fn settings(sampler: u32, seed: u32) -> RenderSettings {
    RenderSettings {
        width: 32,
        height: 32,
        spp: 64,
        max_depth: 3,
        seed,
        light_sampler: sampler,
        ..RenderSettings::default()
    }
}

/// The median over pixels of the ratio of `a`'s per-sample variance to `b`'s (pixels where
/// both vary): robust to the pixels whose variance is the same for both samplers (emitters
/// seen directly, partly covering a pixel).
fn median_variance_ratio(a: &wavetrace::film::Film, b: &wavetrace::film::Film) -> f64 {
    let var = |f: &wavetrace::film::Film, i: usize| f.variance_of_mean_f64(i).iter().sum::<f64>();
    let mut ratios: Vec<f64> = (0..a.pixels.len())
        .filter(|&i| var(a, i) > 0.0 && var(b, i) > 0.0)
        .map(|i| var(a, i) / var(b, i))
        .collect();
    ratios.sort_by(f64::total_cmp);
    ratios[ratios.len() / 2]
}

#[test]
fn many_lights_bvh_and_power_agree_and_the_gpu_matches() {
    let scene = common::prepared("many-lights.gltf");
    assert!(
        scene.lights.len() >= 10_000,
        "{} emitters",
        scene.lights.len()
    );
    assert!(!scene.light_nodes.is_empty());
    let bvh = render_cpu(&scene, &settings(LIGHT_SAMPLER_BVH, 1));
    let power = render_cpu(&scene, &settings(LIGHT_SAMPLER_POWER, 2));
    assert_eq!(bvh.film.dropped + power.film.dropped, 0);
    // Two comparisons in this test: α = 0.01 split between them (Šidák).
    let alpha = wavetrace::stats::sidak(0.01, 2);
    assert_agree_at(&bvh.film, &power.film, alpha, "light BVH vs power (CPU)");
    let factor = median_variance_ratio(&power.film, &bvh.film);
    println!("many-lights: median over pixels of the variance by power / through the light BVH = {factor:.2}");
    assert!(
        factor > 1.0,
        "the light BVH did not lower the variance ({factor})"
    );
    if let Some(gpu) = render_gpu(&scene, &settings(LIGHT_SAMPLER_BVH, 3), None) {
        assert_eq!(gpu.film.dropped, 0);
        assert_agree_at(&gpu.film, &bvh.film, alpha, "light BVH: GPU vs CPU");
    }
}

/// The Cornell box's ceiling light with a point, a spot and a directional light added, under an
/// environment map: every kind of emitter the table holds, in its order.
fn mixed_scene() -> PreparedScene {
    let mut scene = Scene::load(&common::scene_path("cornell-box.gltf")).unwrap();
    let light = |kind: u32, position: Vec3, direction: Vec3, intensity: f32| GpuPunctualLight {
        position: position.to_array(),
        kind,
        direction: direction.normalize().to_array(),
        intensity: [intensity, 0.8 * intensity, 0.6 * intensity],
        ..Default::default()
    };
    let (lo, hi) = scene.bounds();
    let centre = 0.5 * (lo + hi);
    let size = (hi - lo).max_element();
    let mut spot = light(
        LIGHT_SPOT,
        centre + Vec3::new(0.2, 0.3, 0.1) * size,
        Vec3::new(-0.3, -1.0, -0.2),
        0.3 * size * size,
    );
    // KHR_lights_punctual's cone scale and offset for inner 0.3 rad, outer 0.6 rad.
    spot.spot_scale = 1.0 / (0.3f32.cos() - 0.6f32.cos());
    spot.spot_offset = -0.6f32.cos() * spot.spot_scale;
    scene.punctual = vec![
        light(
            LIGHT_DIRECTIONAL,
            Vec3::ZERO,
            Vec3::new(0.2, -1.0, -0.3),
            0.5,
        ),
        light(
            LIGHT_POINT,
            centre + Vec3::new(-0.25, 0.1, 0.2) * size,
            Vec3::NEG_Y,
            0.1 * size * size,
        ),
        spot,
    ];
    PreparedScene::new(&scene)
}

#[test]
fn mixed_emitters_under_an_environment_agree_across_samplers_and_devices() {
    let scene = mixed_scene();
    // Directional light last, after the bounded lights the BVH covers.
    let last = scene.lights.last().unwrap();
    assert_ne!(last.triangle & LIGHT_ENTRY_PUNCTUAL, 0);
    assert!(scene.light_bounded_cdf > 0.0 && scene.light_bounded_cdf < 1.0);
    let rgb: Vec<Vec3> = (0..32 * 16)
        .map(|t| {
            if t == 5 * 32 + 11 {
                Vec3::splat(300.0)
            } else {
                Vec3::new(0.3, 0.4, 0.5)
            }
        })
        .collect();
    let map = Arc::new(EnvironmentMap::from_rgb(32, 16, &rgb).unwrap());
    let s = |sampler, seed| RenderSettings {
        env_map: Some(Arc::clone(&map)),
        ..settings(sampler, seed)
    };
    let alpha = wavetrace::stats::sidak(0.01, 2);
    let bvh = render_cpu(&scene, &s(LIGHT_SAMPLER_BVH, 1));
    let power = render_cpu(&scene, &s(LIGHT_SAMPLER_POWER, 2));
    assert_agree_at(
        &bvh.film,
        &power.film,
        alpha,
        "mixed emitters: BVH vs power",
    );
    if let Some(gpu) = render_gpu(&scene, &s(LIGHT_SAMPLER_BVH, 3), None) {
        assert_eq!(gpu.film.dropped, 0);
        assert_agree_at(&gpu.film, &bvh.film, alpha, "mixed emitters: GPU vs CPU");
    }
}
