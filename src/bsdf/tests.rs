//! (Over 900 lines: the statistical tests of every lobe and extension share their scenes, samplers and helpers.)
//! The BSDF against its own pdf (χ² goodness of fit), `sample` against `eval`/`pdf`, energy,
//! reciprocity and the Lambertian special case.

use super::fresnel::*;
use super::gltf::*;
use super::lambert::*;
use super::lobes::*;
use super::microfacet::*;
use super::vertex::*;
use crate::layout::{GpuMaterial, MATERIAL_UNLIT};
use crate::sampling::rng_uniform4;
use crate::stats::{chi_square_gof, sidak};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

fn material(base: f32, metallic: f32, roughness: f32, transmission: f32) -> GpuMaterial {
    GpuMaterial {
        base_color: [base; 3],
        metallic,
        roughness,
        ior: 1.5,
        transmission,
        specular: 1.0,
        // Solid glass: the boundary of a volume (thicknessFactor > 0); the thin-walled cases
        // (`thin_pane`) set it to 0.
        thickness: 1.0,
        ..Default::default()
    }
}

/// A unit direction with cosine `cos` to +Z, rotated by `phi` about it.
fn direction(cos: f32, phi: f32) -> Vec3 {
    let s = (1.0 - cos * cos).max(0.0).sqrt();
    Vec3::new(s * phi.cos(), s * phi.sin(), cos)
}

fn u3(seed: u32, i: u32) -> Vec3 {
    let u = rng_uniform4(seed, i, 0, 0);
    Vec3::new(u.x, u.y, u.z)
}

const NG: Vec3 = Vec3::new(0.0, 0.0, 1.0);

/// Materials × incident directions (outside, and inside for transmission) the tests sweep.
fn sweep(roughnesses: &[f32]) -> Vec<(GpuMaterial, Vec3, String)> {
    let mut cases = Vec::new();
    for &r in roughnesses {
        for (metallic, transmission) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.5), (0.3, 0.0)]
        {
            for cos in [0.95, 0.5, 0.12] {
                let mut sides = vec![1.0];
                if transmission > 0.0 {
                    sides.push(-1.0);
                }
                for side in sides {
                    let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                    let m = material(0.8, metallic, r, transmission);
                    let name = format!(
                        "roughness {r}, metallic {metallic}, transmission {transmission}, wo {wo}"
                    );
                    cases.push((m, wo, name));
                }
            }
        }
    }
    cases
}

#[test]
fn sample_returns_the_pdf_and_value_that_pdf_and_eval_compute() {
    for (m, wo, name) in sweep(&[0.0, 0.02, 0.1, 0.4, 1.0]) {
        for i in 0..20_000 {
            let Some(s) = bsdf_sample(&m, NG, wo, u3(1, i), TransportMode::Radiance) else {
                continue;
            };
            assert!(
                s.weight.is_finite() && s.weight.min_element() >= 0.0,
                "{name}: {s:?}"
            );
            if s.delta {
                continue;
            }
            let pdf = bsdf_pdf(&m, NG, wo, s.wi);
            assert!(
                (s.pdf - pdf).abs() <= 1e-3 * pdf,
                "{name}: sample pdf {} vs pdf() {pdf}",
                s.pdf
            );
            let f = bsdf_eval(&m, NG, wo, s.wi, TransportMode::Radiance);
            let expected = f * s.wi.z.abs() / pdf;
            assert!(
                (s.weight - expected).abs().max_element()
                    <= 1e-3 * expected.max_element().max(1e-3),
                "{name}: weight {} vs f·cos/pdf {expected}",
                s.weight
            );
        }
    }
}

/// Histogram of sampled directions over the whole sphere in (θ, φ) cells around +Z against the
/// pdf integrated over each cell (midpoint rule on a sub-grid, the sin θ of the solid angle
/// included; no sub-sample lies on a cell edge, where pdfs jump at the horizon), plus one cell
/// for samples that produced no direction.
fn chi_square_p(sample: &dyn Fn(Vec3) -> Option<Vec3>, pdf: &dyn Fn(Vec3) -> f32, n: u32) -> f64 {
    let (nt, np, sub) = (32usize, 32usize, 32usize);
    let mut observed = vec![0f64; nt * np + 1];
    for i in 0..n {
        match sample(u3(7, i)) {
            Some(w) => {
                let theta = w.z.clamp(-1.0, 1.0).acos();
                let mut phi = w.y.atan2(w.x);
                if phi < 0.0 {
                    phi += 2.0 * PI;
                }
                let a = ((theta / PI * nt as f32) as usize).min(nt - 1);
                let b = ((phi / (2.0 * PI) * np as f32) as usize).min(np - 1);
                observed[a * np + b] += 1.0;
            }
            None => observed[nt * np] += 1.0,
        }
    }
    let (dt, dp) = (PI as f64 / nt as f64, 2.0 * PI as f64 / np as f64);
    // (cos φ, sin φ) of every sub-grid column, shared by all rows of cells: the same values as
    // taking them at each sub-point, without most of the quadrature's trigonometry.
    let columns: Vec<(f64, f64)> = (0..np * sub)
        .map(|k| {
            let phi = ((k / sub) as f64 + ((k % sub) as f64 + 0.5) / sub as f64) * dp;
            (phi.cos(), phi.sin())
        })
        .collect();
    // Midpoint rule over an (sθ × sub) sub-grid of cell (a, b); also says whether the pdf was 0
    // at some sub-points and positive at others.
    let integrate = |a: usize, b: usize, st: usize| -> (f64, bool, bool) {
        let (mut sum, mut zero, mut positive) = (0.0, false, false);
        for i in 0..st {
            let theta = (a as f64 + (i as f64 + 0.5) / st as f64) * dt;
            let (sin_theta, cos_theta) = theta.sin_cos();
            for &(cos_phi, sin_phi) in &columns[b * sub..(b + 1) * sub] {
                let w = Vec3::new(
                    (sin_theta * cos_phi) as f32,
                    (sin_theta * sin_phi) as f32,
                    cos_theta as f32,
                );
                let p = pdf(w) as f64;
                zero |= p <= 0.0;
                positive |= p > 0.0;
                sum += p * sin_theta;
            }
        }
        (sum * dt * dp / (st * sub) as f64 * n as f64, zero, positive)
    };
    let coarse: Vec<(f64, bool, bool)> = (0..nt * np)
        .map(|k| integrate(k / np, k % np, sub))
        .collect();
    let mut expected = vec![0f64; nt * np + 1];
    for k in 0..nt * np {
        // Cells on the edge of the support (the pdf 0 at some sub-points, or 0 everywhere beside
        // a cell where it is not) get a 32× finer grid in θ: refraction packs directions near the
        // edge of its cone into slivers thinner than the coarse grid.
        let (a, b) = (k / np, k % np);
        let neighbour_positive = [(a.wrapping_sub(1), b), (a + 1, b)]
            .iter()
            .any(|&(x, y)| x < nt && coarse[x * np + y].2);
        let (sum, zero, positive) = coarse[k];
        expected[k] = if zero && (positive || neighbour_positive) {
            integrate(a, b, 32 * sub).0
        } else {
            sum
        };
    }
    let mass: f64 = expected.iter().sum();
    expected[nt * np] = (n as f64 - mass).max(0.0);
    // As pbrt-v4's χ² test: a cell the quadrature found empty may hold a few samples (a sliver
    // of the support thinner than the sub-grid, e.g. refraction through microfacets at the
    // horizon) — at most 10⁻⁵ of them; such cells join the pooled cell of small expectations.
    let stray: f64 = (0..nt * np)
        .filter(|&k| expected[k] <= 0.0)
        .map(|k| observed[k])
        .sum();
    if stray > 1e-5 * n as f64 {
        eprintln!("{stray} samples where the pdf integrates to 0");
        return 0.0;
    }
    for e in &mut expected[..nt * np] {
        *e = e.max(1e-12);
    }
    chi_square_gof(&observed, &expected).2
}

/// [`chi_square_p`] of `bsdf_sample`'s directions against `bsdf_pdf` for material `m` seen from
/// `wo` (leaving out samples of delta lobes where `skip_delta`). The frame, which both build
/// from (m, wo) alone, is built once for the million samples and the quadrature's pdf values
/// rather than at each of them: the same numbers bit for bit, in about half the time.
fn chi_square_bsdf(m: &GpuMaterial, wo: Vec3, skip_delta: bool) -> f64 {
    let frame = BsdfFrame::new(m, NG, wo);
    chi_square_p(
        &|u| {
            frame
                .as_ref()?
                .sample(u, TransportMode::Radiance)
                .filter(|s| !(skip_delta && s.delta))
                .map(|s| s.wi)
        },
        &|wi| frame.as_ref().map_or(0.0, |f| f.pdf(wi)),
        1_000_000,
    )
}

#[test]
fn ggx_visible_normals_match_their_pdf() {
    // Isotropic and anisotropic (KHR_materials_anisotropy) roughnesses.
    let cases: Vec<(Vec2, f32)> = [
        Vec2::splat(0.1),
        Vec2::splat(0.4),
        Vec2::splat(1.0),
        Vec2::new(0.6, 0.05),
        Vec2::new(0.2, 0.9),
    ]
    .iter()
    .flat_map(|&a| [0.95f32, 0.5, 0.1].map(|c| (a, c)))
    .collect();
    let alpha = sidak(0.01, cases.len());
    for (a, cos) in cases {
        let wo = direction(cos, 1.1);
        let p = chi_square_p(
            &|u| Some(sample_ggx_vndf(wo, a, Vec2::new(u.x, u.y))),
            &|m| ggx_vndf_pdf(wo, m, a),
            1_000_000,
        );
        assert!(
            p > alpha,
            "GGX VNDF α {a}, cos θo {cos}: χ² p = {p} < {alpha}"
        );
    }
}

#[test]
fn bsdf_sample_matches_its_pdf() {
    // Rough lobes only: a delta lobe has no density to compare with.
    let cases = sweep(&[0.3, 0.7]);
    let alpha = sidak(0.01, cases.len());
    for (m, wo, name) in cases {
        let p = chi_square_bsdf(&m, wo, false);
        assert!(p > alpha, "{name}: χ² p = {p} < {alpha}");
    }
}

/// Directional albedo ∫ f |cos| dωi by Monte Carlo with the BSDF's own sampling: mean and
/// standard error of the weights (delta lobes included).
fn albedo(m: &GpuMaterial, wo: Vec3, n: u32) -> (f64, f64) {
    let (mut s, mut s2) = (0.0, 0.0);
    for i in 0..n {
        if let Some(x) = bsdf_sample(m, NG, wo, u3(11, i), TransportMode::Radiance) {
            let w = x.weight.max_element() as f64;
            s += w;
            s2 += w * w;
        }
    }
    let mean = s / n as f64;
    (
        mean,
        ((s2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt(),
    )
}

/// Directions in and above the surface, for the reciprocity checks.
const RECIPROCITY_DIRECTIONS: [(f32, f32); 3] = [(0.9, 0.1), (0.4, 2.0), (0.15, 4.0)];

/// What every lobe's sampling must satisfy on each case (rough lobes: `sample` has a density):
/// χ² of `bsdf_sample`'s directions against `bsdf_pdf` at α = 0.01 Šidák-corrected over the
/// cases, and, in both transport modes, each of 5000 samples' pdf equal to `bsdf_pdf` and its
/// weight to f·|cos|/pdf within 10⁻³. A sample from a delta lobe fails the test, unless
/// `skip_delta` (cases with smooth layers), which leaves it out. Prints the smallest p.
fn assert_sampling_matches_pdf_and_eval(
    cases: &[(GpuMaterial, Vec3, String)],
    what: &str,
    skip_delta: bool,
) {
    let alpha = sidak(0.01, cases.len());
    let mut smallest: f64 = 1.0;
    for (m, wo, name) in cases {
        let p = chi_square_bsdf(m, *wo, skip_delta);
        smallest = smallest.min(p);
        assert!(p > alpha, "{name}: χ² p = {p} < {alpha}");
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            for i in 0..5000 {
                let Some(s) = bsdf_sample(m, NG, *wo, u3(2, i), mode) else {
                    continue;
                };
                if skip_delta && s.delta {
                    continue;
                }
                assert!(!s.delta, "{name}");
                let pdf = bsdf_pdf(m, NG, *wo, s.wi);
                assert!(
                    (s.pdf - pdf).abs() <= 1e-3 * pdf,
                    "{name}: {} vs {pdf}",
                    s.pdf
                );
                let expected = bsdf_eval(m, NG, *wo, s.wi, mode) * s.wi.z.abs() / pdf;
                assert!(
                    (s.weight - expected).abs().max_element()
                        <= 1e-3 * expected.max_element().max(1e-3),
                    "{name}: {} vs {expected}",
                    s.weight
                );
            }
        }
    }
    println!(
        "{what} χ²: smallest p {smallest:.3} over {} cases (α per test {alpha:.2e})",
        cases.len()
    );
}

/// Each case's BSDF is reciprocal in reflection, f(a, b) = f(b, a), and its importance
/// transmission is the radiance one transposed.
fn assert_reciprocal_and_transposed(cases: &[(GpuMaterial, Vec3, String)]) {
    let dirs = RECIPROCITY_DIRECTIONS.map(|(cos, phi)| direction(cos, phi));
    for (m, _, name) in cases {
        for a in dirs {
            for b in dirs {
                let fab = bsdf_eval(m, NG, a, b, TransportMode::Radiance);
                let fba = bsdf_eval(m, NG, b, a, TransportMode::Radiance);
                assert!(
                    (fab - fba).abs().max_element() <= 1e-4 * fab.max_element().max(1e-3),
                    "{name}: {fab} vs {fba}"
                );
                let below = b * Vec3::new(1.0, 1.0, -1.0);
                let out_in = bsdf_eval(m, NG, a, below, TransportMode::Radiance);
                let adjoint = bsdf_eval(m, NG, below, a, TransportMode::Importance);
                assert!(
                    (adjoint - out_in).abs().max_element() <= 1e-3 * out_in.max_element().max(1e-3),
                    "{name}: {adjoint} vs {out_in}"
                );
            }
        }
    }
}

/// Each (material, wo) reflects at most what it receives: its Monte Carlo albedo (10⁵ samples)
/// at most 1 + z·se + 10⁻⁴, z the normal quantile of α = 0.01 Šidák-corrected over the checks.
/// Returns the largest albedo.
fn assert_albedo_at_most_one(checks: &[(GpuMaterial, Vec3)]) -> f64 {
    let z = crate::stats::normal_quantile_upper(sidak(0.01, checks.len()));
    let mut largest: f64 = 0.0;
    for (m, wo) in checks {
        let (a, se) = albedo(m, *wo, 100_000);
        largest = largest.max(a);
        assert!(
            a <= 1.0 + z * se + 1e-4,
            "{m:?} from {wo}: albedo {a} ± {se}"
        );
    }
    largest
}

#[test]
fn no_parameter_set_creates_energy() {
    // Metals and dielectrics without the diffuse lobe (pure GGX reflection and transmission)
    // must reflect at most what they receive. Transmission is checked from outside, where the
    // radiance scaling 1/η² keeps it below 1 by itself, and the η² is stated in the module doc.
    let mut checks = Vec::new();
    for r in [0.0, 0.05, 0.2, 0.5, 1.0] {
        for cos in [1.0, 0.7, 0.3, 0.05] {
            for (metallic, transmission) in [(1.0, 0.0), (0.0, 1.0)] {
                checks.push((
                    material(1.0, metallic, r, transmission),
                    direction(cos, 0.3),
                ));
            }
        }
    }
    assert_albedo_at_most_one(&checks);
}

#[test]
fn dielectric_mix_gains_energy_at_grazing() {
    // glTF's fresnel_mix((1 − F)·diffuse + F·specular) with a white base is not energy-conserving
    // where the specular lobe is rough: F is taken per direction on v·h, so at grazing angles the
    // specular lobe gains more than the diffuse loses. The spec accepts this (no energy
    // compensation in the core model); this test documents the size of the gain and that it is
    // absent at normal incidence.
    let m = material(1.0, 0.0, 1.0, 0.0);
    let (normal, se_n) = albedo(&m, direction(1.0, 0.0), 400_000);
    let (grazing, se_g) = albedo(&m, direction(0.05, 0.0), 400_000);
    println!("white rough plastic: albedo {normal:.4} ± {se_n:.4} at normal incidence, {grazing:.4} ± {se_g:.4} at cos θ = 0.05");
    assert!(
        normal <= 1.0 + 4.0 * se_n,
        "albedo {normal} at normal incidence"
    );
    assert!(
        grazing > normal,
        "the grazing gain disappeared: {grazing} vs {normal}"
    );
}

#[test]
fn smooth_glass_reflects_and_transmits_everything() {
    // Delta lobes only: F + (1 − F) = 1, the transmitted part scaled by 1/η² for radiance.
    let m = material(1.0, 0.0, 0.0, 1.0);
    for cos in [1.0, 0.6, 0.2] {
        let wo = direction(cos, 0.0);
        let f = fresnel_dielectric(cos, dielectric_f0(1.5), 1.0, 1.5);
        let (mut refl, mut trans) = (0.0, 0.0);
        let n = 100_000;
        for i in 0..n {
            let s = bsdf_sample(&m, NG, wo, u3(5, i), TransportMode::Radiance).unwrap();
            assert!(s.delta);
            if s.wi.z > 0.0 {
                refl += s.weight.x as f64 / n as f64;
            } else {
                trans += s.weight.x as f64 * 2.25 / n as f64;
            }
        }
        assert!(
            (refl + trans - 1.0).abs() < 1e-4,
            "cos {cos}: {refl} + {trans}"
        );
        // Each sample carries weight 1 (reflection) or 1/η² (transmission), chosen with
        // probability F: the split's error is binomial.
        let se = (f * (1.0 - f) / n as f32).sqrt() as f64;
        assert!(
            (refl - f as f64).abs() < 5.0 * se + 1e-6,
            "cos {cos}: F {f}, reflected {refl}"
        );
    }
    // From inside beyond the critical angle (sin θ > 1/1.5): total internal reflection.
    let wo = direction(0.5, 0.0) * Vec3::new(1.0, 1.0, -1.0);
    let s = bsdf_sample(&m, NG, wo, u3(5, 0), TransportMode::Radiance).unwrap();
    assert!(s.delta && s.wi.z < 0.0 && (s.weight - Vec3::ONE).abs().max_element() < 1e-6);
}

#[test]
fn rough_glass_of_ior_one_passes_light_straight_through() {
    // KHR_materials_transmission at ior 1 (TransmissionRoughnessTest's "air" row): whatever the
    // roughness, the transmitted light leaves along −wo, a delta, with weight (1 − F(wo))/p;
    // the rough reflection stays a lobe with a density.
    for roughness in [0.2f32, 0.5, 1.0] {
        let m = GpuMaterial {
            ior: 1.0,
            ..material(1.0, 0.0, roughness, 1.0)
        };
        for cos in [0.9f32, 0.4] {
            let wo = direction(cos, 0.3);
            let frame = BsdfFrame::new(&m, NG, wo).unwrap();
            let p = frame.lobe_pmf[LOBE_TRANSMISSION];
            assert!(
                p > 0.5,
                "roughness {roughness}, cos {cos}: transmission pmf {p}"
            );
            let (mut straight, mut lobe) = (0, 0);
            for i in 0..2000 {
                let Some(s) = frame.sample(u3(8, i), TransportMode::Radiance) else {
                    continue;
                };
                if s.wi.z < 0.0 {
                    assert!(s.delta && (s.wi + wo).length() < 1e-6, "{:?}", s);
                    let f =
                        fresnel_layers(cos, frame.f0, frame.f90, 1.0, Vec3::ONE, 0.0, &frame.film)
                            .0;
                    let want = (1.0 - f.max_element()) / p;
                    assert!(
                        (s.weight.x - want).abs() < 1e-5 * want,
                        "{} vs {want}",
                        s.weight.x
                    );
                    straight += 1;
                } else {
                    assert!(!s.delta && s.pdf > 0.0);
                    lobe += 1;
                }
            }
            // (F0 is 0 at ior 1: the reflection is chosen rarely, by its Fresnel estimate.)
            assert!(straight > 1000, "{straight} straight, {lobe} reflected");
            // No density anywhere below: the delta is left out of eval and pdf.
            assert_eq!(frame.pdf(-wo), 0.0);
            assert_eq!(frame.eval(-wo, TransportMode::Radiance), Vec3::ZERO);
        }
    }
}

#[test]
fn reflection_is_reciprocal_and_refraction_obeys_the_eta_squared_rule() {
    let dirs = [
        direction(0.9, 0.1),
        direction(0.4, 2.0),
        direction(0.15, 4.0),
    ];
    for r in [0.2, 0.6] {
        for (metallic, transmission) in [(0.0, 0.0), (1.0, 0.0), (0.4, 0.6)] {
            let m = material(0.7, metallic, r, transmission);
            for a in dirs {
                for b in dirs {
                    let fab = bsdf_eval(&m, NG, a, b, TransportMode::Radiance);
                    let fba = bsdf_eval(&m, NG, b, a, TransportMode::Radiance);
                    assert!((fab - fba).abs().max_element() <= 1e-4 * fab.max_element().max(1e-3));
                    // Transmission: f(a → inside b) / η_b² = f(inside b → a) / η_a² (Veach 1997,
                    // eq. 5.14), and the importance-mode BSDF is the radiance one transposed.
                    let below = b * Vec3::new(1.0, 1.0, -1.0);
                    let out_in = bsdf_eval(&m, NG, a, below, TransportMode::Radiance);
                    let in_out = bsdf_eval(&m, NG, below, a, TransportMode::Radiance);
                    let lhs = out_in / 2.25;
                    assert!(
                        (lhs - in_out).abs().max_element() <= 1e-3 * lhs.max_element().max(1e-3),
                        "{lhs} vs {in_out}"
                    );
                    let adjoint = bsdf_eval(&m, NG, below, a, TransportMode::Importance);
                    assert!(
                        (adjoint - out_in).abs().max_element()
                            <= 1e-3 * out_in.max_element().max(1e-3)
                    );
                }
            }
        }
    }
}

#[test]
fn specular_factor_zero_is_exactly_lambertian() {
    let m = GpuMaterial {
        specular: 0.0,
        ..material(0.6, 0.0, 1.0, 0.0)
    };
    let wo = direction(0.3, 0.5);
    for i in 0..10_000 {
        let s = bsdf_sample(&m, NG, wo, u3(3, i), TransportMode::Radiance).unwrap();
        assert!(!s.delta && s.wi.z > 0.0);
        assert!(
            (s.weight - Vec3::splat(0.6)).abs().max_element() < 1e-5,
            "{}",
            s.weight
        );
        assert!((s.pdf - s.wi.z / PI).abs() < 1e-5);
        let f = bsdf_eval(&m, NG, wo, s.wi, TransportMode::Radiance);
        assert!((f - Vec3::splat(0.6 / PI)).abs().max_element() < 1e-6);
    }
    // Both faces reflect alike; nothing passes through.
    let back = -wo;
    assert!(bsdf_eval(&m, NG, back, -Vec3::Z, TransportMode::Radiance).x > 0.0);
    assert_eq!(
        bsdf_eval(&m, NG, wo, -Vec3::Z, TransportMode::Radiance),
        Vec3::ZERO
    );
}

#[test]
fn visibility_equals_height_correlated_smith() {
    for a in [0.05, 0.3, 1.0] {
        for (co, ci) in [(0.9, 0.2), (0.5, 0.5), (0.1, 0.99)] {
            let (wo, wi) = (direction(co, 0.0), direction(ci, 1.0));
            let a = Vec2::splat(a);
            let g2 = 1.0 / (1.0 + ggx_lambda(wo, a) + ggx_lambda(wi, a));
            let v = ggx_visibility(wo, wi, a);
            assert!(
                (v - g2 / (4.0 * co * ci)).abs() <= 1e-5 * v,
                "α {a}: {v} vs {}",
                g2 / (4.0 * co * ci)
            );
        }
    }
}

/// KHR_materials_specular's colour cases: F0 below the clamp, above it on one channel, and a
/// weakened specular factor.
fn specular_color_material(roughness: f32, transmission: f32, k: usize) -> GpuMaterial {
    GpuMaterial {
        specular_color: [[0.3, 1.8, 0.9], [40.0, 0.0, 1.0], [2.0, 2.0, 0.5]][k],
        specular: [1.0, 1.0, 0.4][k],
        ..material(0.7, 0.0, roughness, transmission)
    }
}

#[test]
fn specular_color_follows_the_extension_formula() {
    // dielectric_f0 = min(((ior − 1)/(ior + 1))² · specularColor, 1) · specular, F90 = specular,
    // F = F0 + (F90 − F0)(1 − |v·h|)⁵ per channel, the diffuse scaled by 1 − max(F)
    // (KHR_materials_specular, "Implementation"), written out here independently.
    for k in 0..3 {
        let m = specular_color_material(0.5, 0.0, k);
        let (wo, wi) = (direction(0.8, 0.2), direction(0.45, 2.5));
        let h = (wo + wi).normalize();
        let vh = wo.dot(h);
        let f0 = (Vec3::splat(0.04) * Vec3::from(m.specular_color)).min(Vec3::ONE) * m.specular;
        let f = f0 + (Vec3::splat(m.specular) - f0) * (1.0 - vh).powi(5);
        let alpha = 0.25;
        let expected = (1.0 - f.max_element()) * Vec3::splat(0.7) / PI
            + f * ggx_d(h, Vec2::splat(alpha)) * ggx_visibility(wo, wi, Vec2::splat(alpha));
        let got = bsdf_eval(&m, NG, wo, wi, TransportMode::Radiance);
        assert!(
            (got - expected).abs().max_element() <= 1e-5 * expected.max_element(),
            "case {k}: {got} vs {expected}"
        );
    }
}

#[test]
fn specular_color_sampling_matches_its_pdf_and_eval() {
    let mut cases = Vec::new();
    for r in [0.3, 0.7] {
        for transmission in [0.0, 1.0] {
            for k in 0..3 {
                for cos in [0.9, 0.3] {
                    for side in [1.0, -1.0] {
                        if side < 0.0 && transmission == 0.0 {
                            continue;
                        }
                        let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                        cases.push((specular_color_material(r, transmission, k), wo));
                    }
                }
            }
        }
    }
    let alpha = sidak(0.01, cases.len());
    for (m, wo) in cases {
        let p = chi_square_bsdf(&m, wo, false);
        assert!(p > alpha, "{m:?} from {wo}: χ² p = {p} < {alpha}");
        for i in 0..2000 {
            let Some(s) = bsdf_sample(&m, NG, wo, u3(2, i), TransportMode::Radiance) else {
                continue;
            };
            let pdf = bsdf_pdf(&m, NG, wo, s.wi);
            assert!((s.pdf - pdf).abs() <= 1e-3 * pdf, "{} vs {pdf}", s.pdf);
            let f = bsdf_eval(&m, NG, wo, s.wi, TransportMode::Radiance);
            let expected = f * s.wi.z.abs() / pdf;
            assert!(
                (s.weight - expected).abs().max_element()
                    <= 1e-3 * expected.max_element().max(1e-3)
            );
        }
    }
}

#[test]
fn specular_color_is_reciprocal_and_conserves_energy_without_the_diffuse() {
    let dirs = [
        direction(0.9, 0.1),
        direction(0.4, 2.0),
        direction(0.15, 4.0),
    ];
    for k in 0..3 {
        let m = specular_color_material(0.4, 0.0, k);
        for a in dirs {
            for b in dirs {
                let fab = bsdf_eval(&m, NG, a, b, TransportMode::Radiance);
                let fba = bsdf_eval(&m, NG, b, a, TransportMode::Importance);
                assert!((fab - fba).abs().max_element() <= 1e-4 * fab.max_element().max(1e-3));
            }
        }
    }
    // A black base leaves the specular lobe alone: F ≤ 1 per channel, so no gain.
    let mut checks = Vec::new();
    for r in [0.0, 0.2, 0.6, 1.0] {
        for cos in [1.0, 0.5, 0.1] {
            for k in 0..3 {
                let m = GpuMaterial {
                    base_color: [0.0; 3],
                    ..specular_color_material(r, 0.0, k)
                };
                checks.push((m, direction(cos, 0.3)));
            }
        }
    }
    assert_albedo_at_most_one(&checks);
}

#[test]
fn unlit_scatters_nothing() {
    let m = GpuMaterial {
        flags: crate::layout::MATERIAL_UNLIT,
        ..material(0.8, 0.0, 0.5, 0.5)
    };
    for i in 0..1000 {
        let wo = direction(0.1 + 0.0009 * i as f32, 0.3) * if i % 2 == 0 { 1.0 } else { -1.0 };
        let wi = direction(0.7, 1.0 + i as f32);
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            assert_eq!(bsdf_eval(&m, NG, wo, wi, mode), Vec3::ZERO);
            assert_eq!(bsdf_eval(&m, NG, wo, -wi, mode), Vec3::ZERO);
            assert!(bsdf_sample(&m, NG, wo, u3(4, i), mode).is_none());
        }
        assert_eq!(bsdf_pdf(&m, NG, wo, wi), 0.0);
        assert_eq!(bsdf_albedo_estimate(&m, NG, wo), 0.0);
    }
}

/// A coated material: `base` (metallic, transmission) under a coat of weight `cc` and roughness
/// `cc_r`, the coat's normal tilted away from the surface's when `tilt`.
fn coated(metallic: f32, transmission: f32, cc: f32, cc_r: f32, tilt: bool) -> GpuMaterial {
    GpuMaterial {
        clearcoat: cc,
        clearcoat_roughness: cc_r,
        clearcoat_normal: if tilt {
            Vec3::new(0.3, -0.2, 1.0).normalize().to_array()
        } else {
            [0.0; 3]
        },
        ..material(0.7, metallic, 0.5, transmission)
    }
}

#[test]
fn clearcoat_follows_fresnel_coat() {
    // coated = (1 − clearcoat·F_c(|V·N_c|))·material + clearcoat·F_c·D·G/(4|V·N_c||L·N_c|)
    // (KHR_materials_clearcoat, "Layering"), written out here independently.
    for (metallic, transmission) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
        let m = coated(metallic, transmission, 0.8, 0.4, false);
        let base = GpuMaterial {
            clearcoat: 0.0,
            ..m
        };
        let (wo, wi) = (direction(0.8, 0.2), direction(0.45, 2.5));
        let fc = 0.04 + 0.96 * (1.0 - wo.z).powi(5);
        let h = (wo + wi).normalize();
        let a = Vec2::splat(0.16);
        let coat = ggx_d(h, a) * ggx_visibility(wo, wi, a);
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            let v = if mode == TransportMode::Radiance {
                wo.z
            } else {
                wi.z
            };
            let fc = 0.04 + 0.96 * (1.0 - v).powi(5);
            let expected = (1.0 - 0.8 * fc) * bsdf_eval(&base, NG, wo, wi, mode)
                + Vec3::splat(0.8 * fc * coat);
            let got = bsdf_eval(&m, NG, wo, wi, mode);
            assert!(
                (got - expected).abs().max_element() <= 1e-5 * expected.max_element(),
                "{mode:?}: {got} vs {expected}"
            );
        }
        // Below the surface only the base's transmission, scaled by 1 − clearcoat·F_c(wo).
        let below = wi * Vec3::new(1.0, 1.0, -1.0);
        let expected = (1.0 - 0.8 * fc) * bsdf_eval(&base, NG, wo, below, TransportMode::Radiance);
        let got = bsdf_eval(&m, NG, wo, below, TransportMode::Radiance);
        assert!((got - expected).abs().max_element() <= 1e-5 * expected.max_element().max(1e-6));
    }
}

fn coated_cases() -> Vec<(GpuMaterial, Vec3, String)> {
    let mut cases = Vec::new();
    for (metallic, transmission) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
        for (cc, cc_r) in [(1.0, 0.2), (0.5, 0.6)] {
            for tilt in [false, true] {
                for cos in [0.9, 0.3] {
                    let mut sides = vec![1.0];
                    if transmission > 0.0 {
                        sides.push(-1.0);
                    }
                    for side in sides {
                        let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                        let name = format!(
                            "metallic {metallic}, transmission {transmission}, clearcoat {cc} \
                             roughness {cc_r}, tilted {tilt}, wo {wo}"
                        );
                        cases.push((coated(metallic, transmission, cc, cc_r, tilt), wo, name));
                    }
                }
            }
        }
    }
    cases
}

#[test]
fn clearcoat_sampling_matches_its_pdf_and_eval() {
    assert_sampling_matches_pdf_and_eval(&coated_cases(), "clearcoat", false);
}

#[test]
fn clearcoat_importance_is_the_transposed_radiance_bsdf() {
    // With a tilted coat normal, directions stay where `bend_shading_normal` leaves it alone
    // (a bent normal depends on wo, which no transpose can follow).
    for (m, _, name) in coated_cases() {
        let dirs = if m.clearcoat_normal == [0.0; 3] {
            [
                direction(0.9, 0.1),
                direction(0.4, 2.0),
                direction(0.15, 4.0),
            ]
        } else {
            [
                direction(0.95, 0.1),
                direction(0.8, 2.0),
                direction(0.7, 4.0),
            ]
        };
        for a in dirs {
            for b in dirs {
                let fab = bsdf_eval(&m, NG, a, b, TransportMode::Radiance);
                let fba = bsdf_eval(&m, NG, b, a, TransportMode::Importance);
                assert!(
                    (fab - fba).abs().max_element() <= 1e-4 * fab.max_element().max(1e-3),
                    "{name}: {fab} vs {fba}"
                );
            }
        }
    }
}

#[test]
fn clearcoat_conserves_energy_over_conserving_bases() {
    // The coat's layering mixes the base and a GGX lobe (albedo ≤ 1) with weights summing to 1,
    // so over a metal or a glass (each ≤ 1, `no_parameter_set_creates_energy`) it creates none.
    let mut checks = Vec::new();
    for (metallic, transmission) in [(1.0, 0.0), (0.0, 1.0)] {
        for (cc, cc_r) in [(1.0, 0.0), (1.0, 0.3), (0.6, 1.0)] {
            for r in [0.0, 0.3, 1.0] {
                for cos in [1.0, 0.5, 0.1] {
                    let m = GpuMaterial {
                        clearcoat: cc,
                        clearcoat_roughness: cc_r,
                        ..material(1.0, metallic, r, transmission)
                    };
                    checks.push((m, direction(cos, 0.3)));
                }
            }
        }
    }
    let worst = assert_albedo_at_most_one(&checks);
    println!("highest coated albedo: {worst:.4}");
    // White furnace: a smooth coat over a smooth white mirror reflects everything, exactly.
    let mirror = GpuMaterial {
        clearcoat: 1.0,
        clearcoat_roughness: 0.0,
        ..material(1.0, 1.0, 0.0, 0.0)
    };
    for cos in [1.0, 0.5, 0.05] {
        let (a, se) = albedo(&mirror, direction(cos, 0.3), 10_000);
        assert!((a - 1.0).abs() < 1e-5 && se < 1e-6, "cos {cos}: {a} ± {se}");
    }
    // A smooth coat over black reflects clearcoat·F_c(cos θo) and nothing else.
    let black = GpuMaterial {
        clearcoat: 0.7,
        clearcoat_roughness: 0.0,
        specular: 0.0,
        ..material(0.0, 0.0, 0.5, 0.0)
    };
    for cos in [1.0, 0.5, 0.05] {
        let (a, _) = albedo(&black, direction(cos, 0.3), 10_000);
        let expected = 0.7 * fresnel_coat(cos) as f64;
        assert!((a - expected).abs() < 1e-5, "cos {cos}: {a} vs {expected}");
    }
}

/// A sheen over `base` (metallic, transmission), colour `c` and sheen roughness `r`.
fn sheened(metallic: f32, transmission: f32, c: [f32; 3], r: f32) -> GpuMaterial {
    GpuMaterial {
        sheen_color: c,
        sheen_roughness: r,
        ..material(0.7, metallic, 0.5, transmission)
    }
}

#[test]
fn sheen_follows_the_albedo_scaling_formula() {
    // sheenColor·D_s·ν_s + material·min(1 − max(c)·E(V·N), 1 − max(c)·E(L·N))
    // (KHR_materials_sheen, "Albedo-scaling technique"), written out here.
    use super::sheen::*;
    for (metallic, transmission) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
        let c = [0.9, 0.4, 0.2];
        let m = sheened(metallic, transmission, c, 0.5);
        let base = GpuMaterial {
            sheen_color: [0.0; 3],
            ..m
        };
        let (wo, wi) = (direction(0.8, 0.2), direction(0.3, 2.5));
        let a = 0.25;
        let h = (wo + wi).normalize();
        let lobe = charlie_d(h.z, a) * sheen_visibility(wo.z, wi.z, a);
        let scale = (1.0 - 0.9 * sheen_albedo(wo.z, 0.5)).min(1.0 - 0.9 * sheen_albedo(wi.z, 0.5));
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            let expected = Vec3::from(c) * lobe + scale * bsdf_eval(&base, NG, wo, wi, mode);
            let got = bsdf_eval(&m, NG, wo, wi, mode);
            assert!(
                (got - expected).abs().max_element() <= 1e-5 * expected.max_element(),
                "{mode:?}: {got} vs {expected}"
            );
            let back = bsdf_eval(&m, NG, wi, wo, mode);
            assert!(
                (back - got).abs().max_element() <= 1e-4 * got.max_element(),
                "reciprocity"
            );
        }
    }
}

fn sheen_cases() -> Vec<(GpuMaterial, Vec3, String)> {
    let mut cases = Vec::new();
    for (metallic, transmission) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0)] {
        for (c, r) in [
            ([1.0, 1.0, 1.0], 1.0),
            ([0.8, 0.3, 0.5], 0.3),
            ([0.5, 0.5, 0.5], 0.07),
        ] {
            for cos in [0.9, 0.3] {
                let mut sides = vec![1.0];
                if transmission > 0.0 {
                    sides.push(-1.0);
                }
                for side in sides {
                    let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                    let name = format!(
                        "metallic {metallic}, transmission {transmission}, sheen {c:?} \
                         roughness {r}, wo {wo}"
                    );
                    cases.push((sheened(metallic, transmission, c, r), wo, name));
                }
            }
        }
    }
    cases
}

#[test]
fn sheen_sampling_matches_its_pdf_and_eval() {
    assert_sampling_matches_pdf_and_eval(&sheen_cases(), "sheen", false);
}

#[test]
fn sheen_albedo_is_the_tabulated_one_and_the_scaling_conserves_energy() {
    use super::sheen::*;
    // Over a black base the lobe alone: its Monte Carlo albedo is c·E(cos θo) as tabulated.
    let mut checks = Vec::new();
    for r in [0.07, 0.3, 0.6, 1.0] {
        for cos in [0.95, 0.6, 0.3] {
            checks.push((r, cos));
        }
    }
    let z = crate::stats::normal_quantile_upper(sidak(0.01, 2 * checks.len()));
    for &(r, cos) in &checks {
        let m = GpuMaterial {
            specular: 0.0,
            ..sheened(0.0, 0.0, [1.0; 3], r)
        };
        let m = GpuMaterial {
            base_color: [0.0; 3],
            ..m
        };
        let (a, se) = albedo(&m, direction(cos, 0.4), 200_000);
        let e = sheen_albedo_quadrature(cos as f64, r as f64);
        // The table's bilinear error between nodes is part of the tolerance.
        let table = sheen_albedo(cos, r) as f64;
        assert!(
            (a - e).abs() <= z * se + 1e-4,
            "roughness {r}, cos {cos}: Monte Carlo {a} ± {se} vs E {e} (table {table})"
        );
    }
    // Over a white Lambertian base (specular 0, albedo 1) the scaled sum reflects at most what
    // it receives, up to the table's interpolation error, where E ≤ 1.
    let mut worst: f64 = 0.0;
    for &(r, cos) in &checks {
        let m = GpuMaterial {
            specular: 0.0,
            base_color: [1.0; 3],
            ..sheened(0.0, 0.0, [1.0; 3], r)
        };
        let (a, se) = albedo(&m, direction(cos, 0.4), 200_000);
        let gap =
            (sheen_albedo_quadrature(cos as f64, r as f64) - sheen_albedo(cos, r) as f64).abs();
        worst = worst.max(a);
        assert!(
            a <= 1.0 + z * se + gap + 1e-4,
            "roughness {r}, cos {cos}: albedo {a} ± {se}"
        );
    }
    println!("sheen over white: highest albedo {worst:.4}");
    // The spec's model gains energy at grazing views of a smooth sheen (documented in `sheen`).
    assert!(sheen_albedo_quadrature(1.0 / 31.0, 0.07) > 1.0);
}

/// KHR_materials_anisotropy cases: a material whose anisotropy direction lies at 0.4 rad from
/// +X in the surface's plane.
fn anisotropic(metallic: f32, transmission: f32, roughness: f32, strength: f32) -> GpuMaterial {
    GpuMaterial {
        anisotropy: strength,
        anisotropy_direction: [0.4f32.cos(), 0.4f32.sin(), 0.0],
        ..material(0.8, metallic, roughness, transmission)
    }
}

#[test]
fn anisotropy_follows_the_extension_formula() {
    // KHR_materials_anisotropy, "Implementation", written out independently in world terms:
    // α_t = mix(α, 1, s²), α_b = α; D = a2·(a2/|(α_b T·H, α_t B·H, a2 N·H)|²)²/π with a2 = α_t α_b;
    // V = 0.5 / (N·L |(α_t T·V, α_b B·V, N·V)| + N·V |(α_t T·L, α_b B·L, N·L)|).
    let (t, b) = (Vec3::new(0.4f32.cos(), 0.4f32.sin(), 0.0), Vec3::ZERO);
    let b = if b == Vec3::ZERO { NG.cross(t) } else { b };
    for (roughness, strength) in [(0.3, 0.6), (0.5, 1.0), (0.1, 0.3)] {
        let m = anisotropic(1.0, 0.0, roughness, strength);
        let alpha = roughness * roughness;
        let at = alpha + (1.0 - alpha) * strength * strength;
        let ab = alpha;
        for (wo, wi) in [
            (direction(0.8, 0.2), direction(0.45, 2.5)),
            (direction(0.3, 1.0), direction(0.9, 4.0)),
            (direction(0.6, 0.4), direction(0.6, 3.5)),
        ] {
            let h = (wo + wi).normalize();
            let a2 = at * ab;
            let fv = Vec3::new(ab * t.dot(h), at * b.dot(h), a2 * NG.dot(h));
            let w2 = a2 / fv.dot(fv);
            let d = a2 * w2 * w2 / PI;
            let gv = NG.dot(wi) * Vec3::new(at * t.dot(wo), ab * b.dot(wo), NG.dot(wo)).length();
            let gl = NG.dot(wo) * Vec3::new(at * t.dot(wi), ab * b.dot(wi), NG.dot(wi)).length();
            let v = 0.5 / (gv + gl);
            let f = Vec3::splat(0.8) + Vec3::splat(0.2) * (1.0 - wo.dot(h)).powi(5);
            let expected = f * d * v;
            let got = bsdf_eval(&m, NG, wo, wi, TransportMode::Radiance);
            assert!(
                (got - expected).abs().max_element() <= 1e-4 * expected.max_element(),
                "roughness {roughness}, strength {strength}: {got} vs {expected}"
            );
        }
    }
    // Strength 0 is the isotropic model exactly, whatever the direction.
    let iso = material(0.8, 0.3, 0.4, 0.0);
    let aniso = GpuMaterial {
        anisotropy_direction: [0.0, 1.0, 0.0],
        ..iso
    };
    let (wo, wi) = (direction(0.7, 0.3), direction(0.4, 2.0));
    assert_eq!(
        bsdf_eval(&iso, NG, wo, wi, TransportMode::Radiance),
        bsdf_eval(&aniso, NG, wo, wi, TransportMode::Radiance)
    );
    // Rotating the direction by 90° swaps the two axes: the same lobe turned a quarter.
    let m = anisotropic(1.0, 0.0, 0.4, 0.8);
    let turned = GpuMaterial {
        anisotropy_direction: [-(0.4f32.sin()), 0.4f32.cos(), 0.0],
        ..m
    };
    let quarter = |v: Vec3| Vec3::new(-v.y, v.x, v.z);
    let (wo, wi) = (direction(0.7, 0.3), direction(0.4, 2.0));
    let a = bsdf_eval(&m, NG, wo, wi, TransportMode::Radiance);
    let c = bsdf_eval(
        &turned,
        NG,
        quarter(wo),
        quarter(wi),
        TransportMode::Radiance,
    );
    assert!(
        (a - c).abs().max_element() <= 1e-4 * a.max_element(),
        "{a} vs {c}"
    );
}

fn anisotropic_cases() -> Vec<(GpuMaterial, Vec3, String)> {
    let mut cases = Vec::new();
    for (metallic, transmission) in [(1.0, 0.0), (0.0, 0.0), (0.0, 1.0)] {
        for (roughness, strength) in [(0.3, 0.7), (0.6, 0.4), (0.2, 1.0)] {
            for (cos, phi) in [(0.9, 0.7), (0.4, 2.1), (0.15, 0.4)] {
                let mut sides = vec![1.0];
                if transmission > 0.0 {
                    sides.push(-1.0);
                }
                for side in sides {
                    let wo = direction(cos, phi) * Vec3::new(1.0, 1.0, side);
                    let name = format!(
                        "anisotropy {strength}, roughness {roughness}, metallic {metallic}, \
                         transmission {transmission}, wo {wo}"
                    );
                    cases.push((
                        anisotropic(metallic, transmission, roughness, strength),
                        wo,
                        name,
                    ));
                }
            }
        }
    }
    cases
}

#[test]
fn anisotropic_sampling_matches_its_pdf_and_eval() {
    assert_sampling_matches_pdf_and_eval(&anisotropic_cases(), "anisotropy", false);
}

#[test]
fn anisotropy_is_reciprocal_and_conserves_energy() {
    assert_reciprocal_and_transposed(&anisotropic_cases());
    // A white anisotropic metal and a clear anisotropic dielectric (seen from outside, where
    // 1/η² keeps transmission below 1) reflect at most what they receive.
    let mut checks = Vec::new();
    for (roughness, strength) in [(0.0, 1.0), (0.1, 0.5), (0.3, 1.0), (0.7, 0.6), (1.0, 1.0)] {
        for cos in [1.0, 0.5, 0.1] {
            for phi in [0.4, 1.97] {
                for (metallic, transmission) in [(1.0, 0.0), (0.0, 1.0)] {
                    let m = GpuMaterial {
                        base_color: [1.0; 3],
                        ..anisotropic(metallic, transmission, roughness, strength)
                    };
                    checks.push((m, direction(cos, phi)));
                }
            }
        }
    }
    let largest = assert_albedo_at_most_one(&checks);
    println!("anisotropic albedo: largest {largest:.4}");
}

/// KHR_materials_iridescence cases: a film of index 1.6 and thickness `d` nm.
fn iridescent(
    metallic: f32,
    transmission: f32,
    roughness: f32,
    factor: f32,
    d: f32,
) -> GpuMaterial {
    GpuMaterial {
        iridescence: factor,
        iridescence_ior: 1.6,
        iridescence_thickness: d,
        ..material(0.8, metallic, roughness, transmission)
    }
}

#[test]
fn thin_film_fresnel_has_its_limits() {
    use super::iridescence::*;
    // No path difference: the fitted matching functions integrate to X = Y = Z = 1 (the
    // fit's normalisation; equal-energy white), whose linear Rec. 709 value is the matrix's
    // row sums (1.2048, 0.9483, 0.9088) — the extension's code does not white-balance.
    let white = eval_sensitivity(0.0, Vec3::ZERO);
    let e = Vec3::new(
        3.2404542 - 1.5371385 - 0.4985314,
        -0.969266 + 1.8760108 + 0.041556,
        0.0556434 - 0.2040259 + 1.0572252,
    );
    assert!(
        (white - e).abs().max_element() < 5e-3,
        "sensitivity at zero path difference: {white} vs {e}"
    );
    // A film of no thickness at normal incidence is no film: the base's Fresnel F0, up to the
    // clamp R123 ≥ 10⁻⁵ of the extension's code (an error below 10⁻²). (At oblique angles the
    // extension's Schlick interfaces keep a vanishing film's (1 − cos)⁵ reflection: not a
    // limit the code has.)
    for f0 in [0.04, 0.2, 0.7] {
        {
            let got = fresnel_iridescence(1.0, 1.6, 1.0, 0.0, Vec3::splat(f0));
            let (schlick, cos) = (f0, 1.0);
            assert!(
                (got - Vec3::splat(schlick)).abs().max_element() < 1e-2,
                "F0 {f0}, cos {cos}: {got} vs {schlick}"
            );
        }
    }
    // A film colours the reflection: thickness changes the hue, and within [0, 1].
    let a = fresnel_iridescence(1.0, 1.6, 0.9, 250.0, Vec3::splat(0.04));
    let b = fresnel_iridescence(1.0, 1.6, 0.9, 450.0, Vec3::splat(0.04));
    assert!(
        (a - b).abs().max_element() > 0.1 * a.max_element(),
        "{a} vs {b}"
    );
    for d in [0.0, 100.0, 300.0, 600.0, 1200.0] {
        for cos in [1.0, 0.5, 0.05] {
            for f0 in [0.0, 0.04, 0.5, 0.95] {
                let f = fresnel_iridescence(1.0, 1.6, cos, d, Vec3::splat(f0));
                assert!(
                    f.is_finite() && f.min_element() >= 0.0,
                    "{d} {cos} {f0}: {f}"
                );
            }
        }
    }
}

/// The film's cos (reduced by whole turns, then a polynomial the GPU twin evaluates alike)
/// is cos: within 1e-6 of the f64 cos of the same f32 argument over the phases a film produces
/// (|x| ≤ 200 rad: an optical path difference of 2 × 2.2 × 5 µm at the matching functions'
/// highest frequency). The bound: the reduced argument's roundings (≤ 1.2e-7 at |r| ≤ π, the
/// 2π rest's f32 error 1.6e-10 per turn), the series' truncation (4e-9) and its rounding
/// (terms up to 4.9 at |r| = π, each rounded to 3e-7 or less).
#[test]
fn film_cos_is_cos() {
    use super::iridescence::film_cos;
    let mut worst = (0.0f64, 0.0f32);
    for i in 0..=400_000 {
        let x = -200.0 + i as f32 * 1e-3;
        for x in [x, f32::from_bits(x.to_bits() + 1)] {
            let e = (film_cos(x) as f64 - (x as f64).cos()).abs();
            if e > worst.0 {
                worst = (e, x);
            }
        }
    }
    let bound = 1e-6;
    assert!(
        worst.0 < bound,
        "film_cos({}) is off by {:e}",
        worst.1,
        worst.0
    );
    assert_eq!(film_cos(0.0), 1.0);
}

#[test]
fn iridescence_mixes_the_fresnel_as_the_extension_writes() {
    use super::iridescence::fresnel_iridescence;
    // F = mix(F_base(v·h), F_film(v·h), factor) for the dielectric (film over F0 = 0.04) and the
    // metal (film over F0 = baseColor), the diffuse scaled by 1 − max(F).
    let (wo, wi) = (direction(0.8, 0.2), direction(0.45, 2.5));
    let h = (wo + wi).normalize();
    let vh = wo.dot(h);
    let alpha = Vec2::splat(0.25);
    let spec = ggx_d(h, alpha) * ggx_visibility(wo, wi, alpha);
    for factor in [0.0, 0.4, 1.0] {
        for metallic in [0.0, 1.0] {
            let m = iridescent(metallic, 0.0, 0.5, factor, 380.0);
            let got = bsdf_eval(&m, NG, wo, wi, TransportMode::Radiance);
            let base_f0 = if metallic > 0.0 {
                Vec3::splat(0.8)
            } else {
                Vec3::splat(0.04)
            };
            let f_base = if metallic > 0.0 {
                fresnel_conductor(Vec3::splat(0.8), vh)
            } else {
                Vec3::splat(fresnel_dielectric(vh, 0.04, 1.0, 1.5))
            };
            let film = fresnel_iridescence(1.0, 1.6, vh, 380.0, base_f0).min(Vec3::ONE);
            let f = f_base + (film - f_base) * factor;
            let expected = if metallic > 0.0 {
                f * spec
            } else {
                (1.0 - f.max_element()) * Vec3::splat(0.8) / PI + f * spec
            };
            assert!(
                (got - expected).abs().max_element() <= 1e-5 * expected.max_element(),
                "factor {factor}, metallic {metallic}: {got} vs {expected}"
            );
        }
    }
}

fn iridescent_cases() -> Vec<(GpuMaterial, Vec3, String)> {
    let mut cases = Vec::new();
    for (metallic, transmission) in [(1.0, 0.0), (0.0, 0.0), (0.0, 1.0), (0.5, 0.5)] {
        for (roughness, d) in [(0.3, 300.0), (0.7, 550.0)] {
            for cos in [0.9, 0.35] {
                let mut sides = vec![1.0];
                if transmission > 0.0 {
                    sides.push(-1.0);
                }
                for side in sides {
                    let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                    let name = format!(
                        "iridescence d {d}, roughness {roughness}, metallic {metallic}, \
                         transmission {transmission}, wo {wo}"
                    );
                    cases.push((
                        iridescent(metallic, transmission, roughness, 1.0, d),
                        wo,
                        name,
                    ));
                }
            }
        }
    }
    cases
}

#[test]
fn iridescent_sampling_matches_its_pdf_and_eval() {
    assert_sampling_matches_pdf_and_eval(&iridescent_cases(), "iridescence", false);
}

#[test]
fn iridescence_is_reciprocal_and_conserves_energy() {
    assert_reciprocal_and_transposed(&iridescent_cases());
    // Filmed white metal and clear glass (from outside) reflect at most what they receive,
    // smooth (delta lobes: F + (1 − F) per channel) and rough.
    let mut checks = Vec::new();
    for roughness in [0.0, 0.2, 0.6] {
        for d in [150.0, 400.0, 800.0] {
            for cos in [1.0, 0.5, 0.1] {
                for (metallic, transmission) in [(1.0, 0.0), (0.0, 1.0)] {
                    let m = GpuMaterial {
                        base_color: [1.0; 3],
                        ..iridescent(metallic, transmission, roughness, 1.0, d)
                    };
                    checks.push((m, direction(cos, 0.3)));
                }
            }
        }
    }
    let largest = assert_albedo_at_most_one(&checks);
    println!("iridescent albedo: largest {largest:.4}");
}

/// KHR_materials_diffuse_transmission cases.
fn translucent(base: f32, metallic: f32, roughness: f32, dt: f32, color: [f32; 3]) -> GpuMaterial {
    GpuMaterial {
        diffuse_transmission: dt,
        diffuse_transmission_color: color,
        ..material(base, metallic, roughness, 0.0)
    }
}

#[test]
fn diffuse_transmission_follows_the_extension_formula() {
    // mix(c/π on wo's side, dtColor/π on the far side, dt) under 1 − max(F) of the specular
    // layer (F on v·h; for the far side h of wo and wi mirrored), written out independently.
    let m = translucent(0.6, 0.2, 0.5, 0.7, [0.5, 0.9, 0.2]);
    let wo = direction(0.8, 0.2);
    let f_at = |vh: f32| 0.04 + 0.96 * (1.0 - vh).powi(5);
    // Far side.
    let wi = direction(0.45, 2.5) * Vec3::new(1.0, 1.0, -1.0);
    let h = (wo + wi * Vec3::new(1.0, 1.0, -1.0)).normalize();
    let expected = 0.8 * 0.7 * (1.0 - f_at(wo.dot(h))) * Vec3::new(0.5, 0.9, 0.2) / PI;
    let got = bsdf_eval(&m, NG, wo, wi, TransportMode::Radiance);
    assert!(
        (got - expected).abs().max_element() <= 1e-5 * expected.max_element(),
        "{got} vs {expected}"
    );
    // Near side: the diffuse part is (1 − dt) of the Lambertian one.
    let wi = direction(0.45, 2.5);
    let without = GpuMaterial {
        diffuse_transmission: 0.0,
        ..m
    };
    let h = (wo + wi).normalize();
    let diffuse = 0.8 * (1.0 - f_at(wo.dot(h))) * 0.6 / PI;
    let a = bsdf_eval(&m, NG, wo, wi, TransportMode::Radiance);
    let b = bsdf_eval(&without, NG, wo, wi, TransportMode::Radiance);
    assert!(
        ((b - a) - Vec3::splat(0.7 * diffuse)).abs().max_element() < 1e-5,
        "{a} {b}"
    );
}

fn translucent_cases() -> Vec<(GpuMaterial, Vec3, String)> {
    let mut cases = Vec::new();
    for (metallic, roughness, dt) in [(0.0, 0.5, 0.5), (0.0, 0.0, 1.0), (0.3, 0.8, 0.7)] {
        for cos in [0.9, 0.3] {
            for side in [1.0, -1.0] {
                let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                let name = format!("dt {dt}, metallic {metallic}, roughness {roughness}, wo {wo}");
                cases.push((
                    translucent(0.7, metallic, roughness, dt, [0.4, 0.9, 0.6]),
                    wo,
                    name,
                ));
            }
        }
    }
    cases
}

#[test]
fn diffuse_transmission_sampling_matches_its_pdf_and_eval() {
    assert_sampling_matches_pdf_and_eval(&translucent_cases(), "diffuse transmission", true);
}

#[test]
fn diffuse_transmission_is_reciprocal_and_a_white_leaf_keeps_all_the_light() {
    let dirs = RECIPROCITY_DIRECTIONS.map(|(cos, phi)| direction(cos, phi));
    for (m, _, name) in translucent_cases() {
        for a in dirs {
            for b in dirs {
                let below = b * Vec3::new(1.0, 1.0, -1.0);
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let fab = bsdf_eval(&m, NG, a, below, mode);
                    let fba = bsdf_eval(&m, NG, below, a, mode);
                    assert!(
                        (fab - fba).abs().max_element() <= 1e-4 * fab.max_element().max(1e-3),
                        "{name}: {fab} vs {fba}"
                    );
                }
            }
        }
    }
    // White furnace: a white Lambertian leaf without the specular layer (specular 0) splits
    // every bit of light between its sides: each sample weighs exactly 1.
    for dt in [0.0, 0.3, 1.0] {
        let m = GpuMaterial {
            specular: 0.0,
            ..translucent(1.0, 0.0, 1.0, dt, [1.0; 3])
        };
        for cos in [1.0, 0.5, 0.05] {
            let wo = direction(cos, 0.3);
            let (a, se) = albedo(&m, wo, 20_000);
            assert!(
                (a - 1.0).abs() < 1e-5 && se < 1e-5,
                "dt {dt}, cos {cos}: {a} ± {se}"
            );
        }
    }
}

/// A plain diffuse frame's shorter path through eval, pdf and sample gives the general path's
/// floats bit for bit (the frame with `plain` cleared takes the general path), over random plain
/// materials (colour, black too, roughness, anisotropy, ior, specular colour, unlit), shading
/// normals, sides and directions; every frame of a material `material_is_plain` accepts is
/// plain, and a material with any other lobe is neither.
/// Random plain case `i`: a material `material_is_plain` accepts (colour, black too, roughness,
/// anisotropy, ior, specular colour, unlit), and the surface's ng, ns (half the cases a shading
/// normal of its own, tilted from ng) and wo.
fn plain_case(i: u32) -> (GpuMaterial, Vec3, Vec3, Vec3) {
    let r = rng_uniform4(91, i, 0, 0);
    let q = rng_uniform4(91, i, 1, 0);
    let base = Vec3::new(r.x, r.y, r.z) * [1.0, 1e-3, 0.0][(i % 7).min(2) as usize];
    let m = GpuMaterial {
        base_color: base.into(),
        metallic: 0.0,
        roughness: r.w,
        ior: 0.8 + q.x,
        specular: 0.0,
        specular_color: [q.y * 2.0, 1.0, q.z],
        anisotropy: if i % 3 == 0 { q.w } else { 0.0 },
        anisotropy_direction: [0.48, 0.6, -0.64],
        sheen_roughness: q.x,
        clearcoat_roughness: q.y,
        flags: if i % 11 == 5 { MATERIAL_UNLIT } else { 0 },
        ..Default::default()
    };
    assert!(material_is_plain(&m));
    let ng = unit(rng_uniform4(91, i, 2, 0));
    let ns = if i % 2 == 0 {
        ng
    } else {
        (ng + 0.6 * unit(rng_uniform4(91, i, 3, 0))).normalize()
    };
    (m, ng, ns, unit(rng_uniform4(91, i, 4, 0)))
}

#[test]
fn plain_diffuse_frames_equal_the_general_path() {
    let mut plain_frames = 0;
    for i in 0..4000u32 {
        let (m, ng, ns, wo) = plain_case(i);
        let Some(frame) = BsdfFrame::new_shading(&m, ng, ns, wo) else {
            continue;
        };
        assert!(frame.plain, "case {i}: {m:?}");
        plain_frames += 1;
        let general = BsdfFrame {
            plain: false,
            ..frame
        };
        assert_same_frames(&frame, &general, i, 97, 8);
    }
    assert!(plain_frames > 3900, "{plain_frames}");
    // Any other lobe, or no light scattered at all, takes the general path.
    let plain = GpuMaterial {
        base_color: [0.5; 3],
        metallic: 0.0,
        specular: 0.0,
        ..Default::default()
    };
    let others = [
        GpuMaterial {
            metallic: 0.01,
            ..plain
        },
        GpuMaterial {
            specular: 0.01,
            ..plain
        },
        GpuMaterial {
            transmission: 0.5,
            ..plain
        },
        GpuMaterial {
            diffuse_transmission: 0.5,
            ..plain
        },
        GpuMaterial {
            sheen_color: [0.0, 0.1, 0.0],
            ..plain
        },
        GpuMaterial {
            clearcoat: 0.1,
            ..plain
        },
        GpuMaterial {
            iridescence: 0.5,
            ..plain
        },
    ];
    let frame = |m: &GpuMaterial| BsdfFrame::new(m, NG, direction(0.6, 0.3)).unwrap();
    assert!(frame(&plain).plain && material_is_plain(&plain));
    for (k, m) in others.iter().enumerate() {
        assert!(
            !frame(m).plain && !material_is_plain(m),
            "material {k}: {m:?}"
        );
    }
}

/// A LambertFrame is the BsdfFrame of its material, float for float: the same frames exist
/// (None alike where wo grazes the surface), the same albedo estimate, and eval, pdf, |cos| and
/// sample give the general path's bits (the frame with `plain` cleared), in both transport
/// modes, over the random plain cases of `plain_diffuse_frames_equal_the_general_path` and
/// directions on both sides.
#[test]
fn lambert_frames_equal_the_general_path() {
    let mut frames = 0;
    for i in 0..4000u32 {
        let (m, ng, ns, wo) = plain_case(i);
        // Every eighth case grazes: wo in the surface's plane.
        let wo = if i % 8 == 3 {
            (wo - ng * ng.dot(wo)).normalize()
        } else {
            wo
        };
        let Some((lambert, general)) = both_frames(
            LambertFrame::new(&m, ng, ns, wo),
            BsdfFrame::new_shading(&m, ng, ns, wo),
            i,
        ) else {
            continue;
        };
        let general = BsdfFrame {
            plain: false,
            ..general
        };
        frames += 1;
        assert_same_frames(&lambert, &general, i, 93, 8);
    }
    assert!(frames > 3400, "{frames}");
}

/// Both frames of case `i`, where the two constructors agree that there is one (else the
/// case fails): none at a vertex either refuses.
fn both_frames<A, B>(a: Option<A>, b: Option<B>, i: u32) -> Option<(A, B)> {
    assert_eq!(a.is_some(), b.is_some(), "case {i}");
    a.zip(b)
}

/// Two frames of case `i` give the same albedo estimate and, at `directions` directions and
/// samples drawn from `seed` and `seed + 1 + k`, the same eval (both transport modes), sample,
/// pdf and cosine, bit for bit.
fn assert_same_frames(
    a: &impl VertexBsdf,
    b: &impl VertexBsdf,
    i: u32,
    seed: u32,
    directions: u32,
) {
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    let sampled =
        |s: Option<BsdfSample>| s.map(|s| (bits(s.wi), bits(s.weight), s.pdf.to_bits(), s.delta));
    assert_eq!(
        a.albedo_estimate().to_bits(),
        b.albedo_estimate().to_bits(),
        "case {i}"
    );
    for k in 0..directions {
        let wi = unit(rng_uniform4(seed, i, k, 0));
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            assert_eq!(
                bits(a.eval(wi, mode)),
                bits(b.eval(wi, mode)),
                "case {i}, eval at {wi}"
            );
            let u = u3(seed + 1 + k, i);
            assert_eq!(
                sampled(a.sample(u, mode)),
                sampled(b.sample(u, mode)),
                "case {i}, sample {k}"
            );
        }
        assert_eq!(
            a.pdf(wi).to_bits(),
            b.pdf(wi).to_bits(),
            "case {i}, pdf at {wi}"
        );
        assert_eq!(
            a.cos_theta(wi).to_bits(),
            b.cos_theta(wi).to_bits(),
            "case {i}, cos at {wi}"
        );
    }
}

/// `ShadingFrame` (light tracing, BDPT) is the plain frame exactly where the material is plain,
/// and either way gives the general frame's eval, pdf, sample and cosine bit for bit: plain
/// materials and the same made general by one layer each (metal, specular, film, transmission,
/// diffuse transmission, sheen, coat).
#[test]
fn shading_frames_are_the_general_frames() {
    let mut kinds = [0; 2];
    for i in 0..2000u32 {
        let (mut m, ng, ns, wo) = plain_case(i);
        if i % 2 == 1 {
            m.flags = 0;
            match (i / 2) % 7 {
                0 => m.metallic = 0.5,
                1 => m.specular = 0.5,
                2 => m.iridescence = 0.5,
                3 => m.transmission = 0.5,
                4 => m.diffuse_transmission = 0.5,
                5 => m.sheen_color = [0.5; 3],
                _ => m.clearcoat = 0.5,
            }
        }
        let Some((frame, general)) = both_frames(
            ShadingFrame::new_shading(&m, ng, ns, wo),
            BsdfFrame::new_shading(&m, ng, ns, wo),
            i,
        ) else {
            continue;
        };
        let lambert = matches!(frame, ShadingFrame::Lambert(_));
        assert_eq!(lambert, material_is_plain(&m), "case {i}");
        kinds[lambert as usize] += 1;
        assert_same_frames(&frame, &general, i, 95, 4);
    }
    assert!(kinds[0] > 900 && kinds[1] > 900, "{kinds:?}");
}

/// A unit vector from four uniform numbers (the first three, centred).
fn unit(u: glam::Vec4) -> Vec3 {
    (Vec3::new(u.x, u.y, u.z) - Vec3::splat(0.5)).normalize()
}

/// A thin-walled pane (KHR_materials_transmission without a volume: thicknessFactor 0).
fn thin_pane(base: [f32; 3], roughness: f32, transmission: f32) -> GpuMaterial {
    GpuMaterial {
        base_color: base,
        thickness: 0.0,
        ..material(0.0, 0.0, roughness, transmission)
    }
}

fn thin_cases() -> Vec<(GpuMaterial, Vec3, String)> {
    let mut cases = Vec::new();
    for r in [0.3, 0.7] {
        for transmission in [1.0, 0.5] {
            for cos in [0.95, 0.5, 0.12] {
                // Both sides alike: a thin wall has no inside.
                for side in [1.0, -1.0] {
                    let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                    let name = format!("thin, roughness {r}, transmission {transmission}, wo {wo}");
                    cases.push((thin_pane([0.9, 0.6, 0.3], r, transmission), wo, name));
                }
            }
        }
    }
    // Under a sheen and a coat, and anisotropic.
    for (k, wo) in [
        direction(0.6, 0.2),
        direction(0.3, 1.0) * Vec3::new(1.0, 1.0, -1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let base = thin_pane([0.8; 3], 0.5, 1.0);
        cases.push((
            GpuMaterial {
                sheen_color: [0.5, 0.7, 0.9],
                sheen_roughness: 0.4,
                clearcoat: 0.5,
                clearcoat_roughness: 0.3,
                ..base
            },
            wo,
            format!("thin under sheen and coat, wo {wo} ({k})"),
        ));
        cases.push((
            GpuMaterial {
                anisotropy: 0.7,
                anisotropy_direction: [1.0, 0.0, 0.0],
                ..base
            },
            wo,
            format!("thin anisotropic, wo {wo} ({k})"),
        ));
    }
    cases
}

#[test]
fn thin_walled_sampling_matches_its_pdf_and_eval() {
    assert_sampling_matches_pdf_and_eval(&thin_cases(), "thin-walled transmission", false);
}

#[test]
fn thin_walled_transmission_is_symmetric_in_both_modes() {
    // No refraction, no η²: f(a → b below) = f(b below → a) in radiance, and the importance
    // BSDF equals the radiance one (where solid glass differs by η², see
    // `reflection_is_reciprocal_and_refraction_obeys_the_eta_squared_rule`). Without the coat,
    // whose F_c on V makes it non-reciprocal (`clearcoat_importance_is_the_transposed_radiance_bsdf`).
    let cases: Vec<_> = thin_cases()
        .into_iter()
        .filter(|(m, _, _)| m.clearcoat == 0.0)
        .collect();
    assert_reciprocal_and_transposed(&cases);
    let dirs = RECIPROCITY_DIRECTIONS.map(|(cos, phi)| direction(cos, phi));
    for (m, _, name) in &cases {
        for a in dirs {
            for b in dirs {
                let below = b * Vec3::new(1.0, 1.0, -1.0);
                let out_in = bsdf_eval(m, NG, a, below, TransportMode::Radiance);
                let in_out = bsdf_eval(m, NG, below, a, TransportMode::Radiance);
                let importance = bsdf_eval(m, NG, a, below, TransportMode::Importance);
                for other in [in_out, importance] {
                    assert!(
                        (other - out_in).abs().max_element()
                            <= 1e-4 * out_in.max_element().max(1e-3),
                        "{name}: {out_in} vs {other}"
                    );
                }
            }
        }
    }
}

#[test]
fn rough_thin_walls_blur_about_the_straight_through_direction() {
    // The transmitted lobe is the reflection lobe mirrored through the plane: its peak is at
    // −wo, not at the refracted direction, and its value there is the reflection's at the
    // mirror direction times (1 − F)/F · c (the same D, V and half vector).
    let m = thin_pane([0.9, 0.6, 0.3], 0.4, 1.0);
    for cos in [0.9f32, 0.5] {
        let wo = direction(cos, 0.3);
        let frame = BsdfFrame::new(&m, NG, wo).unwrap();
        let through = frame.eval(-wo, TransportMode::Radiance);
        let refracted = refract_through(wo, Vec3::Z, 1.5).unwrap();
        let bent = frame.eval(refracted, TransportMode::Radiance);
        assert!(through.x > bent.x, "cos {cos}: {through} ≤ {bent}");
        let mirror = Vec3::new(-wo.x, -wo.y, wo.z);
        let h = Vec3::Z;
        let fd = frame.fresnel(wo.dot(h)).0.max_element();
        let spec = ggx_d(h, frame.alpha) * ggx_visibility(wo, mirror, frame.alpha);
        let want = (1.0 - fd) * spec * Vec3::new(0.9, 0.6, 0.3);
        assert!(
            (through - want).abs().max_element() <= 1e-5 * want.max_element(),
            "cos {cos}: {through} vs {want}"
        );
    }
}

#[test]
fn smooth_thin_pane_passes_one_minus_fresnel_of_its_colour_straight_through() {
    // A smooth thin pane of base colour C seen from either side at angle θ: the transmitted
    // sample leaves along −wo with f·|cos| = (1 − F(θ))·C in both transport modes (no 1/η²),
    // and the reflected one carries F(θ): together, for a white pane, exactly 1.
    let c = Vec3::new(0.9, 0.6, 0.3);
    let m = thin_pane(c.to_array(), 0.0, 1.0);
    for side in [1.0, -1.0] {
        for cos in [1.0f32, 0.7, 0.3, 0.05] {
            let wo = direction(cos, 0.4) * Vec3::new(1.0, 1.0, side);
            let f = fresnel_dielectric(cos, dielectric_f0(1.5), 1.0, 1.5);
            let frame = BsdfFrame::new(&m, NG, wo).unwrap();
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let (wi, value) = frame.delta_lobe(LOBE_TRANSMISSION, mode).unwrap();
                assert!((frame.to_world(wi) + wo).length() < 1e-6, "{wi} vs {wo}");
                let want = (1.0 - f) * c;
                assert!(
                    (value - want).abs().max_element() < 1e-6,
                    "side {side}, cos {cos}: {value} vs {want}"
                );
                let (_, reflected) = frame.delta_lobe(LOBE_REFLECTION, mode).unwrap();
                assert!((reflected - Vec3::splat(f)).abs().max_element() < 1e-6);
            }
            // Sampled: weight · pmf is the same (1 − F)·C.
            let mut seen = false;
            for i in 0..64 {
                let Some(s) = frame.sample(u3(21, i), TransportMode::Radiance) else {
                    continue;
                };
                assert!(s.delta);
                if s.wi.dot(NG) * side < 0.0 {
                    let got = s.weight * frame.lobe_pmf[LOBE_TRANSMISSION];
                    assert!((got - (1.0 - f) * c).abs().max_element() < 1e-5, "{got}");
                    seen = true;
                }
            }
            assert!(seen, "side {side}, cos {cos}: no transmitted sample");
        }
    }
}

#[test]
fn white_thin_walls_conserve_energy() {
    // A white thin pane reflects F and transmits the rest: at most 1 (single scattering loses
    // a little at high roughness, as the reflection lobe does).
    let mut checks = Vec::new();
    for r in [0.0, 0.2, 0.6, 1.0] {
        for cos in [0.95, 0.5, 0.12] {
            for side in [1.0, -1.0] {
                let wo = direction(cos, 0.7) * Vec3::new(1.0, 1.0, side);
                checks.push((thin_pane([1.0; 3], r, 1.0), wo));
            }
        }
    }
    let largest = assert_albedo_at_most_one(&checks);
    println!("white thin walls: largest albedo {largest:.4}");
}

/// `m` with energy compensation on (`energy.rs`).
fn compensated(m: GpuMaterial) -> GpuMaterial {
    GpuMaterial {
        flags: m.flags | crate::layout::MATERIAL_ENERGY_COMPENSATION,
        ..m
    }
}

#[test]
fn ggx_albedo_tables_match_the_quadrature_between_their_nodes() {
    use super::energy::*;
    // Between the nodes (cell centres) against a fresh quadrature: the tables' error, bilinear
    // interpolation included. Printed; bounded by 0.02 absolute.
    let mut worst: f64 = 0.0;
    for (mu, r) in [
        (0.05, 0.2),
        (0.3, 0.5),
        (0.55, 0.8),
        (0.9, 0.35),
        (0.16, 0.95),
        (0.72, 0.62),
    ] {
        let (a, b) = ggx_albedo_quadrature(mu, r, 512);
        let t = ggx_albedo(mu as f32, r as f32);
        worst = worst
            .max((t.x as f64 - a).abs())
            .max((t.y as f64 - b).abs());
    }
    println!("GGX albedo tables: largest error between nodes {worst:.2e}");
    assert!(worst < 0.02, "{worst}");
    // The smooth row is Schlick's split exactly; the averages of A + B fall with roughness.
    let node = 12.0 / 31.0;
    let smooth = ggx_albedo(node, 0.0);
    assert!((smooth.y - schlick_weight(node)).abs() < 1e-6);
    assert!((ggx_albedo_avg(0.0).x - 20.0 / 21.0).abs() < 1e-5);
    let e = |r: f32| ggx_albedo_avg(r).x + ggx_albedo_avg(r).y;
    assert!(e(0.0) > 0.999 && e(0.5) < e(0.2) && e(1.0) < e(0.5) && e(1.0) > 0.3);
}

#[test]
fn white_furnaces_reflect_everything_with_compensation_and_lose_light_without() {
    // A white rough metal and a white rough dielectric (Lambertian base under a white specular
    // layer): with compensation each reflects exactly 1 (within z·se at α = 0.01,
    // Šidák-corrected), without it less; the loss is printed.
    let mut checks = Vec::new();
    for metallic in [1.0, 0.0] {
        for r in [0.3, 0.6, 1.0] {
            for cos in [0.9, 0.5, 0.15] {
                checks.push((material(1.0, metallic, r, 0.0), direction(cos, 0.4)));
            }
        }
    }
    let z = crate::stats::normal_quantile_upper(sidak(0.01, 2 * checks.len()) / 2.0);
    for (m, wo) in &checks {
        let (on, se) = albedo(&compensated(*m), *wo, 200_000);
        assert!(
            (on - 1.0).abs() <= z * se + 2e-3,
            "metallic {}, roughness {}, wo {wo}: {on} ± {se} with compensation",
            m.metallic,
            m.roughness
        );
        let (off, se_off) = albedo(m, *wo, 200_000);
        println!(
            "metallic {}, roughness {}, cos {:.2}: {off:.4} ± {se_off:.4} single-scattering, {on:.4} ± {se:.4} compensated",
            m.metallic, m.roughness, wo.z
        );
        if m.roughness >= 0.6 && m.metallic == 1.0 {
            assert!(
                off < 1.0 - z * se_off - 0.02,
                "{off}: no loss to compensate"
            );
        }
    }
}

#[test]
fn compensated_lobes_sample_as_they_evaluate_and_stay_reciprocal() {
    // The multiple-scattering lobe rides on the reflection lobe's visible-normal sampling:
    // sampling still follows the mixture pdf and weights are f·cos/pdf; f stays reciprocal.
    let cases: Vec<_> = sweep(&[0.3, 0.7])
        .into_iter()
        .map(|(m, wo, name)| (compensated(m), wo, format!("compensated {name}")))
        .collect();
    assert_sampling_matches_pdf_and_eval(&cases, "energy-compensated", false);
    let translucent: Vec<_> = translucent_cases()
        .into_iter()
        .map(|(m, wo, name)| (compensated(m), wo, name))
        .collect();
    assert_reciprocal_and_transposed(&cases);
    assert_reciprocal_and_transposed(&translucent);
}

#[test]
fn compensation_leaves_lambert_exact_and_the_coat_and_sheen_their_scaling() {
    // specularFactor 0: the same floats with compensation as without (the plain frame).
    let lambert = GpuMaterial {
        specular: 0.0,
        ..material(0.6, 0.0, 1.0, 0.0)
    };
    let wo = direction(0.3, 0.5);
    for i in 0..1000 {
        let a = bsdf_sample(&lambert, NG, wo, u3(3, i), TransportMode::Radiance);
        let b = bsdf_sample(
            &compensated(lambert),
            NG,
            wo,
            u3(3, i),
            TransportMode::Radiance,
        );
        assert_eq!(format!("{a:?}"), format!("{b:?}"));
    }
    // A coat over a compensated base: (1 − clearcoat·F_c(wo))·f_base + the coat, f_base the
    // compensated base's own f; a sheen: f_base·scale + the sheen lobe, as without compensation.
    let base = compensated(material(0.7, 0.3, 0.5, 0.0));
    let coated = GpuMaterial {
        clearcoat: 0.6,
        clearcoat_roughness: 0.3,
        ..base
    };
    let sheened = GpuMaterial {
        sheen_color: [0.8, 0.5, 0.3],
        sheen_roughness: 0.5,
        ..base
    };
    for (a, b) in [(0.8f32, 0.3f32), (0.4, 2.0)] {
        let wo = direction(a, 0.2);
        let wi = direction(0.6, b);
        let mode = TransportMode::Radiance;
        let f_base = bsdf_eval(&base, NG, wo, wi, mode);
        let coat = BsdfFrame::new(&coated, NG, wo).unwrap();
        let wc = coat.cc_weight(wi, mode);
        let want = (1.0 - wc) * f_base + Vec3::splat(wc * coat.eval_clearcoat(wi, mode));
        let got = bsdf_eval(&coated, NG, wo, wi, mode);
        assert!((got - want).abs().max_element() < 1e-5, "{got} vs {want}");
        let frame = BsdfFrame::new(&sheened, NG, wo).unwrap();
        let h = (wo + wi).normalize();
        let lobe = Vec3::from(sheened.sheen_color)
            * (super::sheen::charlie_d(h.z, frame.sheen_alpha)
                * super::sheen::sheen_visibility(wo.z, wi.z, frame.sheen_alpha));
        let want = f_base * frame.sheen_scale(wi.z) + lobe;
        let got = bsdf_eval(&sheened, NG, wo, wi, mode);
        assert!((got - want).abs().max_element() < 1e-5, "{got} vs {want}");
    }
}
