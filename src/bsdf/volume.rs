//! KHR_materials_volume: Beer–Lambert attenuation inside transmissive meshes. Twin of
//! `shaders/inc/volume.glsl`, same names.
//!
//! A volume material's mesh is closed and its front faces look outwards (the convention of the
//! transmission lobe: the front face is the outside). Light travelling a distance d inside it
//! keeps T = exp(−σ d) = attenuationColor^(d / attenuationDistance) (the extension's
//! "Attenuation"), σ = −ln(attenuationColor)/attenuationDistance per channel, stored in
//! `GpuMaterial::attenuation` by the loader (0 for thin-walled materials, thicknessFactor 0).
//! A path tracer measures d itself, so thicknessFactor and its texture (a rasteriser's estimate
//! of d) are not used.
//!
//! Which medium a segment crosses is read from its ends: a segment lies inside a volume where it
//! leaves a volume surface into its back side, or arrives at one from its back side
//! ([`volume_sigma`] at either end; the two agree where both ends are on the volume's surface).
//! The path state keeps the coefficient of the ray's origin end (`PathState::medium`), the hit
//! gives the other. Not modelled: nested or overlapping volumes, and objects inside a volume
//! whose segments touch neither end of the volume's surface (a segment between two surfaces
//! inside the volume is not attenuated).

use crate::layout::GpuMaterial;
use glam::Vec3;

/// σ = −ln(attenuationColor)/attenuationDistance per channel (a colour component of 0 is taken
/// as 10⁻³⁰: T = 10⁻³⁰ per attenuation distance); 0 for a thin-walled material (thicknessFactor
/// 0) or an infinite distance.
pub fn attenuation_coefficient(thickness: f32, color: Vec3, distance: f32) -> Vec3 {
    if !(thickness > 0.0 && distance.is_finite() && distance > 0.0) {
        return Vec3::ZERO;
    }
    let sigma = |c: f32| -(c.clamp(1e-30, 1.0)).ln() / distance;
    Vec3::new(sigma(color.x), sigma(color.y), sigma(color.z))
}

/// The attenuation coefficient of the medium that direction `w` enters at a surface of
/// material `m` with front-face normal `ng`: the material's σ behind its back face, else 0.
pub fn volume_sigma(m: &GpuMaterial, ng: Vec3, w: Vec3) -> Vec3 {
    if ng.dot(w) < 0.0 {
        Vec3::from(m.attenuation)
    } else {
        Vec3::ZERO
    }
}

/// Beer–Lambert transmittance exp(−σ t) of a segment of length `t` (f32::MAX or more: an
/// infinite one, which a medium absorbs completely); 1 where σ is 0.
pub fn transmittance(sigma: Vec3, t: f32) -> Vec3 {
    let channel = |s: f32| if s > 0.0 { (-s * t).exp() } else { 1.0 };
    Vec3::new(channel(sigma.x), channel(sigma.y), channel(sigma.z))
}
