//! The GGX (Trowbridge–Reitz) microfacet model and Schlick's Fresnel, in the local shading frame
//! (+Z = normal, every direction unit length): twin of `shaders/inc/microfacet.glsl`.
//!
//! glTF 2.0 Appendix B: D is GGX with α = roughness², V the height-correlated Smith visibility
//! G₂ / (4 |n·l| |n·v|), F Schlick's approximation on v·h. Visible normals are sampled after
//! Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4), 2018.
//!
//! Every function takes the roughness as α = (α_x, α_y) along the frame's X (tangent) and Y
//! (bitangent) axes: the anisotropic GGX of KHR_materials_anisotropy (α_t, α_b), of which the
//! isotropic model is α_x = α_y = α (one copy of the code serves both).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Below this α the specular lobes are perfectly smooth (delta lobes: a mirror and, for
/// transmission, a refraction). roughness 0 is such a lobe in glTF; α = 10⁻³ (roughness ≈ 0.03)
/// is where a GGX lobe is already narrower than any pixel footprint and its f32 evaluation
/// (D ∝ 1/α²) stops being meaningful.
pub const ALPHA_DELTA: f32 = 1e-3;

/// GGX normal distribution D(m) with respect to solid angle of microfacet normals, m on +Z's
/// side: 1 / (π α_x α_y (m_x²/α_x² + m_y²/α_y² + m_z²)²) (Heitz 2014, "Understanding the
/// Masking-Shadowing Function", eq. 85; Walter et al. 2007, eq. 33 where α_x = α_y; glTF
/// Appendix B "D" and KHR_materials_anisotropy's D_GGX_anisotropic). The sum keeps its
/// precision for narrow lobes (the textbook (n·m)²(α² − 1) + 1 cancels when n·m → 1, α → 0).
pub fn ggx_d(m: Vec3, alpha: Vec2) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let (x, y) = (m.x / alpha.x, m.y / alpha.y);
    let d = x * x + y * y + m.z * m.z;
    1.0 / (PI * alpha.x * alpha.y * d * d)
}

/// Smith's Λ for GGX: (−1 + √(1 + (α_x² w_x² + α_y² w_y²)/w_z²)) / 2 (Heitz 2014, eqs. 72 and
/// 86), for a direction on either side.
pub fn ggx_lambda(w: Vec3, alpha: Vec2) -> f32 {
    let c2 = w.z * w.z;
    if c2 == 0.0 {
        return f32::MAX; // grazing: fully masked (finite, as the GLSL twin must be)
    }
    let (x, y) = (alpha.x * w.x, alpha.y * w.y);
    let t2 = (x * x + y * y) / c2;
    0.5 * (-1.0 + (1.0 + t2).sqrt())
}

/// Smith masking of one direction, G₁ = 1 / (1 + Λ).
pub fn ggx_g1(w: Vec3, alpha: Vec2) -> f32 {
    1.0 / (1.0 + ggx_lambda(w, alpha))
}

/// Height-correlated Smith visibility V = G₂ / (4 |n·l| |n·v|) of local `wo`, `wi` (either
/// side), written as KHR_materials_anisotropy's V_GGX_anisotropic writes it:
/// 0.5 / (|n·l| |(α_x v_x, α_y v_y, v_z)| + |n·v| |(α_x l_x, α_y l_y, l_z)|), which for
/// α_x = α_y is glTF Appendix B's 0.5 / (|n·l| √(α² + (1 − α²)(n·v)²) + …) and equals
/// G₂ = 1 / (1 + Λ(v) + Λ(l)) (Heitz 2014, eq. 99) divided by 4 |n·l| |n·v|.
pub fn ggx_visibility(wo: Vec3, wi: Vec3, alpha: Vec2) -> f32 {
    let stretched = |w: Vec3| Vec3::new(alpha.x * w.x, alpha.y * w.y, w.z).length();
    let denom = wi.z.abs() * stretched(wo) + wo.z.abs() * stretched(wi);
    if denom > 0.0 {
        0.5 / denom
    } else {
        0.0
    }
}

/// A visible normal of GGX seen from `wo` (wo.z > 0), from two uniform numbers (Heitz 2018,
/// listing 1, anisotropic as written there): stretch the view to the hemisphere
/// configuration, sample the projected hemisphere, unstretch.
pub fn sample_ggx_vndf(wo: Vec3, alpha: Vec2, u: Vec2) -> Vec3 {
    let vh = Vec3::new(alpha.x * wo.x, alpha.y * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    Vec3::new(alpha.x * nh.x, alpha.y * nh.y, nh.z.max(0.0)).normalize()
}

/// Pdf of [`sample_ggx_vndf`] with respect to solid angle of microfacet normals:
/// D_wo(m) = G₁(wo) max(0, wo·m) D(m) / wo.z (Heitz 2018, eq. 1).
pub fn ggx_vndf_pdf(wo: Vec3, m: Vec3, alpha: Vec2) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    ggx_g1(wo, alpha) * wo.dot(m).max(0.0) * ggx_d(m, alpha) / wo.z
}

/// (1 − cos)⁵, Schlick's weight of F90 (clamped so that |cos| ≤ 1 rounding cannot flip it).
pub fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// glTF's metal Fresnel (Appendix B, conductor_fresnel): baseColor + (1 − baseColor)(1 − |v·h|)⁵.
pub fn fresnel_conductor(base_color: Vec3, cos: f32) -> Vec3 {
    base_color + (Vec3::ONE - base_color) * schlick_weight(cos.abs())
}

/// glTF's dielectric Fresnel F0 + (F90 − F0)(1 − cos)⁵ (Appendix B fresnel_mix, with
/// KHR_materials_specular's F0 = ((ior − 1)/(ior + 1))² · specular and F90 = specular) for a
/// direction with cosine `cos_i` to the microfacet normal on the side it arrives from. `etap`
/// is the ratio η_other side / η_this side: leaving a denser medium (etap < 1) Schlick is taken
/// on the transmitted angle, and beyond the critical angle every bit reflects (F = 1).
pub fn fresnel_dielectric(cos_i: f32, f0: f32, f90: f32, etap: f32) -> f32 {
    let mut c = cos_i.abs().min(1.0);
    if etap < 1.0 {
        let sin2_t = (1.0 - c * c) / (etap * etap);
        if sin2_t >= 1.0 {
            return 1.0;
        }
        c = (1.0 - sin2_t).sqrt();
    }
    f0 + (f90 - f0) * schlick_weight(c)
}

/// [`fresnel_dielectric`] with an RGB F0 (KHR_materials_specular's specularColor): each channel
/// F0 + (F90 − F0)(1 − cos)⁵, the same transmitted-angle rule, and 1 on total internal
/// reflection.
pub fn fresnel_dielectric_color(cos_i: f32, f0: Vec3, f90: f32, etap: f32) -> Vec3 {
    let mut c = cos_i.abs().min(1.0);
    if etap < 1.0 {
        let sin2_t = (1.0 - c * c) / (etap * etap);
        if sin2_t >= 1.0 {
            return Vec3::ONE;
        }
        c = (1.0 - sin2_t).sqrt();
    }
    f0 + (Vec3::splat(f90) - f0) * schlick_weight(c)
}

/// KHR_materials_specular's dielectric F0 (section "Interaction with other extensions"):
/// min(((ior − 1)/(ior + 1))² · specularColor, 1) · specular.
pub fn specular_f0(ior: f32, specular_color: Vec3, specular: f32) -> Vec3 {
    (dielectric_f0(ior) * specular_color).min(Vec3::ONE) * specular
}

/// F0 of a dielectric of index `ior` against air: ((ior − 1)/(ior + 1))² (KHR_materials_ior).
pub fn dielectric_f0(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// Mirror of `wo` about the (microfacet) normal `m`.
pub fn reflect_about(wo: Vec3, m: Vec3) -> Vec3 {
    2.0 * wo.dot(m) * m - wo
}

/// Refraction of `wo` (on `m`'s side, wo·m > 0) through the interface with normal `m`, where
/// `etap` = η_transmitted / η_incident: Snell's law; None on total internal reflection.
pub fn refract_through(wo: Vec3, m: Vec3, etap: f32) -> Option<Vec3> {
    let cos_i = wo.dot(m);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (etap * etap);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / etap + (cos_i / etap - cos_t) * m)
}
