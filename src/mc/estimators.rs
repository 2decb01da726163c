//! The lecture's estimators of I = ∫₀¹ f(x) dx ("Monte Carlo methods", Pelikán), each as it is
//! written there, generic over the integrand and the source of uniform numbers.

use super::distribution::Sampler1D;
use super::roulette::roulette;
use super::uniform::Uniform;
use crate::mis::{mis_weight, Heuristic};

/// a / p with 0 where a = 0: a density may vanish only where the integrand does (lecture, "PDF
/// (density) p(x)": p(x) > 0 where f(x) ≠ 0), so 0/0 there is a zero contribution.
fn ratio(a: f64, p: f64) -> f64 {
    if a == 0.0 {
        0.0
    } else {
        a / p
    }
}

/// Primary estimate ⟨I⟩_prim = f(ξ), ξ ~ R(0, 1) (lecture, "Monte Carlo quadrature").
/// Variance σ²_prim = ∫ f² − I².
pub fn primary(f: impl Fn(f64) -> f64, u: &mut impl Uniform) -> f64 {
    f(u.next())
}

/// The mean of N independent copies of a primary estimate (lecture, "Secondary estimate":
/// I = Σ I_i with I_i = ∫ f/N, each estimated by its own primary estimate). Variance σ²/N.
pub fn secondary_of(n: usize, mut estimate: impl FnMut() -> f64) -> f64 {
    (0..n).map(|_| estimate()).sum::<f64>() / n as f64
}

/// Secondary estimate ⟨I⟩_sec = (1/N) Σ f(ξ_i). Variance σ²_sec = σ²_prim / N.
pub fn secondary(f: impl Fn(f64) -> f64, n: usize, u: &mut impl Uniform) -> f64 {
    secondary_of(n, || primary(&f, u))
}

/// Stratified estimate ⟨I⟩_strat = (1/N) Σ f(ξ_i), ξ_i uniform in A_i = [i/N, (i + 1)/N)
/// (lecture, "Stratified sampling", uniform division of (0, 1)). Variance
/// σ²_strat = (1/N) ∫ f² − Σ I_i² ≤ σ²_sec, I_i = ∫_{A_i} f.
pub fn stratified(f: impl Fn(f64) -> f64, n: usize, u: &mut impl Uniform) -> f64 {
    let h = 1.0 / n as f64;
    (0..n).map(|i| f((i as f64 + u.next()) * h)).sum::<f64>() * h
}

/// Importance sampling by CDF inversion ⟨I⟩_imp = f(P⁻¹(τ)) / p(P⁻¹(τ)), τ ~ R(0, 1)
/// (lecture, "Importance sampling", "Algorithm"). Variance σ²_imp = ∫ f²/p − I².
pub fn importance(f: impl Fn(f64) -> f64, p: &dyn Sampler1D, u: &mut impl Uniform) -> f64 {
    let x = p.sample(u.next());
    ratio(f(x), p.pdf(x))
}

/// Combined sampling with one sample per strategy: ⟨I⟩_comb = Σ_i w_i(ξ_i) f(ξ_i) / p_i(ξ_i),
/// ξ_i = P_i⁻¹(τ_i), with the weights of [`mis_weight`] (average, maximum, balance, power β),
/// which sum to 1 at every x so the estimate is unbiased (lecture, "Combined sampling",
/// "Eliminating bias"). Variance: see [`super::predict`].
pub fn combined(
    f: impl Fn(f64) -> f64,
    strategies: &[&dyn Sampler1D],
    heuristic: Heuristic,
    u: &mut impl Uniform,
) -> f64 {
    let mut pdfs = vec![0f32; strategies.len()];
    let mut total = 0.0;
    for (i, s) in strategies.iter().enumerate() {
        let x = s.sample(u.next());
        for (slot, other) in pdfs.iter_mut().zip(strategies) {
            *slot = other.pdf(x) as f32;
        }
        let w = mis_weight(heuristic, i, &pdfs) as f64;
        total += ratio(w * f(x), s.pdf(x));
    }
    total
}

/// Control function ⟨I⟩_con = f(ξ) − g(ξ) + J with J = ∫ g known in closed form (lecture,
/// "Control function"). Variance ∫ (f − g)² − (I − J)².
pub fn control(
    f: impl Fn(f64) -> f64,
    g: impl Fn(f64) -> f64,
    j: f64,
    u: &mut impl Uniform,
) -> f64 {
    let x = u.next();
    f(x) - g(x) + j
}

/// Russian roulette for a single integral: ⟨I⟩_Russ = f(ξ/P)/P for ξ < P, else 0 (lecture,
/// "Russian roulette for single integral": I = ∫₀ᴾ f(t/P)/P dt, 0 < P ≤ 1). The survivor's ξ/P
/// is again uniform on [0, 1), so it is the sample. Variance σ²_Russ = (1/P) ∫ f² − I².
pub fn russian_roulette(f: impl Fn(f64) -> f64, p: f64, u: &mut impl Uniform) -> f64 {
    let xi = u.next();
    match roulette(xi, p) {
        Some(weight) => weight * f((xi * weight).min(1.0 - f64::EPSILON / 2.0)),
        None => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mc::{integrands, LinearRamp, UniformDensity};

    /// The midpoints (k + ½)/m of m cells in order: a deterministic stand-in for ξ that makes
    /// the mean over m draws a midpoint-rule quadrature of the estimator over u.
    fn midpoints(m: usize) -> impl FnMut() -> f64 {
        let mut k = 0usize;
        move || {
            let u = (k % m) as f64 + 0.5;
            k += 1;
            u / m as f64
        }
    }

    /// Each estimator's expectation over its uniform numbers equals I: the mean over a fine
    /// midpoint grid of u (one number per estimate) is the midpoint rule of E⟨I⟩.
    #[test]
    fn one_number_estimators_integrate_to_i() {
        let m = 200_000;
        for i in integrands().unwrap() {
            let f = i.f;
            let mut u = midpoints(m);
            let checks = [
                ("primary", secondary_of(m, || primary(f, &mut u))),
                (
                    "importance",
                    secondary_of(m, || importance(f, i.importance.as_ref(), &mut u)),
                ),
                (
                    "control",
                    secondary_of(m, || control(f, i.control, i.control_integral, &mut u)),
                ),
                (
                    "roulette",
                    secondary_of(m, || russian_roulette(f, 0.5, &mut u)),
                ),
                ("stratified", stratified(f, m, &mut || 0.5)),
            ];
            for (name, value) in checks {
                let tolerance = 1e-3 * i.exact;
                assert!(
                    (value - i.exact).abs() < tolerance,
                    "{} {name}: {value} vs {}",
                    i.name,
                    i.exact
                );
            }
        }
    }

    /// Combined sampling with one number per strategy: E over the (τ₁, τ₂) grid, each strategy's
    /// term depending on its own τ only, is the sum of the midpoint rules of the two terms.
    #[test]
    fn combined_weights_keep_the_expectation() {
        let f = |x: f64| 3.0 * x * x;
        let strategies: [&dyn Sampler1D; 2] = [&UniformDensity, &LinearRamp];
        let m = 200_000;
        for h in [
            Heuristic::Average,
            Heuristic::Maximum,
            Heuristic::Balance,
            Heuristic::Power(2.0),
        ] {
            let mut u = {
                // Both strategies get the k-th midpoint: τ₁ = τ₂ changes no term's expectation.
                let mut grid = midpoints(m);
                let mut last = 0.0;
                let mut odd = false;
                move || {
                    if !odd {
                        last = grid();
                    }
                    odd = !odd;
                    last
                }
            };
            let value = secondary_of(m, || combined(f, &strategies, h, &mut u));
            assert!((value - 1.0).abs() < 1e-3, "{h:?}: {value}");
        }
    }

    #[test]
    fn roulette_is_the_lectures_case_split() {
        // ξ < P: f(ξ/P)/P; otherwise 0.
        let f = |x: f64| x + 1.0;
        assert_eq!(russian_roulette(f, 0.25, &mut || 0.1), (0.4 + 1.0) / 0.25);
        assert_eq!(russian_roulette(f, 0.25, &mut || 0.25), 0.0);
        assert_eq!(russian_roulette(f, 1.0, &mut || 0.7), 1.7);
        assert_eq!(crate::mc::roulette_f32(0.3, 0.5), Some(2.0));
        assert_eq!(crate::mc::roulette_f32(0.5, 0.5), None);
        assert_eq!(crate::mc::roulette_f32(0.99, 1.5), Some(1.0));
        assert_eq!(crate::mc::roulette_f32(0.0, 0.0), None);
        assert_eq!(crate::mc::roulette_f32(0.0, f32::NAN), None);
    }
}
