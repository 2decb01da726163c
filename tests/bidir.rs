//! Light tracing and bidirectional path tracing (`--integrator light|bdpt`) against the path
//! tracer, and path expressions (`--paths`): same expectation, per tile.
//!
//! A light subpath splats into many pixels, so neighbouring pixels of one render are
//! correlated and a per-pixel variance understates a tile's. The comparisons here therefore
//! take each tile's mean over independent batches (renders of their own seeds, independent
//! sampler): the batch means are independent and identically distributed whatever the
//! correlation inside a batch, and Welch's test runs on them, Šidák-corrected over tiles ×
//! channels at α = 0.01.

mod common;

use common::prepared;
use wavetrace::cpu::Integrator;
use wavetrace::layout::SAMPLER_INDEPENDENT;
use wavetrace::paths::PathExpr;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::stats::{sidak, welch_t_test};

const TILE: u32 = 8;
const BATCHES: u32 = 12;

/// Per tile and channel: the mean over `BATCHES` independent renders and the variance of that
/// mean (from the spread of the batch means, BATCHES − 1 degrees of freedom).
fn batch_tiles(scene: &PreparedScene, settings: &RenderSettings, seed: u32) -> Vec<[(f64, f64); 3]> {
    let (w, h) = (settings.width, settings.height);
    let (tx, ty) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let mut sums = vec![[Vec::new(), Vec::new(), Vec::new()]; (tx * ty) as usize];
    for b in 0..BATCHES {
        let s = RenderSettings {
            seed: seed * 1000 + b,
            ..settings.clone()
        };
        let film = wavetrace::cpu::render(scene, &s).film;
        assert_eq!(film.dropped, 0, "{:?} dropped samples", settings.integrator);
        let mut tile_sum = vec![[0.0f64; 3]; (tx * ty) as usize];
        let mut tile_n = vec![0u32; (tx * ty) as usize];
        for y in 0..h {
            for x in 0..w {
                let p = &film.pixels[(x + y * w) as usize];
                let t = ((x / TILE) + (y / TILE) * tx) as usize;
                for c in 0..3 {
                    tile_sum[t][c] += p.sum[c] as f64 / p.count.max(1) as f64;
                }
                tile_n[t] += 1;
            }
        }
        for t in 0..tile_sum.len() {
            for c in 0..3 {
                sums[t][c].push(tile_sum[t][c] / tile_n[t] as f64);
            }
        }
    }
    sums.iter()
        .map(|chans| {
            let f = |v: &Vec<f64>| {
                let n = v.len() as f64;
                let mean = v.iter().sum::<f64>() / n;
                let var = v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
                (mean, var / n)
            };
            [f(&chans[0]), f(&chans[1]), f(&chans[2])]
        })
        .collect()
}

/// Whether `a` and `b` have the same expectation per tile; the report names failing tiles.
fn same_expectation(
    scene: &PreparedScene,
    a: &RenderSettings,
    b: &RenderSettings,
    alpha: f64,
) -> Result<(), String> {
    let ta = batch_tiles(scene, a, 1);
    let tb = batch_tiles(scene, b, 2);
    let tests = ta.len() * 3;
    let per_test = sidak(alpha, tests);
    let df = (BATCHES - 1) as f64;
    let mut failures = Vec::new();
    let mut min_p = 1.0f64;
    for (t, (x, y)) in ta.iter().zip(&tb).enumerate() {
        for c in 0..3 {
            let (_, _, p) = welch_t_test(x[c].0, x[c].1, df, y[c].0, y[c].1, df);
            min_p = min_p.min(p);
            if p < per_test {
                failures.push(format!(
                    "tile {t} channel {c}: {:.5} ± {:.5} vs {:.5} ± {:.5} (p = {p:.3e})",
                    x[c].0,
                    x[c].1.sqrt(),
                    y[c].0,
                    y[c].1.sqrt()
                ));
            }
        }
    }
    println!("{tests} tile × channel tests, smallest p = {min_p:.3e}, per-test α = {per_test:.3e}");
    if failures.is_empty() {
        Ok(())
    } else {
        Err(failures.join("\n"))
    }
}

fn settings(integrator: Integrator, spp: u32, max_depth: u32) -> RenderSettings {
    RenderSettings {
        width: 32,
        height: 32,
        spp,
        max_depth,
        sampler: SAMPLER_INDEPENDENT,
        integrator,
        ..Default::default()
    }
}

/// Scenes × integrators, Šidák over the whole test.
#[test]
fn light_and_bdpt_match_the_path_tracer() {
    let cases: &[(&str, Integrator)] = &[
        ("cornell-box.gltf", Integrator::Light),
        ("cornell-box.gltf", Integrator::Bdpt),
        ("furnace.gltf", Integrator::Light),
        ("furnace.gltf", Integrator::Bdpt),
        ("cornell-materials.gltf", Integrator::Bdpt),
        ("veach-mis.gltf", Integrator::Bdpt),
        ("instances.gltf", Integrator::Bdpt),
        ("many-lights.gltf", Integrator::Bdpt),
    ];
    let alpha = sidak(0.01, cases.len());
    let mut failed = Vec::new();
    for &(name, integrator) in cases {
        let scene = prepared(name);
        let spp = if integrator == Integrator::Bdpt { 4 } else { 8 };
        let ours = settings(integrator, spp, 5);
        let path = settings(Integrator::Path, spp, 5);
        print!("{name} {integrator:?}: ");
        if let Err(e) = same_expectation(&scene, &ours, &path, alpha) {
            failed.push(format!("{name} {integrator:?}:\n{e}"));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}
