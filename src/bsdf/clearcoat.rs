//! KHR_materials_clearcoat's lobe over the base: its frame about the coat's normal, its weight
//! clearcoat · F_c(|V·N_c|) and its GGX evaluation and pdf. Twin of `shaders/inc/clearcoat.glsl`.

use super::fresnel::fresnel_coat;
use super::gltf::BsdfFrame;
use super::lobes::TransportMode;
use super::microfacet::*;
use glam::Vec3;

impl BsdfFrame {
    pub(super) fn cc_is_delta(&self) -> bool {
        self.cc_alpha.x < ALPHA_DELTA
    }

    pub(super) fn to_cc_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.cc_t), v.dot(self.cc_b), v.dot(self.cc_n))
    }

    /// The coat's weight clearcoat · F_c(|V·N_c|) for world-space `wi`: V is `wo` for radiance,
    /// `wi` for importance (the transposed BSDF).
    pub(super) fn cc_weight(&self, wi: Vec3, mode: TransportMode) -> f32 {
        let v = match mode {
            TransportMode::Radiance => self.cc_wo.z,
            TransportMode::Importance => wi.dot(self.cc_n),
        };
        self.clearcoat * fresnel_coat(v)
    }

    /// The coat's GGX lobe D·V at world-space `wi` (0 for a delta coat or `wi` below the coat or
    /// the geometric surface), times |cos| to N_c over |cos| to the shading normal of the
    /// direction the integrator multiplies by (`wi` for radiance; `wo` for importance, the
    /// transpose).
    pub(super) fn eval_clearcoat(&self, wi: Vec3, mode: TransportMode) -> f32 {
        let wc = self.to_cc_local(wi);
        if self.cc_is_delta() || wc.z <= 0.0 || wi.dot(self.ng_world) <= 0.0 {
            return 0.0;
        }
        let h = (self.cc_wo + wc).normalize();
        let spec = ggx_d(h, self.cc_alpha) * ggx_visibility(self.cc_wo, wc, self.cc_alpha);
        if self.cc_n == self.n {
            return spec;
        }
        let ratio = match mode {
            TransportMode::Radiance => wc.z / wi.dot(self.n).abs(),
            TransportMode::Importance => self.cc_wo.z / self.wo.z,
        };
        if ratio.is_finite() {
            spec * ratio
        } else {
            0.0
        }
    }

    /// Solid-angle pdf of the coat's visible-normal sampling at world-space `wi`.
    pub(super) fn pdf_clearcoat(&self, wi: Vec3) -> f32 {
        let wc = self.to_cc_local(wi);
        if self.cc_is_delta() || wc.z <= 0.0 || wi.dot(self.ng_world) <= 0.0 {
            return 0.0;
        }
        let h = (self.cc_wo + wc).normalize();
        ggx_vndf_pdf(self.cc_wo, h, self.cc_alpha) / (4.0 * self.cc_wo.dot(h))
    }
}
