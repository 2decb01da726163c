//! The stratified sampler (lecture, "Stratified sampling": N rooks) against the independent one
//! on the CPU reference: same expectation, and lower variance of the pixel estimates.

mod common;

use common::{prepared, render_cpu};
use wavetrace::layout::{SAMPLER_INDEPENDENT, SAMPLER_STRATIFIED};
use wavetrace::render::RenderSettings;

const SEEDS: u32 = 16;

/// Per-pixel variance, across `SEEDS` independent renders, of the pixel estimate, summed over
/// the image, with the degrees of freedom of that sum.
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
    let pixels = films[0].pixels.len();
    let mut total = 0.0;
    for p in 0..pixels {
        let values: Vec<f64> = films
            .iter()
            .map(|f| f.mean(p).element_sum() as f64)
            .collect();
        let mean = values.iter().sum::<f64>() / SEEDS as f64;
        total += values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (SEEDS - 1) as f64;
    }
    (total, (pixels as u32 * (SEEDS - 1)) as f64)
}

#[test]
fn stratification_lowers_the_variance_of_direct_lighting() {
    let (stratified, dof) = variance_across_seeds(SAMPLER_STRATIFIED);
    let (independent, _) = variance_across_seeds(SAMPLER_INDEPENDENT);
    let ratio = stratified / independent;
    // Were the variances equal, the ratio of the two sums would be ≈ 1 with a standard deviation
    // of about √(2/dof + 2/dof) (each sum ≈ a χ² with `dof` degrees of freedom, scaled); demand a
    // ratio below 1 by more than 4 of those.
    let sigma = (4.0 / dof).sqrt();
    println!(
        "variance ratio stratified / independent = {ratio:.3} (σ under equality ≈ {sigma:.3})"
    );
    assert!(
        ratio < 1.0 - 4.0 * sigma,
        "stratification did not lower the variance: ratio {ratio:.3}"
    );
}
