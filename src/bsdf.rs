//! The Lambertian BSDF: evaluation, sampling and pdf.
//!
//! Direction convention (here and in `shaders/inc/bsdf.glsl`, never swapped): `wo` points from
//! the surface towards where the light goes (the previous vertex, e.g. the camera), `wi` from the
//! surface towards where it comes from (the next vertex, e.g. a light); both are unit vectors
//! pointing away from the surface. `n` is the shading normal already flipped to `wo`'s side, so
//! both faces of every surface reflect. `bsdf_eval` returns f without the cosine.

use crate::sampling::{build_frame, cosine_hemisphere_pdf, sample_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A sampled incident direction with its BSDF value and solid-angle pdf.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub f: Vec3,
    pub pdf: f32,
}

/// f(wo, wi) of a Lambertian surface: albedo / π on `wo`'s side, 0 through the surface.
pub fn bsdf_eval(albedo: Vec3, n: Vec3, _wo: Vec3, wi: Vec3) -> Vec3 {
    if n.dot(wi) > 0.0 {
        albedo * FRAC_1_PI
    } else {
        Vec3::ZERO
    }
}

/// Pdf of [`bsdf_sample`] with respect to solid angle: cos θᵢ / π on `wo`'s side.
pub fn bsdf_pdf(n: Vec3, _wo: Vec3, wi: Vec3) -> f32 {
    cosine_hemisphere_pdf(n.dot(wi))
}

/// Cosine-weighted sample of `wi` around `n`.
pub fn bsdf_sample(albedo: Vec3, n: Vec3, wo: Vec3, u: Vec2) -> BsdfSample {
    let local = sample_cosine_hemisphere(u);
    let (t, b) = build_frame(n);
    let wi = (t * local.x + b * local.y + n * local.z).normalize();
    BsdfSample {
        wi,
        f: bsdf_eval(albedo, n, wo, wi),
        pdf: bsdf_pdf(n, wo, wi),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::rng_uniform4;

    #[test]
    fn sample_pdf_equals_pdf_and_energy_is_conserved() {
        // E[f·cos/pdf] = albedo exactly for a Lambertian surface: check each sample's weight and
        // that the returned pdf equals bsdf_pdf().
        let albedo = Vec3::new(0.9, 0.5, 0.1);
        let n = Vec3::new(0.3, -0.2, 0.9).normalize();
        let wo = Vec3::new(0.1, 0.4, 0.8).normalize();
        for i in 0..100_000 {
            let u = rng_uniform4(3, i, 0, 0);
            let s = bsdf_sample(albedo, n, wo, Vec2::new(u.x, u.y));
            if s.pdf == 0.0 {
                continue;
            }
            assert!((s.pdf - bsdf_pdf(n, wo, s.wi)).abs() <= 1e-6 * s.pdf.max(1.0));
            let weight = s.f * n.dot(s.wi) / s.pdf;
            assert!(
                (weight - albedo).abs().max_element() < 1e-3,
                "weight {weight}"
            );
        }
    }

    #[test]
    fn no_transmission() {
        let n = Vec3::Z;
        assert_eq!(bsdf_eval(Vec3::ONE, n, Vec3::Z, -Vec3::Z), Vec3::ZERO);
        assert_eq!(bsdf_pdf(n, Vec3::Z, Vec3::new(0.0, 0.6, -0.8)), 0.0);
    }
}
