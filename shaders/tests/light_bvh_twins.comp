#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Runs the GLSL twins of src/lights/light_bvh/mod.rs (shaders/inc/light_bvh.glsl) on a light BVH the test
// builds, so tests/twins/light_bvh_twins.rs can compare each with its Rust twin. One invocation per
// case; inputs and output slots are listed in tests/twins/light_bvh_twins.rs.
#include "layout.glsl"
#define LIGHT_BVH_NODE_ONLY
#include "light_bvh.glsl"
#undef LIGHT_BVH_NODE_ONLY

layout(std430, set = 0, binding = 0) readonly buffer Inputs { vec4 inputs[]; };
layout(std430, set = 0, binding = 1) buffer Outputs { vec4 outputs[]; };
layout(std430, set = 0, binding = 2) readonly buffer LightNodes { GpuLightNode light_nodes[]; };
layout(std430, set = 0, binding = 3) readonly buffer LightTrails { uint light_trails[]; };
layout(push_constant) uniform Push { uint case_count; };

#include "rng.glsl"
#include "light_bvh.glsl"

#define INPUTS_PER_CASE 3u
#define OUTPUTS_PER_CASE 2u

layout(local_size_x = WORKGROUP_SIZE) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= case_count) return;
    uint base = i * INPUTS_PER_CASE;
    vec4 in0 = inputs[base];
    vec4 in1 = inputs[base + 1u];
    vec4 in2 = inputs[base + 2u];
    vec3 p = in0.xyz;
    float u = in0.w;
    vec3 n = in1.xyz;
    uint query = floatBitsToUint(in1.w);
    uint node = floatBitsToUint(in2.x);

    uint light;
    float pmf;
    bool found = light_bvh_sample(p, n, u, light, pmf);
    uint o = i * OUTPUTS_PER_CASE;
    outputs[o] = vec4(found ? 1.0 : 0.0, uintBitsToFloat(light), pmf, light_bvh_pmf(p, n, query));
    outputs[o + 1u] = vec4(light_bounds_importance(light_nodes[node], p, n), 0.0, 0.0, 0.0);
}
