//! The samplers on the CPU reference, direct lighting of the Cornell box: N-rooks stratification
//! (lecture, "Stratified sampling") lowers the variance of the pixel estimates below independent
//! sampling, and Owen-scrambled Sobol points (a (0,2)-sequence per pair: stratified in every
//! elementary interval, not only rows and columns) lower it below N rooks.

use crate::common::{prepared, render_cpu};
use wavetrace::layout::{SAMPLER_INDEPENDENT, SAMPLER_SOBOL, SAMPLER_STRATIFIED};
use wavetrace::render::RenderSettings;

const SEEDS: u32 = 256;
/// Standard deviations of the variance ratio under equal variances that a difference must
/// exceed (one-sided p < 3.2e-5 for a normal ratio).
const Z: f64 = 4.0;

/// The sum over the image of each pixel estimate's variance across `SEEDS` independent renders,
/// and an estimate of that sum's own variance: Σ over pixels of Var(s²), with
/// Var(s²) = μ₄/n − σ⁴(n − 3)/(n(n − 1)) for n values (Cramér 1946, §27.4), which holds for
/// any distribution of the pixel estimate, heavy tails included. The sum is dominated by the
/// few pixels on the light's edge (their coverage of the light varies most), so it has far fewer
/// effective degrees of freedom than pixels × (SEEDS − 1): hence the many seeds, and a variance
/// estimated from the data.
fn variance_across_seeds(sampler: u32) -> (f64, f64) {
    let scene = prepared("cornell-box.gltf");
    let films: Vec<_> = (0..SEEDS)
        .map(|seed| {
            let s = RenderSettings {
                width: 16,
                height: 16,
                spp: 16,
                max_depth: 1,
                seed,
                sampler,
                ..Default::default()
            };
            render_cpu(&scene, &s).film
        })
        .collect();
    let n = SEEDS as f64;
    let (mut total, mut total_var) = (0.0, 0.0);
    for p in 0..films[0].pixels.len() {
        let values: Vec<f64> = films
            .iter()
            .map(|f| f.mean(p).element_sum() as f64)
            .collect();
        let mean = values.iter().sum::<f64>() / n;
        let s2 = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
        let m4 = values.iter().map(|v| (v - mean).powi(4)).sum::<f64>() / n;
        total += s2;
        total_var += (m4 / n - s2 * s2 * (n - 3.0) / (n * (n - 1.0))).max(0.0);
    }
    (total, total_var)
}

/// The ratio a / b of two summed variances and its standard error (delta method: the relative
/// variances of independent sums add).
fn ratio(a: (f64, f64), b: (f64, f64)) -> (f64, f64) {
    (a.0 / b.0, (a.1 / (a.0 * a.0) + b.1 / (b.0 * b.0)).sqrt())
}

#[test]
fn stratification_lowers_the_variance_of_direct_lighting() {
    let (r, sigma) = ratio(
        variance_across_seeds(SAMPLER_STRATIFIED),
        variance_across_seeds(SAMPLER_INDEPENDENT),
    );
    println!("variance ratio stratified / independent = {r:.3} (σ ≈ {sigma:.3})");
    assert!(
        r < 1.0 - Z * sigma,
        "stratification did not lower the variance: ratio {r:.3}, σ {sigma:.3}"
    );
}

#[test]
fn sobol_lowers_the_variance_below_stratification() {
    let (r, sigma) = ratio(
        variance_across_seeds(SAMPLER_SOBOL),
        variance_across_seeds(SAMPLER_STRATIFIED),
    );
    println!("variance ratio sobol / stratified = {r:.3} (σ ≈ {sigma:.3})");
    assert!(
        r < 1.0 - Z * sigma,
        "Sobol points did not lower the variance below N rooks: ratio {r:.3}, σ {sigma:.3}"
    );
}
