// Warps with their pdfs (measure named) and inverses: twin of src/sampling.rs.
#ifndef SAMPLING_GLSL
#define SAMPLING_GLSL
#include "convert.glsl"

#define PI 3.14159265358979323846
#define INV_PI 0.31830988618379067154

// Cosine-weighted direction around +Z (Malley's method, disk CDF inverted: r = sqrt(u0)).
vec3 sample_cosine_hemisphere(vec2 u) {
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float z = sqrt(max(1.0 - u.x, 0.0));
    return vec3(r * cos(phi), r * sin(phi), z);
}

// Pdf of sample_cosine_hemisphere with respect to solid angle: cos(theta) / pi.
float cosine_hemisphere_pdf(float cos_theta) {
    return max(cos_theta, 0.0) * INV_PI;
}

vec2 invert_cosine_hemisphere_sample(vec3 w) {
    float phi = atan(w.y, w.x) / (2.0 * PI);
    if (phi < 0.0) phi += 1.0;
    return vec2(w.x * w.x + w.y * w.y, phi);
}

// Uniform point on a triangle as barycentrics (b1, b2) of p1, p2 (Shirley & Chiu 1997).
vec2 sample_uniform_triangle(vec2 u) {
    float su = sqrt(u.x);
    return vec2(u.y * su, (1.0 - u.y) * su);
}

// Pdf of sample_uniform_triangle with respect to area: 1 / area.
float uniform_triangle_pdf(float area) {
    return 1.0 / area;
}

vec2 invert_uniform_triangle_sample(vec2 b) {
    float su = b.x + b.y;
    return vec2(su * su, su > 0.0 ? b.x / su : 0.0);
}

// Uniform point on the unit disk by Shirley and Chiu's concentric mapping ("A Low Distortion Map
// Between Disk and Square", JGT 1997; pbrt-v3 13.6.2): twin of sampling::sample_concentric_disk.
vec2 sample_concentric_disk(vec2 u) {
    vec2 a = 2.0 * u - vec2(1.0);
    if (a.x == 0.0 && a.y == 0.0) return vec2(0.0);
    float r, phi;
    if (abs(a.x) > abs(a.y)) {
        r = a.x;
        phi = (0.25 * PI) * (a.y / a.x);
    } else {
        r = a.y;
        phi = 0.5 * PI - (0.25 * PI) * (a.x / a.y);
    }
    return r * vec2(cos(phi), sin(phi));
}

// Pdf of sample_concentric_disk with respect to area on the unit disk: 1 / pi.
float uniform_disk_pdf() {
    return INV_PI;
}

// Russian roulette for a single integral (lecture): survive with probability p, weight 1/p;
// p >= 1 always survives with weight 1. Twin of mc::roulette_f32.
bool roulette(float u, float p, out float weight) {
    weight = 1.0;
    if (p >= 1.0) return true;
    if (u < p) {
        weight = 1.0 / p;
        return true;
    }
    return false;
}

// Orthonormal basis around unit n (Duff et al., JCGT 2017, Listing 3).
void build_frame(vec3 n, out vec3 t, out vec3 b) {
    float sign_z = n.z >= 0.0 ? 1.0 : -1.0;
    float a = -1.0 / (sign_z + n.z);
    float bb = n.x * n.y * a;
    t = vec3(1.0 + sign_z * n.x * n.x * a, sign_z * bb, -sign_z * n.x);
    b = vec3(bb, sign_z + n.y * n.y * a, -n.y);
}

// Moves p off its surface along n, the side the new ray leaves to (Waechter & Binder, Ray
// Tracing Gems, ch. 6). n is a unit normal, so int_scale * n is within trunc_to_int's range.
vec3 offset_ray_origin(vec3 p, vec3 n) {
    const float origin = 1.0 / 32.0;
    const float float_scale = 1.0 / 65536.0;
    const float int_scale = 256.0;
    ivec3 of_i = trunc_to_int(int_scale * n);
    vec3 p_i = intBitsToFloat(floatBitsToInt(p) + ivec3(p.x < 0.0 ? -of_i.x : of_i.x,
                                                       p.y < 0.0 ? -of_i.y : of_i.y,
                                                       p.z < 0.0 ? -of_i.z : of_i.z));
    return vec3(abs(p.x) < origin ? p.x + float_scale * n.x : p_i.x,
                abs(p.y) < origin ? p.y + float_scale * n.y : p_i.y,
                abs(p.z) < origin ? p.z + float_scale * n.z : p_i.z);
}

// Uniform direction in the cone of half-angle theta_max around +Z (cos theta uniform on
// [cos theta_max, 1]); cos_max = -1 gives the whole sphere (src/sampling.rs).
vec3 sample_uniform_cone(vec2 u, float cos_max) {
    float z = 1.0 - u.x * (1.0 - cos_max);
    float r = sqrt(max(1.0 - z * z, 0.0));
    float phi = 2.0 * PI * u.y;
    return vec3(r * cos(phi), r * sin(phi), z);
}

// Pdf of sample_uniform_cone with respect to solid angle: 1 / (2 pi (1 - cos theta_max)).
float uniform_cone_pdf(float cos_max) {
    return 1.0 / (2.0 * PI * (1.0 - cos_max));
}

#endif
