// Light tracing ("next event estimation for light tracing"): the GPU twin of the light-subpath
// half of src/cpu/bidir/light_tracing.rs, same names. Paths start on an emitter chosen by power and every
// vertex is joined to the pinhole; the contribution splats onto the pixel it lands in.
#ifndef LIGHT_TRACING_GLSL
#define LIGHT_TRACING_GLSL
#include "scene_arrays.glsl"
#include "convert.glsl"
#include "punctual.glsl"

// The pixel a direction from the pinhole lands in, the film-wide importance W_e = 1/(A cos^4)
// (area measure) and the direction pdf 1/(A cos^3), A = 4 tan^2(fov/2) aspect; false outside
// the film (src/cpu/bidir/light_tracing.rs, camera_importance).
bool camera_importance(vec3 dir, out uint pixel, out float we, out float pdf) {
    pixel = 0u;
    we = 0.0;
    pdf = 0.0;
    float c = dot(dir, frame.cam_forward);
    if (!(c > 0.0)) return false;
    float t = frame.tan_half_fov_y;
    float sx = dot(dir, frame.cam_right) / (c * t * frame.aspect);
    float sy = dot(dir, frame.cam_up) / (c * t);
    float px = (sx + 1.0) * 0.5 * float(frame.width);
    float py = (1.0 - sy) * 0.5 * float(frame.height);
    if (!(px >= 0.0 && px < float(frame.width) && py >= 0.0 && py < float(frame.height))) return false;
    uvec2 at = uvec2(trunc_to_int(vec2(py, px)));
    pixel = min(at.x, frame.height - 1u) * frame.width + min(at.y, frame.width - 1u);
    float film_area = 4.0 * t * t * frame.aspect;
    pdf = 1.0 / (film_area * c * c * c);
    we = pdf / c;
    return true;
}

// phi(w_cam, w_light) of a scattering vertex: f |n_s . w_light| / |n_g . w_light|, f the path
// tracer's BSDF seen from the camera side (src/cpu/bidir/light_tracing.rs, phi).
vec3 phi(GpuMaterial mat, vec3 ng, vec3 ns, vec3 w_cam, vec3 w_light) {
    float cos_g = abs(dot(ng, w_light));
    BsdfFrame f;
    if (!(cos_g > 0.0) || !bsdf_frame_new_shading(mat, ng, ns, w_cam, f)) return vec3(0.0);
    return bsdf_frame_eval(f, w_light, TRANSPORT_RADIANCE) * (bsdf_frame_cos(f, w_light) / cos_g);
}

// Whether the camera, in direction w from a point of triangle `index` (front-face normal ng),
// sees the point: not on the back face of a single-sided triangle, which primary rays cull
// (surface.glsl, culled; src/cpu/bidir/light_tracing.rs, camera_sees).
bool camera_sees(uint index, vec3 ng, vec3 w) {
    return (triangle_at(index).material & TRIANGLE_TEST_CULL) == 0u || dot(ng, w) >= 0.0;
}

// A surface vertex can be joined to the camera if its material has a non-delta lobe.
bool connectible(GpuMaterial m) {
    float alpha = m.roughness * m.roughness;
    return (1.0 - m.metallic) * (1.0 - m.transmission) > 0.0 || alpha >= ALPHA_DELTA;
}

// Queues the join of vertex p (geometric normal ng, or a punctual light: on_surface false) to
// the pinhole, carrying beta * value * G * W_e, value the vertex's phi or emission towards the
// camera given by value_towards(w). The shadow ray's `pad` names the pixel it lands in.
bool camera_connection(vec3 p, vec3 ng, bool on_surface, out vec3 w, out float dist,
                       out uint pixel, out float g_we, out ShadowRay shadow) {
    vec3 cam = frame.cam_position;
    vec3 d = cam - p;
    dist = length(d);
    w = d / dist;
    g_we = 0.0;
    float we, pdf;
    if (!camera_importance(-w, pixel, we, pdf)) return false;
    float cos_cam = dot(-w, frame.cam_forward);
    // Camera rays start on the near plane.
    if (cos_cam * dist <= frame.cam_znear) return false;
    float cos_here = on_surface ? abs(dot(ng, w)) : 1.0;
    g_we = cos_here * cos_cam / (dist * dist) * we;
    shadow.origin = on_surface ? offset_ray_origin(p, dot(ng, w) > 0.0 ? ng : -ng) : p;
    vec3 target = cam - w * (frame.cam_znear / cos_cam);
    vec3 seg = target - shadow.origin;
    shadow.t_max = length(seg);
    shadow.dir = seg / shadow.t_max;
    shadow.pad = pixel;
    return true;
}

// Queues a join to the camera that camera_connection made, carrying `contribution`, unless it
// is zero or the path expression (`accepted`) leaves the path out.
void queue_camera_join(ShadowRay shadow, vec3 contribution, uint path, bool accepted) {
    if (!(max_component(contribution) > 0.0) || !accepted) return;
    shadow.contribution = contribution;
    shadow.path = path;
    shadow_rays[queue_push_slot(COUNTER_SHADOW)] = shadow;
}

// Adds c to pixel's splat sums of the batch's pass `slot` (the sample index less the batch's
// first: a batch holds whole passes, or a run of pixels of one): each channel in units of
// 2^-24 as a 64-bit integer split into a low and a high word; the low word's carry is detected
// from atomicAdd's old value, so the total is exact and independent of the order of the
// additions. Non-finite, negative and absurd (>= 2^39) values are not added.
void splat_add(uint slot, uint pixel, vec3 c) {
    pixel += slot * frame.band_pixel_count;
    for (uint ch = 0u; ch < 3u; ch++) {
        float v = c[ch];
        if (!(v > 0.0) || !(v < 549755813888.0)) continue;
        float hi_f = floor(v * (1.0 / 256.0));
        float lo_f = (v - hi_f * 256.0) * 16777216.0;
        uint hi = uint(hi_f);
        uint lo = uint(lo_f < 16777216.0 ? lo_f + 0.5 : lo_f);
        uint word = 6u * pixel + 2u * ch;
        uint old = atomicAdd(splats[word], lo);
        uint carry = old > 0xffffffffu - lo ? 1u : 0u;
        if (hi + carry != 0u) atomicAdd(splats[word + 1u], hi + carry);
    }
}

#endif
