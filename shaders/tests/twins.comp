#version 460
#extension GL_GOOGLE_include_directive : require
// Runs the GLSL twins of src/sampling.rs, src/sobol.rs, src/bsdf.rs, src/mis.rs and src/bvh.rs on inputs the
// test chooses, so tests/twins.rs can compare each function with its Rust twin and name the one
// that disagrees. One invocation per case; the output slots are listed in tests/twins.rs.
#include "layout.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 1) buffer Outputs { vec4 outputs[]; };
layout(std430, set = 0, binding = 2) readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
layout(std430, set = 0, binding = 3) readonly buffer Triangles { GpuTriangle triangles[]; };
layout(push_constant) uniform Push { uint case_count; };

#include "rng.glsl"
#include "sampling.glsl"
#include "bsdf.glsl"
#include "mis.glsl"
#include "bvh.glsl"

#define INPUTS_PER_CASE 4u
#define OUTPUTS_PER_CASE 16u

layout(local_size_x = WORKGROUP_SIZE) in;

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
    outputs[o + 3u] = vec4(invert_uniform_triangle_sample(b), mis_weight2(i % 4u, 1.5 + float(i % 3u), u.x, u.y, (i & 4u) != 0u), uniform_triangle_pdf(u.z + 0.5));
    vec3 t, bt;
    build_frame(n, t, bt);
    outputs[o + 4u] = vec4(t, 0.0);
    outputs[o + 5u] = vec4(bt, 0.0);
    outputs[o + 6u] = vec4(offset_ray_origin(wo * 10.0 * u.w, n), 0.0);
    vec3 albedo = vec3(0.2, 0.5, 0.9);
    vec3 f;
    float pdf;
    vec3 wi = bsdf_sample(albedo, n, wo, u.xy, f, pdf);
    outputs[o + 7u] = vec4(wi, pdf);
    outputs[o + 8u] = vec4(f, bsdf_pdf(n, wo, wi));
    outputs[o + 9u] = vec4(bsdf_eval(albedo, n, wo, -wo), 0.0);

    // A ray through the scene: origin from the key's bits, direction -wo.
    vec3 origin = uintBitsToFloat(key.xyz);
    HitRecord hit;
    bvh_intersect_closest(origin, -wo, 0.0, 3.402823466e38, hit);
    outputs[o + 10u] = vec4(hit.t, uintBitsToFloat(hit.triangle), hit.u, hit.v);
    float t_max = u.z * 4.0;
    outputs[o + 11u] = vec4(bvh_intersect_any(origin, -wo, 0.0, t_max) ? 1.0 : 0.0, t_max, 0.0, 0.0);

    uint n_perm = 1u + i % 300u;
    uint p = permute(i % n_perm, n_perm, key.x);
    vec2 strat = stratify2(key.x, i, i % 64u, 64u, key.y, u.zw);
    outputs[o + 12u] = vec4(uintBitsToFloat(p), strat, 0.0);

    // Sobol points: a key's bits and the case number as indices, then keyed pairs.
    outputs[o + 13u] = uintBitsToFloat(uvec4(sobol2(key.x), sobol2(i)));
    uvec4 keys = sobol_keys(key.x, i, key.y);
    outputs[o + 14u] = uintBitsToFloat(uvec4(laine_karras_permutation(key.y, key.z),
                                             nested_uniform_scramble(key.z, key.x),
                                             shuffled_scrambled_sobol2(i % 256u, keys)));
    outputs[o + 15u] = vec4(sobol_pair(key.x, i, i % 64u, key.y), uintBitsToFloat(keys.xw));
}
