// The Lambertian BSDF: twin of src/bsdf.rs. Direction convention: wo points towards where the
// light goes (previous vertex), wi towards where it comes from; both point away from the
// surface; n is the shading normal flipped to wo's side. bsdf_eval returns f without the cosine.
#ifndef BSDF_GLSL
#define BSDF_GLSL
#include "sampling.glsl"

vec3 bsdf_eval(vec3 albedo, vec3 n, vec3 wo, vec3 wi) {
    return dot(n, wi) > 0.0 ? albedo * INV_PI : vec3(0.0);
}

// Pdf of bsdf_sample with respect to solid angle.
float bsdf_pdf(vec3 n, vec3 wo, vec3 wi) {
    return cosine_hemisphere_pdf(dot(n, wi));
}

// Cosine-weighted sample of wi around n; returns wi, writes f and the solid-angle pdf.
vec3 bsdf_sample(vec3 albedo, vec3 n, vec3 wo, vec2 u, out vec3 f, out float pdf) {
    vec3 local = sample_cosine_hemisphere(u);
    vec3 t, b;
    build_frame(n, t, b);
    vec3 wi = normalize(t * local.x + b * local.y + n * local.z);
    f = bsdf_eval(albedo, n, wo, wi);
    pdf = bsdf_pdf(n, wo, wi);
    return wi;
}

#endif
