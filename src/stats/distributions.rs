//! The distributions behind the tests: Γ and the incomplete gamma and beta functions, p-values and
//! quantiles of the normal, Student t and χ² distributions, Šidák's correction, Welch's t test and
//! Pearson's χ² goodness-of-fit test (statrs underneath).

use statrs::distribution::{ChiSquared, ContinuousCDF, Normal, StudentsT};

/// ln Γ(x) for x > 0 (`statrs`).
pub fn ln_gamma(x: f64) -> f64 {
    statrs::function::gamma::ln_gamma(x)
}

/// Regularised incomplete beta I_x(a, b), a, b > 0, x ∈ [0, 1]; NaN outside.
pub fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    statrs::function::beta::checked_beta_reg(a, b, x).unwrap_or(f64::NAN)
}

/// Regularised lower incomplete gamma P(a, x) = γ(a, x)/Γ(a), a > 0, x ≥ 0; NaN outside.
pub fn incomplete_gamma_p(a: f64, x: f64) -> f64 {
    statrs::function::gamma::checked_gamma_lr(a, x).unwrap_or(f64::NAN)
}

/// Regularised upper incomplete gamma Q(a, x) = 1 − P(a, x), without cancellation in the upper
/// tail; NaN outside a > 0, x ≥ 0.
pub fn incomplete_gamma_q(a: f64, x: f64) -> f64 {
    statrs::function::gamma::checked_gamma_ur(a, x).unwrap_or(f64::NAN)
}

/// Above this many degrees of freedom Student's t is taken as the normal: the relative error of
/// a two-sided p-value is O(t⁴/df), below 10⁻³ for |t| ≤ 5, and the incomplete beta's continued
/// fraction would need O(√df) terms.
const T_AS_NORMAL_DF: f64 = 1e6;

/// Two-sided p-value P(|T| ≥ |t|) of Student's t with `df` > 0 degrees of freedom (df may be
/// huge, fractional or +∞). NaN for df ≤ 0 or NaN input.
pub fn student_t_two_sided_p(t: f64, df: f64) -> f64 {
    if t.is_nan() || df.is_nan() || df <= 0.0 {
        return f64::NAN;
    }
    if t.is_infinite() {
        return 0.0;
    }
    let tail = if df > T_AS_NORMAL_DF {
        Normal::standard().sf(t.abs())
    } else {
        match StudentsT::new(0.0, 1.0, df) {
            Ok(d) => d.sf(t.abs()),
            Err(_) => return f64::NAN,
        }
    };
    (2.0 * tail).min(1.0)
}

/// Upper-tail p-value P(X ≥ chi2) of χ² with `dof` > 0 degrees of freedom.
pub fn chi_square_p(chi2: f64, dof: f64) -> f64 {
    if chi2 <= 0.0 {
        return if dof > 0.0 { 1.0 } else { f64::NAN };
    }
    match ChiSquared::new(dof) {
        Ok(d) => d.sf(chi2),
        Err(_) => f64::NAN,
    }
}

/// The x with P(X ≥ x) = `p` for X ~ χ²(`d`), by bisection on [`chi_square_p`].
pub fn chi_square_quantile_upper(p: f64, d: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, d + 40.0 * (2.0 * d).sqrt() + 2000.0);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if chi_square_p(mid, d) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The z with P(Z > z) = `p` for a standard normal Z (0 < p < 1/2): −Φ⁻¹(p), which keeps its
/// precision for tiny p.
pub fn normal_quantile_upper(p: f64) -> f64 {
    -Normal::standard().inverse_cdf(p)
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
pub(crate) fn welch_with_known_variance(
    diff: f64,
    parts: [(f64, f64); 2],
    known_var: f64,
) -> (f64, f64, f64) {
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
