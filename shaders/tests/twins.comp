#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Runs the GLSL twins of src/sampling.rs, src/sobol/mod.rs, src/bsdf/, src/mis.rs, src/bvh/binary.rs and
// src/scene/camera.rs on inputs the test chooses, so tests/twins/twins.rs can compare each function
// with its Rust twin and name the one that disagrees. One invocation per case; the output slots are listed in tests/twins/twins.rs.
#include "layout.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 1) buffer Outputs { vec4 outputs[]; };
layout(std430, set = 0, binding = 2) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, set = 0, binding = 3) readonly buffer Triangles { GpuTriangle triangles[]; };
// Camera set-ups (std430 gives FrameParams the offsets of its std140 uniform).
layout(std430, set = 0, binding = 4) readonly buffer Frames { FrameParams frames[]; };
layout(push_constant) uniform Push { uint case_count; };

#include "rng.glsl"
#include "sampling.glsl"
// The BSDF reads the sheen and GGX albedo tables from the first camera set-up (FrameParams).
#define SHEEN_ALBEDO_TABLE frames[0].sheen_albedo
#define GGX_ALBEDO_TABLE frames[0].ggx_albedo
#include "bsdf.glsl"
#include "mis.glsl"
#include "bvh.glsl"
#include "qbvh.glsl"
#include "camera.glsl"
#include "spectrum.glsl"

#define INPUTS_PER_CASE 4u
#define OUTPUTS_PER_CASE 28u

layout(local_size_x = WORKGROUP_SIZE) in;

// The material of case i (tests/twins/twins.rs, twin_material): roughness, metal, transmission,
// specular factor and colour, clearcoat, sheen, anisotropy, iridescence, diffuse transmission swept by the case index; one block of 64 in
// 512 plain diffuse; the last 512 cases are unlit.
GpuMaterial twin_material(uint i) {
    GpuMaterial m;
    m.base_color = vec3(0.2, 0.5, 0.9);
    m.flags = (i / 512u == 7u ? MATERIAL_UNLIT : 0u)
            | ((i / 5u) % 2u == 0u ? MATERIAL_ENERGY_COMPENSATION : 0u);
    m.emission = vec3(0.0);
    uint r = i % 4u;
    m.roughness = r == 0u ? 0.0 : (r == 1u ? 0.05 : (r == 2u ? 0.3 : 0.8));
    uint k = (i / 4u) % 4u;
    m.metallic = k == 1u ? 1.0 : (k == 3u ? 0.5 : 0.0);
    m.transmission = k == 2u ? 1.0 : (k == 3u ? 0.5 : 0.0);
    m.ior = i % 7u == 3u ? 1.0 : 1.5;  // ior 1: the transmission is a delta at any roughness
    m.specular = (i / 16u) % 2u == 0u ? 1.0 : 0.5;
    uint c = (i / 128u) % 3u;
    m.specular_color = c == 0u ? vec3(1.0) : (c == 1u ? vec3(0.3, 1.8, 0.9) : vec3(40.0, 0.0, 1.0));
    m.specular_texture = NO_TEXTURE;
    m.specular_color_texture = NO_TEXTURE;
    m.clearcoat = (i / 1024u) % 2u == 1u ? 0.7 : 0.0;
    m.clearcoat_roughness = (i / 256u) % 2u == 0u ? 0.0 : 0.35;
    m.clearcoat_texture = NO_TEXTURE;
    m.clearcoat_roughness_texture = NO_TEXTURE;
    m.clearcoat_normal_texture = NO_TEXTURE;
    m.clearcoat_normal_scale = 1.0;
    m.clearcoat_normal = vec3(0.0);
    bool sheen = (i / 64u) % 4u == 3u;
    m.sheen_color = sheen ? vec3(0.9, 0.4, 0.7) : vec3(0.0);
    m.sheen_roughness = (i / 8u) % 2u == 0u ? 0.3 : 0.8;
    m.sheen_color_texture = NO_TEXTURE;
    m.sheen_roughness_texture = NO_TEXTURE;
    m.anisotropy = (i / 3u) % 3u == 1u ? 0.8 : 0.0;
    m.anisotropy_direction = vec3(0.48, 0.6, -0.64);
    m.anisotropy_rotation = 0.0;
    m.anisotropy_texture = NO_TEXTURE;
    m.iridescence = (i / 3u) % 3u == 2u ? 0.9 : 0.0;
    m.iridescence_ior = 1.6;
    m.iridescence_thickness_min = 100.0;
    m.iridescence_thickness = 350.0;
    m.iridescence_texture = NO_TEXTURE;
    m.iridescence_thickness_texture = NO_TEXTURE;
    m.attenuation = vec3(0.0);
    m.thickness = (i / 32u) % 2u == 1u ? 1.0 : 0.0;
    m.diffuse_transmission = (i / 5u) % 3u == 1u ? 0.6 : 0.0;
    m.diffuse_transmission_color = vec3(0.3, 0.9, 0.5);
    m.diffuse_transmission_texture = NO_TEXTURE;
    m.diffuse_transmission_color_texture = NO_TEXTURE;
    m.dispersion = (i / 8u) % 2u == 1u ? 1.5 : 0.0;
    // One block of 64 cases in 512 plain diffuse (BsdfFrame.plain: the plain frames' path).
    if ((i / 64u) % 8u == 5u && i / 512u != 7u) {
        m.metallic = 0.0;
        m.transmission = 0.0;
        m.specular = 0.0;
        m.clearcoat = 0.0;
        m.iridescence = 0.0;
        m.diffuse_transmission = 0.0;
    }
    return m;
}

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= case_count) return;
    vec4 u = inputs[INPUTS_PER_CASE * i];                            // four uniforms
    vec3 n = inputs[INPUTS_PER_CASE * i + 1u].xyz;                   // unit normal
    vec3 wo = inputs[INPUTS_PER_CASE * i + 2u].xyz;                  // unit, on n's side
    uvec4 key = floatBitsToUint(inputs[INPUTS_PER_CASE * i + 3u]);   // RNG key / ray origin bits
    uint o = OUTPUTS_PER_CASE * i;

    outputs[o + 0u] = rng_uniform4(key.x, key.y, key.z, key.w);
    vec3 w = sample_cosine_hemisphere(u.xy);
    outputs[o + 1u] = vec4(w, cosine_hemisphere_pdf(w.z));
    vec2 b = sample_uniform_triangle(u.zw);
    outputs[o + 2u] = vec4(invert_cosine_hemisphere_sample(w), b);
    outputs[o + 3u] = vec4(invert_uniform_triangle_sample(b), mis_weight2(i % 6u, 1.5 + float(i % 3u), u.x, u.y, (i & 4u) != 0u), uniform_triangle_pdf(u.z + 0.5));
    vec3 t, bt;
    build_frame(n, t, bt);
    outputs[o + 4u] = vec4(t, 0.0);
    outputs[o + 5u] = vec4(bt, 0.0);
    outputs[o + 6u] = vec4(offset_ray_origin(wo * 10.0 * u.w, n), 0.0);
    GpuMaterial m = twin_material(i);
    // Half the coated cases have a coat normal of their own.
    if ((i / 2048u) % 2u == 1u) m.clearcoat_normal = normalize(n + 0.5 * wo);
    vec3 wo_side = (i & 32u) != 0u ? -wo : wo;
    vec3 wi, weight;
    float pdf;
    bool delta;
    bool ok = bsdf_sample(m, n, wo_side, u.xyz, TRANSPORT_RADIANCE, wi, weight, pdf, delta);
    outputs[o + 7u] = vec4(wi, pdf);
    outputs[o + 8u] = vec4(weight, ok ? (delta ? 2.0 : 1.0) : 0.0);
    vec3 wi_test = normalize(u.xyz - vec3(0.5));
    uint mode = (i & 64u) != 0u ? TRANSPORT_IMPORTANCE : TRANSPORT_RADIANCE;
    outputs[o + 9u] = vec4(bsdf_eval(m, n, wo_side, wi_test, mode), bsdf_pdf(m, n, wo_side, wi_test));
    // A ray through the scene: origin from the key's bits, direction -wo, with one or two axes
    // still in one case of 64 (twins.rs, scene_ray_dir): a subgroup with such a lane takes the
    // quantised walk's min/max slab form, the others its sign-selected form.
    vec3 origin = uintBitsToFloat(key.xyz);
    vec3 dir = -wo;
    if (i % 64u == 3u) dir.x = 0.0;
    if (i % 64u == 35u) dir.yz = vec2(0.0, 1e-40);
    HitRecord hit;
    bvh_intersect_closest(origin, dir, 0.0, 3.402823466e38, uvec4(0u), hit);
    outputs[o + 10u] = vec4(hit.t, uintBitsToFloat(hit.triangle), hit.u, hit.v);
    float t_max = u.z * 4.0;
    outputs[o + 11u] = vec4(bvh_intersect_any(origin, dir, 0.0, t_max, uvec4(0u)) ? 1.0 : 0.0, t_max, 0.0, 0.0);
    // The same rays through the quantised 4-wide nodes (qbvh.glsl), whose root the input after
    // the cases names.
    uint wide_root = floatBitsToUint(inputs[case_count * INPUTS_PER_CASE].x);
    HitRecord wide_hit = HitRecord(3.402823466e38, NO_HIT, 0.0, 0.0, 0u, 0u, 0u, 0u);
    qbvh_closest_from(wide_root, origin, dir, 0.0, uvec4(0u), wide_hit);
    outputs[o + 26u] = vec4(wide_hit.t, uintBitsToFloat(wide_hit.triangle), wide_hit.u, wide_hit.v);
    outputs[o + 27u] = vec4(qbvh_any_from(wide_root, origin, dir, 0.0, t_max, uvec4(0u)) ? 1.0 : 0.0, t_max, 0.0, 0.0);

    uint n_perm = 1u + i % 300u;
    uint p = permute(i % n_perm, n_perm, key.x);
    vec2 strat = stratify2(key.x, i, i % 64u, 64u, key.y, u.zw);
    outputs[o + 12u] = vec4(uintBitsToFloat(p), strat, 0.0);

    // Microfacet pieces in the local frame, wo = the cosine-sampled w (z >= 0).
    vec2 alpha = vec2(0.02 + u.w, (i & 2u) != 0u ? 0.02 + u.x : 0.02 + u.w);
    vec3 h = sample_ggx_vndf(w, alpha, u.zw);
    outputs[o + 13u] = vec4(h, ggx_vndf_pdf(w, h, alpha));
    outputs[o + 14u] = vec4(ggx_d(h, alpha), ggx_lambda(w, alpha), ggx_visibility(w, h, alpha),
                            fresnel_dielectric(u.x, dielectric_f0(1.5), u.y, (i & 1u) != 0u ? 1.5 : 1.0 / 1.5));
    vec3 refracted;
    bool refracts = refract_through(w, vec3(0.0, 0.0, 1.0), (i & 1u) != 0u ? 1.5 : 1.0 / 1.5, refracted);
    outputs[o + 15u] = vec4(refracted, refracts ? 1.0 : 0.0);
    outputs[o + 16u] = vec4(fresnel_conductor(m.base_color, u.y), bsdf_albedo_estimate(m, n, wo_side));
    float rr_weight;
    bool survives = roulette(u.x, u.y * 1.2, rr_weight);
    outputs[o + 17u] = vec4(survives ? 1.0 : 0.0, rr_weight, 0.0, 0.0);
    // Sobol points: a key's bits and the case number as indices, then keyed pairs.
    outputs[o + 18u] = uintBitsToFloat(uvec4(sobol2(key.x), sobol2(i)));
    uvec4 keys = sobol_keys(key.x, i, key.y);
    outputs[o + 19u] = uintBitsToFloat(uvec4(laine_karras_permutation(key.y, key.z),
                                             nested_uniform_scramble(key.z, key.x),
                                             shuffled_scrambled_sobol2(i % 256u, keys)));
    outputs[o + 20u] = vec4(sobol_pair(key.x, i, i % 64u, key.y), uintBitsToFloat(keys.xw));
    outputs[o + 21u] = vec4(sample_concentric_disk(u.xy), uniform_disk_pdf(), 0.0);
    // A camera ray: set-up i % frames.length(), a pixel from the key, jitter u.xy, lens u.zw.
    FrameParams f = frames[i % uint(frames.length())];
    vec3 ray_origin, ray_dir;
    camera_ray(f, key.w % (f.width * f.height), u.xy, u.zw, ray_origin, ray_dir);
    outputs[o + 22u] = vec4(ray_origin, 0.0);
    outputs[o + 23u] = vec4(ray_dir, 0.0);
    // Spectral sampling (KHR_materials_dispersion): a wavelength from u.x, its pdf, a
    // dispersive ior, the material's gate, the RGB response and the path's weight.
    float lambda = sample_wavelength(u.x);
    outputs[o + 24u] = vec4(lambda, wavelength_pdf(lambda), dispersive_ior(1.3 + u.y, 4.0 * u.z, lambda),
                            is_dispersive(m) ? 1.0 : 0.0);
    outputs[o + 25u] = vec4(wavelength_rgb(lambda), wavelength_weight(lambda).y);
}
