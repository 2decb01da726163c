//! Light tracing ("next event estimation for light tracing") on the CPU: the pinhole's importance,
//! a light vertex joined to the camera, and the splats that land on the film. Twin of
//! `shaders/inc/light_tracing.glsl`, same names.

// `!(x > 0.0)` rejects NaN along with the non-positive, on purpose, as the GLSL twin does.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::bdpt::{Bidir, Kind, Vertex};
use crate::bsdf::{TransportMode, VertexBsdf};
use crate::layout::TRIANGLE_TEST_CULL;
use glam::Vec3;

impl<'a> Bidir<'a> {
    /// The pixel a direction from the pinhole lands in, W_e (area measure) and the direction
    /// pdf there: 1/(A cos⁴θ) and 1/(A cos³θ); None outside the film.
    pub fn camera_importance(&self, dir: Vec3) -> Option<(u32, f32, f32)> {
        let f = self.frame;
        let cos = dir.dot(Vec3::from(f.cam_forward));
        if !(cos > 0.0) {
            return None;
        }
        let t = f.tan_half_fov_y;
        let sx = dir.dot(Vec3::from(f.cam_right)) / (cos * t * f.aspect);
        let sy = dir.dot(Vec3::from(f.cam_up)) / (cos * t);
        let px = (sx + 1.0) * 0.5 * f.width as f32;
        let py = (1.0 - sy) * 0.5 * f.height as f32;
        if !(px >= 0.0 && px < f.width as f32 && py >= 0.0 && py < f.height as f32) {
            return None;
        }
        let pixel = (py as u32).min(f.height - 1) * f.width + (px as u32).min(f.width - 1);
        let pdf = 1.0 / (self.film_area * cos * cos * cos);
        Some((pixel, pdf / cos, pdf))
    }

    pub(crate) fn camera_vertex(&self) -> Vertex {
        Vertex::endpoint(
            Kind::Camera,
            Vec3::from(self.frame.cam_position),
            Vec3::from(self.frame.cam_forward),
            Vec3::ONE,
            1.0,
            0,
        )
    }

    // --- emitters ---------------------------------------------------------------------------

    /// φ(ω_c, ω_l) of a scattering vertex: f·|n_s·ω_l| / |n_g·ω_l| (module docs).
    pub(crate) fn phi(&self, v: &Vertex, w_cam: Vec3, w_light: Vec3) -> Vec3 {
        let cos_g = v.ng.dot(w_light).abs();
        match self.bsdf(v, w_cam) {
            Some(frame) if cos_g > 0.0 => {
                frame.eval(w_light, TransportMode::Radiance) * (frame.cos_theta(w_light) / cos_g)
            }
            _ => Vec3::ZERO,
        }
    }

    // --- subpaths ---------------------------------------------------------------------------

    /// Whether the camera, in direction `w` from surface vertex `v`, sees it: not on the back
    /// face of a single-sided triangle, which primary rays cull (`surface::culled`).
    pub(crate) fn camera_sees(&self, v: &Vertex, w: Vec3) -> bool {
        let tri = &self.scene.triangles[v.index as usize];
        tri.material & TRIANGLE_TEST_CULL == 0 || v.ng.dot(w) >= 0.0
    }

    /// A surface vertex can be joined to another if its material has a non-delta lobe.
    pub(crate) fn connectible(&self, v: &Vertex) -> bool {
        match v.kind {
            Kind::Surface => {
                let m = &v.mat;
                let alpha = m.roughness * m.roughness;
                let diffuse = (1.0 - m.metallic) * (1.0 - m.transmission) > 0.0;
                diffuse || alpha >= crate::bsdf::microfacet::ALPHA_DELTA
            }
            _ => true,
        }
    }
}

/// Adds `c` to a pixel's splat sums, each channel a 64-bit fixed-point integer in units of
/// 2⁻²⁴ (light_tracing.glsl, `splat_add`, which adds the same integers with 32-bit atomics):
/// integer sums do not depend on the order of the additions. Non-finite, negative and absurd
/// (≥ 2³⁹) values are not added.
pub fn splat_add(sums: &mut [u64; 3], c: Vec3) {
    for (sum, v) in sums.iter_mut().zip(c.to_array()) {
        if !(v > 0.0) || !(v < 549_755_813_888.0) {
            continue;
        }
        let hi = (v * (1.0 / 256.0)).floor();
        let lo = (v - hi * 256.0) * 16_777_216.0;
        let lo = if lo < 16_777_216.0 { lo + 0.5 } else { lo } as u32;
        *sum = sum.wrapping_add(((hi as u64) << 32) + lo as u64);
    }
}

/// The value of a pixel's splat sums (accumulate_splats.comp).
pub fn splat_value(sums: &[u64; 3]) -> Vec3 {
    Vec3::from(
        sums.map(|s| (s >> 32) as u32 as f32 * 256.0 + s as u32 as f32 * (1.0 / 16_777_216.0)),
    )
}
