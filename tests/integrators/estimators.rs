//! `wavetrace estimators` as users meet it: a table per integrand, every check passing for the
//! default settings (a fixed seed, so a deterministic outcome), exit status 0; bad arguments
//! are refused with exit status 2.

use std::process::{Command, Output};

fn wavetrace(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(args)
        .output()
        .expect("the wavetrace binary runs")
}

#[test]
fn estimators_prints_every_estimator_and_passes() {
    let o = wavetrace(&["estimators"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "exit {:?}\n{out}\n{}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
    let tables: Vec<&str> = out.split("\nf(x) = ").skip(1).collect();
    let names = ["3x²", "x sin πx", "2(1 − x) + peak at 0.3", "peak at 0.8"];
    assert_eq!(tables.len(), names.len(), "{out}");
    for (table, name) in tables.iter().zip(names) {
        assert!(table.starts_with(&format!("{name},")), "{name}\n{out}");
        for row in [
            "primary f(ξ)",
            "secondary, N samples",
            "stratified, N strata",
            "importance p = ",
            "combined, average",
            "combined, maximum",
            "combined, balance",
            "combined, power β = 2",
            "control g = ",
            "Russian roulette P = 0.5",
            "σ²_sec = σ²_prim/N",
            "σ²_strat ≤ σ²_sec",
            "balance bound (σ²_bal − (1 − 1/n)·I²)/N",
        ] {
            assert!(table.contains(row), "{name}: no {row}\n{out}");
        }
    }
    assert!(out.contains("importance p = 2x (P⁻¹ = √u)"), "{out}");
    assert!(
        out.contains("importance p = table of x sin πx, 32 bins"),
        "{out}"
    );
    assert!(!out.contains("FAIL"), "{out}");
    assert!(out.contains("all checks passed"), "{out}");
}

#[test]
fn estimators_settings_change_the_table_and_bad_ones_are_refused() {
    let o = wavetrace(&[
        "estimators",
        "--samples",
        "8",
        "--trials",
        "300",
        "--seed",
        "3",
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("T = 300 independent estimates of N = 8 samples"),
        "{out}"
    );
    assert!(
        matches!(o.status.code(), Some(0) | Some(1)),
        "{:?}",
        o.status
    );
    for bad in [["--samples", "0"], ["--trials", "1"], ["--alpha", "2"]] {
        let o = wavetrace(&["estimators", bad[0], bad[1]]);
        assert_eq!(o.status.code(), Some(2), "{bad:?} accepted");
        assert!(!String::from_utf8_lossy(&o.stderr).is_empty());
    }
}
