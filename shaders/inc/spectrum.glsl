// Spectral sampling for KHR_materials_dispersion: one wavelength per path. Twin of
// src/spectrum.rs, same names; the RGB conversion and which paths carry a wavelength are
// stated in its module docs.
#ifndef SPECTRUM_GLSL
#define SPECTRUM_GLSL

#define LAMBDA_MIN 360.0
#define LAMBDA_MAX 830.0
// Per-channel integral of the clipped response (spectrum::RESPONSE_NORMALISATION).
#define RESPONSE_NORMALISATION vec3(176.17732, 115.391275, 109.370545)

// One lobe of the piecewise Gaussian of Wyman, Sloan & Shirley 2013, eq. 2.
float spectrum_lobe(float lambda, float mu, float sigma1, float sigma2) {
    float t = (lambda - mu) / (lambda < mu ? sigma1 : sigma2);
    return exp(-0.5 * t * t);
}

// CIE 1931 2-degree colour-matching functions (Wyman et al. 2013, multi-lobe fit).
vec3 cie_xyz(float lambda) {
    float x = 1.056 * spectrum_lobe(lambda, 599.8, 37.9, 31.0) + 0.362 * spectrum_lobe(lambda, 442.0, 16.0, 26.7)
        - 0.065 * spectrum_lobe(lambda, 501.1, 20.4, 26.2);
    float y = 0.821 * spectrum_lobe(lambda, 568.8, 46.9, 40.5) + 0.286 * spectrum_lobe(lambda, 530.9, 16.3, 31.1);
    float z = 1.217 * spectrum_lobe(lambda, 437.0, 11.8, 36.0) + 0.681 * spectrum_lobe(lambda, 459.0, 26.0, 13.8);
    return vec3(x, y, z);
}

// CIE XYZ -> linear sRGB (D65), IEC 61966-2-1.
vec3 xyz_to_linear_srgb(vec3 c) {
    return vec3(3.2404542 * c.x - 1.5371385 * c.y - 0.4985314 * c.z,
                -0.969266 * c.x + 1.8760108 * c.y + 0.041556 * c.z,
                0.0556434 * c.x - 0.2040259 * c.y + 1.0572252 * c.z);
}

// r(lambda): linear sRGB response, each channel integrating to 1 over the range.
vec3 wavelength_rgb(float lambda) {
    if (!(lambda >= LAMBDA_MIN && lambda <= LAMBDA_MAX)) return vec3(0.0);
    return max(xyz_to_linear_srgb(cie_xyz(lambda)), vec3(0.0)) / RESPONSE_NORMALISATION;
}

// Inverse CDF of p ~ sech^2(0.0072 (lambda - 538)) (Radziszewski et al. 2009; pbrt-v4).
float sample_wavelength(float u) {
    float lambda = 538.0 - 138.88889 * atanh(0.8569106 - 1.827502 * u);
    return clamp(lambda, LAMBDA_MIN, LAMBDA_MAX);
}

float wavelength_pdf(float lambda) {
    if (!(lambda >= LAMBDA_MIN && lambda <= LAMBDA_MAX)) return 0.0;
    float c = cosh(0.0072 * (lambda - 538.0));
    return 0.003939804 / (c * c);
}

// r(lambda) / p(lambda).
vec3 wavelength_weight(float lambda) {
    float pdf = wavelength_pdf(lambda);
    return pdf > 0.0 ? wavelength_rgb(lambda) / pdf : vec3(0.0);
}

// KHR_materials_dispersion: n(lambda) = max(n_d + (n_d - 1)/V_d (523655/lambda^2 - 1.5168), 1),
// V_d = 20 / dispersion.
float dispersive_ior(float ior, float dispersion, float lambda) {
    if (dispersion <= 0.0) return ior;
    return max(ior + (ior - 1.0) * (dispersion / 20.0) * (523655.0 / (lambda * lambda) - 1.5168), 1.0);
}

bool is_dispersive(GpuMaterial m) {
    return m.dispersion > 0.0 && m.transmission > 0.0 && m.thickness > 0.0 && m.metallic < 1.0
        && (m.flags & MATERIAL_UNLIT) == 0u;
}

// The material as a path of wavelength lambda sees it (0: no change).
void material_at_wavelength(inout GpuMaterial m, float lambda) {
    if (lambda > 0.0 && is_dispersive(m)) m.ior = dispersive_ior(m.ior, m.dispersion, lambda);
}

// The wavelength of sample (pixel, sample_index): the x of its own block.
float sample_wavelength_of(uint seed, uint pixel, uint sample_index) {
    return sample_wavelength(rng_uniform4(seed, pixel, sample_index, WAVELENGTH_BLOCK).x);
}

#endif
