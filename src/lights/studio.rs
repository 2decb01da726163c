//! The built-in studio environment: what lights a file that has no light of its own when no
//! `--env` is given (DESIGN.md, "Lighting by default"), as Blender opens with a grey world and
//! model viewers light with a neutral studio. Procedural and neutral (the same radiance in R, G
//! and B), written into an ordinary equirectangular map of [`STUDIO_WIDTH`] × [`STUDIO_HEIGHT`]
//! texels, each texel the radiance [`studio_radiance`] at its centre's direction, so the CPU and
//! the GPU look it up and importance-sample it exactly as they do a user's `.hdr`
//! (`environment.rs` ↔ `environment.glsl`): there is no second implementation to keep twin.
//!
//! In the map's frame (+Y up, −Z ahead of a default glTF camera, which sits on +Z):
//! - a dome: 0.27 + 0.33·y above the horizon (0.27 at the horizon, 0.6 straight up) and a floor
//!   of 0.09 below it;
//! - a key soft box of radiance [`KEY_RADIANCE`] filling a cap of 15° about (−1, 1.2, 1) (high
//!   on the camera's left, 40° up, in front of the model);
//! - a fill of 1.1 in a cap of 25° about (1.2, 0.4, 0.9) (low on the right, in front);
//! - a rim of 2.2 in a cap of 20° about (0.3, 0.9, −1) (high behind the model, for its edges).
//!
//! An upward white Lambertian plane under it reflects E/π ≈ 0.9 (E, its irradiance, ≈ 2.8;
//! `tests/materials/environment.rs` integrates it), so a light grey reads light grey in an
//! 8-bit picture at exposure 0 rather than clipping.
//!
//! Between texel centres the lookup is bilinear, as for every map.

use super::environment::EnvironmentMap;
use glam::Vec3;
use std::f32::consts::PI;
use std::sync::{Arc, OnceLock};

/// The map's size in texels (0.7° a texel).
pub const STUDIO_WIDTH: u32 = 512;
pub const STUDIO_HEIGHT: u32 = 256;

/// The key soft box's radiance.
pub const KEY_RADIANCE: f32 = 6.0;
/// The dome's radiance at the horizon and straight up (linear in y between), and the floor's.
pub const DOME_HORIZON: f32 = 0.27;
pub const DOME_ZENITH: f32 = 0.6;
pub const FLOOR: f32 = 0.09;

/// The soft boxes: direction (unnormalised), cap half-angle in degrees, radiance.
const BOXES: [([f32; 3], f32, f32); 3] = [
    ([-1.0, 1.2, 1.0], 15.0, KEY_RADIANCE),
    ([1.2, 0.4, 0.9], 25.0, 1.1),
    ([0.3, 0.9, -1.0], 20.0, 2.2),
];

/// The studio's radiance arriving from direction `d` (unit, the map's frame), the same in
/// every channel: the dome or floor, or a soft box where `d` lies in its cap.
pub fn studio_radiance(d: Vec3) -> Vec3 {
    for (axis, degrees, radiance) in BOXES {
        if d.dot(Vec3::from(axis).normalize()) >= degrees.to_radians().cos() {
            return Vec3::splat(radiance);
        }
    }
    Vec3::splat(if d.y >= 0.0 {
        DOME_HORIZON + (DOME_ZENITH - DOME_HORIZON) * d.y
    } else {
        FLOOR
    })
}

/// The direction at the centre of texel (i, j) (row j from the top): the inverse of
/// `environment::env_direction_uv`, θ = v·π, φ = (u − ½)·2π, (x, y, z) = (sin θ sin φ, cos θ,
/// −sin θ cos φ).
pub fn texel_direction(i: u32, j: u32, width: u32, height: u32) -> Vec3 {
    let u = (i as f32 + 0.5) / width as f32;
    let v = (j as f32 + 0.5) / height as f32;
    let (theta, phi) = (v * PI, (u - 0.5) * 2.0 * PI);
    Vec3::new(
        theta.sin() * phi.sin(),
        theta.cos(),
        -theta.sin() * phi.cos(),
    )
}

/// The studio map (built once).
pub fn studio() -> Arc<EnvironmentMap> {
    static MAP: OnceLock<Arc<EnvironmentMap>> = OnceLock::new();
    Arc::clone(MAP.get_or_init(|| {
        let rgb: Vec<Vec3> = (0..STUDIO_HEIGHT)
            .flat_map(|j| {
                (0..STUDIO_WIDTH).map(move |i| {
                    studio_radiance(texel_direction(i, j, STUDIO_WIDTH, STUDIO_HEIGHT))
                })
            })
            .collect();
        Arc::new(EnvironmentMap::from_rgb(STUDIO_WIDTH, STUDIO_HEIGHT, &rgb).expect("not black"))
    }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::FrameParams;
    use crate::lights::environment::{env_direction_uv, env_radiance};

    #[test]
    fn texel_directions_invert_the_lookup() {
        let mut frame = FrameParams::default();
        studio().write_frame_params(Vec3::ONE, 0.0, &mut frame);
        for (i, j) in [(0, 0), (17, 100), (255, 128), (511, 255)] {
            let d = texel_direction(i, j, STUDIO_WIDTH, STUDIO_HEIGHT);
            let (uv, _) = env_direction_uv(&frame, d);
            let want = glam::Vec2::new(
                (i as f32 + 0.5) / STUDIO_WIDTH as f32,
                (j as f32 + 0.5) / STUDIO_HEIGHT as f32,
            );
            assert!(
                (uv - want).abs().max_element() < 1e-5,
                "({i}, {j}): {uv} vs {want}"
            );
        }
    }

    #[test]
    fn the_map_shows_the_documented_radiance() {
        // At texel centres the bilinear lookup returns the texel: the formula, to RGBE's 2⁻⁸.
        let map = studio();
        let mut frame = FrameParams::default();
        map.write_frame_params(Vec3::ONE, 0.0, &mut frame);
        for j in (0..STUDIO_HEIGHT).step_by(7) {
            for i in (0..STUDIO_WIDTH).step_by(5) {
                let d = texel_direction(i, j, STUDIO_WIDTH, STUDIO_HEIGHT);
                let got = env_radiance(&map, &frame, d);
                let want = studio_radiance(d);
                assert!(
                    (got - want).abs().max_element() <= want.x / 128.0,
                    "({i}, {j}): {got} vs {want}"
                );
                assert!(got.x == got.y && got.y == got.z, "neutral");
            }
        }
        // Straight up, the horizon from above and below, inside the key box.
        let key = Vec3::new(-1.0, 1.2, 1.0).normalize();
        let low = Vec3::new(0.0, 0.05, -1.0).normalize();
        for (d, want) in [
            (Vec3::Y, DOME_ZENITH),
            (low, DOME_HORIZON + (DOME_ZENITH - DOME_HORIZON) * low.y),
            (Vec3::new(0.0, -0.3, -1.0).normalize(), FLOOR),
            (key, KEY_RADIANCE),
        ] {
            assert!((studio_radiance(d).x - want).abs() < 1e-4, "{d}");
            let got = env_radiance(&map, &frame, d).x;
            assert!((got - want).abs() < 0.02 * want, "{d}: {got} vs {want}");
        }
    }
}
