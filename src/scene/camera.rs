//! The pinhole camera: an orthonormal frame, a vertical field of view and an optional aspect.

use glam::{Mat4, Vec3};

/// A perspective pinhole camera in world space. `right`, `up` and `forward` are orthonormal
/// and right-handed (`right = forward × up`); the image plane spans ±tan(yfov/2) along `up`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit viewing direction (glTF: the node's −Z).
    pub forward: Vec3,
    /// Unit, points to the right of the image.
    pub right: Vec3,
    /// Unit, points to the top of the image (glTF: the node's +Y).
    pub up: Vec3,
    /// Vertical field of view in radians, in (0, π).
    pub yfov: f32,
    /// Width / height the file asks for; `None` lets the film decide.
    pub aspect_ratio: Option<f32>,
}

/// Field of view of the default camera.
const FRAMING_YFOV_DEGREES: f32 = 40.0;

impl Camera {
    /// The default camera for a scene without one: looks down −Z with +Y up, yfov 40°, on the
    /// +Z side of the centre of `bounds` (min, max), just far enough for the bounding sphere
    /// to fit in the vertical field of view.
    pub fn framing(bounds: (Vec3, Vec3)) -> Camera {
        let (lo, hi) = bounds;
        let centre = 0.5 * (lo + hi);
        let radius = 0.5 * (hi - lo).length();
        let yfov = FRAMING_YFOV_DEGREES.to_radians();
        // A sphere of radius r seen from distance d fills a half-angle asin(r / d).
        let distance = if radius.is_finite() && radius > 0.0 {
            radius / (0.5 * yfov).sin()
        } else {
            1.0
        };
        let centre = if centre.is_finite() {
            centre
        } else {
            Vec3::ZERO
        };
        Camera {
            position: centre + Vec3::Z * distance,
            forward: Vec3::NEG_Z,
            right: Vec3::X,
            up: Vec3::Y,
            yfov,
            aspect_ratio: None,
        }
    }

    /// A camera at a glTF camera node: origin, −Z and +Y of `world` give position, forward and
    /// up; the frame is re-orthonormalised (forward kept, up made perpendicular to it).
    /// Errors describe the problem (the caller names the node).
    pub(crate) fn from_node(
        world: &Mat4,
        yfov: f32,
        aspect_ratio: Option<f32>,
    ) -> Result<Camera, String> {
        if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f32::consts::PI) {
            return Err(format!("yfov = {yfov} rad is not in (0, π)"));
        }
        if let Some(aspect) = aspect_ratio {
            if !(aspect.is_finite() && aspect > 0.0) {
                return Err(format!(
                    "aspectRatio = {aspect} is not a positive finite number"
                ));
            }
        }
        let position = world.transform_point3(Vec3::ZERO);
        let forward = world.transform_vector3(Vec3::NEG_Z).try_normalize();
        let up = world.transform_vector3(Vec3::Y);
        let (Some(forward), true) = (forward, position.is_finite()) else {
            return Err(
                "its node transform is degenerate (no finite viewing direction)".to_owned(),
            );
        };
        let Some(right) = forward.cross(up).try_normalize() else {
            return Err(
                "its node transform is degenerate (up is parallel to the viewing direction)"
                    .to_owned(),
            );
        };
        Ok(Camera {
            position,
            forward,
            right,
            up: right.cross(forward),
            yfov,
            aspect_ratio,
        })
    }

    /// tan(yfov / 2): half the height of the image plane at unit distance.
    pub fn tan_half_fov_y(&self) -> f32 {
        (0.5 * self.yfov).tan()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn framing_fits_the_bounding_sphere() {
        let cam = Camera::framing((Vec3::new(-1.0, -2.0, -3.0), Vec3::new(3.0, 2.0, 1.0)));
        let centre = Vec3::new(1.0, 0.0, -1.0);
        let radius = Vec3::new(2.0, 2.0, 2.0).length();
        let d = (cam.position - centre).length();
        assert!(((radius / d).asin() - 0.5 * cam.yfov).abs() < 1e-5);
        assert_eq!(cam.forward, Vec3::NEG_Z);
        assert!((cam.position.z - centre.z - d).abs() < 1e-5);
    }

    #[test]
    fn node_frame_is_orthonormalised() {
        let world = Mat4::from_rotation_y(0.5) * Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0));
        let cam = Camera::from_node(&world, 1.0, None).unwrap();
        for v in [cam.forward, cam.right, cam.up] {
            assert!((v.length() - 1.0).abs() < 1e-6);
        }
        assert!(cam.forward.dot(cam.up).abs() < 1e-6);
        assert!((cam.right - cam.forward.cross(cam.up)).length() < 1e-6);
        assert!(Camera::from_node(&Mat4::IDENTITY, 0.0, None).is_err());
        assert!(Camera::from_node(&Mat4::IDENTITY, 4.0, None).is_err());
        assert!(Camera::from_node(&Mat4::ZERO, 1.0, None).is_err());
    }
}
