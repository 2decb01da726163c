// The shading frame a vertex's lobes see: the shading normal bent towards the viewer, the
// anisotropy's tangent frame and roughness. Twin of src/bsdf/shading.rs.
#ifndef SHADING_GLSL
#define SHADING_GLSL
#include "microfacet.glsl"

// BsdfFrame::new_shading's minimum height of wo's reflection above the geometric surface.
#define SHADING_NORMAL_MIN_COS 0.01

// Shading normal ns (on ng's side) bent so that wo's mirror reflection about it lies at least
// SHADING_NORMAL_MIN_COS above the geometric surface (Keller et al. 2017, "The Iray Light
// Transport Simulation and Rendering System", A.3). ng, wo unit with dot(ng, wo) > 0.
vec3 bend_shading_normal(vec3 ns, vec3 ng, vec3 wo) {
    vec3 r = 2.0 * dot(wo, ns) * ns - wo;
    float height = dot(r, ng);
    if (height >= SHADING_NORMAL_MIN_COS) return ns;
    vec3 tangential = r - height * ng;
    float len = length(tangential);
    if (!(len > 1e-12)) return ng;
    vec3 lifted = tangential * (sqrt(1.0 - SHADING_NORMAL_MIN_COS * SHADING_NORMAL_MIN_COS) / len)
                + SHADING_NORMAL_MIN_COS * ng;
    return normalize(wo + lifted);
}

// KHR_materials_anisotropy's (alpha_t, alpha_b) = (mix(alpha, 1, strength^2), alpha); a delta
// where alpha_t < ALPHA_DELTA, else alpha_b at least ALPHA_DELTA (bsdf/shading.rs, anisotropic_alpha).
vec2 anisotropic_alpha(float alpha, float strength) {
    if (strength <= 0.0) return vec2(alpha);
    float at = alpha + (1.0 - alpha) * strength * strength;
    return vec2(at, at < ALPHA_DELTA ? alpha : max(alpha, ALPHA_DELTA));
}

// The tangent frame about n: the anisotropy direction made orthogonal to n where strength > 0,
// else (and where it is degenerate) build_frame's (bsdf/shading.rs, anisotropic_frame).
void anisotropic_frame(vec3 n, float strength, vec3 direction, out vec3 t, out vec3 b) {
    if (strength > 0.0) {
        t = direction - n * dot(n, direction);
        float len = length(t);
        if (len > 1e-12 && !isinf(len)) {
            t /= len;
            b = cross(n, t);
            return;
        }
    }
    build_frame(n, t, b);
}

#endif
