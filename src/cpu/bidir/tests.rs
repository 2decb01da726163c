use super::bdpt::*;
use super::light_tracing::*;
use crate::cpu::path::{emitted_radiance, RayCounts};
use crate::layout::{GpuPunctualLight, LIGHT_SPOT, RR_OFF};
use crate::lights::{punctual_intensity, punctual_window, spot_cos_outer};
use crate::mis::Heuristic;
use crate::render::RenderSettings;
use crate::render::{Integrator, PreparedScene};
use glam::Vec3;

fn cornell(name: &str) -> PreparedScene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    let scene = crate::scene::Scene::load(&path).unwrap();
    PreparedScene::new(&scene)
}

/// A camera subpath of at least `min_vertices` that ends on an emitter, with (`with_delta`) or
/// without a delta bounce.
fn emitter_path(b: &Bidir, min_vertices: usize, with_delta: bool) -> Vec<Vertex> {
    let mut counts = RayCounts::default();
    let mut path = Vec::new();
    for sample in 0..64 {
        for pixel in 0..b.frame.width * b.frame.height {
            b.camera_subpath((pixel, sample), 9, &mut path, &mut counts);
            let last = &path[path.len() - 1];
            if path.len() >= min_vertices
                && emitted_radiance(&last.mat, last.ng.dot(last.wo)).max_element() > 0.0
                && path.iter().any(|v| v.delta) == with_delta
                && !last.delta
            {
                return path;
            }
        }
    }
    panic!("no camera subpath of {min_vertices} vertices reaches the light");
}

/// The camera subpath's directions and densities recomputed from its vertex positions (the walk
/// takes them from the sampled rays, whose origins are offset off the surfaces): what the MIS
/// algebra is tested on, apart from the offsets.
fn from_positions(b: &Bidir, path: &[Vertex]) -> Vec<Vertex> {
    let n = path.len();
    let mut z = path.to_vec();
    for i in 1..n {
        z[i].wo = (z[i - 1].p - z[i].p).normalize();
    }
    for i in 1..n {
        // After a delta bounce both densities are the sentinel 1 (`walk`).
        z[i].pdf_fwd = if z[i - 1].delta {
            1.0
        } else {
            b.pdf(&z[i - 1], (i >= 2).then(|| &z[i - 2]), &z[i])
        };
    }
    for i in 0..n - 1 {
        z[i].pdf_rev = if z[i + 1].delta {
            1.0
        } else if i + 2 < n {
            b.pdf(&z[i + 1], Some(&z[i + 2]), &z[i])
        } else {
            let light = Vertex {
                kind: Kind::AreaLight,
                ..z[n - 1]
            };
            b.to_area(
                b.emission_pdf(&light, (z[i].p - light.p).normalize()),
                light.p,
                &z[i],
            )
        };
    }
    z
}

/// The full path x₀ (emitter) … z₀ (camera) split after its first s vertices: the light
/// subpath the other way round, its densities those a light subpath would have had.
fn split(b: &Bidir, full: &[Vertex], s: usize) -> (Vec<Vertex>, Vec<Vertex>) {
    let n = full.len();
    let t = n - s;
    let camera = full[..t].to_vec();
    let mut light: Vec<Vertex> = Vec::new();
    for j in 0..s {
        let z = &full[n - 1 - j];
        let mut y = *z;
        if j == 0 {
            y.kind = Kind::AreaLight;
            y.pdf_fwd = b.light_origin_pdf(z);
            y.beta = Vec3::splat(1.0 / y.pdf_fwd);
            y.wo = Vec3::ZERO;
        } else {
            let prev = light[j - 1];
            y.wo = (prev.p - y.p).normalize();
            y.pdf_fwd = if j == 1 {
                b.to_area(
                    b.emission_pdf(&prev, (y.p - prev.p).normalize()),
                    prev.p,
                    &y,
                )
            } else if prev.delta {
                // After a delta bounce: the sentinel 1, as `walk` stores it.
                1.0
            } else {
                b.pdf(&prev, Some(&light[j - 2]), &y)
            };
        }
        // Generating it from the camera side is the camera subpath's forward density.
        y.pdf_rev = z.pdf_fwd;
        light.push(y);
    }
    (light, camera)
}

/// Veach's condition for an unbiased combination: over every strategy (s, t) that can make a
/// path, the weights sum to 1 — for each heuristic, on paths of 3 to 7 vertices.
#[test]
fn mis_weights_of_all_strategies_sum_to_one() {
    for (name, with_delta) in [
        ("cornell-box.gltf", false),
        ("cornell-materials.gltf", true),
    ] {
        weights_sum_to_one(name, with_delta);
    }
}

/// [`mis_weights_of_all_strategies_sum_to_one`] on paths of `name`, with or without a delta
/// bounce (strategies joining at a delta vertex cannot make the path and weigh 0).
fn weights_sum_to_one(name: &str, with_delta: bool) {
    let scene = cornell(name);
    let settings = RenderSettings {
        width: 16,
        height: 16,
        max_depth: 8,
        rr_mode: RR_OFF,
        ..Default::default()
    };
    let frame = scene.frame_params(&settings);
    for heuristic in [
        Heuristic::Power(2.0),
        Heuristic::Balance,
        Heuristic::Average,
        Heuristic::Maximum,
    ] {
        let b = Bidir::new(&scene, &frame, Integrator::Bdpt, heuristic, None);
        for min in 3..=7 {
            let full = from_positions(&b, &emitter_path(&b, min, with_delta));
            let n = full.len();
            let mut total = 0.0;
            let mut weights = Vec::new();
            for s in 0..n {
                let t = n - s;
                let (light, camera) = split(&b, &full, s);
                let sampled = (s == 1).then(|| light[0]);
                // A strategy that would join at a delta vertex cannot make the path.
                let joins_delta = (s > 0 && light[s - 1].delta) || camera[t - 1].delta;
                let w = if joins_delta {
                    0.0
                } else {
                    b.mis_weight(&light, &camera, sampled.as_ref(), s, t)
                };
                assert!(
                    (0.0..=1.0).contains(&w),
                    "{heuristic:?} s={s} t={t}: w = {w}"
                );
                weights.push(w);
                total += w;
            }
            // f32 arithmetic over at most nine pdf ratios per weight.
            assert!(
                (total - 1.0).abs() < 1e-5,
                "{name} {heuristic:?}, {n} vertices: weights {weights:?} sum to {total}"
            );
        }
    }
}

/// The light subpath's point-light helpers give what the path tracer's `punctual_incident`
/// gives: I·falloff·window/d².
#[test]
fn punctual_emission_matches_the_path_tracer() {
    let light = GpuPunctualLight {
        position: [0.0, 2.0, 0.0],
        kind: LIGHT_SPOT,
        direction: [0.0, -1.0, 0.0],
        range: 5.0,
        intensity: [3.0, 2.0, 1.0],
        spot_scale: 1.0 / (0.95 - 0.8),
        spot_offset: -0.8 / (0.95 - 0.8),
        ..Default::default()
    };
    for p in [
        Vec3::new(0.3, 0.0, 0.1),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, -2.5, 0.2),
    ] {
        let (_, d, li) = crate::lights::punctual_incident(&light, p);
        let w = (p - Vec3::from(light.position)) / d;
        let mine = punctual_intensity(&light, w) * punctual_window(&light, d) / (d * d);
        assert!(
            (mine - li).abs().max_element() <= 1e-6 * li.max_element().max(1.0),
            "{p}"
        );
    }
    assert!((spot_cos_outer(&light) - 0.8).abs() < 1e-5);
}

/// The fixed-point splat sum: exact for sums of values on its 2⁻²⁴ grid in any order, within
/// half a unit per value otherwise, and the value it reports within f32 rounding.
#[test]
fn splat_sums_do_not_depend_on_order() {
    let values: Vec<f32> = (0..1000)
        .map(|i| ((i * 7919) % 1000) as f32 * 0.37 + 1e-4 * i as f32)
        .chain([3.0e6, 1.0e-7, 255.99998, 256.0])
        .collect();
    let mut a = [0u64; 3];
    let mut b = [0u64; 3];
    for &v in &values {
        splat_add(&mut a, Vec3::splat(v));
    }
    for &v in values.iter().rev() {
        splat_add(&mut b, Vec3::splat(v));
    }
    assert_eq!(a, b);
    let exact: f64 = values.iter().map(|&v| v as f64).sum();
    let got = splat_value(&a).x as f64;
    let half_units = values.len() as f64 * 0.5 / 16_777_216.0;
    assert!(
        (got - exact).abs() <= half_units + exact * 2.0 * f32::EPSILON as f64,
        "{got} vs {exact}"
    );
    // Non-finite, negative and absurd values are left out.
    splat_add(&mut a, Vec3::new(f32::NAN, -1.0, 1e12));
    assert_eq!(a, b);
}
