//! KHR_materials_dispersion on scenes/prism.gltf (tools/gen_scenes.py, `prism`): a glass prism
//! of Abbe number 10 between the camera and a white slit the camera sees only through it.
//!
//! - The extension loads (no "ignored" note), and a malformed `dispersion` is one error naming
//!   its JSON path.
//! - The prism splits the slit's white into a spectrum in the order physics gives: blue refracts
//!   more than red, so the camera must look further towards the apex (+X, the image's right) to
//!   see the slit in blue (tools/gen_scenes.py, `prism_apparent_angle`: 450, 550 and 650 nm at
//!   +3.3, +0.6 and −0.8 degrees). The channels' centroids across the spectrum must lie red <
//!   green < blue, each step significant over independent batches.
//! - Without dispersion the same render is grey in every pixel, bit for bit: paths that meet no
//!   dispersive material stay RGB and carry no colour noise.
//! - The GPU agrees with the CPU per tile for the path tracer, light tracing and BDPT.

use crate::common;

use crate::common::{batch_tiles, compare_batch_tiles, BATCHES};
use wavetrace::film::Film;
use wavetrace::layout::SAMPLER_INDEPENDENT;
use wavetrace::render::Integrator;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::Scene;
use wavetrace::stats::{sidak, welch_t_test};

const WIDTH: u32 = 96;
const HEIGHT: u32 = 64;

fn settings(integrator: Integrator, spp: u32, seed: u32) -> RenderSettings {
    RenderSettings {
        width: WIDTH,
        height: HEIGHT,
        spp,
        seed,
        max_depth: 8,
        sampler: SAMPLER_INDEPENDENT,
        integrator,
        ..RenderSettings::default()
    }
}

fn prism() -> Scene {
    Scene::load(&common::scene_path("prism.gltf")).unwrap_or_else(|e| panic!("{e:#}"))
}

#[test]
fn the_extension_loads_and_bad_values_are_named() {
    let scene = prism();
    assert!(
        scene
            .notes
            .iter()
            .all(|n| !n.contains("KHR_materials_dispersion")),
        "{:?}",
        scene.notes
    );
    let glass = scene
        .materials
        .iter()
        .find(|m| m.name == "dispersive glass")
        .unwrap();
    assert_eq!((glass.ior, glass.dispersion), (1.5, 2.0));
    let text = std::fs::read_to_string(common::scene_path("prism.gltf")).unwrap();
    let dir = std::env::temp_dir().join(format!("wavetrace-dispersion-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for bad in ["-1.0", "\"strong\"", "[2.0]"] {
        let path = dir.join("bad-prism.gltf");
        std::fs::write(
            &path,
            text.replace("\"dispersion\": 2.0", &format!("\"dispersion\": {bad}")),
        )
        .unwrap();
        let message = format!("{:#}", Scene::load(&path).expect_err(bad));
        assert!(
            message.contains("bad-prism.gltf")
                && message.contains("materials[2].extensions.KHR_materials_dispersion.dispersion")
                && message.contains("non-negative"),
            "{bad}: {message}"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The rows through the prism's middle and the columns from its apex to past the spectrum's
/// blue end (the white image of the slit that reaches the camera by an internal reflection
/// lies left of the apex, outside).
const ROWS: std::ops::Range<u32> = 26..38;
const COLUMNS: std::ops::Range<u32> = 43..66;

/// Per channel, the intensity-weighted mean column over [`ROWS`] × [`COLUMNS`].
fn centroids(film: &Film) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    let mut weight = [0.0f64; 3];
    for y in ROWS {
        for x in COLUMNS {
            let p = film.mean_f64((x + y * film.width) as usize);
            for c in 0..3 {
                sum[c] += x as f64 * p[c] as f64;
                weight[c] += p[c] as f64;
            }
        }
    }
    std::array::from_fn(|c| sum[c] / weight[c])
}

#[test]
fn a_prism_spreads_white_light_red_to_blue() {
    let prepared = PreparedScene::new(&prism());
    let per_batch: Vec<[f64; 3]> = (0..BATCHES)
        .map(|b| {
            let film = common::render_cpu(&prepared, &settings(Integrator::Path, 32, 100 + b)).film;
            centroids(&film)
        })
        .collect();
    // Each step (green − red, blue − green) over the batches: its mean, the variance of that
    // mean from the batches' spread, one-sided at α = 0.01 Šidák-corrected over the two.
    let alpha = sidak(0.01, 2);
    let n = BATCHES as f64;
    for (lo, hi, what) in [(0, 1, "green − red"), (1, 2, "blue − green")] {
        let d: Vec<f64> = per_batch.iter().map(|c| c[hi] - c[lo]).collect();
        let mean = d.iter().sum::<f64>() / n;
        let var = d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0);
        let (t, _, p) = welch_t_test(mean, var / n, n - 1.0, 0.0, 0.0, 1.0);
        println!(
            "{what}: {mean:.3} columns (t = {t:.1}, one-sided p = {:.2e})",
            p / 2.0
        );
        assert!(
            t > 0.0 && p / 2.0 < alpha,
            "{what}: {mean:.3} columns, t = {t:.2}, one-sided p = {:.3e} (α {alpha:.2e}); per batch {per_batch:?}",
            p / 2.0
        );
    }
}

#[test]
fn without_dispersion_every_pixel_stays_grey() {
    let text = std::fs::read_to_string(common::scene_path("prism.gltf")).unwrap();
    let dir = std::env::temp_dir().join(format!("wavetrace-no-dispersion-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("prism-without-dispersion.gltf");
    std::fs::write(
        &path,
        text.replace("\"dispersion\": 2.0", "\"dispersion\": 0.0"),
    )
    .unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    std::fs::remove_dir_all(&dir).ok();
    let prepared = PreparedScene::new(&scene);
    assert_eq!(
        prepared.frame_params(&RenderSettings::default()).spectral,
        0
    );
    for integrator in [Integrator::Path, Integrator::Bdpt] {
        let film = common::render_cpu(&prepared, &settings(integrator, 8, 3)).film;
        let mut lit = 0;
        for y in 0..HEIGHT {
            for x in 0..WIDTH {
                let p = film.mean_f64((x + y * film.width) as usize);
                assert!(
                    p[0] == p[1] && p[1] == p[2],
                    "{integrator:?}: pixel ({x}, {y}) is {p:?}"
                );
                lit += usize::from(p[0] > 0.0);
            }
        }
        assert!(lit > 1000, "{integrator:?}: only {lit} pixels lit");
    }
    // With dispersion, the same render through the prism is coloured.
    let film = common::render_cpu(
        &PreparedScene::new(&prism()),
        &settings(Integrator::Path, 8, 3),
    )
    .film;
    let c = centroids(&film);
    assert!(c[0] != c[2], "{c:?}");
}

#[test]
fn gpu_matches_cpu_on_the_prism() {
    let prepared = PreparedScene::new(&prism());
    let cases = [
        ("path", Integrator::Path, 8),
        ("light", Integrator::Light, 8),
        ("bdpt", Integrator::Bdpt, 4),
    ];
    let small = |integrator, spp| RenderSettings {
        width: 48,
        height: 32,
        ..settings(integrator, spp, 0)
    };
    let cpu = |s: &RenderSettings| Some(common::render_cpu(&prepared, s).film);
    let gpu = |s: &RenderSettings| common::render_gpu(&prepared, s, None).map(|o| o.film);
    let tiles = (48 / 8) * (32 / 8);
    let per_test = sidak(0.01, cases.len() * tiles * 3);
    let mut failures = Vec::new();
    for (k, &(name, integrator, spp)) in cases.iter().enumerate() {
        let Some(g) = batch_tiles(&small(integrator, spp), 10 + 2 * k as u32, &gpu) else {
            return;
        };
        let c = batch_tiles(&small(integrator, spp), 11 + 2 * k as u32, &cpu).unwrap();
        let min_p = compare_batch_tiles(name, &g, &c, "CPU", per_test, &mut failures);
        println!("{name}: GPU vs CPU smallest p {min_p:.3e} (per-test α {per_test:.2e})");
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
