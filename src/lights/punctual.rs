//! KHR_lights_punctual's point, spot and directional lights as the integrators see them: the
//! radiance arriving from one (range window and spot falloff), a light's intensity along a
//! direction and its cone. Twin of `shaders/inc/punctual.glsl`, same names.

use crate::layout::{GpuPunctualLight, LIGHT_DIRECTIONAL, LIGHT_SPOT};
use glam::Vec3;

/// Direction to, distance to (−1 for a directional light, at infinity) and radiance arriving from punctual
/// light `l` at `p`, as KHR_lights_punctual defines them: I/d² times the range window
/// clamp(1 − (d/range)⁴, 0, 1) and, for a spot, the smooth cone falloff
/// clamp(cos·scale + offset, 0, 1)²; a directional light gives its irradiance from −direction
/// (punctual.glsl).
pub fn punctual_incident(l: &GpuPunctualLight, p: Vec3) -> (Vec3, f32, Vec3) {
    let intensity = Vec3::from(l.intensity);
    let direction = Vec3::from(l.direction);
    if l.kind == LIGHT_DIRECTIONAL {
        return (-direction, -1.0, intensity);
    }
    let to = Vec3::from(l.position) - p;
    let d2 = to.dot(to);
    let d = d2.sqrt();
    if !(d > 0.0) {
        return (Vec3::Z, 0.0, Vec3::ZERO);
    }
    let wi = to / d;
    let mut li = intensity / d2;
    if l.range > 0.0 {
        let x = d / l.range;
        li *= (1.0 - x * x * x * x).clamp(0.0, 1.0);
    }
    if l.kind == LIGHT_SPOT {
        let a = (direction.dot(-wi) * l.spot_scale + l.spot_offset).clamp(0.0, 1.0);
        li *= a * a;
    }
    (wi, d, li)
}

/// Radiant intensity of a point or spot light along `w` (unit, away from the light):
/// KHR_lights_punctual's I times the spot's smooth falloff clamp(cos·scale + offset, 0, 1)²,
/// as [`punctual_incident`] applies it.
pub fn punctual_intensity(light: &GpuPunctualLight, w: Vec3) -> Vec3 {
    let mut i = Vec3::from(light.intensity);
    if light.kind == LIGHT_SPOT {
        let a = (Vec3::from(light.direction).dot(w) * light.spot_scale + light.spot_offset)
            .clamp(0.0, 1.0);
        i *= a * a;
    }
    i
}

/// The range window clamp(1 − (d/range)⁴, 0, 1) of a punctual light at distance `d` (1 without
/// a range), as [`punctual_incident`] applies it.
pub fn punctual_window(light: &GpuPunctualLight, d: f32) -> f32 {
    if light.range > 0.0 {
        let x = d / light.range;
        (1.0 - x * x * x * x).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// cos of a spot light's outer cone angle, from its falloff constants (scale = 1/(cos inner −
/// cos outer), offset = −cos outer · scale).
pub fn spot_cos_outer(light: &GpuPunctualLight) -> f32 {
    (-light.spot_offset / light.spot_scale).clamp(-1.0, 1.0)
}
