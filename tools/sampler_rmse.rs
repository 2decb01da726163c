//! RMSE against samples per pixel for each sampler (independent, N-rooks stratified, Sobol) on
//! the committed scenes, with the CPU reference integrator:
//!
//!     nice cargo run --release --example sampler_rmse [-- [--seeds K] [--chunks C]
//!         [--chunk-spp N] [--size S] [--max-depth D] [SCENE.gltf ...]]
//!
//! Per scene a reference is rendered as C independent chunks (independent sampler, N spp each,
//! seeds unlike the test renders'), combined in f64. Each test image X (K seeds per sampler and
//! spp) is compared with the reference R: since both are unbiased and independent,
//! E[(X − R)²] = MSE(X) + Var(R), so the pixel's Var(R) — the spread of the chunk means over C,
//! unbiased whatever the sampler — is subtracted. The printed RMSE is √ of the MSE averaged over
//! pixels, channels and seeds, with its standard error over the seeds; "MSE / indep." is the
//! MSE relative to the independent sampler at the same spp.

use anyhow::{bail, Context, Result};
use std::path::PathBuf;
use wavetrace::film::Film;
use wavetrace::layout::{SAMPLER_INDEPENDENT, SAMPLER_SOBOL, SAMPLER_STRATIFIED};
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::Scene;

const SPPS: [u32; 4] = [4, 16, 64, 256];
const SAMPLERS: [(&str, u32); 3] = [
    ("independent", SAMPLER_INDEPENDENT),
    ("stratified", SAMPLER_STRATIFIED),
    ("sobol", SAMPLER_SOBOL),
];
/// Reference chunks use seeds from here on; test images use seeds 1..=K.
const REFERENCE_SEED: u32 = 1_000_000;

struct Options {
    seeds: u32,
    chunks: u32,
    chunk_spp: u32,
    size: u32,
    max_depth: u32,
    scenes: Vec<PathBuf>,
}

fn parse_options() -> Result<Options> {
    let mut o = Options {
        seeds: 8,
        chunks: 16,
        chunk_spp: 1024,
        size: 64,
        max_depth: RenderSettings::default().max_depth,
        scenes: Vec::new(),
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut number = |name: &str| -> Result<u32> {
            let v = args
                .next()
                .with_context(|| format!("{name} needs a value"))?;
            let n: u32 = v.parse().with_context(|| format!("{name} {v}"))?;
            if n == 0 {
                bail!("{name} must be positive");
            }
            Ok(n)
        };
        match a.as_str() {
            "--seeds" => o.seeds = number("--seeds")?.max(2),
            "--chunks" => o.chunks = number("--chunks")?.max(2),
            "--chunk-spp" => o.chunk_spp = number("--chunk-spp")?,
            "--size" => o.size = number("--size")?,
            "--max-depth" => o.max_depth = number("--max-depth")?,
            _ if a.starts_with("--") => bail!("unknown option {a}"),
            _ => o.scenes.push(PathBuf::from(a)),
        }
    }
    if o.scenes.is_empty() {
        o.scenes = ["scenes/cornell-box.gltf", "scenes/furnace.gltf"]
            .map(PathBuf::from)
            .to_vec();
    }
    Ok(o)
}

/// The reference image: per pixel and channel, its mean and the variance of that mean.
struct Reference {
    mean: Vec<[f64; 3]>,
    variance: Vec<[f64; 3]>,
}

/// The mean of `chunks` independent renders and, per pixel, the variance of that mean
/// (the chunk means' sample variance over `chunks`).
fn reference(scene: &PreparedScene, o: &Options) -> Reference {
    let films: Vec<Film> = (0..o.chunks)
        .map(|c| {
            render(
                scene,
                o,
                SAMPLER_INDEPENDENT,
                o.chunk_spp,
                REFERENCE_SEED + c,
            )
        })
        .collect();
    let n = o.chunks as f64;
    let pixels = films[0].len();
    let (mut mean, mut variance) = (vec![[0.0; 3]; pixels], vec![[0.0; 3]; pixels]);
    for p in 0..pixels {
        for c in 0..3 {
            let values: Vec<f64> = films.iter().map(|f| f.mean_f64(p)[c]).collect();
            let m = values.iter().sum::<f64>() / n;
            let s2 = values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1.0);
            mean[p][c] = m;
            variance[p][c] = s2 / n;
        }
    }
    Reference { mean, variance }
}

fn render(scene: &PreparedScene, o: &Options, sampler: u32, spp: u32, seed: u32) -> Film {
    let settings = RenderSettings {
        width: o.size,
        height: o.size,
        spp,
        max_depth: o.max_depth,
        seed,
        sampler,
        ..RenderSettings::default()
    };
    wavetrace::cpu::render(scene, &settings).film
}

/// MSE of `film` against the reference, its variance subtracted, averaged over pixels and
/// channels.
fn mse(film: &Film, r: &Reference) -> f64 {
    let mut total = 0.0;
    for p in 0..film.len() {
        for (c, m) in film.mean_f64(p).iter().enumerate() {
            total += (m - r.mean[p][c]).powi(2) - r.variance[p][c];
        }
    }
    total / (3 * film.len()) as f64
}

fn main() -> Result<()> {
    let o = parse_options()?;
    for path in &o.scenes {
        let scene = Scene::load(path).with_context(|| format!("loading {}", path.display()))?;
        let scene = PreparedScene::new(&scene);
        let r = reference(&scene, &o);
        let ref_var = r.variance.iter().flatten().sum::<f64>() / (3 * r.variance.len()) as f64;
        println!(
            "\n{}: {}×{}, max depth {}, reference {}×{} spp (its RMSE ≈ {:.2e}), {} seeds",
            path.display(),
            o.size,
            o.size,
            o.max_depth,
            o.chunks,
            o.chunk_spp,
            ref_var.sqrt(),
            o.seeds
        );
        println!("| spp | sampler | RMSE | ± (s.e.) | MSE / indep. |");
        println!("|---:|---|---:|---:|---:|");
        for spp in SPPS {
            let mut independent = f64::NAN;
            for (name, sampler) in SAMPLERS {
                let mses: Vec<f64> = (1..=o.seeds)
                    .map(|seed| mse(&render(&scene, &o, sampler, spp, seed), &r))
                    .collect();
                let k = mses.len() as f64;
                let m = mses.iter().sum::<f64>() / k;
                let sd = (mses.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (k - 1.0)).sqrt();
                if sampler == SAMPLER_INDEPENDENT {
                    independent = m;
                }
                // Standard error of √MSE by the delta method: s.e.(MSE) / (2 √MSE).
                let rmse = m.max(0.0).sqrt();
                let se = sd / k.sqrt() / (2.0 * rmse);
                println!(
                    "| {spp} | {name} | {rmse:.4e} | {se:.1e} | {:.3} |",
                    m / independent
                );
            }
        }
    }
    Ok(())
}
