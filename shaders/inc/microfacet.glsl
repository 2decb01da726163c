// The GGX (Trowbridge-Reitz) microfacet model and Schlick's Fresnel in the local shading frame
// (+Z = normal): twin of src/bsdf/microfacet.rs. glTF 2.0 Appendix B: GGX D with
// alpha = roughness^2, height-correlated Smith visibility, Schlick on v.h; visible normals
// sampled after Heitz, JCGT 7(4), 2018. alpha = (alpha_x, alpha_y) along the frame's tangent and
// bitangent: KHR_materials_anisotropy's GGX, isotropic where the two are equal.
#ifndef MICROFACET_GLSL
#define MICROFACET_GLSL
#include "sampling.glsl"

// Below this alpha the specular lobes are perfectly smooth (delta lobes).
#define ALPHA_DELTA 1e-3

// GGX D(m), solid angle of microfacet normals: 1 / (pi ax ay (mx^2/ax^2 + my^2/ay^2 + mz^2)^2)
// (Heitz 2014, eq. 85; KHR_materials_anisotropy's D_GGX_anisotropic); no cancellation for
// narrow lobes.
float ggx_d(vec3 m, vec2 alpha) {
    if (m.z <= 0.0) return 0.0;
    float x = m.x / alpha.x;
    float y = m.y / alpha.y;
    float d = x * x + y * y + m.z * m.z;
    return 1.0 / (PI * alpha.x * alpha.y * d * d);
}

// Smith's Lambda for GGX (Heitz 2014, eqs. 72 and 86).
float ggx_lambda(vec3 w, vec2 alpha) {
    float c2 = w.z * w.z;
    if (c2 == 0.0) return 3.402823466e38;  // grazing: fully masked
    float x = alpha.x * w.x;
    float y = alpha.y * w.y;
    float t2 = (x * x + y * y) / c2;
    return 0.5 * (-1.0 + sqrt(1.0 + t2));
}

float ggx_g1(vec3 w, vec2 alpha) {
    return 1.0 / (1.0 + ggx_lambda(w, alpha));
}

// Height-correlated Smith visibility G2 / (4 |n.l| |n.v|) of local wo, wi (either side), as
// KHR_materials_anisotropy's V_GGX_anisotropic (glTF Appendix B's where ax = ay) writes it.
float ggx_visibility(vec3 wo, vec3 wi, vec2 alpha) {
    float denom = abs(wi.z) * length(vec3(alpha * wo.xy, wo.z)) + abs(wo.z) * length(vec3(alpha * wi.xy, wi.z));
    return denom > 0.0 ? 0.5 / denom : 0.0;
}

// A visible normal of GGX seen from wo (wo.z > 0) (Heitz 2018, listing 1, anisotropic).
vec3 sample_ggx_vndf(vec3 wo, vec2 alpha, vec2 u) {
    vec3 vh = normalize(vec3(alpha.x * wo.x, alpha.y * wo.y, wo.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    vec3 t1 = lensq > 0.0 ? vec3(-vh.y, vh.x, 0.0) / sqrt(lensq) : vec3(1.0, 0.0, 0.0);
    vec3 t2 = cross(vh, t1);
    float r = sqrt(u.x);
    float phi = 2.0 * PI * u.y;
    float p1 = r * cos(phi);
    float s = 0.5 * (1.0 + vh.z);
    float p2 = (1.0 - s) * sqrt(max(1.0 - p1 * p1, 0.0)) + s * r * sin(phi);
    vec3 nh = p1 * t1 + p2 * t2 + sqrt(max(1.0 - p1 * p1 - p2 * p2, 0.0)) * vh;
    return normalize(vec3(alpha.x * nh.x, alpha.y * nh.y, max(nh.z, 0.0)));
}

// Pdf of sample_ggx_vndf, solid angle of microfacet normals (Heitz 2018, eq. 1).
float ggx_vndf_pdf(vec3 wo, vec3 m, vec2 alpha) {
    if (wo.z <= 0.0) return 0.0;
    return ggx_g1(wo, alpha) * max(dot(wo, m), 0.0) * ggx_d(m, alpha) / wo.z;
}

float schlick_weight(float cos_theta) {
    float m = clamp(1.0 - cos_theta, 0.0, 1.0);
    float m2 = m * m;
    return m2 * m2 * m;
}

// glTF's metal Fresnel: baseColor + (1 - baseColor)(1 - |v.h|)^5.
vec3 fresnel_conductor(vec3 base_color, float cos_theta) {
    return base_color + (vec3(1.0) - base_color) * schlick_weight(abs(cos_theta));
}

// glTF's dielectric Fresnel with KHR_materials_specular's F0, F90; leaving a denser medium
// (etap < 1) Schlick on the transmitted angle, total internal reflection beyond the critical one.
float fresnel_dielectric(float cos_i, float f0, float f90, float etap) {
    float c = min(abs(cos_i), 1.0);
    if (etap < 1.0) {
        float sin2_t = (1.0 - c * c) / (etap * etap);
        if (sin2_t >= 1.0) return 1.0;
        c = sqrt(1.0 - sin2_t);
    }
    return f0 + (f90 - f0) * schlick_weight(c);
}

// fresnel_dielectric with an RGB F0 (KHR_materials_specular's specularColor).
vec3 fresnel_dielectric_color(float cos_i, vec3 f0, float f90, float etap) {
    float c = min(abs(cos_i), 1.0);
    if (etap < 1.0) {
        float sin2_t = (1.0 - c * c) / (etap * etap);
        if (sin2_t >= 1.0) return vec3(1.0);
        c = sqrt(1.0 - sin2_t);
    }
    return f0 + (vec3(f90) - f0) * schlick_weight(c);
}

float dielectric_f0(float ior) {
    float r = (ior - 1.0) / (ior + 1.0);
    return r * r;
}

// KHR_materials_specular's dielectric F0: min(((ior - 1)/(ior + 1))^2 specularColor, 1) specular.
vec3 specular_f0(float ior, vec3 specular_color, float specular) {
    return min(dielectric_f0(ior) * specular_color, vec3(1.0)) * specular;
}

vec3 reflect_about(vec3 wo, vec3 m) {
    return 2.0 * dot(wo, m) * m - wo;
}

// Refraction of wo (wo.m > 0) through the interface with normal m, etap = eta_t / eta_i;
// false on total internal reflection.
bool refract_through(vec3 wo, vec3 m, float etap, out vec3 wi) {
    float cos_i = dot(wo, m);
    float sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (etap * etap);
    wi = vec3(0.0);
    if (sin2_t >= 1.0) return false;
    float cos_t = sqrt(1.0 - sin2_t);
    wi = -wo / etap + (cos_i / etap - cos_t) * m;
    return true;
}

#endif
