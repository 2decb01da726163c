//! A plain material's BSDF, the Lambertian lobe alone ([`LambertFrame`]): bit for bit the
//! general frame's values where the material is plain, at a quarter of its size.

use super::lobes::{average, material_is_plain, BsdfSample};
use super::shading::Shading;
use crate::layout::GpuMaterial;
use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A plain diffuse material ([`material_is_plain`]) seen from `wo`: Lambert's lobe alone, the
/// fields a [`plain`](BsdfFrame) [`BsdfFrame`] reads (72 bytes of its 280), whose plain path is
/// this frame's. Its eval, pdf and sample give the general path's floats (test
/// `lambert_frames_equal_the_general_path`).
/// The CPU reference shades every vertex of a plain material with it: building the general
/// frame — the layers' arithmetic and the stores of its fields — was most of a plain vertex's
/// BSDF work.
#[derive(Clone, Copy, Debug)]
pub struct LambertFrame {
    pub(super) t: Vec3,
    pub(super) b: Vec3,
    pub(super) n: Vec3,
    /// The geometric normal on `wo`'s side, in the local frame.
    pub(super) ng: Vec3,
    pub(super) base: Vec3,
    /// The diffuse lobe's probability: 1, or 0 where the surface scatters nothing.
    pub(super) pmf: f32,
    /// The diffuse lobe's albedo estimate, average(base colour) ([`BsdfFrame::albedo_estimate`]).
    pub albedo_estimate: f32,
}

impl LambertFrame {
    /// The frame of a plain material `m` at shading normal `ns` ([`BsdfFrame::new_shading`]
    /// for such a material, which it must be). None where `wo` lies in the surface's plane.
    pub fn new(m: &GpuMaterial, ng: Vec3, ns: Vec3, wo: Vec3) -> Option<LambertFrame> {
        debug_assert!(material_is_plain(m));
        let s = Shading::new(m, ng, ns, wo)?;
        let base = if s.unlit {
            Vec3::ZERO
        } else {
            Vec3::from(m.base_color)
        };
        // new_shading's lobe estimates of a plain material: the diffuse lobe's
        // 1 · (1 − 0) · average(base), every other lobe's an exact 0; normalised by their sum
        // (1 where the surface scatters; NaN where the sum is infinite, as there).
        let diffuse = average(base);
        let total = diffuse;
        Some(LambertFrame {
            t: s.t,
            b: s.b,
            n: s.n,
            ng: s.ng_local,
            base,
            pmf: if total > 0.0 { diffuse / total } else { 0.0 },
            albedo_estimate: total,
        })
    }

    /// Whether local `wi` lies on the same side of the geometric and the shading surface.
    pub(super) fn consistent(&self, wi: Vec3) -> bool {
        (wi.dot(self.ng) > 0.0) == (wi.z > 0.0)
    }

    pub(super) fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Lambert's f at world-space `wi` (the same in both transport modes).
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        let wi = self.to_local(wi);
        if self.consistent(wi) && wi.z > 0.0 {
            FRAC_1_PI * self.base
        } else {
            Vec3::ZERO
        }
    }

    /// The cosine-weighted pdf at world-space `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let wi = self.to_local(wi);
        if self.consistent(wi) && wi.z > 0.0 {
            self.pmf * cosine_hemisphere_pdf(wi.z)
        } else {
            0.0
        }
    }

    /// |cos| between world-space `wi` and the shading normal.
    pub fn cos_theta(&self, wi: Vec3) -> f32 {
        wi.dot(self.n).abs()
    }

    /// A cosine-weighted direction for `u.xy` if the surface scatters anything (`u.z`, the
    /// general frame's lobe choice, is not read); a direction on the surface is no sample.
    pub fn sample(&self, u: Vec3) -> Option<BsdfSample> {
        if !(self.pmf > 0.0) {
            return None;
        }
        let local = sample_cosine_hemisphere(Vec2::new(u.x, u.y));
        if !(local.z > 0.0) {
            return None;
        }
        let wi = self.t * local.x + self.b * local.y + self.n * local.z;
        let pdf = self.pdf(wi);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wi) * (self.cos_theta(wi) / pdf),
            pdf,
            delta: false,
        })
    }
}
