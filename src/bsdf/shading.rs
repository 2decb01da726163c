//! The shading frame a vertex's lobes see: the shading normal bent towards the viewer where it
//! would face away, the anisotropy's tangent frame and roughness (KHR_materials_anisotropy).

use super::microfacet::*;
use crate::layout::{GpuMaterial, MATERIAL_UNLIT};
use crate::sampling::build_frame;
use glam::{Vec2, Vec3};

/// How far above the geometric surface the shading normal must reflect `wo`
/// ([`bend_shading_normal`]): the cosine of the reflected direction with the geometric normal.
pub const SHADING_NORMAL_MIN_COS: f32 = 0.01;

/// A shading normal `ns` (on `ng`'s side) bent so that the mirror reflection of `wo` about it
/// lies at least [`SHADING_NORMAL_MIN_COS`] above the geometric surface (Keller et al. 2017,
/// "The Iray Light Transport Simulation and Rendering System", §A.3): without it, a normal map
/// or interpolated normal that faces away from `wo` turns the surface black. `ng` and `wo` must
/// be unit and on the same side (ng·wo > 0); returns a unit vector with ns·wo > 0.
pub fn bend_shading_normal(ns: Vec3, ng: Vec3, wo: Vec3) -> Vec3 {
    let r = 2.0 * wo.dot(ns) * ns - wo;
    let height = r.dot(ng);
    if height >= SHADING_NORMAL_MIN_COS {
        return ns;
    }
    // Lift the reflection to the minimum height, keeping its azimuth, and take the half vector.
    let tangential = r - height * ng;
    let length = tangential.length();
    if !(length > 1e-12) {
        return ng;
    }
    let lifted = tangential
        * ((1.0 - SHADING_NORMAL_MIN_COS * SHADING_NORMAL_MIN_COS).sqrt() / length)
        + SHADING_NORMAL_MIN_COS * ng;
    (wo + lifted).normalize()
}

/// KHR_materials_anisotropy's roughnesses (α_t, α_b) = (mix(α, 1, strength²), α) (the
/// extension's "Implementation"); (α, α) without anisotropy. The lobe is a delta where α_t <
/// [`ALPHA_DELTA`]; otherwise α_b is at least [`ALPHA_DELTA`] (a lobe rough along the tangent
/// and smooth across it is a line of directions, no density: it is kept finitely narrow).
pub fn anisotropic_alpha(alpha: f32, strength: f32) -> Vec2 {
    if strength <= 0.0 {
        return Vec2::splat(alpha);
    }
    let at = alpha + (1.0 - alpha) * strength * strength;
    Vec2::new(
        at,
        if at < ALPHA_DELTA {
            alpha
        } else {
            alpha.max(ALPHA_DELTA)
        },
    )
}

/// The tangent frame (t, b) about unit `n`: where `strength` > 0, t is `direction` made
/// orthogonal to n (KHR_materials_anisotropy's α_t axis) and b = n × t; else, and where the
/// direction is degenerate, [`build_frame`]'s.
pub fn anisotropic_frame(n: Vec3, strength: f32, direction: Vec3) -> (Vec3, Vec3) {
    if strength > 0.0 {
        let t = direction - n * n.dot(direction);
        let length = t.length();
        if length > 1e-12 && length.is_finite() {
            let t = t / length;
            return (t, n.cross(t));
        }
    }
    build_frame(n)
}

/// The shading frame of a surface seen from `wo`, the first steps of every frame
/// ([`BsdfFrame::new_shading`], [`LambertFrame::new`]).
pub(super) struct Shading {
    /// ng · wo.
    pub(super) cos_g: f32,
    /// Whether `wo` lies on the front face's side.
    pub(super) front: bool,
    /// The geometric normal on `wo`'s side.
    pub(super) ng_wo: Vec3,
    /// The shading normal on `wo`'s side, bent ([`bend_shading_normal`]), and the tangents.
    pub(super) n: Vec3,
    pub(super) t: Vec3,
    pub(super) b: Vec3,
    /// `ng_wo` in the local frame (+Z where the shading normal is the geometric one).
    pub(super) ng_local: Vec3,
    pub(super) unlit: bool,
    /// KHR_materials_anisotropy's strength (0 for an unlit surface).
    pub(super) anisotropy: f32,
}

impl Shading {
    /// None where `wo` lies in the surface's plane (no light leaves along it).
    #[inline(always)]
    pub(super) fn new(m: &GpuMaterial, ng: Vec3, ns: Vec3, wo: Vec3) -> Option<Shading> {
        let cos_g = ng.dot(wo);
        if cos_g == 0.0 || !cos_g.is_finite() {
            return None;
        }
        let front = cos_g > 0.0;
        let ng_wo = if front { ng } else { -ng };
        let n = if ns == ng {
            ng_wo
        } else {
            bend_shading_normal(if front { ns } else { -ns }, ng_wo, wo)
        };
        // The tangent: KHR_materials_anisotropy's direction of α_t where the material has one,
        // else any (the other lobes are isotropic about n).
        let unlit = m.flags & MATERIAL_UNLIT != 0;
        let anisotropy = if unlit { 0.0 } else { m.anisotropy };
        let (t, b) = anisotropic_frame(n, anisotropy, Vec3::from(m.anisotropy_direction));
        let ng_local = if ns == ng {
            Vec3::Z
        } else {
            Vec3::new(ng_wo.dot(t), ng_wo.dot(b), ng_wo.dot(n))
        };
        Some(Shading {
            cos_g,
            front,
            ng_wo,
            n,
            t,
            b,
            ng_local,
            unlit,
            anisotropy,
        })
    }
}
