// KHR_materials_sheen's Charlie distribution and visibility (Conty Estevez & Kulla 2017, as the
// extension writes them) and the tabulated directional albedo: twin of src/bsdf/sheen.rs, same
// names; the model's notes (the roughness clamp, where E exceeds 1) are written down there.
// The E table is FrameParams.sheen_albedo (four entries a vec4): SHEEN_ALBEDO_TABLE names where
// it is bound, `frame.sheen_albedo` (bindings.glsl) unless the includer says otherwise.
#ifndef SHEEN_GLSL
#define SHEEN_GLSL
#ifndef SHEEN_ALBEDO_TABLE
#define SHEEN_ALBEDO_TABLE frame.sheen_albedo
#endif

#define SHEEN_MIN_ROUGHNESS 0.07
#define SHEEN_TABLE_SIZE 32

float sheen_alpha(float roughness) {
    float r = max(roughness, SHEEN_MIN_ROUGHNESS);
    return r * r;
}

// D_s(h) = (2 + 1/alpha) sin^(1/alpha)(theta_h) / 2pi.
float charlie_d(float cos_h, float alpha) {
    float inv_r = 1.0 / alpha;
    float sin2h = max(1.0 - cos_h * cos_h, 0.0);
    return (2.0 + inv_r) * pow(sin2h, inv_r * 0.5) / (2.0 * PI);
}

float sheen_l(float x, float alpha) {
    float t = (1.0 - alpha) * (1.0 - alpha);
    float a = mix(21.5473, 25.3245, t);
    float b = mix(3.82987, 3.32435, t);
    float c = mix(0.19823, 0.16801, t);
    float d = mix(-1.97760, -1.27393, t);
    float e = mix(-4.32054, -4.85967, t);
    return a / (1.0 + b * pow(x, c)) + d * x + e;
}

float sheen_lambda(float cos_theta, float alpha) {
    float c = abs(cos_theta);
    return c < 0.5 ? exp(sheen_l(c, alpha)) : exp(2.0 * sheen_l(0.5, alpha) - sheen_l(1.0 - c, alpha));
}

// nu_s = G_s / (4 |n.l| |n.v|), G_s = 1 / (1 + Lambda(v) + Lambda(l)).
float sheen_visibility(float cos_o, float cos_i, float alpha) {
    float denom = (1.0 + sheen_lambda(cos_o, alpha) + sheen_lambda(cos_i, alpha))
                * (4.0 * abs(cos_o) * abs(cos_i));
    return denom > 0.0 ? 1.0 / denom : 0.0;
}

float sheen_albedo_node(int k) {
    return SHEEN_ALBEDO_TABLE[k >> 2][k & 3];
}

// E(cos theta) of the white lobe, bilinear in the table over (|cos|, roughness).
float sheen_albedo(float cos_theta, float roughness) {
    float last = float(SHEEN_TABLE_SIZE - 1);
    float x = clamp(abs(cos_theta), 0.0, 1.0) * last;
    float y = clamp(roughness, 0.0, 1.0) * last;
    int i = min(int(x), SHEEN_TABLE_SIZE - 2);
    int j = min(int(y), SHEEN_TABLE_SIZE - 2);
    float fx = x - float(i);
    float fy = y - float(j);
    float a00 = sheen_albedo_node(j * SHEEN_TABLE_SIZE + i);
    float a10 = sheen_albedo_node(j * SHEEN_TABLE_SIZE + i + 1);
    float a01 = sheen_albedo_node((j + 1) * SHEEN_TABLE_SIZE + i);
    float a11 = sheen_albedo_node((j + 1) * SHEEN_TABLE_SIZE + i + 1);
    float bottom = a00 + (a10 - a00) * fx;
    float top = a01 + (a11 - a01) * fx;
    return bottom + (top - bottom) * fy;
}

#endif
