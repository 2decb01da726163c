//! Statistics for verification: special functions, p-values, Welch's t test, Pearson's χ² test,
//! and the per-tile two-sample comparison of two films (DESIGN.md, Verification 1–3).
//!
//! Special functions follow Numerical Recipes, 3rd ed. (Press, Teukolsky, Vetterling, Flannery,
//! 2007): ln Γ §6.1, incomplete gamma §6.2, incomplete beta §6.4, Student's t and χ² §6.14.

use crate::film::Film;
use glam::DVec3;
use std::fmt;

/// Relative accuracy targeted by the series and continued fractions.
const EPS: f64 = 1e-15;
/// Smallest magnitude kept in the modified Lentz method (NR3 §5.2).
const FPMIN: f64 = f64::MIN_POSITIVE / EPS;
/// Series / continued-fraction terms before giving up; convergence needs O(√max(a, b)).
const MAX_ITERATIONS: usize = 1_000_000;

/// ln Γ(x) for x > 0 (NR3 §6.1 `gammln`: Lanczos approximation, g = 671/128, 14 terms, relative
/// error < 1e-15); for x < 0.5, ln |Γ(x)| through the reflection formula Γ(x)Γ(1−x) = π/sin πx.
pub fn ln_gamma(x: f64) -> f64 {
    // NR3's coefficients as published (more digits than f64 holds).
    #[allow(clippy::excessive_precision)]
    const COF: [f64; 14] = [
        57.156_235_665_862_923_5,
        -59.597_960_355_475_491_2,
        14.136_097_974_741_747_1,
        -0.491_913_816_097_620_199,
        0.339_946_499_848_118_887e-4,
        0.465_236_289_270_485_756e-4,
        -0.983_744_753_048_795_646e-4,
        0.158_088_703_224_912_494e-3,
        -0.210_264_441_724_104_883e-3,
        0.217_439_618_115_212_643e-3,
        -0.164_318_106_536_763_890e-3,
        0.844_182_239_838_527_433e-4,
        -0.261_908_384_015_814_087e-4,
        0.368_991_826_595_316_234e-5,
    ];
    if x < 0.5 {
        let s = (std::f64::consts::PI * x).sin().abs();
        return (std::f64::consts::PI / s).ln() - ln_gamma(1.0 - x);
    }
    let mut y = x;
    let tmp = x + 671.0 / 128.0;
    let tmp = (x + 0.5) * tmp.ln() - tmp;
    #[allow(clippy::excessive_precision)]
    let mut ser = 0.999_999_999_999_997_092;
    for c in COF {
        y += 1.0;
        ser += c / y;
    }
    tmp + (2.506_628_274_631_000_5 * ser / x).ln()
}

/// Regularised incomplete beta I_x(a, b), a, b > 0, x ∈ [0, 1] (NR3 §6.4 `betai`: continued
/// fraction evaluated with the modified Lentz method, on the side of x where it converges fast,
/// using I_x(a, b) = 1 − I_{1−x}(b, a)).
pub fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    incomplete_beta_xy(a, b, x, 1.0 - x)
}

/// `incomplete_beta` with y = 1 − x supplied exactly by the caller (no cancellation near x = 1).
fn incomplete_beta_xy(a: f64, b: f64, x: f64, y: f64) -> f64 {
    if !(a > 0.0 && b > 0.0 && (0.0..=1.0).contains(&x)) {
        return f64::NAN;
    }
    if x == 0.0 || y == 0.0 {
        return if x == 0.0 { 0.0 } else { 1.0 };
    }
    let front = ln_beta_front(a, b, x, y).exp();
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_continued_fraction(a, b, x, y) / a
    } else {
        1.0 - front * beta_continued_fraction(b, a, y, x) / b
    }
}

/// Above this, ln Γ is expanded with Stirling's series in the prefactors (see `ln_beta_front`).
const STIRLING_MIN: f64 = 100.0;

/// δ(x) = ln Γ(x) − [(x − ½) ln x − x + ½ ln 2π], Stirling's series (DLMF 5.11.1) to x⁻⁷;
/// the truncation error is below 1e-21 for x ≥ 100.
fn stirling_remainder(x: f64) -> f64 {
    let r = 1.0 / (x * x);
    (1.0 / 12.0 - r * (1.0 / 360.0 - r * (1.0 / 1260.0 - r / 1680.0))) / x
}

/// ln of the prefactor x^a y^b / B(a, b) of I_x(a, b), with y = 1 − x. For large a or b the
/// ln Γ terms of the direct form cancel (ln Γ(5e8) ≈ 1e10 leaves a 1e-6 error), so there the
/// Γ ratios are expanded with Stirling's series and combined with the powers analytically:
/// a ln x + ln Γ(a + b) − ln Γ(a) = a ln1p((xb − ya)/a) − ½ ln1p(b/a) + b ln(a + b) − b + δ(a+b) − δ(a).
fn ln_beta_front(a: f64, b: f64, x: f64, y: f64) -> f64 {
    // ln x and ln y without cancellation when x or y is near 1.
    let ln_x = if x > 0.5 { (-y).ln_1p() } else { x.ln() };
    let ln_y = if y > 0.5 { (-x).ln_1p() } else { y.ln() };
    if a < STIRLING_MIN && b < STIRLING_MIN {
        return ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * ln_x + b * ln_y;
    }
    // The front is symmetric under (a, x) ↔ (b, y): make a the larger parameter.
    let (a, b, x, y, ln_y) = if a >= b {
        (a, b, x, y, ln_y)
    } else {
        (b, a, y, x, ln_x)
    };
    let ab = a + b;
    let large_a = a * ((x * b - y * a) / a).ln_1p() - 0.5 * (b / a).ln_1p()
        + stirling_remainder(ab)
        - stirling_remainder(a);
    if b < STIRLING_MIN {
        large_a + b * (ab.ln() + ln_y) - b - ln_gamma(b)
    } else {
        // ln Γ(b) by Stirling too: b ln(y(a+b)) − b − ln Γ(b) = b ln1p((ya − xb)/b) + ½ ln b − ½ ln 2π − δ(b).
        large_a + b * ((y * a - x * b) / b).ln_1p() + 0.5 * b.ln()
            - 0.5 * (2.0 * std::f64::consts::PI).ln()
            - stirling_remainder(b)
    }
}

/// The continued fraction of I_x(a, b) (NR3 §6.4 `betacf`, modified Lentz), y = 1 − x.
fn beta_continued_fraction(a: f64, b: f64, x: f64, y: f64) -> f64 {
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let clamp = |v: f64| if v.abs() < FPMIN { FPMIN } else { v };
    let mut c = 1.0;
    // 1 − (a + b)x/(a + 1), written with y so that it does not cancel when x is near 1.
    let mut d = 1.0 / clamp((1.0 - b + qab * y) / qap);
    let mut h = d;
    for m in 1..MAX_ITERATIONS {
        let m = m as f64;
        let m2 = 2.0 * m;
        // Even step.
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 / clamp(1.0 + aa * d);
        c = clamp(1.0 + aa / c);
        h *= d * c;
        // Odd step.
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 / clamp(1.0 + aa * d);
        c = clamp(1.0 + aa / c);
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() <= EPS {
            break;
        }
    }
    h
}

/// Regularised lower incomplete gamma P(a, x) = γ(a, x)/Γ(a), a > 0, x ≥ 0 (NR3 §6.2 `gammp`:
/// series for x < a + 1, continued fraction otherwise).
pub fn incomplete_gamma_p(a: f64, x: f64) -> f64 {
    incomplete_gamma_pq(a, x).0
}

/// Regularised upper incomplete gamma Q(a, x) = 1 − P(a, x), computed without cancellation in
/// the upper tail (NR3 §6.2 `gammq`).
pub fn incomplete_gamma_q(a: f64, x: f64) -> f64 {
    incomplete_gamma_pq(a, x).1
}

/// (P(a, x), Q(a, x)), each from whichever of series / continued fraction gives it directly.
fn incomplete_gamma_pq(a: f64, x: f64) -> (f64, f64) {
    if a.is_nan() || x.is_nan() || a <= 0.0 || x < 0.0 {
        return (f64::NAN, f64::NAN);
    }
    if x == 0.0 {
        return (0.0, 1.0);
    }
    if x == f64::INFINITY {
        return (1.0, 0.0);
    }
    // ln(e^−x x^a / Γ(a)); for large a with Stirling's series, as a(ln1p(u) − u) + ½ ln a −
    // ½ ln 2π − δ(a), u = (x − a)/a, which avoids the cancellation of a ln x against ln Γ(a).
    let ln_front = if a < STIRLING_MIN {
        -x + a * x.ln() - ln_gamma(a)
    } else {
        let u = (x - a) / a;
        a * (u.ln_1p() - u) + 0.5 * a.ln()
            - 0.5 * (2.0 * std::f64::consts::PI).ln()
            - stirling_remainder(a)
    };
    if x < a + 1.0 {
        // Series (NR3 eq. 6.2.5): γ(a, x) = e^−x x^a Σ x^n / (a (a+1) … (a+n)).
        let (mut ap, mut del) = (a, 1.0 / a);
        let mut sum = del;
        for _ in 0..MAX_ITERATIONS {
            ap += 1.0;
            del *= x / ap;
            sum += del;
            if del.abs() < sum.abs() * EPS {
                break;
            }
        }
        let p = sum * ln_front.exp();
        (p, 1.0 - p)
    } else {
        // Continued fraction (NR3 eq. 6.2.7), modified Lentz.
        let clamp = |v: f64| if v.abs() < FPMIN { FPMIN } else { v };
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / FPMIN;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..MAX_ITERATIONS {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = 1.0 / clamp(an * d + b);
            c = clamp(b + an / c);
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() <= EPS {
                break;
            }
        }
        let q = ln_front.exp() * h;
        (1.0 - q, q)
    }
}

/// Two-sided p-value of Student's t with `df` > 0 degrees of freedom (df may be huge,
/// fractional or +∞). For df < 10⁴: P(|T| ≥ |t|) = I_{df/(df+t²)}(df/2, 1/2) (NR3 eq. 6.14.11),
/// relative error < 1e-11. For larger df the continued fraction is ill-conditioned (x is near 1),
/// so the t is mapped to a normal deviate by Hill's asymptotic expansion (G. W. Hill, "Algorithm
/// 395: Student's t-distribution", CACM 13(10), 1970), error O(df⁻³) (< 1e-13 at df = 10⁴), and
/// P(|Z| ≥ z) = Q(1/2, z²/2). NaN for df ≤ 0 or NaN input.
pub fn student_t_two_sided_p(t: f64, df: f64) -> f64 {
    if t.is_nan() || df.is_nan() || df <= 0.0 {
        return f64::NAN;
    }
    let t2 = t * t;
    if t2 == f64::INFINITY {
        return 0.0;
    }
    if df < 1e4 {
        return incomplete_beta_xy(0.5 * df, 0.5, df / (df + t2), t2 / (df + t2));
    }
    let z2 = if df == f64::INFINITY {
        t2
    } else {
        let a = df - 0.5;
        let b = 48.0 * a * a;
        let y = a * (t2 / df).ln_1p();
        let z =
            (((((-0.4 * y - 3.3) * y - 24.0) * y - 85.5) / (0.8 * y * y + 100.0 + b) + y + 3.0)
                / b
                + 1.0)
                * y.sqrt();
        z * z
    };
    incomplete_gamma_q(0.5, 0.5 * z2)
}

/// Upper-tail p-value of χ² with `dof` > 0 degrees of freedom: P(X ≥ chi2) = Q(dof/2, chi2/2)
/// (NR3 eq. 6.14.38).
pub fn chi_square_p(chi2: f64, dof: f64) -> f64 {
    if chi2 <= 0.0 {
        return if dof > 0.0 { 1.0 } else { f64::NAN };
    }
    incomplete_gamma_q(0.5 * dof, 0.5 * chi2)
}

/// Per-test significance for m independent tests at family-wise level α (Šidák 1967):
/// 1 − (1 − α)^(1/m), computed as −expm1(ln(1 − α)/m) to keep precision for large m.
pub fn sidak(alpha: f64, m: usize) -> f64 {
    if m == 0 {
        return alpha;
    }
    -((-alpha).ln_1p() / m as f64).exp_m1()
}

/// Welch's unequal-variance t test (Welch 1947) of two means, each given with the variance of
/// the mean and its degrees of freedom; df from the Welch–Satterthwaite equation
/// ν = (v_a + v_b)² / (v_a²/ν_a + v_b²/ν_b). Returns (t, df, two-sided p). Both variances 0:
/// p = 1 if the means are equal, else 0 (t = 0 or ±∞, df = 0).
pub fn welch_t_test(
    mean_a: f64,
    var_mean_a: f64,
    df_a: f64,
    mean_b: f64,
    var_mean_b: f64,
    df_b: f64,
) -> (f64, f64, f64) {
    welch_with_known_variance(
        mean_a - mean_b,
        [(var_mean_a, df_a), (var_mean_b, df_b)],
        0.0,
    )
}

/// Welch's test of a difference whose variance is Σ estimated parts (variance, df) plus a part
/// known exactly (infinite df).
fn welch_with_known_variance(diff: f64, parts: [(f64, f64); 2], known_var: f64) -> (f64, f64, f64) {
    let var: f64 = parts.iter().map(|(v, _)| v).sum::<f64>() + known_var;
    if var <= 0.0 {
        let p = if diff == 0.0 { 1.0 } else { 0.0 };
        let t = if diff == 0.0 {
            0.0
        } else {
            diff * f64::INFINITY
        };
        return (t, 0.0, p);
    }
    let denom: f64 = parts
        .iter()
        .filter(|(v, _)| *v > 0.0)
        .map(|(v, df)| v * v / df)
        .sum();
    let df = if denom > 0.0 {
        var * var / denom
    } else {
        f64::INFINITY
    };
    let t = diff / var.sqrt();
    (t, df, student_t_two_sided_p(t, df))
}

/// Pearson's χ² goodness of fit of observed counts against expected counts (same total). As in
/// pbrt-v4's `Chi2Test` (`src/pbrt/util/math.cpp`), cells are visited by increasing expectation
/// and those with expected < 5 are pooled into one cell until it reaches 5. dof = cells − 1
/// (no fitted parameters). A sample in a cell with expected 0 gives χ² = ∞, p = 0.
/// Returns (chi2, dof, p).
pub fn chi_square_gof(observed: &[f64], expected: &[f64]) -> (f64, f64, f64) {
    assert_eq!(
        observed.len(),
        expected.len(),
        "chi_square_gof: observed and expected differ in length"
    );
    const MIN_EXPECTED: f64 = 5.0;
    let mut order: Vec<usize> = (0..expected.len()).collect();
    order.sort_by(|&i, &j| expected[i].total_cmp(&expected[j]));
    let (mut chi2, mut cells) = (0.0, 0usize);
    let (mut pooled_obs, mut pooled_exp) = (0.0, 0.0);
    for i in order {
        let (o, e) = (observed[i], expected[i]);
        if e <= 0.0 {
            if o > 0.0 {
                return (f64::INFINITY, 0.0, 0.0);
            }
        } else if e < MIN_EXPECTED || (pooled_exp > 0.0 && pooled_exp < MIN_EXPECTED) {
            pooled_obs += o;
            pooled_exp += e;
        } else {
            chi2 += (o - e) * (o - e) / e;
            cells += 1;
        }
    }
    if pooled_exp > 0.0 {
        chi2 += (pooled_obs - pooled_exp) * (pooled_obs - pooled_exp) / pooled_exp;
        cells += 1;
    }
    let dof = cells.saturating_sub(1) as f64;
    let p = if dof > 0.0 {
        chi_square_p(chi2, dof)
    } else {
        1.0
    };
    (chi2, dof, p)
}

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
struct TileSide {
    /// Mean over the tile's P pixels of the pixel means.
    mean: [f64; 3],
    /// Variance of that mean: Σ variance_of_mean / P².
    var: [f64; 3],
    /// Welch–Satterthwaite degrees of freedom of `var`.
    df: [f64; 3],
    /// Bound on the f32 summation error of `mean` (Higham 2002, §4.2: |error of a sum of n
    /// terms| ≤ (n − 1)u Σ|xᵢ|), averaged over the tile's pixels.
    rounding: [f64; 3],
}

fn tile_side(film: &Film, x0: u32, x1: u32, y0: u32, y1: u32) -> TileSide {
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
    for tile_y in 0..tiles_y {
        for tile_x in 0..tiles_x {
            let (x0, y0) = (tile_x * tile, tile_y * tile);
            let (x1, y1) = ((x0 + tile).min(a.width), (y0 + tile).min(a.height));
            let (sa, sb) = (tile_side(a, x0, x1, y0, y1), tile_side(b, x0, x1, y0, y1));
            for c in 0..3 {
                let rounding = sa.rounding[c] + sb.rounding[c];
                let (t, _df, p) = welch_with_known_variance(
                    sa.mean[c] - sb.mean[c],
                    [(sa.var[c], sa.df[c]), (sb.var[c], sb.df[c])],
                    rounding * rounding,
                );
                let p = if p.is_nan() { 0.0 } else { p };
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
        }
    }
    Ok(Comparison {
        tests,
        alpha,
        per_test_alpha,
        min_p,
        failures,
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

#[cfg(test)]
#[allow(clippy::excessive_precision)] // reference values as printed by mpmath
mod tests {
    use super::*;
    use glam::Vec3;

    fn close(actual: f64, expected: f64, tolerance: f64) {
        assert!(
            (actual - expected).abs() <= tolerance,
            "got {actual}, expected {expected} ± {tolerance}"
        );
    }

    #[test]
    fn ln_gamma_known_values() {
        close(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln(), 1e-14);
        close(ln_gamma(1.0), 0.0, 1e-14);
        close(ln_gamma(2.0), 0.0, 1e-14);
        close(ln_gamma(10.0), 362_880f64.ln(), 1e-12);
        // ln Γ(100) = ln 99! (Abramowitz & Stegun table 6.4 / exact factorial).
        close(ln_gamma(100.0), 359.134_205_369_575_4, 1e-10);
        // Reflection: Γ(0.25) = 3.625609908221908…
        close(ln_gamma(0.25), 3.625_609_908_221_908_f64.ln(), 1e-13);
    }

    #[test]
    fn incomplete_beta_identities_and_values() {
        // I_x(a, 1) = x^a, I_x(1, b) = 1 − (1 − x)^b, I_x(a, b) = 1 − I_{1−x}(b, a).
        close(incomplete_beta(2.5, 1.0, 0.3), 0.3f64.powf(2.5), 1e-14);
        close(incomplete_beta(1.0, 3.0, 0.2), 1.0 - 0.8f64.powi(3), 1e-14);
        for (a, b, x) in [(0.5, 7.0, 0.1), (3.0, 2.0, 0.8), (40.0, 60.0, 0.45)] {
            close(
                incomplete_beta(a, b, x),
                1.0 - incomplete_beta(b, a, 1.0 - x),
                1e-13,
            );
        }
        // I_{1/2}(a, a) = 1/2.
        close(incomplete_beta(13.7, 13.7, 0.5), 0.5, 1e-13);
        // Reference values (scipy.special.betainc).
        close(incomplete_beta(2.0, 3.0, 0.4), 0.5248, 1e-13);
        close(incomplete_beta(0.5, 0.5, 0.25), 1.0 / 3.0, 1e-13);
        // Large parameters (mpmath quadrature of the density), on both sides of STIRLING_MIN.
        close(
            incomplete_beta(200.0, 300.0, 0.4),
            0.502_428_616_319_931_6,
            1e-13,
        );
        close(
            incomplete_beta(1e4, 2e4, 0.34),
            0.992_713_748_010_027_2,
            1e-12,
        );
        close(
            incomplete_beta(STIRLING_MIN, 3.0, 0.97),
            0.406_336_180_222_592_2,
            1e-13,
        );
        close(
            incomplete_beta(STIRLING_MIN - 0.5, 3.0, 0.97),
            0.409_669_515_196_315_8,
            1e-13,
        );
        close(
            incomplete_gamma_p(STIRLING_MIN, 95.0),
            0.317_356_811_169_800_0,
            1e-13,
        );
        close(
            incomplete_gamma_p(STIRLING_MIN - 0.5, 95.0),
            0.335_577_704_432_810_1,
            1e-13,
        );
        assert_eq!(incomplete_beta(2.0, 3.0, 0.0), 0.0);
        assert_eq!(incomplete_beta(2.0, 3.0, 1.0), 1.0);
    }

    #[test]
    fn incomplete_gamma_known_values() {
        // P(1, x) = 1 − e^−x; P(1/2, x) = erf(√x): erf(1) = 0.8427007929497149.
        close(incomplete_gamma_p(1.0, 2.0), 1.0 - (-2.0f64).exp(), 1e-14);
        close(incomplete_gamma_p(0.5, 1.0), 0.842_700_792_949_714_9, 1e-14);
        close(
            incomplete_gamma_p(5.0, 3.0),
            1.0 - incomplete_gamma_q(5.0, 3.0),
            1e-15,
        );
        // Q(3, 10) = e^−10 (1 + 10 + 50).
        close(
            incomplete_gamma_q(3.0, 10.0),
            (-10.0f64).exp() * 61.0,
            1e-17,
        );
    }

    #[test]
    fn student_t_p_values() {
        // Reference values computed with mpmath (40 digits).
        close(
            student_t_two_sided_p(2.0, 10.0),
            0.073_388_034_770_740_37,
            1e-14,
        );
        close(
            student_t_two_sided_p(-2.0, 10.0),
            0.073_388_034_770_740_37,
            1e-14,
        );
        close(
            student_t_two_sided_p(1.96, 1e5),
            0.049_998_563_194_301_63,
            1e-13,
        );
        close(
            student_t_two_sided_p(1.96, 1e9),
            0.049_995_790_573_729_59,
            1e-13,
        );
        close(
            student_t_two_sided_p(4.0, 3e5) / 6.335_765_238_221_287e-5,
            1.0,
            1e-11,
        );
        // df = 1 is Cauchy: p = 1 − 2 atan(t)/π.
        close(
            student_t_two_sided_p(3.0, 1.0),
            1.0 - 2.0 * 3f64.atan() / std::f64::consts::PI,
            1e-13,
        );
        close(student_t_two_sided_p(0.0, 7.5), 1.0, 1e-15);
        // Large df tends to the normal: P(|Z| ≥ 1.96) = 0.04999579029644087.
        let normal = 0.049_995_790_296_440_87;
        close(student_t_two_sided_p(1.96, 1e15), normal, 1e-12);
        close(student_t_two_sided_p(1.96, f64::INFINITY), normal, 1e-12);
        assert!(student_t_two_sided_p(1.0, 0.0).is_nan());
    }

    #[test]
    fn chi_square_p_values() {
        close(chi_square_p(3.841_458_820_694_124, 1.0), 0.05, 1e-12);
        close(chi_square_p(18.307_038_053_275_146, 10.0), 0.05, 1e-12);
        // Large dof (mpmath references).
        close(
            chi_square_p(10_100.0, 10_000.0),
            0.239_015_325_240_175_1,
            1e-13,
        );
        close(
            chi_square_p(1_002_000.0, 1_000_000.0),
            0.078_718_661_386_129_63,
            1e-12,
        );
        assert_eq!(chi_square_p(0.0, 3.0), 1.0);
    }

    #[test]
    fn sidak_correction() {
        close(sidak(0.01, 1), 0.01, 1e-17);
        close(sidak(0.05, 2), 1.0 - 0.95f64.sqrt(), 1e-16);
        let a = sidak(0.01, 1_000_000);
        close((1.0 - a).powf(1e6), 0.99, 1e-9);
    }

    #[test]
    fn welch_t_test_cases() {
        // t = (1 − 0) / √(0.5 + 0.5) = 1, df = 1 / (0.25/4 + 0.25/4) = 8.
        let (t, df, p) = welch_t_test(1.0, 0.5, 4.0, 0.0, 0.5, 4.0);
        close(t, 1.0, 1e-15);
        close(df, 8.0, 1e-12);
        close(p, student_t_two_sided_p(1.0, 8.0), 1e-15);
        assert_eq!(welch_t_test(2.0, 0.0, 5.0, 2.0, 0.0, 5.0).2, 1.0);
        assert_eq!(welch_t_test(2.0, 0.0, 5.0, 2.5, 0.0, 5.0).2, 0.0);
        // One side exact: df is the other side's.
        close(welch_t_test(1.0, 0.0, 0.0, 0.0, 0.25, 3.0).1, 3.0, 1e-12);
    }

    #[test]
    fn chi_square_gof_pools_small_cells() {
        let expected = [25.0, 25.0, 25.0, 25.0];
        let (chi2, dof, p) = chi_square_gof(&[25.0, 25.0, 25.0, 25.0], &expected);
        assert_eq!((chi2, dof, p), (0.0, 3.0, 1.0));
        let (chi2, dof, _) = chi_square_gof(&[30.0, 20.0, 25.0, 25.0], &expected);
        close(chi2, 2.0, 1e-12);
        assert_eq!(dof, 3.0);
        // Cells with expectation 1, 2, 3 pool into one (6) and the rest stand alone.
        let (chi2, dof, _) =
            chi_square_gof(&[0.0, 2.0, 4.0, 10.0, 10.0], &[1.0, 2.0, 3.0, 10.0, 10.0]);
        assert_eq!(dof, 2.0);
        close(chi2, 0.0, 1e-12);
        // A sample where none may fall.
        assert_eq!(chi_square_gof(&[1.0, 9.0], &[0.0, 10.0]).2, 0.0);
    }

    /// PCG32 (O'Neill 2014, pcg32 XSH RR), for test inputs only.
    struct Pcg32 {
        state: u64,
        inc: u64,
    }

    impl Pcg32 {
        fn new(seed: u64, stream: u64) -> Pcg32 {
            let mut rng = Pcg32 {
                state: 0,
                inc: (stream << 1) | 1,
            };
            rng.next_u32();
            rng.state = rng.state.wrapping_add(seed);
            rng.next_u32();
            rng
        }
        fn next_u32(&mut self) -> u32 {
            let old = self.state;
            self.state = old
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(self.inc);
            let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
            xorshifted.rotate_right((old >> 59) as u32)
        }
        /// Uniform in (0, 1).
        fn uniform(&mut self) -> f64 {
            (self.next_u32() as f64 + 0.5) / 4_294_967_296.0
        }
    }

    const SIZE: u32 = 32;
    const TILE: u32 = 8;
    const SPP: usize = 16;

    /// A skewed sample: exponential with a mean that varies over pixels and channels.
    fn sample(rng: &mut Pcg32, pixel: usize) -> Vec3 {
        let base = 0.5 + (pixel % 7) as f64 * 0.1;
        Vec3::from_array(std::array::from_fn(|c| {
            (-rng.uniform().ln() * base * (1.0 + c as f64)) as f32
        }))
    }

    fn noisy_film(seed: u64) -> Film {
        let mut film = Film::new(SIZE, SIZE);
        let mut rng = Pcg32::new(seed, 7);
        for pixel in 0..film.len() {
            for _ in 0..SPP {
                film.add_sample(pixel, sample(&mut rng, pixel));
            }
        }
        film
    }

    #[test]
    fn same_distribution_passes() {
        // 20 independent pairs at family-wise α = 0.01: P(more than 2 fail) < 0.001 if the test is
        // calibrated (binomial, n = 20, p = 0.01).
        let mut failed = 0;
        for seed in 0..20 {
            let cmp = compare_films(&noisy_film(2 * seed), &noisy_film(2 * seed + 1), TILE, 0.01)
                .unwrap();
            assert_eq!(cmp.tests, 16 * 3);
            if !cmp.passed() {
                failed += 1;
                eprintln!("{cmp}");
            }
        }
        assert!(
            failed <= 2,
            "{failed} of 20 comparisons of identically distributed films failed"
        );
    }

    #[test]
    fn shifted_tile_fails_and_is_reported() {
        let a = noisy_film(100);
        // Film b: independent samples, except tile (2, 1) whose G samples are a's plus a shift of
        // 5 standard errors of the difference of tile means (so t ≈ 5 up to the error of the
        // variance estimate: p ≈ 6e-7 against a per-test level of 2e-4).
        let mut b = noisy_film(101);
        let (tx, ty) = (2u32, 1u32);
        let mut rng = Pcg32::new(100, 7);
        let mut shifted = Film::new(SIZE, SIZE);
        let mut variance_sum = 0.0;
        for pixel in 0..a.len() {
            for _ in 0..SPP {
                shifted.add_sample(pixel, sample(&mut rng, pixel));
            }
            let (x, y) = (pixel as u32 % SIZE, pixel as u32 / SIZE);
            if x / TILE == tx && y / TILE == ty {
                variance_sum += a.variance_of_mean_f64(pixel)[1];
            }
        }
        let pixels = (TILE * TILE) as f64;
        let std_err = (2.0 * variance_sum).sqrt() / pixels;
        let delta = (5.0 * std_err) as f32;
        let mut rng = Pcg32::new(100, 7);
        for pixel in 0..a.len() {
            let (x, y) = (pixel as u32 % SIZE, pixel as u32 / SIZE);
            let in_tile = x / TILE == tx && y / TILE == ty;
            if in_tile {
                b.pixels[pixel] = Default::default();
            }
            for _ in 0..SPP {
                let s = sample(&mut rng, pixel);
                if in_tile {
                    b.add_sample(pixel, s + Vec3::new(0.0, delta, 0.0));
                }
            }
        }
        let cmp = compare_films(&a, &b, TILE, 0.01).unwrap();
        let report = cmp.to_string();
        assert!(!cmp.passed(), "{report}");
        assert_eq!(cmp.failures.len(), 1, "{report}");
        let f = &cmp.failures[0];
        assert_eq!((f.tile_x, f.tile_y, f.channel), (tx, ty, 1), "{report}");
        assert!((f.t + 5.0).abs() < 0.5, "{report}");
        assert!(
            report.contains("tile (2, 1) → pixels x 16..24, y 8..16, channel G"),
            "{report}"
        );
    }

    #[test]
    fn constant_films_with_different_sample_counts_compare_equal() {
        let (mut a, mut b, mut c) = (Film::new(4, 4), Film::new(4, 4), Film::new(4, 4));
        let value = Vec3::new(0.7, 0.1, 3.3);
        for p in 0..16 {
            (0..1000).for_each(|_| a.add_sample(p, value));
            (0..37).for_each(|_| b.add_sample(p, value));
            (0..37).for_each(|_| c.add_sample(p, value * 1.01));
        }
        assert!(compare_films(&a, &b, 2, 0.01).unwrap().passed());
        let cmp = compare_films(&a, &c, 2, 0.01).unwrap();
        assert_eq!(cmp.failures.len(), cmp.tests, "{cmp}");
        assert!(compare_films(&a, &Film::new(4, 5), 2, 0.01).is_err());
    }

    #[test]
    fn film_mean_and_standard_error() {
        let mut film = Film::new(2, 1);
        for v in [1.0, 3.0] {
            film.add_sample(0, Vec3::splat(v));
            film.add_sample(1, Vec3::splat(v + 1.0));
        }
        let (mean, std_err) = film_mean(&film);
        close(mean.x, 2.5, 1e-12);
        // Each pixel: sample variance 2, variance of the mean 1; √2 / 2.
        close(std_err.y, 2f64.sqrt() / 2.0, 1e-12);
    }
}
