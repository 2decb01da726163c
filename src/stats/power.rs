//! The power of the per-tile comparison (`compare_films`) to detect a relative bias, predicted
//! from pilot renders, and the sample count that reaches a stated power (`verify --detect`).
//!
//! Model: the biased side's expectation is (1 + δ) times the unbiased one in every pixel. For
//! tile × channel i with expectation μᵢ and per-sample variances of the two tile means vₐ, v_b
//! (pilot variance of the mean × pilot spp), at N samples per pixel Welch's t is close to normal
//! with mean λᵢ = δ·|μᵢ| / √((vₐ + v_b)/N) (large degrees of freedom), so the test at two-sided
//! level α' (Šidák's per-test level) rejects with probability
//! pᵢ = Φ(λᵢ − z) + Φ(−λᵢ − z), z = Φ⁻¹(1 − α'/2).
//!
//! Two things keep this honest. The normal model needs the film's variance to be the variance
//! of the pixel mean, which holds for independent samples only (a stratified or Sobol pixel
//! mean varies less than its sample variance says), so `verify --detect` renders with the
//! independent sampler. And tiles are independent (their pixels are) but the three channels of
//! a tile move together in a render and the film keeps no covariance, so a tile counts as
//! rejecting with the probability of its likeliest channel — the value for perfectly
//! correlated channels, below the truth — and the family with 1 − Π_tiles (1 − max_c p). The
//! predicted power is thus a lower bound, and the sample count chosen for it is enough.

use super::compare::{tile_side, TileSide};
use super::distributions::{normal_quantile_upper, sidak};
use crate::film::Film;
use statrs::distribution::{ContinuousCDF, Normal};

/// Per tile and channel: the pilot's estimate of the expectation and the per-sample variance of
/// the difference of the two tile means.
pub struct PowerModel {
    tiles: Vec<[(f64, f64); 3]>,
    per_test_alpha: f64,
}

impl PowerModel {
    /// From pilot films `a` and `b` of `pilot_spp` samples per pixel each, for tiles of `tile`
    /// pixels at family-wise level `alpha`.
    pub fn new(a: &Film, b: &Film, pilot_spp: u32, tile: u32, alpha: f64) -> PowerModel {
        let (tiles_x, tiles_y) = (a.width.div_ceil(tile), a.height.div_ceil(tile));
        let mut tiles = Vec::new();
        for ty in 0..tiles_y {
            for tx in 0..tiles_x {
                let (x0, y0) = (tx * tile, ty * tile);
                let (x1, y1) = ((x0 + tile).min(a.width), (y0 + tile).min(a.height));
                let (sa, sb): (TileSide, TileSide) =
                    (tile_side(a, x0, x1, y0, y1), tile_side(b, x0, x1, y0, y1));
                tiles.push(std::array::from_fn(|c| {
                    let mean = 0.5 * (sa.mean[c] + sb.mean[c]);
                    let per_sample = (sa.var[c] + sb.var[c]) * pilot_spp as f64;
                    (mean, per_sample)
                }));
            }
        }
        PowerModel {
            per_test_alpha: sidak(alpha, 3 * tiles.len()),
            tiles,
        }
    }

    /// Probability that the comparison rejects at `spp` samples per pixel when one side is
    /// biased by relative `delta`.
    pub fn power(&self, delta: f64, spp: u32) -> f64 {
        let z = normal_quantile_upper(0.5 * self.per_test_alpha);
        let normal = Normal::standard();
        let mut log_accept = 0.0;
        for channels in &self.tiles {
            let p = channels
                .iter()
                .map(|&(mean, per_sample)| {
                    let shift = delta * mean.abs();
                    if per_sample > 0.0 {
                        let lambda = shift / (per_sample / spp as f64).sqrt();
                        normal.cdf(lambda - z) + normal.cdf(-lambda - z)
                    } else if shift > 0.0 {
                        1.0
                    } else {
                        self.per_test_alpha
                    }
                })
                .fold(0.0f64, f64::max);
            log_accept += (-p.min(1.0)).ln_1p();
        }
        -log_accept.exp_m1()
    }

    /// The smallest spp in [`min_spp`, `max_spp`] whose power to detect `delta` reaches
    /// `target`, with that power; `max_spp` and its power if none does.
    pub fn plan(&self, delta: f64, target: f64, min_spp: u32, max_spp: u32) -> (u32, f64) {
        if self.power(delta, max_spp) < target {
            return (max_spp, self.power(delta, max_spp));
        }
        let (mut lo, mut hi) = (min_spp, max_spp);
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if self.power(delta, mid) >= target {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        (lo, self.power(delta, lo))
    }
}
