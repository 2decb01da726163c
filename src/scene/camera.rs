//! Cameras: an orthonormal frame with a perspective or orthographic projection and a near plane,
//! the thin lens of a render, and the primary rays they give (`camera_ray`, the twin of
//! `shaders/inc/camera.glsl`).

use crate::bvh::Ray;
use crate::layout::{FrameParams, CAMERA_ORTHOGRAPHIC, CAMERA_PERSPECTIVE};
use crate::sampling::sample_concentric_disk;
use glam::{Mat4, Vec2, Vec3};

/// How a camera maps the film to rays: glTF's two camera types.
///
/// The image size comes from `--width`/`--height`, so the film's aspect (width / height) may
/// differ from the camera's: the vertical extent (`yfov` or `ymag`) is kept and the horizontal
/// one follows from the film's aspect. A film with the camera's own aspect (the default when only
/// one side is given) shows exactly the view the file describes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Rays from one point (or a thin lens) through the image plane.
    Perspective {
        /// Vertical field of view in radians, in (0, π).
        yfov: f32,
        /// Width / height the file asks for; `None` lets the film decide.
        aspect_ratio: Option<f32>,
    },
    /// Parallel rays along the viewing direction from a rectangle of the camera's plane.
    Orthographic {
        /// Half the width of the view in scene units (glTF's projection matrix has 1/xmag).
        xmag: f32,
        /// Half the height of the view in scene units (1/ymag in the projection matrix).
        ymag: f32,
    },
}

/// A camera in world space. `right`, `up` and `forward` are orthonormal and right-handed
/// (`right = forward × up`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit viewing direction (glTF: the node's −Z).
    pub forward: Vec3,
    /// Unit, points to the right of the image.
    pub right: Vec3,
    /// Unit, points to the top of the image (glTF: the node's +Y).
    pub up: Vec3,
    pub projection: Projection,
    /// Distance of the near plane from `position` along `forward` (glTF's znear): geometry
    /// closer than it is not seen, since every primary ray starts on it. The far plane (zfar) is
    /// not applied: rays go on to infinity.
    pub znear: f32,
}

/// A thin lens in front of a perspective camera (pbrt-v3 §6.2.3): every ray through one film
/// point passes through the point where the pinhole ray meets the plane in focus.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThinLens {
    /// Radius of the lens in scene units (half of `--aperture`); 0 is a pinhole.
    pub radius: f32,
    /// Distance of the plane in focus along the viewing direction.
    pub focus_distance: f32,
}

/// Field of view of the default camera.
const FRAMING_YFOV_DEGREES: f32 = 40.0;

/// The centre of `bounds` (min, max) and the distance from it at which their bounding sphere
/// just fits a vertical field of view `yfov`: a sphere of radius r seen from distance d fills a
/// half-angle asin(r / d). (The origin and 1 for empty or non-finite bounds.)
fn framing_sphere(bounds: (Vec3, Vec3), yfov: f32) -> (Vec3, f32) {
    let (lo, hi) = bounds;
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let distance = if radius.is_finite() && radius > 0.0 {
        radius / (0.5 * yfov).sin()
    } else {
        1.0
    };
    (
        if centre.is_finite() {
            centre
        } else {
            Vec3::ZERO
        },
        distance,
    )
}

impl Camera {
    /// The default camera for a scene without one: looks down −Z with +Y up, yfov 40°, on the
    /// +Z side of the centre of `bounds` (min, max), just far enough for the bounding sphere
    /// to fit in the vertical field of view; no near plane.
    pub fn framing(bounds: (Vec3, Vec3)) -> Camera {
        let yfov = FRAMING_YFOV_DEGREES.to_radians();
        let (centre, distance) = framing_sphere(bounds, yfov);
        Camera {
            position: centre + Vec3::Z * distance,
            forward: Vec3::NEG_Z,
            right: Vec3::X,
            up: Vec3::Y,
            projection: Projection::Perspective {
                yfov,
                aspect_ratio: None,
            },
            znear: 0.0,
        }
    }

    /// A perspective camera at `from` looking at `at` with `up` towards the top of the image
    /// (`--from`, `--look-at`, `--up`), vertical field of view `yfov` radians; no near plane.
    /// Errors say what is wrong: the two points coincide, or up is parallel to the view.
    pub fn look_at(from: Vec3, at: Vec3, up: Vec3, yfov: f32) -> Result<Camera, String> {
        let Some(forward) = (at - from).try_normalize() else {
            return Err(format!("the camera at {from} looks at itself"));
        };
        let Some(right) = forward.cross(up).try_normalize() else {
            return Err(format!(
                "up {up} is parallel to the viewing direction {forward}"
            ));
        };
        Ok(Camera {
            position: from,
            forward,
            right,
            up: right.cross(forward),
            projection: Projection::Perspective {
                yfov,
                aspect_ratio: None,
            },
            znear: 0.0,
        })
    }

    /// A perspective camera on a sphere about the centre of `bounds` (`--orbit`): azimuth
    /// `azimuth` degrees about +Y from the default view's +Z side (counter-clockwise seen from
    /// above, so 90° is on +X), elevation `elevation` degrees above the horizontal, at
    /// `distance` from the centre (None: the default framing's distance for `yfov`), looking at
    /// the centre with +Y up (straight above or below, up is the horizontal direction away from
    /// the azimuth's side).
    pub fn orbit(
        bounds: (Vec3, Vec3),
        azimuth: f32,
        elevation: f32,
        distance: Option<f32>,
        yfov: f32,
    ) -> Camera {
        let (centre, fits) = framing_sphere(bounds, yfov);
        let distance = distance.unwrap_or(fits);
        let (sa, ca) = azimuth.to_radians().sin_cos();
        let (se, ce) = elevation.to_radians().sin_cos();
        let offset = Vec3::new(sa * ce, se, ca * ce);
        let up = if ce.abs() < 1e-4 {
            -Vec3::new(sa, 0.0, ca) * se.signum()
        } else {
            Vec3::Y
        };
        Camera::look_at(centre + distance * offset, centre, up, yfov)
            .expect("an orbit's up is never parallel to its view")
    }

    /// The field of view of the default camera (`Camera::framing`), in radians.
    pub fn framing_yfov() -> f32 {
        FRAMING_YFOV_DEGREES.to_radians()
    }

    /// A camera at a glTF camera node: origin, −Z and +Y of `world` give position, forward and
    /// up; the frame is re-orthonormalised (forward kept, up made perpendicular to it). The
    /// projection's numbers were checked with the document (`validate.rs`); errors describe the
    /// transform's problem (the caller names the camera and node).
    pub(crate) fn from_node(
        world: &Mat4,
        projection: Projection,
        znear: f32,
    ) -> Result<Camera, String> {
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
            projection,
            znear,
        })
    }

    /// Width / height of the view the file describes: a perspective camera's aspectRatio (if
    /// any), an orthographic camera's xmag / ymag.
    pub fn aspect_ratio(&self) -> Option<f32> {
        match self.projection {
            Projection::Perspective { aspect_ratio, .. } => aspect_ratio,
            Projection::Orthographic { xmag, ymag } => Some(xmag / ymag),
        }
    }

    /// The vertical field of view of a perspective camera.
    pub fn yfov(&self) -> Option<f32> {
        match self.projection {
            Projection::Perspective { yfov, .. } => Some(yfov),
            Projection::Orthographic { .. } => None,
        }
    }

    pub fn is_orthographic(&self) -> bool {
        matches!(self.projection, Projection::Orthographic { .. })
    }

    /// Distance along `forward` from the camera to the centre of `bounds` (min, max): where
    /// the thin lens focuses unless told otherwise.
    pub fn distance_to_centre(&self, bounds: (Vec3, Vec3)) -> f32 {
        (0.5 * (bounds.0 + bounds.1) - self.position).dot(self.forward)
    }

    /// The thin lens of `--aperture` (lens diameter, 0 = pinhole) and `--focus-distance`
    /// (default: [`distance_to_centre`](Camera::distance_to_centre) of the scene's `bounds`).
    /// Errors say what is wrong with the options for this camera.
    pub fn thin_lens(
        &self,
        aperture: f32,
        focus_distance: Option<f32>,
        bounds: (Vec3, Vec3),
    ) -> Result<ThinLens, String> {
        if !(aperture.is_finite() && aperture >= 0.0) {
            return Err(format!(
                "--aperture {aperture}: the lens diameter must be finite and non-negative"
            ));
        }
        if let Some(f) = focus_distance {
            if !(f.is_finite() && f > 0.0) {
                return Err(format!(
                    "--focus-distance {f}: the distance must be positive and finite"
                ));
            }
        }
        if aperture == 0.0 {
            return Ok(ThinLens {
                radius: 0.0,
                focus_distance: focus_distance.unwrap_or(0.0),
            });
        }
        if self.is_orthographic() {
            return Err(format!(
                "--aperture {aperture}: depth of field needs a perspective camera, and this one \
                 is orthographic (its rays are parallel, so there is no lens to open)"
            ));
        }
        let focus_distance = match focus_distance {
            Some(f) => f,
            None => {
                let d = self.distance_to_centre(bounds);
                if !(d.is_finite() && d > 0.0) {
                    return Err(format!(
                        "--aperture {aperture}: the centre of the scene's bounding box is not in \
                         front of the camera (distance {d} along the view), so there is no \
                         default focus: give --focus-distance"
                    ));
                }
                d
            }
        };
        Ok(ThinLens {
            radius: 0.5 * aperture,
            focus_distance,
        })
    }

    /// Writes the camera's part of `frame`: position, frame, projection, near plane and lens.
    /// `frame.width`, `height` and `aspect` (the film's) are the caller's.
    pub fn write_frame_params(&self, lens: ThinLens, frame: &mut FrameParams) {
        frame.cam_position = self.position.to_array();
        frame.cam_right = self.right.to_array();
        frame.cam_up = self.up.to_array();
        frame.cam_forward = self.forward.to_array();
        frame.cam_znear = self.znear;
        match self.projection {
            Projection::Perspective { yfov, .. } => {
                frame.cam_projection = CAMERA_PERSPECTIVE;
                frame.tan_half_fov_y = (0.5 * yfov).tan();
                frame.cam_ymag = 0.0;
                frame.lens_radius = lens.radius;
                frame.focus_distance = lens.focus_distance;
                // Ray cones (texture level of detail): a pinhole's cone starts as a point and
                // widens by the pixel's angle (Akenine-Möller et al. 2019, Ray Tracing Gems
                // ch. 20, eq. 30). A thin lens's cone is taken as the pinhole's.
                frame.cone_width = 0.0;
                frame.cone_spread = (2.0 * (0.5 * yfov).tan() / frame.height.max(1) as f32).atan();
            }
            Projection::Orthographic { ymag, .. } => {
                frame.cam_projection = CAMERA_ORTHOGRAPHIC;
                frame.tan_half_fov_y = 0.0;
                frame.cam_ymag = ymag;
                frame.lens_radius = 0.0;
                frame.focus_distance = 0.0;
                // Parallel rays: a cone of the pixel's height that does not spread.
                frame.cone_width = 2.0 * ymag / frame.height.max(1) as f32;
                frame.cone_spread = 0.0;
            }
        }
    }
}

/// The primary ray through film point (pixel + `jitter`) — jitter uniform in the pixel (box
/// filter), row 0 at the top of the image — with `lens_u` the lens sample: twin of `camera_ray`
/// in `shaders/inc/camera.glsl`.
///
/// The film point in units of the view's half-height is (sx, sy) ∈ [−aspect, aspect] × [−1, 1],
/// aspect the film's. Orthographic: the ray starts at `position + ymag·(sx·right + sy·up)` on the
/// near plane and runs along `forward`. Perspective: the pinhole ray runs along
/// `d = forward + tan(yfov/2)·(sx·right + sy·up)`; a thin lens of radius R > 0 starts the ray at
/// a point of the lens, R times Shirley–Chiu's concentric disk sample of `lens_u`, aimed at the
/// point `position + focus_distance·d` where the pinhole ray meets the plane in focus (pbrt-v3
/// §6.2.3). Either starts on the near plane: t = znear / dot(dir, forward) along the ray.
pub fn camera_ray(frame: &FrameParams, pixel: u32, jitter: Vec2, lens_u: Vec2) -> Ray {
    let px = (pixel % frame.width) as f32 + jitter.x;
    let py = (pixel / frame.width) as f32 + jitter.y;
    let position = Vec3::from(frame.cam_position);
    let forward = Vec3::from(frame.cam_forward);
    let right = Vec3::from(frame.cam_right);
    let up = Vec3::from(frame.cam_up);
    if frame.cam_projection == CAMERA_ORTHOGRAPHIC {
        let sx = (2.0 * px / frame.width as f32 - 1.0) * frame.cam_ymag * frame.aspect;
        let sy = (1.0 - 2.0 * py / frame.height as f32) * frame.cam_ymag;
        return Ray {
            origin: position + sx * right + sy * up + frame.cam_znear * forward,
            dir: forward,
        };
    }
    let sx = (2.0 * px / frame.width as f32 - 1.0) * frame.tan_half_fov_y * frame.aspect;
    let sy = (1.0 - 2.0 * py / frame.height as f32) * frame.tan_half_fov_y;
    let d = forward + sx * right + sy * up;
    let (lens_point, dir) = if frame.lens_radius > 0.0 {
        let lens = frame.lens_radius * sample_concentric_disk(lens_u);
        let lens_point = position + lens.x * right + lens.y * up;
        let focus_point = position + frame.focus_distance * d;
        (lens_point, (focus_point - lens_point).normalize())
    } else {
        (position, d.normalize())
    };
    Ray {
        origin: lens_point + (frame.cam_znear / dir.dot(forward)) * dir,
        dir,
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
        assert!(((radius / d).asin() - 0.5 * cam.yfov().unwrap()).abs() < 1e-5);
        assert_eq!(cam.forward, Vec3::NEG_Z);
        assert!((cam.position.z - centre.z - d).abs() < 1e-5);
        assert_eq!(cam.znear, 0.0);
    }

    #[test]
    fn orbit_zero_is_the_default_view_and_turns_counter_clockwise() {
        let bounds = (Vec3::new(-1.0, -2.0, -3.0), Vec3::new(3.0, 2.0, 1.0));
        let centre = Vec3::new(1.0, 0.0, -1.0);
        let framing = Camera::framing(bounds);
        let yfov = Camera::framing_yfov();
        let front = Camera::orbit(bounds, 0.0, 0.0, None, yfov);
        assert!((front.position - framing.position).length() < 1e-5);
        assert!((front.forward - framing.forward).length() < 1e-6);
        assert!((front.up - framing.up).length() < 1e-6);
        // 90° of azimuth: on +X looking back along −X; 30° up at distance 5.
        let side = Camera::orbit(bounds, 90.0, 0.0, Some(5.0), yfov);
        assert!((side.position - (centre + 5.0 * Vec3::X)).length() < 1e-5);
        assert!((side.forward + Vec3::X).length() < 1e-6);
        let high = Camera::orbit(bounds, 0.0, 30.0, Some(2.0), yfov);
        assert!((high.position - centre - Vec3::new(0.0, 1.0, 3f32.sqrt())).length() < 1e-5);
        // Straight down: a finite frame whose image top points away from the camera's side.
        let top = Camera::orbit(bounds, 0.0, 90.0, Some(2.0), yfov);
        assert!((top.forward + Vec3::Y).length() < 1e-6);
        assert!((top.up + Vec3::Z).length() < 1e-5, "{}", top.up);
        for cam in [front, side, high, top] {
            assert!((cam.right - cam.forward.cross(cam.up)).length() < 1e-5);
            assert!(
                (cam.position + cam.forward * cam.distance_to_centre(bounds) - centre).length()
                    < 1e-4
            );
        }
    }

    #[test]
    fn look_at_refuses_what_has_no_frame() {
        let cam = Camera::look_at(Vec3::new(0.0, 1.0, 4.0), Vec3::ZERO, Vec3::Y, 0.5).unwrap();
        assert!((cam.forward - Vec3::new(0.0, -1.0, -4.0).normalize()).length() < 1e-6);
        assert!(cam.up.y > 0.9 && cam.up.dot(cam.forward).abs() < 1e-6);
        assert_eq!(cam.yfov(), Some(0.5));
        assert!(Camera::look_at(Vec3::ONE, Vec3::ONE, Vec3::Y, 0.5)
            .unwrap_err()
            .contains("looks at itself"));
        assert!(Camera::look_at(Vec3::Y, Vec3::ZERO, Vec3::Y, 0.5)
            .unwrap_err()
            .contains("parallel"));
    }

    #[test]
    fn node_frame_is_orthonormalised() {
        let world = Mat4::from_rotation_y(0.5) * Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0));
        let cam = Camera::from_node(&world, perspective(1.0), 0.1).unwrap();
        for v in [cam.forward, cam.right, cam.up] {
            assert!((v.length() - 1.0).abs() < 1e-6);
        }
        assert!(cam.forward.dot(cam.up).abs() < 1e-6);
        assert!((cam.right - cam.forward.cross(cam.up)).length() < 1e-6);
        assert!(Camera::from_node(&Mat4::ZERO, perspective(1.0), 0.1).is_err());
    }

    fn perspective(yfov: f32) -> Projection {
        Projection::Perspective {
            yfov,
            aspect_ratio: None,
        }
    }

    /// A camera at (1, 2, 3) turned 0.7 rad about +Y and tilted 0.2 rad about its right axis.
    fn turned(projection: Projection, znear: f32) -> Camera {
        let world = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
            * Mat4::from_rotation_y(0.7)
            * Mat4::from_rotation_x(0.2);
        Camera::from_node(&world, projection, znear).unwrap()
    }

    /// The frame of a `width`×`height` film for `camera` and `lens`.
    fn frame(camera: &Camera, width: u32, height: u32, lens: ThinLens) -> FrameParams {
        let mut f = FrameParams {
            width,
            height,
            aspect: width as f32 / height as f32,
            ..Default::default()
        };
        camera.write_frame_params(lens, &mut f);
        f
    }

    /// The film point's coordinates: (along right, along up) of the ray's origin relative to
    /// the camera.
    fn film_coordinates(camera: &Camera, ray: &Ray) -> Vec2 {
        let o = ray.origin - camera.position;
        Vec2::new(o.dot(camera.right), o.dot(camera.up))
    }

    #[test]
    fn orthographic_rays_are_parallel_and_span_xmag_and_ymag() {
        let (xmag, ymag) = (3.0, 2.0);
        let cam = turned(Projection::Orthographic { xmag, ymag }, 0.25);
        // A film of the camera's aspect, 3:2: the view is exactly ±xmag × ±ymag.
        let (w, h) = (30, 20);
        let f = frame(&cam, w, h, ThinLens::default());
        let ray = |pixel: u32, jitter: Vec2| camera_ray(&f, pixel, jitter, Vec2::splat(0.5));
        let corners = [
            (0, Vec2::ZERO, Vec2::new(-xmag, ymag)),
            (w - 1, Vec2::new(1.0, 0.0), Vec2::new(xmag, ymag)),
            (w * h - w, Vec2::new(0.0, 1.0), Vec2::new(-xmag, -ymag)),
            (w * h - 1, Vec2::ONE, Vec2::new(xmag, -ymag)),
        ];
        for (pixel, jitter, expected) in corners {
            let r = ray(pixel, jitter);
            assert_eq!(r.dir, cam.forward, "pixel {pixel}: not along the view");
            let at = film_coordinates(&cam, &r);
            assert!(
                (at - expected).abs().max_element() < 1e-5,
                "pixel {pixel} + {jitter}: origin at {at}, expected {expected}"
            );
            // On the near plane.
            let depth = (r.origin - cam.position).dot(cam.forward);
            assert!((depth - 0.25).abs() < 1e-6, "{depth}");
        }
        // Every ray parallel, including those of the pixels' interiors.
        for pixel in (0..w * h).step_by(37) {
            assert_eq!(ray(pixel, Vec2::new(0.3, 0.8)).dir, cam.forward);
        }
        // A wider film keeps ymag and widens the view: ±ymag·(60/20) horizontally.
        let wide = frame(&cam, 60, 20, ThinLens::default());
        let r = camera_ray(&wide, 59, Vec2::new(1.0, 0.0), Vec2::ZERO);
        let at = film_coordinates(&cam, &r);
        assert!((at - Vec2::new(3.0 * ymag, ymag)).abs().max_element() < 1e-5);
        assert_eq!(cam.aspect_ratio(), Some(1.5));
    }

    #[test]
    fn primary_rays_start_on_the_near_plane() {
        let cam = turned(perspective(0.9), 0.5);
        let f = frame(&cam, 16, 9, ThinLens::default());
        for pixel in [0, 7, 80, 143] {
            let r = camera_ray(&f, pixel, Vec2::new(0.25, 0.75), Vec2::ZERO);
            // From the pinhole, through the film point, starting znear deep.
            let depth = (r.origin - cam.position).dot(cam.forward);
            assert!((depth - 0.5).abs() < 1e-6, "pixel {pixel}: depth {depth}");
            let back = (r.origin - cam.position).normalize();
            assert!((back - r.dir).length() < 1e-6, "pixel {pixel}");
            assert!((r.dir.length() - 1.0).abs() < 1e-6);
        }
        // The image plane spans ±tan(yfov/2) vertically at unit depth, ±aspect times that across.
        let r = camera_ray(&f, 0, Vec2::ZERO, Vec2::ZERO);
        let d = r.dir / r.dir.dot(cam.forward);
        let t = (0.45f32).tan();
        assert!((d.dot(cam.up) - t).abs() < 1e-5);
        assert!((d.dot(cam.right) + t * 16.0 / 9.0).abs() < 1e-5);
        // znear 0 starts at the pinhole exactly.
        let pinhole = frame(&turned(perspective(0.9), 0.0), 16, 9, ThinLens::default());
        let r = camera_ray(&pinhole, 5, Vec2::splat(0.5), Vec2::ZERO);
        assert_eq!(r.origin, cam.position);
    }

    #[test]
    fn thin_lens_rays_of_one_film_point_meet_on_the_focus_plane() {
        let cam = turned(perspective(0.8), 0.1);
        let lens = ThinLens {
            radius: 0.3,
            focus_distance: 4.0,
        };
        let f = frame(&cam, 20, 10, lens);
        for (pixel, jitter) in [(0, Vec2::ZERO), (57, Vec2::new(0.3, 0.6)), (199, Vec2::ONE)] {
            let pinhole = {
                let mut p = f;
                p.lens_radius = 0.0;
                camera_ray(&p, pixel, jitter, Vec2::ZERO)
            };
            let focus =
                cam.position + pinhole.dir * (lens.focus_distance / pinhole.dir.dot(cam.forward));
            let mut spread = 0.0f32;
            for k in 0..64u32 {
                let lens_u = Vec2::new((k % 8) as f32 + 0.5, (k / 8) as f32 + 0.5) / 8.0;
                let r = camera_ray(&f, pixel, jitter, lens_u);
                // Where it crosses the focus plane.
                let t = (lens.focus_distance - (r.origin - cam.position).dot(cam.forward))
                    / r.dir.dot(cam.forward);
                let hit = r.origin + t * r.dir;
                assert!(
                    (hit - focus).length() < 1e-5,
                    "pixel {pixel}, lens {lens_u}: crosses the focus plane at {hit}, not {focus}"
                );
                // It starts on the near plane, within the lens's radius of the axis.
                let depth = (r.origin - cam.position).dot(cam.forward);
                assert!((depth - 0.1).abs() < 1e-6, "{depth}");
                let on_lens = r.origin - r.dir * (0.1 / r.dir.dot(cam.forward));
                let offset = on_lens - cam.position;
                assert!(offset.dot(cam.forward).abs() < 1e-6);
                assert!(offset.length() <= lens.radius + 1e-6);
                spread = spread.max(offset.length());
            }
            // The lens samples do cover the lens.
            assert!(spread > 0.8 * lens.radius, "{spread}");
        }
    }

    #[test]
    fn thin_lens_options_are_checked() {
        let bounds = (Vec3::new(-1.0, -1.0, -1.0), Vec3::ONE);
        let cam = Camera::framing(bounds);
        // Default focus: the bounding box's centre along the view.
        let lens = cam.thin_lens(0.2, None, bounds).unwrap();
        assert_eq!(lens.radius, 0.1);
        assert!((lens.focus_distance - cam.position.z).abs() < 1e-6);
        assert_eq!(
            cam.thin_lens(0.2, Some(2.5), bounds)
                .unwrap()
                .focus_distance,
            2.5
        );
        assert_eq!(cam.thin_lens(0.0, None, bounds).unwrap().radius, 0.0);
        let ortho = Camera {
            projection: Projection::Orthographic {
                xmag: 1.0,
                ymag: 1.0,
            },
            ..cam
        };
        let e = ortho.thin_lens(0.2, None, bounds).unwrap_err();
        assert!(
            e.contains("--aperture") && e.contains("orthographic"),
            "{e}"
        );
        assert!(ortho.thin_lens(0.0, None, bounds).is_ok());
        for bad in [-1.0, f32::NAN, f32::INFINITY] {
            assert!(cam.thin_lens(bad, None, bounds).is_err(), "{bad}");
        }
        let e = cam.thin_lens(0.2, Some(0.0), bounds).unwrap_err();
        assert!(e.contains("--focus-distance"), "{e}");
        // A scene behind the camera has no default focus.
        let behind = Camera {
            forward: Vec3::Z,
            right: Vec3::NEG_X,
            ..cam
        };
        let e = behind.thin_lens(0.2, None, bounds).unwrap_err();
        assert!(e.contains("--focus-distance"), "{e}");
    }
}
