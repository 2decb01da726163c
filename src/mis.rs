//! The seed's combined-sampling weightings (lecture "Monte Carlo methods", §Combined sampling):
//! average, maximum (cutoff), balance and power(β), and the two single-technique estimators
//! (emitter sampling only, BSDF sampling only). Each returns the weight of strategy `i`
//! whose pdf at the sample is `pdfs[i]`; for every x the weights over all strategies sum to 1,
//! which keeps the combined estimate unbiased. Non-finite weights become 0 (Mitsuba's rule).
//! `mis_weight2` (twin of `shaders/inc/mis.glsl`) is the two-strategy form the integrators use,
//! selected with `--mis`.

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
    /// Emitter sampling alone (strategy 0 in the n-strategy form): weight 1 wherever it can
    /// produce the sample, BSDF sampling only where it cannot (e.g. after a delta bounce).
    LightOnly,
    /// BSDF sampling alone (strategy 1 in the n-strategy form): emitter sampling weighs 0.
    BsdfOnly,
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
        Heuristic::LightOnly | Heuristic::BsdfOnly => {
            // The chosen strategy takes everything it can produce; where its pdf is 0 the
            // others share by the balance heuristic, so the weights still sum to 1.
            let chosen = if heuristic == Heuristic::LightOnly {
                0
            } else {
                1
            };
            if pdfs.get(chosen).is_some_and(|&p| p > 0.0) {
                if i == chosen {
                    1.0
                } else {
                    0.0
                }
            } else {
                pdfs[i] / pdfs.iter().sum::<f32>()
            }
        }
    };
    if w.is_finite() {
        w
    } else {
        0.0
    }
}

/// `Heuristic` as the GPU's `FrameParams` carries it: (`MIS_*` code, β).
pub const MIS_POWER: u32 = 0;
pub const MIS_BALANCE: u32 = 1;
pub const MIS_MAXIMUM: u32 = 2;
pub const MIS_AVERAGE: u32 = 3;
pub const MIS_LIGHT_ONLY: u32 = 4;
pub const MIS_BSDF_ONLY: u32 = 5;

impl Heuristic {
    pub fn code_and_beta(self) -> (u32, f32) {
        match self {
            Heuristic::Power(beta) => (MIS_POWER, beta),
            Heuristic::Balance => (MIS_BALANCE, 1.0),
            Heuristic::Maximum => (MIS_MAXIMUM, 0.0),
            Heuristic::Average => (MIS_AVERAGE, 0.0),
            Heuristic::LightOnly => (MIS_LIGHT_ONLY, 0.0),
            Heuristic::BsdfOnly => (MIS_BSDF_ONLY, 0.0),
        }
    }
}

/// Two strategies (emitter sampling and BSDF sampling), as the integrators combine them: the
/// weight of the one whose pdf at the sample is `a`, against the other's `b` (both solid angle).
/// A strategy that cannot produce the sample (pdf 0) leaves the other weight 1, which keeps the
/// weights summing to 1 for average too. `a_is_light` says that `a` is emitter sampling's pdf:
/// it picks the technique of the single-technique modes and gives maximum's ties to that side.
/// Written with the ratio r = b/a so that no power overflows. Twin of `mis_weight2` in mis.glsl.
#[inline]
pub fn mis_weight2(heuristic: u32, beta: f32, a: f32, b: f32, a_is_light: bool) -> f32 {
    if b.is_nan() || b <= 0.0 {
        return 1.0;
    }
    if a.is_nan() || a <= 0.0 {
        return 0.0;
    }
    let r = b / a;
    let w = match heuristic {
        MIS_BALANCE => 1.0 / (1.0 + r),
        MIS_MAXIMUM => {
            if a > b || (a == b && a_is_light) {
                1.0
            } else {
                0.0
            }
        }
        MIS_AVERAGE => 0.5,
        MIS_LIGHT_ONLY => f32::from(u8::from(a_is_light)),
        MIS_BSDF_ONLY => f32::from(u8::from(!a_is_light)),
        _ => 1.0 / (1.0 + if beta == 2.0 { r * r } else { r.powf(beta) }),
    };
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
            Heuristic::LightOnly,
            Heuristic::BsdfOnly,
        ] {
            for pdfs in cases {
                let sum: f32 = (0..pdfs.len()).map(|i| mis_weight(h, i, pdfs)).sum();
                assert!((sum - 1.0).abs() < 1e-6, "{h:?} {pdfs:?}: {sum}");
            }
        }
    }

    #[test]
    fn two_strategy_form_matches_the_general_one() {
        let heuristics = [
            Heuristic::Average,
            Heuristic::Maximum,
            Heuristic::Balance,
            Heuristic::Power(2.0),
            Heuristic::Power(3.5),
            Heuristic::LightOnly,
            Heuristic::BsdfOnly,
        ];
        for h in heuristics {
            let (code, beta) = h.code_and_beta();
            for (a, b) in [
                (0.5f32, 2.0f32),
                (3.0, 1e-3),
                (1e-20, 1e-20),
                (1e30, 1.0),
                (2.0, 2.0),
                (1e-30, 1e30),
            ] {
                let light = mis_weight2(code, beta, a, b, true);
                let bsdf = mis_weight2(code, beta, b, a, false);
                assert!(
                    light.is_finite() && (0.0..=1.0).contains(&light),
                    "{h:?} {a} {b}: {light}"
                );
                assert!(
                    (light + bsdf - 1.0).abs() < 1e-6,
                    "{h:?} {a} {b}: {light} + {bsdf}"
                );
                let general = mis_weight(h, 0, &[a, b]);
                if h != Heuristic::Maximum && general.is_finite() && general > 0.0 && general < 1.0
                {
                    assert!(
                        (light - general).abs() < 1e-5,
                        "{h:?} {a} {b}: {light} vs {general}"
                    );
                }
            }
            // A strategy that cannot produce the sample leaves the other everything.
            assert_eq!(mis_weight2(code, beta, 1.0, 0.0, false), 1.0);
            assert_eq!(mis_weight2(code, beta, 0.0, 1.0, true), 0.0);
        }
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
            Heuristic::LightOnly,
            Heuristic::BsdfOnly,
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
