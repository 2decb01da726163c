#![allow(clippy::excessive_precision)] // reference values as printed by mpmath
//! The special functions are `statrs`'s, accurate to about 1e-10 relative on these arguments
//! (Numerical Recipes' versions, kept in `nr3.rs` as a cross-check, reach 1e-14): the known
//! values below hold them to 1e-10, far finer than any significance level needs.

use super::*;
use crate::film::Film;
use glam::Vec3;

fn close(actual: f64, expected: f64, tolerance: f64) {
    assert!(
        (actual - expected).abs() <= tolerance,
        "got {actual}, expected {expected} ± {tolerance}"
    );
}

#[test]
fn ln_gamma_known_values() {
    close(ln_gamma(0.5), std::f64::consts::PI.sqrt().ln(), 1e-14);
    close(ln_gamma(1.0), 0.0, 1e-14);
    close(ln_gamma(2.0), 0.0, 1e-14);
    close(ln_gamma(10.0), 362_880f64.ln(), 1e-12);
    // ln Γ(100) = ln 99! (Abramowitz & Stegun table 6.4 / exact factorial).
    close(ln_gamma(100.0), 359.134_205_369_575_4, 1e-10);
    // Reflection: Γ(0.25) = 3.625609908221908…
    close(ln_gamma(0.25), 3.625_609_908_221_908_f64.ln(), 1e-13);
}

#[test]
fn incomplete_beta_identities_and_values() {
    // I_x(a, 1) = x^a, I_x(1, b) = 1 − (1 − x)^b, I_x(a, b) = 1 − I_{1−x}(b, a).
    close(incomplete_beta(2.5, 1.0, 0.3), 0.3f64.powf(2.5), 1e-10);
    close(incomplete_beta(1.0, 3.0, 0.2), 1.0 - 0.8f64.powi(3), 1e-10);
    for (a, b, x) in [(0.5, 7.0, 0.1), (3.0, 2.0, 0.8), (40.0, 60.0, 0.45)] {
        close(
            incomplete_beta(a, b, x),
            1.0 - incomplete_beta(b, a, 1.0 - x),
            1e-10,
        );
    }
    // I_{1/2}(a, a) = 1/2.
    close(incomplete_beta(13.7, 13.7, 0.5), 0.5, 1e-10);
    // Reference values (scipy.special.betainc).
    close(incomplete_beta(2.0, 3.0, 0.4), 0.5248, 1e-10);
    close(incomplete_beta(0.5, 0.5, 0.25), 1.0 / 3.0, 1e-10);
    // Large parameters (mpmath quadrature of the density), on both sides of STIRLING_MIN.
    close(
        incomplete_beta(200.0, 300.0, 0.4),
        0.502_428_616_319_931_6,
        1e-10,
    );
    close(
        incomplete_beta(1e4, 2e4, 0.34),
        0.992_713_748_010_027_2,
        1e-10,
    );
    close(
        incomplete_beta(nr3::STIRLING_MIN, 3.0, 0.97),
        0.406_336_180_222_592_2,
        1e-10,
    );
    close(
        incomplete_beta(nr3::STIRLING_MIN - 0.5, 3.0, 0.97),
        0.409_669_515_196_315_8,
        1e-10,
    );
    close(
        incomplete_gamma_p(nr3::STIRLING_MIN, 95.0),
        0.317_356_811_169_800_0,
        1e-10,
    );
    close(
        incomplete_gamma_p(nr3::STIRLING_MIN - 0.5, 95.0),
        0.335_577_704_432_810_1,
        1e-10,
    );
    assert_eq!(incomplete_beta(2.0, 3.0, 0.0), 0.0);
    assert_eq!(incomplete_beta(2.0, 3.0, 1.0), 1.0);
}

#[test]
fn incomplete_gamma_known_values() {
    // P(1, x) = 1 − e^−x; P(1/2, x) = erf(√x): erf(1) = 0.8427007929497149.
    close(incomplete_gamma_p(1.0, 2.0), 1.0 - (-2.0f64).exp(), 1e-10);
    close(incomplete_gamma_p(0.5, 1.0), 0.842_700_792_949_714_9, 1e-10);
    close(
        incomplete_gamma_p(5.0, 3.0),
        1.0 - incomplete_gamma_q(5.0, 3.0),
        1e-10,
    );
    // Q(3, 10) = e^−10 (1 + 10 + 50).
    close(
        incomplete_gamma_q(3.0, 10.0),
        (-10.0f64).exp() * 61.0,
        1e-10,
    );
}

#[test]
fn student_t_p_values() {
    // Reference values computed with mpmath (40 digits).
    close(
        student_t_two_sided_p(2.0, 10.0),
        0.073_388_034_770_740_37,
        1e-10,
    );
    close(
        student_t_two_sided_p(-2.0, 10.0),
        0.073_388_034_770_740_37,
        1e-10,
    );
    close(
        student_t_two_sided_p(1.96, 1e5),
        0.049_998_563_194_301_63,
        1e-10,
    );
    // Above 10⁶ degrees of freedom the normal stands in for t (relative error O(t⁴/df)).
    close(
        student_t_two_sided_p(1.96, 1e9),
        0.049_995_790_573_729_59,
        1e-9,
    );
    close(
        student_t_two_sided_p(4.0, 3e5) / 6.335_765_238_221_287e-5,
        1.0,
        1e-9,
    );
    // df = 1 is Cauchy: p = 1 − 2 atan(t)/π.
    close(
        student_t_two_sided_p(3.0, 1.0),
        1.0 - 2.0 * 3f64.atan() / std::f64::consts::PI,
        1e-10,
    );
    close(student_t_two_sided_p(0.0, 7.5), 1.0, 1e-10);
    // Large df tends to the normal: P(|Z| ≥ 1.96) = 0.04999579029644087.
    let normal = 0.049_995_790_296_440_87;
    close(student_t_two_sided_p(1.96, 1e15), normal, 1e-10);
    close(student_t_two_sided_p(1.96, f64::INFINITY), normal, 1e-10);
    assert!(student_t_two_sided_p(1.0, 0.0).is_nan());
}

#[test]
fn chi_square_p_values() {
    close(chi_square_p(3.841_458_820_694_124, 1.0), 0.05, 1e-10);
    close(chi_square_p(18.307_038_053_275_146, 10.0), 0.05, 1e-10);
    // Large dof (mpmath references).
    close(
        chi_square_p(10_100.0, 10_000.0),
        0.239_015_325_240_175_1,
        1e-10,
    );
    close(
        chi_square_p(1_002_000.0, 1_000_000.0),
        0.078_718_661_386_129_63,
        1e-10,
    );
    assert_eq!(chi_square_p(0.0, 3.0), 1.0);
}

#[test]
fn sidak_correction() {
    close(sidak(0.01, 1), 0.01, 1e-17);
    close(sidak(0.05, 2), 1.0 - 0.95f64.sqrt(), 1e-16);
    let a = sidak(0.01, 1_000_000);
    close((1.0 - a).powf(1e6), 0.99, 1e-9);
}

#[test]
fn welch_t_test_cases() {
    // t = (1 − 0) / √(0.5 + 0.5) = 1, df = 1 / (0.25/4 + 0.25/4) = 8.
    let (t, df, p) = welch_t_test(1.0, 0.5, 4.0, 0.0, 0.5, 4.0);
    close(t, 1.0, 1e-15);
    close(df, 8.0, 1e-12);
    close(p, student_t_two_sided_p(1.0, 8.0), 1e-15);
    assert_eq!(welch_t_test(2.0, 0.0, 5.0, 2.0, 0.0, 5.0).2, 1.0);
    assert_eq!(welch_t_test(2.0, 0.0, 5.0, 2.5, 0.0, 5.0).2, 0.0);
    // One side exact: df is the other side's.
    close(welch_t_test(1.0, 0.0, 0.0, 0.0, 0.25, 3.0).1, 3.0, 1e-12);
}

#[test]
fn chi_square_gof_pools_small_cells() {
    let expected = [25.0, 25.0, 25.0, 25.0];
    let (chi2, dof, p) = chi_square_gof(&[25.0, 25.0, 25.0, 25.0], &expected);
    assert_eq!((chi2, dof, p), (0.0, 3.0, 1.0));
    let (chi2, dof, _) = chi_square_gof(&[30.0, 20.0, 25.0, 25.0], &expected);
    close(chi2, 2.0, 1e-12);
    assert_eq!(dof, 3.0);
    // Cells with expectation 1, 2, 3 pool into one (6) and the rest stand alone.
    let (chi2, dof, _) = chi_square_gof(&[0.0, 2.0, 4.0, 10.0, 10.0], &[1.0, 2.0, 3.0, 10.0, 10.0]);
    assert_eq!(dof, 2.0);
    close(chi2, 0.0, 1e-12);
    // A sample where none may fall.
    assert_eq!(chi_square_gof(&[1.0, 9.0], &[0.0, 10.0]).2, 0.0);
}

/// PCG32 (O'Neill 2014, pcg32 XSH RR), for test inputs only.
struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    fn new(seed: u64, stream: u64) -> Pcg32 {
        let mut rng = Pcg32 {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }
    fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }
    /// Uniform in (0, 1).
    fn uniform(&mut self) -> f64 {
        (self.next_u32() as f64 + 0.5) / 4_294_967_296.0
    }
}

const SIZE: u32 = 32;
const TILE: u32 = 8;
const SPP: usize = 16;

/// A skewed sample: exponential with a mean that varies over pixels and channels.
fn sample(rng: &mut Pcg32, pixel: usize) -> Vec3 {
    let base = 0.5 + (pixel % 7) as f64 * 0.1;
    Vec3::from_array(std::array::from_fn(|c| {
        (-rng.uniform().ln() * base * (1.0 + c as f64)) as f32
    }))
}

fn noisy_film(seed: u64) -> Film {
    let mut film = Film::new(SIZE, SIZE);
    let mut rng = Pcg32::new(seed, 7);
    for pixel in 0..film.len() {
        for _ in 0..SPP {
            film.add_sample(pixel, sample(&mut rng, pixel));
        }
    }
    film
}

#[test]
fn same_distribution_passes() {
    // 20 independent pairs at family-wise α = 0.01: P(more than 2 fail) < 0.001 if the test is
    // calibrated (binomial, n = 20, p = 0.01).
    let mut failed = 0;
    for seed in 0..20 {
        let cmp =
            compare_films(&noisy_film(2 * seed), &noisy_film(2 * seed + 1), TILE, 0.01).unwrap();
        assert_eq!(cmp.tests, 16 * 3);
        if !cmp.passed() {
            failed += 1;
            eprintln!("{cmp}");
        }
    }
    assert!(
        failed <= 2,
        "{failed} of 20 comparisons of identically distributed films failed"
    );
}

#[test]
fn shifted_tile_fails_and_is_reported() {
    let a = noisy_film(100);
    // Film b: independent samples, except tile (2, 1) whose G samples are a's plus a shift of
    // 5 standard errors of the difference of tile means (so t ≈ 5 up to the error of the
    // variance estimate: p ≈ 6e-7 against a per-test level of 2e-4).
    let mut b = noisy_film(101);
    let (tx, ty) = (2u32, 1u32);
    let mut rng = Pcg32::new(100, 7);
    let mut shifted = Film::new(SIZE, SIZE);
    let mut variance_sum = 0.0;
    for pixel in 0..a.len() {
        for _ in 0..SPP {
            shifted.add_sample(pixel, sample(&mut rng, pixel));
        }
        let (x, y) = (pixel as u32 % SIZE, pixel as u32 / SIZE);
        if x / TILE == tx && y / TILE == ty {
            variance_sum += a.variance_of_mean_f64(pixel)[1];
        }
    }
    let pixels = (TILE * TILE) as f64;
    let std_err = (2.0 * variance_sum).sqrt() / pixels;
    let delta = (5.0 * std_err) as f32;
    let mut rng = Pcg32::new(100, 7);
    for pixel in 0..a.len() {
        let (x, y) = (pixel as u32 % SIZE, pixel as u32 / SIZE);
        let in_tile = x / TILE == tx && y / TILE == ty;
        if in_tile {
            b.pixels[pixel] = Default::default();
        }
        for _ in 0..SPP {
            let s = sample(&mut rng, pixel);
            if in_tile {
                b.add_sample(pixel, s + Vec3::new(0.0, delta, 0.0));
            }
        }
    }
    let cmp = compare_films(&a, &b, TILE, 0.01).unwrap();
    let report = cmp.to_string();
    assert!(!cmp.passed(), "{report}");
    assert_eq!(cmp.failures.len(), 1, "{report}");
    let f = &cmp.failures[0];
    assert_eq!((f.tile_x, f.tile_y, f.channel), (tx, ty, 1), "{report}");
    assert!((f.t + 5.0).abs() < 0.5, "{report}");
    assert!(
        report.contains("tile (2, 1) → pixels x 16..24, y 8..16, channel G"),
        "{report}"
    );
}

#[test]
fn constant_films_with_different_sample_counts_compare_equal() {
    let (mut a, mut b, mut c) = (Film::new(4, 4), Film::new(4, 4), Film::new(4, 4));
    let value = Vec3::new(0.7, 0.1, 3.3);
    for p in 0..16 {
        (0..1000).for_each(|_| a.add_sample(p, value));
        (0..37).for_each(|_| b.add_sample(p, value));
        (0..37).for_each(|_| c.add_sample(p, value * 1.01));
    }
    assert!(compare_films(&a, &b, 2, 0.01).unwrap().passed());
    let cmp = compare_films(&a, &c, 2, 0.01).unwrap();
    assert_eq!(cmp.failures.len(), cmp.tests, "{cmp}");
    assert!(compare_films(&a, &Film::new(4, 5), 2, 0.01).is_err());
}

#[test]
fn film_mean_and_standard_error() {
    let mut film = Film::new(2, 1);
    for v in [1.0, 3.0] {
        film.add_sample(0, Vec3::splat(v));
        film.add_sample(1, Vec3::splat(v + 1.0));
    }
    let (mean, std_err) = film_mean(&film);
    close(mean.x, 2.5, 1e-12);
    // Each pixel: sample variance 2, variance of the mean 1; √2 / 2.
    close(std_err.y, 2f64.sqrt() / 2.0, 1e-12);
}

#[test]
fn normal_quantiles() {
    // Tabulated upper quantiles of the standard normal.
    for (p, z) in [
        (0.05, 1.644_853_6),
        (0.005, 2.575_829_3),
        (1e-6, 4.753_424_3),
    ] {
        let got = normal_quantile_upper(p);
        assert!((got - z).abs() < 1e-6, "p {p}: {got} vs {z}");
    }
}

#[test]
fn image_error_of_known_films() {
    // a = (1, 2) and b = (0, 1) in every channel: squared errors 1 and 1; relative
    // 1 / (0 + ε) and 1 / (1 + ε).
    let (mut a, mut b) = (Film::new(2, 1), Film::new(2, 1));
    for (p, (x, y)) in [(1.0, 0.0), (2.0, 1.0)].into_iter().enumerate() {
        a.add_sample(p, Vec3::splat(x));
        b.add_sample(p, Vec3::splat(y));
    }
    let e = image_error(&a, &b, 0.5).unwrap();
    close(e.mse, 1.0, 1e-15);
    close(e.relative_mse, (1.0 / 0.5 + 1.0 / 1.5) / 2.0, 1e-15);
    // Not symmetric: b against a.
    let e = image_error(&b, &a, 0.5).unwrap();
    close(e.relative_mse, (1.0 / 1.5 + 1.0 / 4.5) / 2.0, 1e-15);
    assert_eq!(image_error(&a, &a, 0.5).unwrap().relative_mse, 0.0);
    assert!(image_error(&a, &Film::new(1, 2), 0.5).is_err());
}

/// The `statrs`-backed special functions against the Numerical Recipes implementation they
/// replaced (`stats/nr3.rs`), over the arguments the verification tests use: relative 1e-9 for
/// the gamma and beta functions, 1e-6 for Student's t p-values up to 10⁶ degrees of freedom
/// and 1e-3 beyond (where the normal stands in for t).
#[test]
fn statrs_agrees_with_nr3() {
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
    for &a in &[0.5, 1.0, 2.5, 10.0, 63.5, 500.0, 5e4] {
        for &x in &[
            1e-3,
            0.1,
            1.0,
            3.0,
            0.9 * a,
            a,
            1.2 * a + 5.0,
            3.0 * a + 30.0,
        ] {
            let (p, q) = (incomplete_gamma_p(a, x), incomplete_gamma_q(a, x));
            let (p_nr, q_nr) = (nr3::incomplete_gamma_p(a, x), nr3::incomplete_gamma_q(a, x));
            assert!(
                rel(p, p_nr) < 1e-9 || (p - p_nr).abs() < 1e-15,
                "P({a}, {x}): {p} vs {p_nr}"
            );
            assert!(
                rel(q, q_nr) < 1e-9 || (q - q_nr).abs() < 1e-15,
                "Q({a}, {x}): {q} vs {q_nr}"
            );
        }
        assert!(rel(ln_gamma(a), nr3::ln_gamma(a)) < 1e-12 || ln_gamma(a).abs() < 1e-12);
    }
    for &(a, b) in &[
        (0.5, 0.5),
        (2.0, 3.0),
        (30.0, 0.5),
        (0.5, 400.0),
        (1e3, 1e3),
    ] {
        for &x in &[1e-4, 0.05, 0.3, 0.5, 0.77, 0.999] {
            let (v, v_nr) = (incomplete_beta(a, b, x), nr3::incomplete_beta(a, b, x));
            assert!(
                rel(v, v_nr) < 1e-9 || (v - v_nr).abs() < 1e-15,
                "I_{x}({a}, {b}): {v} vs {v_nr}"
            );
        }
    }
    for &df in &[
        1.0,
        2.5,
        7.0,
        30.0,
        1e3,
        9.9e3,
        2e4,
        1e6,
        1e8,
        f64::INFINITY,
    ] {
        for &t in &[0.0, 0.3, 1.0, 2.0, 3.5, 5.0, 7.0] {
            let (p, p_nr) = (
                student_t_two_sided_p(t, df),
                nr3::student_t_two_sided_p(t, df),
            );
            let tol = if df <= 1e6 { 1e-6 } else { 1e-3 };
            assert!(rel(p, p_nr) < tol, "t = {t}, df = {df}: {p} vs {p_nr}");
        }
    }
    for &p in &[0.25, 1e-3, 1e-7, 1e-12] {
        let z = normal_quantile_upper(p);
        let back = 0.5 * nr3::incomplete_gamma_q(0.5, 0.5 * z * z);
        assert!(rel(back, p) < 1e-9, "z({p}) = {z}: tail {back}");
    }
}
