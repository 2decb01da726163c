// Energy compensation of the GGX lobes: twin of src/bsdf/energy.rs, same names; the model
// (Kulla & Conty 2017's multiple-scattering lobe, the albedo coupling of the layers below the
// specular one) and where it is not applied are written down there. The (A, B) table is
// FrameParams.ggx_albedo (two pairs a vec4, then the averages): GGX_ALBEDO_TABLE names where it
// is bound, `frame.ggx_albedo` (bindings.glsl) unless the includer says otherwise.
#ifndef ENERGY_GLSL
#define ENERGY_GLSL
#ifndef GGX_ALBEDO_TABLE
#define GGX_ALBEDO_TABLE frame.ggx_albedo
#endif

#define GGX_TABLE_SIZE 32

// The table's roughness coordinate of a lobe of GGX alpha (alpha_t, alpha_b).
float table_roughness(vec2 alpha) {
    return sqrt(sqrt(alpha.x * alpha.y));
}

vec2 ggx_albedo_node(int k) {
    vec4 v = GGX_ALBEDO_TABLE[k >> 1];
    return (k & 1) == 0 ? v.xy : v.zw;
}

// (A, B) at cosine mu and table roughness r, bilinear between the nodes.
vec2 ggx_albedo(float mu, float r) {
    float last = float(GGX_TABLE_SIZE - 1);
    float x = clamp(abs(mu), 0.0, 1.0) * last;
    float y = clamp(r, 0.0, 1.0) * last;
    int i = min(int(x), GGX_TABLE_SIZE - 2);
    int j = min(int(y), GGX_TABLE_SIZE - 2);
    float fx = x - float(i);
    float fy = y - float(j);
    vec2 a00 = ggx_albedo_node(j * GGX_TABLE_SIZE + i);
    vec2 a10 = ggx_albedo_node(j * GGX_TABLE_SIZE + i + 1);
    vec2 a01 = ggx_albedo_node((j + 1) * GGX_TABLE_SIZE + i);
    vec2 a11 = ggx_albedo_node((j + 1) * GGX_TABLE_SIZE + i + 1);
    vec2 bottom = a00 + (a10 - a00) * fx;
    vec2 top = a01 + (a11 - a01) * fx;
    return bottom + (top - bottom) * fy;
}

// (A_avg, B_avg) at table roughness r, linear between the nodes.
vec2 ggx_albedo_avg(float r) {
    float y = clamp(r, 0.0, 1.0) * float(GGX_TABLE_SIZE - 1);
    int j = min(int(y), GGX_TABLE_SIZE - 2);
    int base = GGX_TABLE_SIZE * GGX_TABLE_SIZE;
    vec2 a = ggx_albedo_node(base + j);
    vec2 b = ggx_albedo_node(base + j + 1);
    return a + (b - a) * (y - float(j));
}

// Kulla & Conty's F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)), F_avg = F0 + (F90 - F0)/21.
vec3 fresnel_multiple(vec3 f0, float f90, float e_avg) {
    vec3 f_avg = f0 + (vec3(f90) - f0) / 21.0;
    return f_avg * f_avg * e_avg / (vec3(1.0) - f_avg * (1.0 - e_avg));
}

// (1 - E(mu_o))(1 - E(mu_i)) / (pi (1 - E_avg)); 0 where the lobe loses nothing.
float multiple_scattering(float e_o, float e_i, float e_avg) {
    float lost = 1.0 - e_avg;
    return lost > 1e-6 ? max(1.0 - e_o, 0.0) * max(1.0 - e_i, 0.0) * INV_PI / lost : 0.0;
}

// (1 - E^(mu_o))(1 - E^(mu_i)) / (1 - E^_avg); 0 where the layer reflects everything.
float albedo_coupling(float e_o, float e_i, float e_avg) {
    float left = 1.0 - e_avg;
    return left > 1e-6 ? max(1.0 - e_o, 0.0) * max(1.0 - e_i, 0.0) / left : 0.0;
}

// The specular layer's albedo at mu (single scattering plus Kulla & Conty's lobe), and its
// average over mu.
void specular_albedo(vec3 f0, float f90, float mu, float r, out vec3 e, out vec3 e_avg) {
    vec2 ab = ggx_albedo(mu, r);
    vec2 avg = ggx_albedo_avg(r);
    float white = ab.x + ab.y;
    float white_avg = avg.x + avg.y;
    vec3 f_ms = fresnel_multiple(f0, f90, white_avg);
    e = f0 * ab.x + vec3(f90 * ab.y) + f_ms * (1.0 - white);
    e_avg = f0 * avg.x + vec3(f90 * avg.y) + f_ms * (1.0 - white_avg);
}

#endif
