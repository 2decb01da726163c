// Primary rays of perspective (pinhole or thin-lens) and orthographic cameras: twin of
// camera_ray in src/scene/camera.rs, which derives the formulas. Needs layout.glsl and
// sampling.glsl; reads only its FrameParams argument, so test kernels can run it too.
#ifndef CAMERA_GLSL
#define CAMERA_GLSL

// The ray through film point (pixel + jitter), row 0 at the top, with lens sample lens_u. The
// film point in units of the view's half-height is (sx, sy) in [-aspect, aspect] x [-1, 1].
// Orthographic: parallel rays along cam_forward from ymag * (sx, sy). Perspective: the pinhole ray
// along d = forward + tan(yfov/2) (sx right + sy up); a thin lens starts it at a concentric-disk
// point of the lens, aimed at position + focus_distance * d on the plane in focus (pbrt-v3
// 6.2.3). Every ray starts on the near plane, cam_znear along cam_forward.
void camera_ray(FrameParams f, uint pixel, vec2 jitter, vec2 lens_u, out vec3 origin, out vec3 dir) {
    float px = float(pixel % f.width) + jitter.x;
    float py = float(pixel / f.width) + jitter.y;
    if (f.cam_projection == CAMERA_ORTHOGRAPHIC) {
        float sx = (2.0 * px / float(f.width) - 1.0) * f.cam_ymag * f.aspect;
        float sy = (1.0 - 2.0 * py / float(f.height)) * f.cam_ymag;
        origin = f.cam_position + sx * f.cam_right + sy * f.cam_up + f.cam_znear * f.cam_forward;
        dir = f.cam_forward;
        return;
    }
    float sx = (2.0 * px / float(f.width) - 1.0) * f.tan_half_fov_y * f.aspect;
    float sy = (1.0 - 2.0 * py / float(f.height)) * f.tan_half_fov_y;
    vec3 d = f.cam_forward + sx * f.cam_right + sy * f.cam_up;
    vec3 lens_point = f.cam_position;
    if (f.lens_radius > 0.0) {
        vec2 lens = f.lens_radius * sample_concentric_disk(lens_u);
        lens_point = f.cam_position + lens.x * f.cam_right + lens.y * f.cam_up;
        vec3 focus_point = f.cam_position + f.focus_distance * d;
        dir = normalize(focus_point - lens_point);
    } else {
        dir = normalize(d);
    }
    origin = lens_point + (f.cam_znear / dot(dir, f.cam_forward)) * dir;
}

#endif
