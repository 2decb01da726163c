//! `wavetrace estimators`: T independent estimates per estimator and integrand, their measured
//! mean and variance against I and the lecture's predicted variance, and the lecture's variance
//! relations, each a statistical test at a Šidák-corrected significance level.

use super::estimators::{
    combined, control, importance, primary, russian_roulette, secondary_of, stratified,
};
use super::integrands::{integrands, Integrand, ROULETTE_P};
use super::predict::{balance_bound, cumulants, lecture_variance, strategies, Estimator};
use super::uniform::KeyedUniforms;
use crate::mis::Heuristic;
use crate::stats::{
    chi_square_p, chi_square_quantile_upper, incomplete_beta, sidak, student_t_two_sided_p,
};
use anyhow::{bail, Result};

/// What to run.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// N: samples per estimate (per strategy for combined sampling; strata for stratified).
    pub samples: usize,
    /// T: independent estimates per estimator.
    pub trials: usize,
    pub seed: u32,
    /// Family-wise significance level of all checks together.
    pub alpha: f64,
}

/// The estimators of each table, in order.
pub(crate) const ESTIMATORS: [Estimator; 10] = [
    Estimator::Primary,
    Estimator::Secondary,
    Estimator::Stratified,
    Estimator::Importance,
    Estimator::Combined(Heuristic::Average),
    Estimator::Combined(Heuristic::Maximum),
    Estimator::Combined(Heuristic::Balance),
    Estimator::Combined(Heuristic::Power(2.0)),
    Estimator::Control,
    Estimator::Roulette(ROULETTE_P),
];

/// Statistical checks per integrand: mean and variance of each row, strat ≤ sec, and the
/// balance bound for the three other weightings.
const CHECKS_PER_INTEGRAND: usize = 2 * ESTIMATORS.len() + 1 + 3;

/// One estimator's line of a table.
#[derive(Clone, Debug)]
pub struct Row {
    pub label: String,
    pub estimator: Estimator,
    /// Number of independent estimates measured (T, or T·N for the primary row).
    pub count: usize,
    pub mean: f64,
    /// Standard error of the mean, from the measured variance.
    pub standard_error: f64,
    pub measured_variance: f64,
    /// The lecture's formula for the variance of one estimate of this row.
    pub predicted_variance: f64,
    /// Effective degrees of freedom of the measured variance and the acceptance interval of
    /// measured / predicted.
    pub dof: f64,
    pub interval: (f64, f64),
    /// p-values of the tests "mean = I" and "variance = predicted".
    pub mean_p: f64,
    pub variance_p: f64,
}

/// A relation between rows, with its verdict.
#[derive(Clone, Debug)]
pub struct CheckOutcome {
    pub text: String,
    pub ok: bool,
}

/// One integrand's table.
#[derive(Clone, Debug)]
pub struct Section {
    pub name: &'static str,
    pub exact: f64,
    pub exact_text: &'static str,
    pub rows: Vec<Row>,
    pub relations: Vec<CheckOutcome>,
}

/// Everything `wavetrace estimators` prints.
#[derive(Clone, Debug)]
pub struct Report {
    pub settings: Settings,
    /// The per-check significance level (Šidák).
    pub alpha_each: f64,
    pub checks: usize,
    pub sections: Vec<Section>,
}

impl Report {
    /// Lines of the tables whose check failed (a row fails if its mean or its variance does).
    pub fn failures(&self) -> usize {
        let a = self.alpha_each;
        self.sections
            .iter()
            .map(|s| {
                s.rows
                    .iter()
                    .map(|r| (r.mean_p < a) as usize + (r.variance_p < a) as usize)
                    .sum::<usize>()
                    + s.relations.iter().filter(|c| !c.ok).count()
            })
            .sum()
    }
}

/// Degrees of freedom d of a sample variance s² of `count` values with excess kurtosis γ₂, so
/// that d·s²/σ² is approximately χ²(d): Var(s²) = σ⁴ (2/(T − 1) + γ₂/T) matched to χ²'s 2/d.
/// For normal values (γ₂ = 0) d = T − 1 and the interval is the textbook one.
fn variance_dof(count: usize, excess_kurtosis: f64) -> f64 {
    let t = count as f64;
    2.0 / (2.0 / (t - 1.0) + excess_kurtosis / t)
}

/// Count, mean and sum of squared deviations of a stream of values (Welford's update, Knuth
/// TAOCP vol. 2, §4.2.2), so that T·N single samples need no storage.
#[derive(Clone, Copy, Debug, Default)]
struct Running {
    count: usize,
    mean: f64,
    squares: f64,
}

impl Running {
    fn push(&mut self, v: f64) {
        self.count += 1;
        let delta = v - self.mean;
        self.mean += delta / self.count as f64;
        self.squares += delta * (v - self.mean);
    }

    /// The sample variance (n − 1 in the denominator).
    fn variance(&self) -> f64 {
        self.squares / (self.count as f64 - 1.0)
    }
}

/// The label of an estimator's row.
fn label(i: &Integrand, e: Estimator) -> String {
    match e {
        Estimator::Primary => "primary f(ξ), single samples".into(),
        Estimator::Secondary => "secondary, N samples".into(),
        Estimator::Stratified => "stratified, N strata".into(),
        Estimator::Importance => format!("importance p = {}", i.importance.name()),
        Estimator::Combined(Heuristic::Power(b)) => format!("combined, power β = {b}"),
        Estimator::Combined(h) => format!("combined, {}", format!("{h:?}").to_lowercase()),
        Estimator::Control => format!("control g = {}", i.control_text),
        Estimator::Roulette(p) => format!("Russian roulette P = {p}"),
    }
}

/// The statistics of T estimates of estimator `e`, and of the single samples of `Secondary` (the
/// `Primary` row is not run on its own).
fn run_estimator(i: &Integrand, index: u32, e: Estimator, s: &Settings) -> (Running, Running) {
    let n = s.samples;
    let block = index * 16 + ESTIMATORS.iter().position(|x| *x == e).unwrap_or(0) as u32;
    let mut singles = Running::default();
    let mut estimates = Running::default();
    for t in 0..s.trials {
        let estimate = {
            let mut u = KeyedUniforms::new(s.seed, t as u32, block);
            let f = i.f;
            match e {
                Estimator::Primary | Estimator::Secondary => secondary_of(n, || {
                    let v = primary(f, &mut u);
                    singles.push(v);
                    v
                }),
                Estimator::Stratified => stratified(f, n, &mut u),
                Estimator::Importance => {
                    secondary_of(n, || importance(f, i.importance.as_ref(), &mut u))
                }
                Estimator::Combined(h) => {
                    secondary_of(n, || combined(f, &strategies(i), h, &mut u))
                }
                Estimator::Control => {
                    secondary_of(n, || control(f, i.control, i.control_integral, &mut u))
                }
                Estimator::Roulette(p) => secondary_of(n, || russian_roulette(f, p, &mut u)),
            }
        };
        estimates.push(estimate);
    }
    (estimates, singles)
}

/// A row from its estimates: measured against I and the predicted variance of one estimate.
fn row(i: &Integrand, e: Estimator, values: Running, n: usize, alpha_each: f64) -> Row {
    // Per-estimate prediction: primary and stratified as they are, the rest means of N.
    let per_sample = lecture_variance(i, e, n);
    let (predicted, kurtosis) = match e {
        Estimator::Primary => (per_sample, cumulants(i, e, n).excess_kurtosis()),
        Estimator::Stratified => (per_sample, cumulants(i, e, n).excess_kurtosis()),
        _ => (
            per_sample / n as f64,
            cumulants(i, e, n).mean_of(n).excess_kurtosis(),
        ),
    };
    let (mean, measured, count) = (values.mean, values.variance(), values.count);
    // Mean: t = (mean − I) / SE with the measured standard error, so that this tests bias
    // alone (a wrong variance is the next test's business); Student's t, T − 1 df, two-sided.
    let standard_error = (measured / count as f64).sqrt();
    let t = (mean - i.exact) / standard_error;
    let mean_p = student_t_two_sided_p(t, (count - 1) as f64);
    // Variance: d s²/σ² ~ χ²(d), two-sided.
    let dof = variance_dof(count, kurtosis);
    let x = dof * measured / predicted;
    let variance_p = (2.0 * (1.0 - chi_square_p(x, dof)).min(chi_square_p(x, dof))).min(1.0);
    let interval = (
        chi_square_quantile_upper(1.0 - alpha_each / 2.0, dof) / dof,
        chi_square_quantile_upper(alpha_each / 2.0, dof) / dof,
    );
    Row {
        label: label(i, e),
        estimator: e,
        count,
        mean,
        standard_error,
        measured_variance: measured,
        predicted_variance: predicted,
        dof,
        interval,
        mean_p,
        variance_p,
    }
}

/// The lecture's relations for one integrand, from its rows.
fn relations(i: &Integrand, rows: &[Row], n: usize, alpha_each: f64) -> Vec<CheckOutcome> {
    let find = |e: Estimator| rows.iter().find(|r| r.estimator == e).expect("every row");
    let (prim, sec, strat) = (
        find(Estimator::Primary),
        find(Estimator::Secondary),
        find(Estimator::Stratified),
    );
    let mut out = Vec::new();
    // σ²_sec = σ²_prim / N: the secondary row's variance check, against σ²_prim.
    out.push(CheckOutcome {
        text: format!(
            "σ²_sec = σ²_prim/N: N·s²_sec / σ²_prim = {:.4} (the secondary row's interval)",
            n as f64 * sec.measured_variance / prim.predicted_variance
        ),
        ok: sec.variance_p >= alpha_each,
    });
    // σ²_strat ≤ σ²_sec: predicted, and measured by a one-sided F test of the claim
    // (F = s²_strat/s²_sec; p = P(F(d₁, d₂) ≥ F) = I_{d₂/(d₂+d₁F)}(d₂/2, d₁/2)).
    let f_ratio = strat.measured_variance / sec.measured_variance;
    let (d1, d2) = (strat.dof, sec.dof);
    let p = incomplete_beta(0.5 * d2, 0.5 * d1, d2 / (d2 + d1 * f_ratio));
    out.push(CheckOutcome {
        text: format!(
            "σ²_strat ≤ σ²_sec: predicted {:.4e} ≤ {:.4e}; measured s²_strat/s²_sec = {f_ratio:.3e} (F test p = {p:.3})",
            strat.predicted_variance, sec.predicted_variance
        ),
        ok: strat.predicted_variance <= sec.predicted_variance && p >= alpha_each,
    });
    // σ²_comb ≥ σ²_bal − (1 − 1/n) I², for one-sample combined estimates; a row's estimate is
    // the mean of N, so its variance bound is divided by N. Measured: s² not significantly
    // below the bound (one-sided χ²).
    let (_, bound) = balance_bound(i);
    let bound_n = bound / n as f64;
    for r in rows {
        let Estimator::Combined(h) = r.estimator else {
            continue;
        };
        if h == Heuristic::Balance {
            continue;
        }
        let p = if bound_n > 0.0 {
            1.0 - chi_square_p(r.dof * r.measured_variance / bound_n, r.dof)
        } else {
            1.0
        };
        out.push(CheckOutcome {
            text: format!(
                "balance bound (σ²_bal − (1 − 1/n)·I²)/N = {bound_n:.4e} ≤ {}: predicted {:.4e}, measured {:.4e} (p = {p:.3})",
                r.label.trim_start_matches("combined, "),
                r.predicted_variance,
                r.measured_variance
            ),
            ok: r.predicted_variance >= bound_n && p >= alpha_each,
        });
    }
    out
}

/// Runs every estimator on every integrand.
pub fn run(settings: Settings) -> Result<Report> {
    if settings.samples < 1 || settings.trials < 2 {
        bail!(
            "need at least 1 sample per estimate and 2 trials (got N = {}, T = {})",
            settings.samples,
            settings.trials
        );
    }
    let list = integrands()?;
    let checks = CHECKS_PER_INTEGRAND * list.len();
    let alpha_each = sidak(settings.alpha, checks);
    let n = settings.samples;
    let sections = list
        .iter()
        .enumerate()
        .map(|(index, i)| {
            let mut rows = Vec::new();
            for e in ESTIMATORS.iter().skip(1) {
                let (estimates, singles) = run_estimator(i, index as u32, *e, &settings);
                if *e == Estimator::Secondary {
                    rows.push(row(i, Estimator::Primary, singles, n, alpha_each));
                }
                rows.push(row(i, *e, estimates, n, alpha_each));
            }
            let relations = relations(i, &rows, n, alpha_each);
            Section {
                name: i.name,
                exact: i.exact,
                exact_text: i.exact_text,
                rows,
                relations,
            }
        })
        .collect();
    Ok(Report {
        settings,
        alpha_each,
        checks,
        sections,
    })
}

impl std::fmt::Display for Report {
    fn fmt(&self, out: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.settings;
        writeln!(
            out,
            "Monte Carlo estimators of I = ∫₀¹ f(x) dx (lecture \"Monte Carlo methods\"), seed {}.",
            s.seed
        )?;
        writeln!(out, "Each row: T = {} independent estimates of N = {} samples each (combined sampling: N per", s.trials, s.samples)?;
        writeln!(out, "strategy, uniform and p; the primary row: the T·N single samples of the secondary row).")?;
        writeln!(out, "var measured: sample variance of the estimates; var predicted: the lecture's formula by")?;
        writeln!(out, "Gauss–Legendre quadrature; ratio = measured / predicted. Checks at α = {} over {} checks", s.alpha, self.checks)?;
        writeln!(
            out,
            "(Šidák: {:.2e} each): mean within t·SE of I; ratio inside the χ² interval of a sample",
            self.alpha_each
        )?;
        writeln!(out, "variance, d·s²/σ² ~ χ²(d), d = T − 1 for normal estimates, lowered for their kurtosis γ₂:")?;
        writeln!(out, "d = 2 / (2/(T − 1) + γ₂/T).")?;
        for section in &self.sections {
            writeln!(out)?;
            writeln!(
                out,
                "f(x) = {},  I = {} = {:.6}",
                section.name, section.exact_text, section.exact
            )?;
            writeln!(
                out,
                "  {:<46} {:>22} {:>11} {:>11} {:>7} {:>17}",
                "estimator", "mean ± SE", "var meas.", "var pred.", "ratio", "accepted ratio"
            )?;
            for r in &section.rows {
                let ok = r.mean_p >= self.alpha_each && r.variance_p >= self.alpha_each;
                writeln!(
                    out,
                    "  {:<46} {:>11.6} ± {:<8.2e} {:>11.4e} {:>11.4e} {:>7.4} [{:.3}, {:.3}] {}",
                    r.label,
                    r.mean,
                    r.standard_error,
                    r.measured_variance,
                    r.predicted_variance,
                    r.measured_variance / r.predicted_variance,
                    r.interval.0,
                    r.interval.1,
                    if ok { "ok" } else { "FAIL" }
                )?;
            }
            for c in &section.relations {
                writeln!(out, "  {} {}", if c.ok { "ok  " } else { "FAIL" }, c.text)?;
            }
        }
        writeln!(out)?;
        let failed = self.failures();
        if failed == 0 {
            writeln!(out, "all checks passed")
        } else {
            writeln!(out, "{failed} lines FAILED their checks")
        }
    }
}
