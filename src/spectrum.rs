//! Spectral sampling for KHR_materials_dispersion: one wavelength per path. Twin of
//! `shaders/inc/spectrum.glsl`, same names.
//!
//! wavetrace renders in linear sRGB. A dispersive material's index of refraction depends on
//! the wavelength λ ([`dispersive_ior`]), so a path that refracts through one carries a single
//! wavelength, and its RGB contribution is its radiance at λ times the RGB response r(λ)
//! divided by the pdf of λ ([`wavelength_weight`]).
//!
//! **How RGB is converted (stated once, here):** r(λ) = max(0, M·xyz(λ)) / N, per channel,
//! where xyz is the CIE 1931 2° observer in the analytic multi-lobe fit of Wyman, Sloan &
//! Shirley 2013 ("Simple Analytic Approximations to the CIE XYZ Color Matching Functions",
//! JCGT 2(2), §2.2), M the XYZ → linear sRGB (D65) matrix of IEC 61966-2-1, negative
//! (out-of-gamut) responses clipped to 0, and N the per-channel integral of the clipped
//! response over [`LAMBDA_MIN`, `LAMBDA_MAX`] ([`RESPONSE_NORMALISATION`]). So ∫ r_c(λ) dλ = 1
//! for each channel: an RGB light of colour c is read as the spectrum that gives c, a white
//! one as equal energy at every λ, and E[r(λ)/p(λ)] = (1, 1, 1) — multiplying any path's
//! contribution by the weight leaves its expectation unchanged, which is what makes the
//! integrators below unbiased. Non-dispersive materials keep their RGB reflectances (an RGB
//! renderer's usual approximation: reflectance does not vary within a channel).
//!
//! **Which paths carry a wavelength.** Each sample (pixel, sample index) owns one wavelength λ,
//! drawn from its own random-number block ([`crate::layout::dim::WAVELENGTH_BLOCK`]) by
//! [`sample_wavelength`], independent of every other decision of the sample:
//! - the path tracer turns a path spectral at its first vertex whose material is dispersive
//!   ([`is_dispersive`]), before that vertex's emitter sample: from there its throughput carries
//!   the weight r(λ)/p(λ) and every dispersive material on it refracts with n(λ). Paths that
//!   never meet such a material keep their RGB colour and no colour noise.
//! - light tracing and BDPT weight every contribution of the sample by r(λ)/p(λ) once, and
//!   refract with n(λ) everywhere, when the scene has a dispersive material
//!   (`FrameParams::spectral`): their strategies join subpaths traced apart, and one wavelength
//!   for the whole sample keeps every strategy's path the same path.

use crate::layout::{dim, GpuMaterial, MATERIAL_UNLIT};
use crate::sampling::rng_uniform4;
use glam::Vec3;

/// The sampled range of wavelengths, nm (pbrt-v4's visible range; the CIE functions are below
/// 10⁻⁴ of their peak outside it).
pub const LAMBDA_MIN: f32 = 360.0;
pub const LAMBDA_MAX: f32 = 830.0;

/// ∫ max(0, M·xyz(λ)) dλ over [`LAMBDA_MIN`, `LAMBDA_MAX`] per channel (R, G, B), by the
/// composite Simpson rule on 0.01 nm steps in f64 (`tests::normalisation_is_the_integral`
/// recomputes it).
pub const RESPONSE_NORMALISATION: [f32; 3] = [176.177_32, 115.391_27, 109.370_545];

/// The Fraunhofer d line, where KHR_materials_ior's index is given (the dispersion
/// extension's n_d), nm.
pub const LAMBDA_D: f32 = 587.6;

/// One lobe of the piecewise Gaussian of Wyman et al. 2013, eq. 2: exp(−½((λ − μ)/σ)²) with
/// σ = σ₁ below μ and σ₂ above.
fn lobe(lambda: f32, mu: f32, sigma1: f32, sigma2: f32) -> f32 {
    let t = (lambda - mu) / if lambda < mu { sigma1 } else { sigma2 };
    (-0.5 * t * t).exp()
}

/// The CIE 1931 2° colour-matching functions x̄, ȳ, z̄ at `lambda` nm (Wyman et al. 2013,
/// the multi-lobe fit, eq. 2 and Table 1).
pub fn cie_xyz(lambda: f32) -> Vec3 {
    let x = 1.056 * lobe(lambda, 599.8, 37.9, 31.0) + 0.362 * lobe(lambda, 442.0, 16.0, 26.7)
        - 0.065 * lobe(lambda, 501.1, 20.4, 26.2);
    let y = 0.821 * lobe(lambda, 568.8, 46.9, 40.5) + 0.286 * lobe(lambda, 530.9, 16.3, 31.1);
    let z = 1.217 * lobe(lambda, 437.0, 11.8, 36.0) + 0.681 * lobe(lambda, 459.0, 26.0, 13.8);
    Vec3::new(x, y, z)
}

/// CIE XYZ → linear sRGB (D65 white), IEC 61966-2-1.
pub fn xyz_to_linear_srgb(c: Vec3) -> Vec3 {
    Vec3::new(
        3.240_454_2 * c.x - 1.537_138_5 * c.y - 0.498_531_4 * c.z,
        -0.969_266 * c.x + 1.876_010_8 * c.y + 0.041_556 * c.z,
        0.055_643_4 * c.x - 0.204_025_9 * c.y + 1.057_225_2 * c.z,
    )
}

/// The unnormalised response max(0, M·xyz(λ)) (the integrand of [`RESPONSE_NORMALISATION`]).
pub fn clipped_response(lambda: f32) -> Vec3 {
    xyz_to_linear_srgb(cie_xyz(lambda)).max(Vec3::ZERO)
}

/// r(λ): the linear sRGB response to unit spectral radiance at `lambda` nm, each channel
/// integrating to 1 over the sampled range (module docs); 0 outside it.
pub fn wavelength_rgb(lambda: f32) -> Vec3 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return Vec3::ZERO;
    }
    clipped_response(lambda) / Vec3::from(RESPONSE_NORMALISATION)
}

/// Samples a wavelength in [`LAMBDA_MIN`, `LAMBDA_MAX`] from one uniform number by inverting
/// the CDF of p(λ) ∝ sech²(0.0072 (λ − 538)), which follows the eye's sensitivity (Radziszewski
/// et al. 2009, "An Improved Technique for Full Spectral Rendering", as pbrt-v4's
/// `SampleVisibleWavelengths` uses it): λ = 538 − atanh(0.85691062 − 1.82750197 u) / 0.0072.
pub fn sample_wavelength(u: f32) -> f32 {
    let lambda = 538.0 - 138.888_89 * (0.856_910_6 - 1.827_502 * u).atanh();
    lambda.clamp(LAMBDA_MIN, LAMBDA_MAX)
}

/// The pdf of [`sample_wavelength`], per nm: 0.0072 / (tanh(0.0072·292) + tanh(0.0072·178)) /
/// cosh²(0.0072 (λ − 538)) inside the range.
pub fn wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (0.0072 * (lambda - 538.0)).cosh();
    0.003_939_804 / (c * c)
}

/// The RGB weight of a path carrying `lambda`: r(λ)/p(λ) (each channel's expectation is 1).
pub fn wavelength_weight(lambda: f32) -> Vec3 {
    let pdf = wavelength_pdf(lambda);
    if pdf > 0.0 {
        wavelength_rgb(lambda) / pdf
    } else {
        Vec3::ZERO
    }
}

/// KHR_materials_dispersion's index of refraction at `lambda` nm: the two-term Cauchy
/// equation through n_d = `ior` at [`LAMBDA_D`] with Abbe number V_d = 20/`dispersion`, in the
/// extension's closed form max(n_d + (n_d − 1)/V_d · (523655/λ² − 1.5168), 1).
pub fn dispersive_ior(ior: f32, dispersion: f32, lambda: f32) -> f32 {
    if dispersion <= 0.0 {
        return ior;
    }
    (ior + (ior - 1.0) * (dispersion / 20.0) * (523_655.0 / (lambda * lambda) - 1.5168)).max(1.0)
}

/// Whether a surface's refraction depends on the wavelength: KHR_materials_dispersion over a
/// transmissive, non-metallic, lit material with a volume (the extension enhances the volume's
/// transmission; a thin wall, thicknessFactor 0, bends nothing; reflection's Fresnel change
/// with λ is left out with it).
pub fn is_dispersive(m: &GpuMaterial) -> bool {
    m.dispersion > 0.0
        && m.transmission > 0.0
        && m.thickness > 0.0
        && m.metallic < 1.0
        && m.flags & MATERIAL_UNLIT == 0
}

/// The material as a path of wavelength `lambda` sees it (0: none, no change): a dispersive
/// material's ior becomes n(λ).
pub fn material_at_wavelength(m: &mut GpuMaterial, lambda: f32) {
    if lambda > 0.0 && is_dispersive(m) {
        m.ior = dispersive_ior(m.ior, m.dispersion, lambda);
    }
}

/// The wavelength of sample (`pixel`, `sample`): [`sample_wavelength`] of the x of its own
/// block ([`dim::WAVELENGTH_BLOCK`]).
pub fn sample_wavelength_of(seed: u32, pixel: u32, sample: u32) -> f32 {
    sample_wavelength(rng_uniform4(seed, pixel, sample, dim::WAVELENGTH_BLOCK).x)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Composite Simpson over [`LAMBDA_MIN`, `LAMBDA_MAX`] of the clipped response, in f64.
    fn integral(steps: usize) -> [f64; 3] {
        let (a, b) = (LAMBDA_MIN as f64, LAMBDA_MAX as f64);
        let h = (b - a) / steps as f64;
        let mut sum = [0.0f64; 3];
        for k in 0..=steps {
            let w = if k == 0 || k == steps {
                1.0
            } else if k % 2 == 1 {
                4.0
            } else {
                2.0
            };
            let r = clipped_response((a + k as f64 * h) as f32);
            for c in 0..3 {
                sum[c] += w * r[c] as f64;
            }
        }
        sum.map(|s| s * h / 3.0)
    }

    /// The CDF of [`sample_wavelength`]'s density on [`LAMBDA_MIN`, `LAMBDA_MAX`], in f64.
    fn cdf(lambda: f64) -> f64 {
        let t = |l: f64| (0.0072 * (l - 538.0)).tanh();
        (t(lambda) - t(LAMBDA_MIN as f64)) / (t(LAMBDA_MAX as f64) - t(LAMBDA_MIN as f64))
    }

    #[test]
    fn the_wavelength_pdf_is_the_samplers_density() {
        // χ² of 10⁶ wavelengths in 94 bins of 5 nm against the CDF's differences (α = 0.01).
        let n = 1_000_000u32;
        let bins = 94usize;
        let width = (LAMBDA_MAX - LAMBDA_MIN) as f64 / bins as f64;
        let mut observed = vec![0.0f64; bins];
        for k in 0..n {
            let lambda = sample_wavelength(rng_uniform4(1, k, 0, 0).x);
            let b = ((lambda - LAMBDA_MIN) as f64 / width) as usize;
            observed[b.min(bins - 1)] += 1.0;
        }
        let expected: Vec<f64> = (0..bins)
            .map(|b| {
                let a = LAMBDA_MIN as f64 + b as f64 * width;
                n as f64 * (cdf(a + width) - cdf(a))
            })
            .collect();
        let (chi2, dof, p) = crate::stats::chi_square_gof(&observed, &expected);
        println!("sample_wavelength: χ² = {chi2:.1}, dof {dof}, p = {p:.3}");
        assert!(p > 0.01, "χ² = {chi2}, dof {dof}, p = {p}");
        // wavelength_pdf is the CDF's derivative, 0.0072 sech²(0.0072 (λ − 538)) over the
        // range's tanh difference, in f64.
        let t = |l: f64| (0.0072 * (l - 538.0)).tanh();
        for k in 0..=470 {
            let l = LAMBDA_MIN as f64 + k as f64;
            let c = (0.0072 * (l - 538.0)).cosh();
            let derivative = 0.0072 / (c * c) / (t(LAMBDA_MAX as f64) - t(LAMBDA_MIN as f64));
            let pdf = wavelength_pdf(l as f32) as f64;
            assert!(
                (pdf - derivative).abs() <= 1e-5 * derivative,
                "{l} nm: {pdf} vs {derivative}"
            );
        }
    }

    #[test]
    fn a_wavelengths_weight_has_expectation_one_in_every_channel() {
        // E[r(λ)/p(λ)] = ∫ r = 1: the mean of 10⁶ weights within 4.5 standard errors (the
        // standard error measured from the same weights; Šidák over 3 channels at α ≈ 2e-5).
        let n = 1_000_000u32;
        let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
        for k in 0..n {
            let w = wavelength_weight(sample_wavelength(rng_uniform4(2, k, 0, 0).x)).as_dvec3();
            sum += w;
            sum2 += w * w;
        }
        let mean = sum / n as f64;
        let se = ((sum2 / n as f64 - mean * mean) / (n as f64 - 1.0)).powf(0.5);
        println!("E[wavelength_weight] = {mean} ± {se}");
        for c in 0..3 {
            assert!(
                (mean[c] - 1.0).abs() < 4.5 * se[c],
                "channel {c}: {} ± {}",
                mean[c],
                se[c]
            );
        }
    }

    #[test]
    fn the_ior_follows_the_abbe_number() {
        for (ior, dispersion) in [(1.5f32, 1.0f32), (1.33, 0.36), (2.4, 2.04), (1.5, 0.0)] {
            let n = |l: f32| dispersive_ior(ior, dispersion, l) as f64;
            // n_d = ior (the extension's closed form puts λ_d at 587.56 nm: within 1e-5).
            assert!(
                (n(587.56) - ior as f64).abs() < 1e-5,
                "n_d {} vs {ior}",
                n(587.56)
            );
            if dispersion > 0.0 {
                // V_d = (n_d − 1)/(n_F − n_C) = 20/dispersion, to f32 rounding of n_F − n_C.
                let abbe = (ior as f64 - 1.0) / (n(486.1) - n(656.3));
                let want = 20.0 / dispersion as f64;
                assert!((abbe - want).abs() < 2e-3 * want, "V_d {abbe} vs {want}");
                // Blue bends more than red.
                assert!(n(450.0) > n(550.0) && n(550.0) > n(650.0));
            } else {
                assert_eq!(n(450.0), ior as f64);
            }
        }
        // Never below 1.
        assert_eq!(dispersive_ior(1.01, 100.0, 830.0), 1.0);
    }

    #[test]
    fn only_lit_transmissive_dielectrics_disperse() {
        let glass = GpuMaterial {
            metallic: 0.0,
            transmission: 1.0,
            dispersion: 1.0,
            thickness: 1.0,
            ..GpuMaterial::default()
        };
        assert!(is_dispersive(&glass));
        for m in [
            GpuMaterial {
                dispersion: 0.0,
                ..glass
            },
            GpuMaterial {
                transmission: 0.0,
                ..glass
            },
            GpuMaterial {
                thickness: 0.0,
                ..glass
            },
            GpuMaterial {
                metallic: 1.0,
                ..glass
            },
            GpuMaterial {
                flags: MATERIAL_UNLIT,
                ..glass
            },
        ] {
            assert!(!is_dispersive(&m));
            let mut seen = m;
            material_at_wavelength(&mut seen, 450.0);
            assert_eq!(seen.ior, m.ior);
        }
        let mut blue = glass;
        material_at_wavelength(&mut blue, 450.0);
        assert_eq!(blue.ior, dispersive_ior(1.5, 1.0, 450.0));
        let mut none = glass;
        material_at_wavelength(&mut none, 0.0);
        assert_eq!(none.ior, 1.5);
    }

    #[test]
    fn normalisation_is_the_integral() {
        let n = integral(47_000);
        println!("RESPONSE_NORMALISATION = {n:?}");
        for c in 0..3 {
            let rel = (n[c] - RESPONSE_NORMALISATION[c] as f64).abs() / n[c];
            assert!(
                rel < 1e-6,
                "channel {c}: {} vs {}",
                RESPONSE_NORMALISATION[c],
                n[c]
            );
        }
    }
}
