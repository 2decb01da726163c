//! The per-tile two-sample comparison of two films (DESIGN.md, Verification 3) and the mean of
//! a film with its standard error, built on the tests of the parent module.

use super::distributions::{sidak, welch_with_known_variance};
use crate::film::Film;
use glam::DVec3;
use std::fmt;

/// A tile × channel whose two films differ significantly.
#[derive(Clone, Debug, PartialEq)]
pub struct TileFailure {
    /// Tile column and row (tile (0, 0) holds pixel (0, 0), the top-left corner).
    pub tile_x: u32,
    pub tile_y: u32,
    /// 0 = R, 1 = G, 2 = B.
    pub channel: usize,
    /// Tile means (mean over the tile's pixels of the pixel means) of film a and film b.
    pub mean_a: f64,
    pub mean_b: f64,
    /// Standard error of mean_a − mean_b.
    pub std_err: f64,
    /// Welch's t of mean_a − mean_b.
    pub t: f64,
    /// Two-sided p-value.
    pub p: f64,
}

/// Outcome of `compare_films`.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// Number of tile × channel tests.
    pub tests: usize,
    /// Family-wise significance level.
    pub alpha: f64,
    /// Šidák-corrected level of each test: a test fails if p < per_test_alpha.
    pub per_test_alpha: f64,
    /// Smallest p-value over all tests (1 if there were none).
    pub min_p: f64,
    /// Failing tests, in tile row-major order then channel.
    pub failures: Vec<TileFailure>,
    /// Welch's t of every tile and channel (a − b over its standard error), tiles in row-major
    /// order: the signed heat map of `wavetrace verify`.
    pub tile_t: Vec<[f64; 3]>,
    /// Tile edge in pixels and the film size, to name each failure's pixel range.
    pub tile: u32,
    pub width: u32,
    pub height: u32,
}

impl Comparison {
    /// True when no tile × channel test rejected equality.
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

impl fmt::Display for Comparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{}: {} of {} tile×channel Welch t tests failed ({}×{} tiles of {}×{} px; family-wise α = {}, \
             Šidák per-test α = {:.3e}; smallest p = {:.3e})",
            if self.passed() { "PASS" } else { "FAIL" },
            self.failures.len(),
            self.tests,
            self.width.div_ceil(self.tile.max(1)),
            self.height.div_ceil(self.tile.max(1)),
            self.tile,
            self.tile,
            self.alpha,
            self.per_test_alpha,
            self.min_p,
        )?;
        for e in &self.failures {
            let (x0, y0) = (e.tile_x * self.tile, e.tile_y * self.tile);
            let (x1, y1) = (
                (x0 + self.tile).min(self.width),
                (y0 + self.tile).min(self.height),
            );
            writeln!(
                f,
                "  tile ({}, {}) → pixels x {}..{}, y {}..{}, channel {}: mean a = {:.6e}, mean b = {:.6e}, \
                 std err = {:.3e}, t = {:.2}, p = {:.3e}",
                e.tile_x,
                e.tile_y,
                x0,
                x1,
                y0,
                y1,
                ["R", "G", "B"][e.channel],
                e.mean_a,
                e.mean_b,
                e.std_err,
                e.t,
                e.p,
            )?;
        }
        Ok(())
    }
}

/// Unit roundoff of f32 (2⁻²⁴).
const F32_UNIT_ROUNDOFF: f64 = f32::EPSILON as f64 / 2.0;

/// One film's statistics over one tile, per channel.
pub(super) struct TileSide {
    /// Mean over the tile's P pixels of the pixel means.
    pub(super) mean: [f64; 3],
    /// Variance of that mean: Σ variance_of_mean / P².
    pub(super) var: [f64; 3],
    /// Welch–Satterthwaite degrees of freedom of `var`.
    df: [f64; 3],
    /// Bound on the f32 summation error of `mean` (Higham 2002, §4.2: |error of a sum of n
    /// terms| ≤ (n − 1)u Σ|xᵢ|), averaged over the tile's pixels.
    rounding: [f64; 3],
}

pub(super) fn tile_side(film: &Film, x0: u32, x1: u32, y0: u32, y1: u32) -> TileSide {
    let mut side = TileSide {
        mean: [0.0; 3],
        var: [0.0; 3],
        df: [0.0; 3],
        rounding: [0.0; 3],
    };
    let mut df_denominator = [0.0; 3];
    let count = ((x1 - x0) * (y1 - y0)) as f64;
    for y in y0..y1 {
        for x in x0..x1 {
            let p = x as usize + y as usize * film.width as usize;
            let (m, v) = (film.mean_f64(p), film.variance_of_mean_f64(p));
            let n = film.pixels[p].count as f64;
            for c in 0..3 {
                side.mean[c] += m[c];
                side.var[c] += v[c];
                side.rounding[c] += n * F32_UNIT_ROUNDOFF * m[c].abs();
                if v[c] > 0.0 {
                    df_denominator[c] += v[c] * v[c] / (n - 1.0);
                }
            }
        }
    }
    // Σ v_p and Σ v_p²/(n_p − 1) scale alike by 1/P², so the df can use the unscaled sums.
    side.df = std::array::from_fn(|c| {
        if df_denominator[c] > 0.0 {
            side.var[c] * side.var[c] / df_denominator[c]
        } else {
            f64::INFINITY
        }
    });
    TileSide {
        mean: side.mean.map(|m| m / count),
        var: side.var.map(|v| v / (count * count)),
        df: side.df,
        rounding: side.rounding.map(|r| r / count),
    }
}

/// Per-tile two-sample comparison of two films of equal size (DESIGN.md, Verification 3).
///
/// Tiles are `tile`×`tile` pixels (edge tiles smaller). Per tile and channel and for each film:
/// the tile mean of its P pixel means, its variance Σ variance_of_mean / P², and its degrees of
/// freedom by Welch–Satterthwaite over the pixels, (Σ v_p)² / Σ (v_p² / (n_p − 1)), which is
/// Σ (n_p − 1) when the pixel variances are equal and discounts pixels whose variance is 0.
/// The two tile means are compared with Welch's t test; the difference's variance also holds
/// the bound on f32 summation error of both tile means as a known term, so films of a constant
/// (variance 0) rendered with different sample counts compare equal. Each test is at Šidák's
/// level for family-wise `alpha` over tiles × channels; a test with p < that level fails (a
/// non-finite tile mean fails with p = 0).
///
/// Pixels with fewer than 2 samples contribute no variance, so both films need ≥ 2 samples per
/// pixel for the test to mean anything. Errors if the sizes differ or `tile` is 0.
pub fn compare_films(a: &Film, b: &Film, tile: u32, alpha: f64) -> anyhow::Result<Comparison> {
    anyhow::ensure!(
        (a.width, a.height) == (b.width, b.height),
        "cannot compare films of different sizes: {}×{} and {}×{}",
        a.width,
        a.height,
        b.width,
        b.height
    );
    anyhow::ensure!(tile > 0, "tile size must be at least 1 pixel");
    anyhow::ensure!(
        alpha > 0.0 && alpha < 1.0,
        "significance level α = {alpha} is not in (0, 1)"
    );
    let (tiles_x, tiles_y) = (a.width.div_ceil(tile), a.height.div_ceil(tile));
    let tests = tiles_x as usize * tiles_y as usize * 3;
    let per_test_alpha = sidak(alpha, tests);
    let mut min_p: f64 = 1.0;
    let mut failures = Vec::new();
    let mut tile_t = Vec::with_capacity(tests / 3);
    for tile_y in 0..tiles_y {
        for tile_x in 0..tiles_x {
            let (x0, y0) = (tile_x * tile, tile_y * tile);
            let (x1, y1) = ((x0 + tile).min(a.width), (y0 + tile).min(a.height));
            let (sa, sb) = (tile_side(a, x0, x1, y0, y1), tile_side(b, x0, x1, y0, y1));
            let mut ts = [0.0; 3];
            for (c, tc) in ts.iter_mut().enumerate() {
                let rounding = sa.rounding[c] + sb.rounding[c];
                let (t, _df, p) = welch_with_known_variance(
                    sa.mean[c] - sb.mean[c],
                    [(sa.var[c], sa.df[c]), (sb.var[c], sb.df[c])],
                    rounding * rounding,
                );
                let p = if p.is_nan() { 0.0 } else { p };
                *tc = t;
                min_p = min_p.min(p);
                if p < per_test_alpha {
                    failures.push(TileFailure {
                        tile_x,
                        tile_y,
                        channel: c,
                        mean_a: sa.mean[c],
                        mean_b: sb.mean[c],
                        std_err: (sa.var[c] + sb.var[c] + rounding * rounding).sqrt(),
                        t,
                        p,
                    });
                }
            }
            tile_t.push(ts);
        }
    }
    Ok(Comparison {
        tests,
        alpha,
        per_test_alpha,
        min_p,
        failures,
        tile_t,
        tile,
        width: a.width,
        height: a.height,
    })
}

/// Mean over all pixels of the pixel means, with its standard error √(Σ variance_of_mean) / P
/// (for analytic scenes whose every pixel has the same expected value).
pub fn film_mean(film: &Film) -> (DVec3, DVec3) {
    let (mut mean, mut var) = (DVec3::ZERO, DVec3::ZERO);
    for p in 0..film.len() {
        mean += DVec3::from_array(film.mean_f64(p));
        var += DVec3::from_array(film.variance_of_mean_f64(p));
    }
    let count = film.len().max(1) as f64;
    (mean / count, var.map(f64::sqrt) / count)
}

/// The ε of the relative MSE: Rousselle, Knaus & Zwicker's 10⁻², which keeps near-black
/// reference pixels from dominating the mean.
pub const RELATIVE_MSE_EPSILON: f64 = 1e-2;

/// Error of film `a` against the reference `b`, over pixels and channels of the pixel means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// Mean of (a − b)².
    pub mse: f64,
    /// Mean of (a − b)² / (b² + ε).
    pub relative_mse: f64,
    pub epsilon: f64,
}

/// Plain and relative mean squared error of `a` against the reference `b` (equal sizes).
pub fn image_error(a: &Film, b: &Film, epsilon: f64) -> anyhow::Result<ImageError> {
    anyhow::ensure!(
        (a.width, a.height) == (b.width, b.height) && !a.is_empty(),
        "cannot measure the error of a {}×{} film against a {}×{} one",
        a.width,
        a.height,
        b.width,
        b.height
    );
    let (mut squared, mut relative) = (0.0, 0.0);
    for p in 0..a.len() {
        for (x, y) in a.mean_f64(p).into_iter().zip(b.mean_f64(p)) {
            squared += (x - y) * (x - y);
            relative += (x - y) * (x - y) / (y * y + epsilon);
        }
    }
    let count = 3.0 * a.len() as f64;
    Ok(ImageError {
        mse: squared / count,
        relative_mse: relative / count,
        epsilon,
    })
}
