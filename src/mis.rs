//! The seed's combined-sampling weightings (lecture "Monte Carlo methods", §Combined sampling):
//! average, maximum (cutoff), balance and power(β). Each returns the weight of strategy `i`
//! whose pdf at the sample is `pdfs[i]`; for every x the weights over all strategies sum to 1,
//! which keeps the combined estimate unbiased. Non-finite weights become 0 (Mitsuba's rule).
//! `shaders/inc/mis.glsl` has the two-strategy forms the integrators use.

/// Which weighting combines the strategies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Heuristic {
    /// w_i = 1/n.
    Average,
    /// w_i = 1 where p_i is the largest pdf, else 0.
    Maximum,
    /// w_i = p_i / Σ p_j.
    Balance,
    /// w_i = p_i^β / Σ p_j^β (β = 2 in the integrators).
    Power(f32),
}

/// Weight of strategy `i` among strategies with pdfs `pdfs` at the same sample.
pub fn mis_weight(heuristic: Heuristic, i: usize, pdfs: &[f32]) -> f32 {
    let w = match heuristic {
        Heuristic::Average => 1.0 / pdfs.len() as f32,
        Heuristic::Maximum => {
            // Ties go to the lowest index, so the weights still sum to exactly 1.
            let best = pdfs
                .iter()
                .enumerate()
                .fold(0, |best, (j, &p)| if p > pdfs[best] { j } else { best });
            if best == i {
                1.0
            } else {
                0.0
            }
        }
        Heuristic::Balance => pdfs[i] / pdfs.iter().sum::<f32>(),
        Heuristic::Power(beta) => {
            pdfs[i].powf(beta) / pdfs.iter().map(|p| p.powf(beta)).sum::<f32>()
        }
    };
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

/// Power heuristic with β = 2 for two strategies: the weight of the one with pdf `a`.
pub fn mis_power2(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    let w = a2 / (a2 + b2);
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one() {
        let cases: [&[f32]; 4] = [&[0.3, 2.0], &[1.0, 1.0, 5.0], &[0.0, 4.0], &[7.0]];
        for h in [
            Heuristic::Average,
            Heuristic::Maximum,
            Heuristic::Balance,
            Heuristic::Power(2.0),
            Heuristic::Power(3.5),
        ] {
            for pdfs in cases {
                let sum: f32 = (0..pdfs.len()).map(|i| mis_weight(h, i, pdfs)).sum();
                assert!((sum - 1.0).abs() < 1e-6, "{h:?} {pdfs:?}: {sum}");
            }
        }
    }

    #[test]
    fn power2_matches_general_form_and_is_finite() {
        for (a, b) in [(0.5f32, 2.0f32), (3.0, 0.0), (1e-30, 1e-30), (1e30, 1.0)] {
            let w = mis_power2(a, b);
            assert!(w.is_finite() && (0.0..=1.0).contains(&w));
            let g = mis_weight(Heuristic::Power(2.0), 0, &[a, b]);
            if g.is_finite() && g > 0.0 {
                assert!((w - g).abs() < 1e-5, "{a} {b}: {w} vs {g}");
            }
        }
        assert_eq!(mis_power2(0.0, 0.0), 0.0);
        assert_eq!(mis_power2(1.0, 0.0), 1.0);
    }

    #[test]
    fn combined_estimator_is_unbiased() {
        // ∫₀¹ 3x² dx = 1 with two strategies, p₁ = 1 (uniform) and p₂ = 2x (inverted CDF
        // x = √u), each weighting: the exact expectation by midpoint quadrature over u.
        let f = |x: f32| 3.0 * x * x;
        let m = 20_000;
        for h in [
            Heuristic::Average,
            Heuristic::Maximum,
            Heuristic::Balance,
            Heuristic::Power(2.0),
        ] {
            let mut total = 0.0f64;
            for k in 0..m {
                let u = (k as f32 + 0.5) / m as f32;
                let x1 = u;
                let x2 = u.sqrt();
                let pdfs = |x: f32| [1.0, 2.0 * x];
                total += (mis_weight(h, 0, &pdfs(x1)) * f(x1) / 1.0) as f64;
                total += (mis_weight(h, 1, &pdfs(x2)) * f(x2) / (2.0 * x2)) as f64;
            }
            let estimate = total / m as f64;
            assert!((estimate - 1.0).abs() < 1e-3, "{h:?}: {estimate}");
        }
    }
}
