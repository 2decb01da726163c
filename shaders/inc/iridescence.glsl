// KHR_materials_iridescence's thin-film Fresnel (Belcour & Barla 2017, as the extension's
// evalIridescence / evalSensitivity write it): twin of src/bsdf/iridescence.rs, same names;
// the model's notes are written down there.
#ifndef IRIDESCENCE_GLSL
#define IRIDESCENCE_GLSL
#include "sampling.glsl"

float ior_to_fresnel0(float transmitted, float incident) {
    float r = (transmitted - incident) / (transmitted + incident);
    return r * r;
}

vec3 fresnel0_to_ior(vec3 f0) {
    vec3 s = sqrt(f0);
    return (vec3(1.0) + s) / (vec3(1.0) - s);
}

float iridescence_schlick(float f0, float cos_theta) {
    float m = clamp(1.0 - cos_theta, 0.0, 1.0);
    return f0 + (1.0 - f0) * m * m * m * m * m;
}

// cos x for the film's phases, by the same additions and products as src/bsdf/iridescence.rs:
// x less its nearest whole turns (Cody & Waite: 2 pi as 6.28125, exact in multiples, plus the
// rest), then cos's Taylor series to x^18 by Horner's rule. Vulkan holds a device's own cos to
// nothing outside [-pi, pi] (and to 2^-11 inside).
float film_cos(float x) {
    const float TURN = 2.0 * PI;
    float k = floor(x * (1.0 / TURN) + 0.5);
    float r = (x - k * 6.28125) - k * 1.935307169e-03;
    float r2 = r * r;
    float p = -1.561920681e-16;
    p = p * r2 + 4.779477256e-14;
    p = p * r2 - 1.147074536e-11;
    p = p * r2 + 2.087675588e-09;
    p = p * r2 - 2.755731998e-07;
    p = p * r2 + 2.480158764e-05;
    p = p * r2 - 1.388888923e-03;
    p = p * r2 + 4.166666791e-02;
    p = p * r2 - 5.000000000e-01;
    return p * r2 + 1.0;
}

vec3 film_cos(vec3 x) {
    return vec3(film_cos(x.x), film_cos(x.y), film_cos(x.z));
}

// The XYZ matching functions' response to optical path difference opd (nm), in linear Rec. 709.
vec3 eval_sensitivity(float opd, vec3 shift) {
    float phase = 2.0 * PI * opd * 1.0e-9;
    vec3 val = vec3(5.4856e-13, 4.4201e-13, 5.2481e-13);
    vec3 pos = vec3(1.6810e+06, 1.7953e+06, 2.2084e+06);
    vec3 var = vec3(4.3278e+09, 9.3046e+09, 6.6121e+09);
    vec3 xyz = val * sqrt(2.0 * PI * var) * film_cos(pos * phase + shift) * exp(-phase * phase * var);
    xyz.x += 9.7470e-14 * sqrt(2.0 * PI * 4.5282e+09) * film_cos(2.2399e+06 * phase + shift.x)
           * exp(-4.5282e+09 * phase * phase);
    xyz /= 1.0685e-7;
    return vec3(3.2404542 * xyz.x - 1.5371385 * xyz.y - 0.4985314 * xyz.z,
                -0.9692660 * xyz.x + 1.8760108 * xyz.y + 0.0415560 * xyz.z,
                0.0556434 * xyz.x - 0.2040259 * xyz.y + 1.0572252 * xyz.z);
}

// The thin film's RGB reflectance at cosine cos1, over a base of RGB F0 base_f0.
vec3 fresnel_iridescence(float outside_ior, float film_ior, float cos1, float thickness, vec3 base_f0) {
    float t = clamp(thickness / 0.03, 0.0, 1.0);
    float film = outside_ior + (film_ior - outside_ior) * t * t * (3.0 - 2.0 * t);
    float sin2_2 = (outside_ior / film) * (outside_ior / film) * (1.0 - cos1 * cos1);
    float cos2_sq = 1.0 - sin2_2;
    if (cos2_sq < 0.0) return vec3(1.0);
    float cos2 = sqrt(cos2_sq);
    float r12 = iridescence_schlick(ior_to_fresnel0(film, outside_ior), cos1);
    float t121 = 1.0 - r12;
    float phi12 = film < outside_ior ? PI : 0.0;
    float phi21 = PI - phi12;
    vec3 base_ior = fresnel0_to_ior(clamp(base_f0, vec3(0.0), vec3(0.9999)));
    vec3 r23 = vec3(iridescence_schlick(ior_to_fresnel0(base_ior.x, film), cos2),
                    iridescence_schlick(ior_to_fresnel0(base_ior.y, film), cos2),
                    iridescence_schlick(ior_to_fresnel0(base_ior.z, film), cos2));
    vec3 phi23 = vec3(base_ior.x < film ? PI : 0.0, base_ior.y < film ? PI : 0.0, base_ior.z < film ? PI : 0.0);
    float opd = 2.0 * film * thickness * cos2;
    vec3 phi = vec3(phi21) + phi23;
    vec3 r123 = clamp(r12 * r23, vec3(1e-5), vec3(0.9999));
    vec3 sqrt_r123 = sqrt(r123);
    vec3 rs = t121 * t121 * r23 / (vec3(1.0) - r123);
    vec3 i = vec3(r12) + rs;
    vec3 cm = rs - vec3(t121);
    for (int m = 1; m <= 2; m++) {
        cm *= sqrt_r123;
        i += cm * 2.0 * eval_sensitivity(float(m) * opd, float(m) * phi);
    }
    return max(i, vec3(0.0));
}

#endif
