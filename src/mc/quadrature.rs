//! Gauss–Legendre quadrature: the reference values the estimators' measured means and variances
//! are checked against.

use std::f64::consts::PI;
/// Points per Gauss–Legendre panel.
const GAUSS_ORDER: usize = 8;

/// Nodes and weights of n-point Gauss–Legendre quadrature on [−1, 1] (Numerical Recipes, 3rd
/// ed., §4.6 `gauleg`: Newton's method on P_n from the asymptotic guess cos(π(i + ¾)/(n + ½)),
/// weights 2 / ((1 − z²) P_n'(z)²)).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                // P_n(z) by the three-term recurrence, then P_n'(z).
                let (mut p1, mut p2) = (1.0, 0.0);
                for j in 0..n {
                    let p3 = p2;
                    p2 = p1;
                    p1 = ((2 * j + 1) as f64 * z * p2 - j as f64 * p3) / (j + 1) as f64;
                }
                derivative = n as f64 * (z * p1 - p2) / (z * z - 1.0);
                let step = p1 / derivative;
                z -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            (z, 2.0 / ((1.0 - z * z) * derivative * derivative))
        })
        .collect()
}

/// ∫ₐᵇ f by composite Gauss–Legendre quadrature: `panels` equal panels of 8 points each (exact
/// for polynomials of degree 15 on each panel).
pub fn integrate(f: impl Fn(f64) -> f64, a: f64, b: f64, panels: usize) -> f64 {
    let rule = gauss_legendre(GAUSS_ORDER);
    let h = (b - a) / panels as f64;
    let mut total = 0.0;
    for k in 0..panels {
        let mid = a + (k as f64 + 0.5) * h;
        let panel: f64 = rule.iter().map(|(z, w)| w * f(mid + 0.5 * h * z)).sum();
        total += 0.5 * h * panel;
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_is_exact_for_degree_15() {
        let rule = gauss_legendre(GAUSS_ORDER);
        let total: f64 = rule.iter().map(|(_, w)| w).sum();
        assert!((total - 2.0).abs() < 1e-14);
        for k in 0..16 {
            let q = integrate(|x| x.powi(k), 0.0, 1.0, 1);
            let exact = 1.0 / (k + 1) as f64;
            assert!((q - exact).abs() < 1e-14, "x^{k}: {q} vs {exact}");
        }
    }
}
