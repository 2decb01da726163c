//! Integrands on [0, 1) with known integrals, each with the densities its estimators sample and
//! a control function, and the deterministic quadrature that predicts their variances.

use super::distribution::{Distribution1D, LinearRamp, Lorentzian, Sampler1D};
use super::quadrature::integrate;
use anyhow::Result;
use std::f64::consts::PI;

/// A test integrand of the lecture's estimators.
pub struct Integrand {
    /// How the table names it, e.g. "3x²".
    pub name: &'static str,
    /// The integrand on [0, 1).
    pub f: fn(f64) -> f64,
    /// I = ∫₀¹ f, in closed form.
    pub exact: f64,
    /// The closed form as text, e.g. "1/π".
    pub exact_text: &'static str,
    /// The density of importance sampling, also the second strategy of combined sampling
    /// (the first is uniform).
    pub importance: Box<dyn Sampler1D>,
    /// The control function g and its name.
    pub control: fn(f64) -> f64,
    pub control_text: &'static str,
    /// J = ∫₀¹ g, in closed form.
    pub control_integral: f64,
    /// Points in (0, 1) where the quadrature's integrands may have kinks or jumps (where the
    /// maximum heuristic switches strategy, bin edges of a table), so that panels end there.
    pub breaks: Vec<f64>,
}

impl Integrand {
    /// ∫₀¹ g by quadrature with panels that end at every break: about `QUADRATURE_PANELS`
    /// panels over [0, 1), at least one per piece.
    pub fn quadrature(&self, g: impl Fn(f64) -> f64) -> f64 {
        let mut edges = vec![0.0];
        edges.extend(self.breaks.iter().copied().filter(|b| *b > 0.0 && *b < 1.0));
        edges.push(1.0);
        edges.sort_by(f64::total_cmp);
        edges
            .windows(2)
            .map(|e| {
                let panels = ((e[1] - e[0]) * QUADRATURE_PANELS as f64).ceil().max(1.0);
                integrate(&g, e[0], e[1], panels as usize)
            })
            .sum()
    }
}

/// Panels per unit length of [`Integrand::quadrature`].
pub const QUADRATURE_PANELS: usize = 4096;

/// Survival probability of the Russian-roulette estimate in the experiment.
pub const ROULETTE_P: f64 = 0.5;

/// Bins of the tabulated density of x sin πx.
const TABLE_BINS: usize = 32;

/// The peak of the third integrand, also its sampling density and its control function.
const PEAK: Lorentzian = Lorentzian {
    centre: 0.3,
    width: 0.01,
};

fn cubic_ramp(x: f64) -> f64 {
    3.0 * x * x
}

fn cubic_ramp_control(x: f64) -> f64 {
    3.0 * x - 0.5
}

fn x_sin_pi_x(x: f64) -> f64 {
    x * (PI * x).sin()
}

fn x_sin_pi_x_control(x: f64) -> f64 {
    12.0 / PI * x * x * (1.0 - x)
}

/// A peak that neither uniform nor 2x sampling fits, and a wider one as its control function.
const OFF_PEAK: Lorentzian = Lorentzian {
    centre: 0.8,
    width: 0.01,
};
const OFF_PEAK_CONTROL: Lorentzian = Lorentzian {
    centre: 0.8,
    width: 0.015,
};

fn off_peak(x: f64) -> f64 {
    OFF_PEAK.pdf(x)
}

fn off_peak_control(x: f64) -> f64 {
    OFF_PEAK_CONTROL.pdf(x)
}

fn ramp_and_peak(x: f64) -> f64 {
    2.0 * (1.0 - x) + PEAK.pdf(x)
}

fn peak(x: f64) -> f64 {
    PEAK.pdf(x)
}

/// The test integrands:
/// - 3x² (I = 1), importance-sampled with p = 2x by analytic P⁻¹(u) = √u;
/// - x sin πx (I = 1/π), importance-sampled with a 32-bin table of itself (CDF inverted by
///   binary search), which fits it well;
/// - 2(1 − x) + a narrow Lorentzian peak at 0.3 (I = 2), sampled with the peak's own density: neither
///   uniform nor peak sampling alone handles both parts, combined sampling does;
/// - a narrow peak at 0.8 (I = 1) sampled by uniform and 2x, neither of which fits it: balance
///   is then poor in absolute terms, σ²_bal > (1 − 1/n) I², and the lecture's bound on the
///   other weightings is positive, a real constraint.
pub fn integrands() -> Result<Vec<Integrand>> {
    let table = Distribution1D::from_function(x_sin_pi_x, TABLE_BINS, "x sin πx")?;
    // The peak density equals the uniform one where w / (Z (w² + d²)) = 1.
    let z = PEAK.width / PEAK.pdf(PEAK.centre) / (PEAK.width * PEAK.width);
    let d = (PEAK.width / z - PEAK.width * PEAK.width).sqrt();
    Ok(vec![
        Integrand {
            name: "3x²",
            f: cubic_ramp,
            exact: 1.0,
            exact_text: "1",
            importance: Box::new(LinearRamp),
            control: cubic_ramp_control,
            control_text: "3x − 1/2",
            control_integral: 1.0,
            breaks: vec![0.5],
        },
        Integrand {
            name: "x sin πx",
            f: x_sin_pi_x,
            exact: 1.0 / PI,
            exact_text: "1/π",
            importance: Box::new(table),
            control: x_sin_pi_x_control,
            control_text: "(12/π) x² (1 − x)",
            control_integral: 1.0 / PI,
            breaks: (1..TABLE_BINS)
                .map(|k| k as f64 / TABLE_BINS as f64)
                .collect(),
        },
        Integrand {
            name: "2(1 − x) + peak at 0.3",
            f: ramp_and_peak,
            exact: 2.0,
            exact_text: "2",
            importance: Box::new(PEAK),
            control: peak,
            control_text: "the peak",
            control_integral: 1.0,
            breaks: vec![PEAK.centre - d, PEAK.centre + d],
        },
        Integrand {
            name: "peak at 0.8",
            f: off_peak,
            exact: 1.0,
            exact_text: "1",
            importance: Box::new(LinearRamp),
            control: off_peak_control,
            control_text: "a wider peak (w = 0.015)",
            control_integral: 1.0,
            breaks: vec![0.5],
        },
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quadrature_gives_the_closed_forms() {
        for i in integrands().unwrap() {
            let q = i.quadrature(i.f);
            assert!(
                (q - i.exact).abs() < 1e-12,
                "{}: {q} vs {}",
                i.name,
                i.exact
            );
            let j = i.quadrature(i.control);
            let expected = i.control_integral;
            assert!((j - expected).abs() < 1e-12, "{}: J = {j}", i.name);
            // The maximum heuristic switches at the breaks: the densities are equal there.
            if i.name.contains("peak") {
                for b in &i.breaks {
                    assert!((i.importance.pdf(*b) - 1.0).abs() < 1e-12);
                }
            }
        }
    }
}
