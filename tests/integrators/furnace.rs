//! White furnace (DESIGN.md, Verification 2): the camera inside a closed sphere of albedo a = 0.5
//! emitting Le = 0.5, so L = Le·(1 − a^(N+1))/(1 − a) at --max-depth N, 1.0 in the limit. Each
//! integrator's image mean must lie within 4 standard errors of it, Russian roulette on.

use crate::common::{prepared, render_cpu, render_gpu};
use wavetrace::film::Film;
use wavetrace::mis::Heuristic;
use wavetrace::render::RenderSettings;
use wavetrace::stats::film_mean;

const LE: f64 = 0.5;
const ALBEDO: f64 = 0.5;

fn expected(max_depth: u32) -> f64 {
    LE * (1.0 - ALBEDO.powi(max_depth as i32 + 1)) / (1.0 - ALBEDO)
}

fn settings(max_depth: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width: 16,
        height: 16,
        spp,
        max_depth,
        seed: 3,
        ..RenderSettings::default()
    }
}

fn check(film: &Film, max_depth: u32, who: &str) {
    assert_eq!(film.dropped, 0, "{who}: NaN/Inf samples");
    let (mean, err) = film_mean(film);
    let l = expected(max_depth);
    for c in 0..3 {
        let z = (mean[c] - l) / err[c].max(1e-12);
        println!(
            "{who} depth {max_depth} channel {c}: mean {:.6} ± {:.6}, expected {l:.6}, z = {z:.2}",
            mean[c], err[c]
        );
        assert!(
            z.abs() < 4.0,
            "{who}, --max-depth {max_depth}, channel {c}: mean {} is {z:.2} standard errors ({}) from the analytic {l}",
            mean[c],
            err[c]
        );
    }
}

#[test]
fn cpu_furnace_matches_analytic_radiance() {
    let scene = prepared("furnace.gltf");
    for depth in [2, 40] {
        check(
            &render_cpu(&scene, &settings(depth, 256)).film,
            depth,
            "cpu",
        );
    }
}

#[test]
fn gpu_furnace_matches_analytic_radiance() {
    let scene = prepared("furnace.gltf");
    for depth in [2, 40] {
        let Some(out) = render_gpu(&scene, &settings(depth, 256), None) else {
            return;
        };
        check(&out.film, depth, "gpu");
    }
}

/// With no scattering every camera ray sees the sphere's emission exactly: L = Le, no variance.
#[test]
fn emitters_seen_directly_are_exact() {
    let scene = prepared("furnace.gltf");
    let s = settings(0, 4);
    let mut films = vec![("cpu", render_cpu(&scene, &s).film)];
    if let Some(out) = render_gpu(&scene, &s, None) {
        films.push(("gpu", out.film));
    }
    for (who, film) in films {
        for (i, _) in film.pixels.iter().enumerate() {
            let m = film.mean(i);
            assert!(
                (m - glam::Vec3::splat(LE as f32)).abs().max_element() < 1e-6,
                "{who}: pixel {i} = {m}, expected exactly {LE}"
            );
        }
    }
}

/// Every weighting of the seed keeps the estimate unbiased: in the furnace, where every triangle
/// emits, emitter and BSDF sampling both contribute at every vertex.
#[test]
fn every_mis_heuristic_is_unbiased_in_the_furnace() {
    let scene = prepared("furnace.gltf");
    for mis in [
        Heuristic::Average,
        Heuristic::Maximum,
        Heuristic::Balance,
        Heuristic::Power(3.0),
    ] {
        let s = RenderSettings {
            mis,
            ..settings(5, 64)
        };
        check(&render_cpu(&scene, &s).film, 5, &format!("cpu {mis:?}"));
        if let Some(out) = render_gpu(&scene, &s, None) {
            check(&out.film, 5, &format!("gpu {mis:?}"));
        }
    }
}
