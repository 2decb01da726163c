//! Fresnel terms: the clear coat's Schlick reflectance, and the layered Fresnel of the base
//! (dielectric and metal, with KHR_materials_specular's F0 and F90 and the thin film of
//! KHR_materials_iridescence mixed in), on v·h. Twin of `shaders/inc/fresnel.glsl`.

use super::iridescence::fresnel_iridescence;
use super::microfacet::*;
use glam::Vec3;

/// The clearcoat's Fresnel weight F_c = F0 + (1 − F0)(1 − |cos|)⁵ with F0 = ((1.5 − 1)/(1.5 +
/// 1))² = 0.04 (KHR_materials_clearcoat, `fresnel_coat`).
pub fn fresnel_coat(cos: f32) -> f32 {
    let f0 = dielectric_f0(1.5);
    f0 + (1.0 - f0) * schlick_weight(cos.abs())
}

/// KHR_materials_iridescence's film: its factor (0: none), index and thickness (nm).
#[derive(Clone, Copy, Debug)]
pub struct ThinFilm {
    pub factor: f32,
    pub ior: f32,
    pub thickness: f32,
}

/// The dielectric (RGB: KHR_materials_specular's F0, F90, [`fresnel_dielectric_color`]) and the
/// metal ([`fresnel_conductor`]) Fresnel terms at cosine `cos` to the microfacet normal on
/// `wo`'s side, each mixed with the thin film's reflectance by its factor as
/// KHR_materials_iridescence writes it: F = mix(F_base, F_film, iridescenceFactor), the film over
/// a base of F0 = the dielectric's F0 or the base colour ([`fresnel_iridescence`], seen from air
/// at the outside cosine: the transmitted angle's when `etap` < 1; total internal reflection
/// stays 1). The film's reflectance is clamped to [0, 1] so that the layers below keep a
/// non-negative 1 − max(F).
pub fn fresnel_layers(
    cos: f32,
    f0: Vec3,
    f90: f32,
    etap: f32,
    base: Vec3,
    metallic: f32,
    film: &ThinFilm,
) -> (Vec3, Vec3) {
    let mut fd = fresnel_dielectric_color(cos, f0, f90, etap);
    let mut fm = fresnel_conductor(base, cos);
    if film.factor <= 0.0 {
        return (fd, fm);
    }
    let mut c = cos.abs().min(1.0);
    let mut tir = false;
    if etap < 1.0 {
        let sin2_t = (1.0 - c * c) / (etap * etap);
        tir = sin2_t >= 1.0;
        c = (1.0 - sin2_t).max(0.0).sqrt();
    }
    if !tir && metallic < 1.0 {
        let thin = fresnel_iridescence(1.0, film.ior, c, film.thickness, f0).min(Vec3::ONE);
        fd += (thin - fd) * film.factor;
    }
    if metallic > 0.0 {
        let thin = fresnel_iridescence(1.0, film.ior, cos.abs().min(1.0), film.thickness, base)
            .min(Vec3::ONE);
        fm += (thin - fm) * film.factor;
    }
    (fd, fm)
}
