//! What each estimator's variance should be: the lecture's formulas evaluated by quadrature
//! ([`Integrand::quadrature`]), and the fourth cumulant that sizes the confidence interval of a
//! measured variance. All for one primary-level estimate unless the name says N.

use super::distribution::{Sampler1D, UniformDensity};
use super::integrands::{Integrand, QUADRATURE_PANELS};
use super::quadrature::integrate;
use crate::mis::{mis_weight, Heuristic};

/// The lecture's estimators, as the experiment runs them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Estimator {
    /// f(ξ).
    Primary,
    /// (1/N) Σ f(ξ_i).
    Secondary,
    /// One sample in each of N equal strata.
    Stratified,
    /// f/p at ξ = P⁻¹(τ), p the integrand's importance density.
    Importance,
    /// Uniform and importance sampling combined with a weighting.
    Combined(Heuristic),
    /// f − g + J.
    Control,
    /// Russian roulette with survival probability P.
    Roulette(f64),
}

/// The two strategies of combined sampling: uniform, and the integrand's importance density.
pub fn strategies(i: &Integrand) -> [&dyn Sampler1D; 2] {
    [&UniformDensity, i.importance.as_ref()]
}

/// The weight of strategy `k` at x, from the pdfs of all strategies there.
pub fn weight(i: &Integrand, h: Heuristic, k: usize, x: f64) -> f64 {
    let pdfs = strategies(i).map(|s| s.pdf(x) as f32);
    mis_weight(h, k, &pdfs) as f64
}

/// Variance of one estimate by the lecture's formulas; `n` matters only for the stratified
/// estimate, which is an N-sample estimate by construction.
pub fn lecture_variance(i: &Integrand, e: Estimator, n: usize) -> f64 {
    let f = i.f;
    let big_i = i.exact;
    match e {
        // σ²_prim = ∫ f² − I²; σ²_sec = σ²_prim / N is applied by the caller.
        Estimator::Primary | Estimator::Secondary => i.quadrature(|x| f(x) * f(x)) - big_i * big_i,
        // σ²_strat = Σ_i [(1/N) ∫_{A_i} f² − I_i²] = (1/N) ∫ f² − Σ I_i².
        Estimator::Stratified => {
            let h = 1.0 / n as f64;
            strata(n)
                .map(|(a, b, panels)| {
                    let ik = integrate(f, a, b, panels);
                    h * integrate(|x| f(x) * f(x), a, b, panels) - ik * ik
                })
                .sum()
        }
        // σ²_imp = ∫ f²/p − I².
        Estimator::Importance => {
            let p = i.importance.as_ref();
            i.quadrature(|x| f(x) * f(x) / p.pdf(x)) - big_i * big_i
        }
        // σ²_comb = ∫ [Σ_i w_i²/p_i] f² − Σ_i [∫ w_i f]² (lecture, "Variance of combined
        // estimate"; the slide's last line drops the square of f, which its first line has).
        Estimator::Combined(h) => {
            let s = strategies(i);
            let second = i.quadrature(|x| {
                let sum: f64 = (0..s.len())
                    .map(|k| weight(i, h, k, x).powi(2) / s[k].pdf(x))
                    .sum();
                sum * f(x) * f(x)
            });
            let firsts: f64 = (0..s.len())
                .map(|k| i.quadrature(|x| weight(i, h, k, x) * f(x)).powi(2))
                .sum();
            second - firsts
        }
        // Var(f − g + J) = ∫ (f − g)² − (I − J)².
        Estimator::Control => {
            let g = i.control;
            let d = big_i - i.control_integral;
            i.quadrature(|x| (f(x) - g(x)).powi(2)) - d * d
        }
        // σ²_Russ = ∫₀ᴾ [f(t/P)/P]² dt − I² = (1/P) ∫ f² − I².
        Estimator::Roulette(p) => i.quadrature(|x| f(x) * f(x)) / p - big_i * big_i,
    }
}

/// The balance heuristic's variance as the lecture writes it, σ²_bal = ∫ f² / Σ_j p_j −
/// Σ_i [∫ p_i f / Σ_j p_j]², and its bound for any weighting, σ²_comb ≥ σ²_bal − (1 − 1/n) I²
/// (lecture, "Balance heuristics"; Veach 1997, Theorem 9.2). Returns (σ²_bal, bound). The
/// bound needs f ≥ 0: its proof uses Σ_i (∫ w_i f)² ≤ I², which fails for a signed f (for
/// sin 2πx, I = 0, the maximum heuristic beats balance).
pub fn balance_bound(i: &Integrand) -> (f64, f64) {
    let s = strategies(i);
    let f = i.f;
    let sum_p = |x: f64| s.iter().map(|p| p.pdf(x)).sum::<f64>();
    let second = i.quadrature(|x| f(x) * f(x) / sum_p(x));
    let firsts: f64 = s
        .iter()
        .map(|p| i.quadrature(|x| p.pdf(x) * f(x) / sum_p(x)).powi(2))
        .sum();
    let bal = second - firsts;
    let n = s.len() as f64;
    (bal, bal - (1.0 - 1.0 / n) * i.exact * i.exact)
}

/// Mean, variance and fourth cumulant κ₄ = μ₄ − 3μ₂² of a random variable.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Cumulants {
    pub mean: f64,
    pub variance: f64,
    pub k4: f64,
}

impl Cumulants {
    /// Of v(X), X with density q, by two passes of `quad` (mean first, then central moments,
    /// so that a small variance is not lost against a large mean).
    fn of(
        quad: impl Fn(&dyn Fn(f64) -> f64) -> f64,
        v: impl Fn(f64) -> f64,
        q: impl Fn(f64) -> f64,
    ) -> Self {
        let mean = quad(&|x| v(x) * q(x));
        let mu2 = quad(&|x| (v(x) - mean).powi(2) * q(x));
        let mu4 = quad(&|x| (v(x) - mean).powi(4) * q(x));
        Cumulants {
            mean,
            variance: mu2,
            k4: mu4 - 3.0 * mu2 * mu2,
        }
    }

    /// Of the sum of two independent variables: cumulants add.
    fn plus(self, o: Cumulants) -> Self {
        Cumulants {
            mean: self.mean + o.mean,
            variance: self.variance + o.variance,
            k4: self.k4 + o.k4,
        }
    }

    /// Of a·X: κ_k scales by a^k.
    fn scaled(self, a: f64) -> Self {
        Cumulants {
            mean: a * self.mean,
            variance: a * a * self.variance,
            k4: a.powi(4) * self.k4,
        }
    }

    /// Of the mean of n independent copies.
    pub fn mean_of(self, n: usize) -> Self {
        let sum = Cumulants {
            mean: n as f64 * self.mean,
            variance: n as f64 * self.variance,
            k4: n as f64 * self.k4,
        };
        sum.scaled(1.0 / n as f64)
    }

    /// Excess kurtosis γ₂ = κ₄ / σ⁴ (0 for a constant).
    pub fn excess_kurtosis(&self) -> f64 {
        if self.variance > 0.0 {
            self.k4 / (self.variance * self.variance)
        } else {
            0.0
        }
    }
}

/// The cumulants of one estimate computed directly from its distribution (not through the
/// lecture's formulas); for the stratified estimate, of the N-sample estimate.
pub fn cumulants(i: &Integrand, e: Estimator, n: usize) -> Cumulants {
    let f = i.f;
    let quad = |g: &dyn Fn(f64) -> f64| i.quadrature(g);
    match e {
        Estimator::Primary | Estimator::Secondary => Cumulants::of(quad, f, |_| 1.0),
        Estimator::Stratified => {
            // Σ_k f(ξ_k)/N, ξ_k uniform on A_k (density N there).
            let h = 1.0 / n as f64;
            strata(n)
                .map(|(a, b, panels)| {
                    let on_stratum = |g: &dyn Fn(f64) -> f64| integrate(g, a, b, panels);
                    Cumulants::of(on_stratum, f, |_| n as f64).scaled(h)
                })
                .fold(Cumulants::default(), Cumulants::plus)
        }
        Estimator::Importance => {
            let p = i.importance.as_ref();
            Cumulants::of(quad, |x| f(x) / p.pdf(x), |x| p.pdf(x))
        }
        Estimator::Combined(h) => strategies(i)
            .iter()
            .enumerate()
            .map(|(k, s)| {
                Cumulants::of(quad, |x| weight(i, h, k, x) * f(x) / s.pdf(x), |x| s.pdf(x))
            })
            .fold(Cumulants::default(), Cumulants::plus),
        Estimator::Control => {
            let (g, j) = (i.control, i.control_integral);
            Cumulants::of(quad, |x| f(x) - g(x) + j, |_| 1.0)
        }
        Estimator::Roulette(p) => {
            // f(x)/P with probability P (x uniform), 0 otherwise: μ_k = P ∫ (f/P − m)^k + (1 − P)(−m)^k.
            let mean = quad(&|x| f(x));
            let central =
                |k: i32| p * quad(&|x| (f(x) / p - mean).powi(k)) + (1.0 - p) * (-mean).powi(k);
            let (mu2, mu4) = (central(2), central(4));
            Cumulants {
                mean,
                variance: mu2,
                k4: mu4 - 3.0 * mu2 * mu2,
            }
        }
    }
}

/// The N equal strata of [0, 1) as (start, end, quadrature panels for each).
fn strata(n: usize) -> impl Iterator<Item = (f64, f64, usize)> {
    let h = 1.0 / n as f64;
    let panels = (QUADRATURE_PANELS / n).max(4);
    (0..n).map(move |k| (k as f64 * h, (k + 1) as f64 * h, panels))
}
