//! The lecture's variance relations, measured: every estimator unbiased, every measured variance
//! inside the χ² interval of its predicted value, σ²_sec = σ²_prim/N, σ²_strat ≤ σ²_sec and the
//! balance heuristic's bound. Each test reads one run of the experiment, whose checks share a
//! family-wise α = 0.01 (Šidák), so together these tests fail by chance with probability ≤ 0.01.

use super::predict::{strategies, weight};
use super::*;
use crate::mis::Heuristic;

/// The experiment with a seed of its own (not the CLI's default) and N = 32 samples per estimate.
fn report() -> Report {
    run(Settings {
        samples: 32,
        trials: 2000,
        seed: 12345,
        alpha: 0.01,
    })
    .expect("valid settings")
}

#[test]
fn every_estimator_is_unbiased() {
    let r = report();
    for s in &r.sections {
        for row in &s.rows {
            assert!(
                row.mean_p >= r.alpha_each,
                "{}, {}: mean {} ± {} vs I = {} (p = {})",
                s.name,
                row.label,
                row.mean,
                row.standard_error,
                s.exact,
                row.mean_p
            );
        }
    }
}

#[test]
fn measured_variances_match_the_lectures_formulas() {
    let r = report();
    for s in &r.sections {
        for row in &s.rows {
            let ratio = row.measured_variance / row.predicted_variance;
            assert!(
                row.variance_p >= r.alpha_each,
                "{}, {}: measured / predicted variance = {ratio} outside [{}, {}] (d = {}, p = {})",
                s.name,
                row.label,
                row.interval.0,
                row.interval.1,
                row.dof,
                row.variance_p
            );
        }
    }
}

#[test]
fn secondary_variance_is_primary_over_n() {
    let r = report();
    let n = r.settings.samples as f64;
    for s in &r.sections {
        let get = |e: Estimator| s.rows.iter().find(|row| row.estimator == e).unwrap();
        let (prim, sec) = (get(Estimator::Primary), get(Estimator::Secondary));
        assert_eq!(sec.predicted_variance * n, prim.predicted_variance);
        // Measured: the T secondary estimates' variance times N, inside the χ² interval of
        // σ²_prim (the secondary row's check, restated as the lecture's relation).
        let scaled = sec.measured_variance * n / prim.predicted_variance;
        assert!(
            (sec.interval.0..=sec.interval.1).contains(&scaled),
            "{}: N·s²_sec/σ²_prim = {scaled}",
            s.name
        );
        assert!(s.relations[0].ok, "{}", s.relations[0].text);
    }
}

#[test]
fn stratified_is_no_worse_than_secondary() {
    let r = report();
    for s in &r.sections {
        let c = s
            .relations
            .iter()
            .find(|c| c.text.starts_with("σ²_strat"))
            .unwrap();
        assert!(c.ok, "{}: {}", s.name, c.text);
    }
}

#[test]
fn every_weighting_respects_the_balance_bound() {
    let r = report();
    for s in &r.sections {
        let bounds: Vec<_> = s
            .relations
            .iter()
            .filter(|c| c.text.starts_with("balance bound"))
            .collect();
        assert_eq!(bounds.len(), 3, "average, maximum and power are checked");
        for c in bounds {
            assert!(c.ok, "{}: {}", s.name, c.text);
        }
    }
    // Exactly, by quadrature, for more weightings than the table shows.
    for i in integrands().unwrap() {
        let (_, bound) = balance_bound(&i);
        for h in [
            Heuristic::Average,
            Heuristic::Maximum,
            Heuristic::Balance,
            Heuristic::Power(0.5),
            Heuristic::Power(2.0),
            Heuristic::Power(8.0),
        ] {
            let v = lecture_variance(&i, Estimator::Combined(h), 1);
            assert!(
                v >= bound,
                "{} {h:?}: σ²_comb = {v} < bound {bound}",
                i.name
            );
        }
    }
}

/// The bound holds for f ≥ 0 only: for sin 2πx (I = 0) with uniform and 2x sampling, the
/// maximum heuristic has a lower variance than balance, below the bound σ²_bal − (1 − 1/n)·0.
#[test]
fn balance_bound_needs_a_nonnegative_integrand() {
    let sine = Integrand {
        name: "sin 2πx",
        f: |x| (2.0 * std::f64::consts::PI * x).sin(),
        exact: 0.0,
        exact_text: "0",
        importance: Box::new(LinearRamp),
        control: |_| 0.0,
        control_text: "0",
        control_integral: 0.0,
        breaks: vec![0.5],
    };
    let (_, bound) = balance_bound(&sine);
    let maximum = lecture_variance(&sine, Estimator::Combined(Heuristic::Maximum), 1);
    assert!(maximum < bound, "σ²_max = {maximum}, bound {bound}");
}

/// The lecture's variance formulas equal the variance computed directly as the second central
/// moment of each estimate (two independent derivations over the same quadrature). The
/// tolerance is the quadrature's rounding: 1e-9 of the estimate's second moment E[⟨I⟩²], from
/// which the formulas subtract I². Each estimate's expectation is I.
#[test]
fn lecture_formulas_equal_direct_moments() {
    let n = 16;
    for i in integrands().unwrap() {
        // Every estimator of the tables but the secondary one (the primary's mean of N).
        for e in super::experiment::ESTIMATORS
            .into_iter()
            .filter(|e| !matches!(e, Estimator::Secondary))
        {
            let lecture = lecture_variance(&i, e, n);
            let direct = cumulants(&i, e, n);
            let scale = direct.variance + direct.mean.powi(2);
            assert!(
                (lecture - direct.variance).abs() <= 1e-9 * scale,
                "{} {e:?}: lecture {lecture} vs direct {}",
                i.name,
                direct.variance
            );
            // Combined estimates weight in f32 (`mis_weight`): weights that sum to 1 within
            // 2·ε_f32 move the expectation by at most 2·ε_f32·∫|f|.
            let weights = match e {
                Estimator::Combined(_) => {
                    2.0 * f32::EPSILON as f64 * i.quadrature(|x| (i.f)(x).abs())
                }
                _ => 0.0,
            };
            assert!(
                (direct.mean - i.exact).abs() <= 1e-9 * scale.sqrt() + weights,
                "{} {e:?}: mean {}",
                i.name,
                direct.mean
            );
        }
    }
}

/// The lecture's own balance formula (∫ f²/Σp − Σ (∫ p_i f/Σp)²) equals the general combined
/// formula with the balance weights of `mis_weight`, which are f32: each weight carries a
/// relative rounding of a few 2⁻²⁴, so the two agree to 4·ε_f32·(σ²_bal + 2I²) (the second
/// moment is σ²_bal + Σ(∫w_i f)² ≤ σ²_bal + I²).
#[test]
fn balance_formula_is_the_combined_formula_with_balance_weights() {
    for i in integrands().unwrap() {
        let (bal, _) = balance_bound(&i);
        let general = lecture_variance(&i, Estimator::Combined(Heuristic::Balance), 1);
        let tolerance = 4.0 * f32::EPSILON as f64 * (bal + 2.0 * i.exact * i.exact);
        assert!(
            (bal - general).abs() <= tolerance,
            "{}: {bal} vs {general}",
            i.name
        );
        // The weights sum to 1 everywhere (unbiasedness, lecture "Eliminating bias").
        for k in 1..100 {
            let x = k as f64 / 100.0 - 0.003;
            let sum: f64 = (0..strategies(&i).len())
                .map(|s| weight(&i, Heuristic::Power(2.0), s, x))
                .sum();
            assert!((sum - 1.0).abs() < 1e-6, "{} at {x}: {sum}", i.name);
        }
    }
}

#[test]
fn same_seed_same_numbers() {
    let a = report();
    let b = report();
    let means = |r: &Report| -> Vec<f64> {
        r.sections
            .iter()
            .flat_map(|s| s.rows.iter().map(|row| row.mean))
            .collect()
    };
    assert_eq!(means(&a), means(&b));
    let c = run(Settings {
        seed: 1,
        ..a.settings
    })
    .unwrap();
    assert_ne!(means(&a), means(&c));
}

#[test]
fn bad_settings_are_errors() {
    let ok = Settings {
        samples: 4,
        trials: 10,
        seed: 0,
        alpha: 0.01,
    };
    assert!(run(Settings { samples: 0, ..ok }).is_err());
    assert!(run(Settings { trials: 1, ..ok }).is_err());
}
