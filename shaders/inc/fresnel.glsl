// Fresnel terms: the clear coat's Schlick reflectance, and the layered Fresnel of the base
// (dielectric and metal, with the thin film mixed in). Twin of src/bsdf/fresnel.rs.
#ifndef FRESNEL_GLSL
#define FRESNEL_GLSL
#include "microfacet.glsl"
#include "iridescence.glsl"

// The clearcoat's Fresnel weight, F0 = 0.04 (ior 1.5) (KHR_materials_clearcoat, fresnel_coat).
float fresnel_coat(float cos_theta) {
    float f0 = dielectric_f0(1.5);
    return f0 + (1.0 - f0) * schlick_weight(abs(cos_theta));
}

// The dielectric (RGB) and metal Fresnel terms at cosine cos to the microfacet normal on wo's
// side, each mixed with the thin film's by its factor (bsdf/fresnel.rs, fresnel_layers).
void fresnel_layers(float cos_theta, vec3 f0, float f90, float etap, vec3 base, float metallic,
                    float film, float film_ior, float film_thickness, out vec3 fd, out vec3 fm) {
    fd = fresnel_dielectric_color(cos_theta, f0, f90, etap);
    fm = fresnel_conductor(base, cos_theta);
    if (!SCENE_HAS(FEATURE_IRIDESCENCE) || film <= 0.0) return;
    float c = min(abs(cos_theta), 1.0);
    bool tir = false;
    if (etap < 1.0) {
        float sin2_t = (1.0 - c * c) / (etap * etap);
        tir = sin2_t >= 1.0;
        c = sqrt(max(1.0 - sin2_t, 0.0));
    }
    if (!tir && metallic < 1.0) {
        vec3 thin = min(fresnel_iridescence(1.0, film_ior, c, film_thickness, f0), vec3(1.0));
        fd += (thin - fd) * film;
    }
    if (metallic > 0.0) {
        vec3 thin = min(fresnel_iridescence(1.0, film_ior, min(abs(cos_theta), 1.0), film_thickness, base), vec3(1.0));
        fm += (thin - fm) * film;
    }
}

#endif
