#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Runs the GLSL twins of src/texture.rs, src/surface.rs and bend_shading_normal on a synthetic
// textured scene the test builds, so tests/twins/surface_twins.rs can compare each with its Rust twin.
// One invocation per case; inputs and output slots are listed in tests/twins/surface_twins.rs.
#include "layout.glsl"

layout(std430, set = 0, binding = 0) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 1) buffer Outputs { vec4 outputs[]; };
layout(std430, set = 0, binding = 2) readonly buffer Textures { GpuTexture textures[]; };
layout(std430, set = 0, binding = 3) readonly buffer TextureRefs { GpuTextureRef texture_refs[]; };
layout(std430, set = 0, binding = 4) readonly buffer Texels { uint texels[]; };
layout(std430, set = 0, binding = 5) readonly buffer Vertices { GpuVertex vertices[]; };
layout(std430, set = 0, binding = 6) readonly buffer Triangles { GpuTriangle triangles[]; };
layout(std430, set = 0, binding = 7) readonly buffer TriangleVertices { uvec4 triangle_vertices[]; };
layout(std430, set = 0, binding = 8) readonly buffer Materials { GpuMaterial materials[]; };
layout(push_constant) uniform Push { uint case_count; };

#include "rng.glsl"
#include "sampling.glsl"
// Only bend_shading_normal of the BSDF runs here: a one-entry stand-in for the sheen and GGX
// albedo tables.
const vec4 SHEEN_TABLE_UNUSED[1] = vec4[](vec4(0.0));
#define SHEEN_ALBEDO_TABLE SHEEN_TABLE_UNUSED
#define GGX_ALBEDO_TABLE SHEEN_TABLE_UNUSED
#include "bsdf.glsl"
#include "texture.glsl"
#include "surface.glsl"

#define INPUTS_PER_CASE 6u
#define OUTPUTS_PER_CASE 17u

layout(local_size_x = WORKGROUP_SIZE) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= case_count) return;
    uint base = i * INPUTS_PER_CASE;
    vec4 in0 = inputs[base];
    vec4 in1 = inputs[base + 1u];
    vec4 in2 = inputs[base + 2u];
    vec4 in3 = inputs[base + 3u];
    vec4 in4 = inputs[base + 4u];
    vec4 in5 = inputs[base + 5u];
    vec2 uv0 = in0.xy;
    vec2 uv1 = in0.zw;
    vec2 lod = in1.xy;
    uint ref_index = floatBitsToUint(in1.z);
    uint level = floatBitsToUint(in1.w) & 255u;
    bool linear = (floatBitsToUint(in1.w) >> 8u) != 0u;
    uint tri_index = floatBitsToUint(in2.z);
    uint mat_index = floatBitsToUint(in2.w);
    vec3 ns = in3.xyz;
    vec3 wo = in4.xyz;
    vec3 ng = in5.xyz;
    uvec4 key = uvec4(floatBitsToUint(in3.w), floatBitsToUint(in4.w), 7u, 11u);
    uint o = i * OUTPUTS_PER_CASE;

    GpuTextureRef r = texture_refs[ref_index];
    GpuTexture t = textures[r.texture];
    outputs[o + 0u] = sample_texture_ref(ref_index, uv0, uv1, lod);
    outputs[o + 1u] = texture_sample_level(t, min(level, t.levels - 1u), uv0, linear);
    outputs[o + 2u] = vec4(texture_lod(t, r, lod.x), reduce_coordinate(uv0.x, t.wrap_s),
                           float(wrap_texel(int(i % 20u) - 5, 5, t.wrap_t)),
                           texture_ref_uv(r, uv0, uv1).x);

    GpuTriangle tri = triangle_at(tri_index);
    SurfacePoint sp = surface_point(tri, triangle_vertices_at(tri_index), in2.x, in2.y);
    outputs[o + 3u] = vec4(sp.ns, surface_lod_base(sp, 1.0, 1.0).x);
    outputs[o + 4u] = vec4(sp.uv0, sp.uv1);
    GpuMaterial m = materials[mat_index];
    vec2 lod_sp = surface_lod_base(sp, in5.w, dot(sp.ng, wo));
    vec3 e_ns;
    GpuMaterial e = surface_material_normal(m, sp, lod_sp, e_ns);
    outputs[o + 5u] = vec4(e.base_color, e.alpha);
    outputs[o + 6u] = vec4(e.metallic, e.roughness, e.emission.x, e.transmission);
    outputs[o + 7u] = vec4(e_ns, alpha_random(key, tri_index));
    vec3 ng_wo = dot(ng, wo) > 0.0 ? ng : -ng;
    vec3 ns_side = dot(ns, ng_wo) > 0.0 ? ns : -ns;
    outputs[o + 8u] = vec4(bend_shading_normal(ns_side, ng_wo, wo),
                           triangle_present(tri_index, in2.x, in2.y, key, vec3(0.0)) ? 1.0 : 0.0);
    outputs[o + 9u] = vec4(e.specular_color, e.specular);
    outputs[o + 10u] = vec4(e.emission, 0.0);
    outputs[o + 11u] = vec4(e.clearcoat, e.clearcoat_roughness, 0.0, 0.0);
    outputs[o + 12u] = vec4(e.clearcoat_normal, 0.0);
    outputs[o + 13u] = vec4(e.sheen_color, e.sheen_roughness);
    outputs[o + 14u] = vec4(e.anisotropy_direction, e.anisotropy);
    outputs[o + 15u] = vec4(e.iridescence, e.iridescence_thickness, 0.0, 0.0);
    outputs[o + 16u] = vec4(e.diffuse_transmission_color, e.diffuse_transmission);
}
