// Light BVH sampling: the GLSL twin of src/lights/light_bvh/mod.rs (same names, same arithmetic in the same
// order; tests/twins/light_bvh_twins.rs compares them). Importance of a node after Conty Estevez &
// Kulla 2018, "Importance Sampling of Many Lights with Adaptive Tree Splitting", in pbrt-v4's
// LightBounds::Importance form; descent and pmf as pbrt-v4's BVHLightSampler.
//
// Two parts. The node struct and its constants come first, guarded by LIGHT_BVH_NODE_GLSL, so a
// shader can include this file with LIGHT_BVH_NODE_ONLY defined before declaring its buffers:
//     #define LIGHT_BVH_NODE_ONLY
//     #include "light_bvh.glsl"
//     #undef LIGHT_BVH_NODE_ONLY
//     layout(...) readonly buffer LightNodes { GpuLightNode light_nodes[]; };
//     layout(...) readonly buffer LightTrails { uint light_trails[]; };
//     #include "light_bvh.glsl"
// The functions (second include) read light_nodes[] and light_trails[] and need rng.glsl
// (ONE_MINUS_EPSILON). A layout.glsl that defines the struct defines LIGHT_BVH_NODE_GLSL.

#ifndef LIGHT_BVH_NODE_GLSL
#define LIGHT_BVH_NODE_GLSL

// One node of the flattened light BVH, depth first, root at 0. Total: 64 bytes.
struct GpuLightNode {
    vec3 bounds_min;      // 12 bytes
    float phi;            // 4 bytes: emitted power of the lights below
    vec3 bounds_max;      // 12 bytes
    float cos_theta_o;    // 4 bytes: normals within θo of w
    vec3 w;               // 12 bytes: unit axis of the normal cone
    float cos_theta_e;    // 4 bytes: emission within θe of a normal
    uint child_or_light;  // 4 bytes: interior: second child (first = this + 1); leaf: light index
    uint flags;           // 4 bytes: LIGHT_NODE_LEAF | LIGHT_NODE_TWO_SIDED
    float radius;         // 4 bytes: half the box's diagonal (its bounding sphere's radius)
    float sin_theta_o;    // 4 bytes: sqrt(max(0, 1 - cos_theta_o^2))
};

#define LIGHT_NODE_LEAF 1u
#define LIGHT_NODE_TWO_SIDED 2u
#define MAX_LIGHT_BVH_DEPTH 31u
#define NO_LIGHT_TRAIL 0xffffffffu
#define LIGHT_BVH_MIN_DISTANCE_SQUARED 1e-20

#endif  // LIGHT_BVH_NODE_GLSL

#if !defined(LIGHT_BVH_GLSL) && !defined(LIGHT_BVH_NODE_ONLY)
#define LIGHT_BVH_GLSL
// Kernels that read the nodes from an image define light_node_at (scene_arrays.glsl).
#ifndef light_node_at
#define light_node_at(i) light_nodes[i]
#endif

bool light_node_is_leaf(GpuLightNode node) { return (node.flags & LIGHT_NODE_LEAF) != 0u; }
bool light_node_two_sided(GpuLightNode node) { return (node.flags & LIGHT_NODE_TWO_SIDED) != 0u; }

// cos(max(0, θa − θb)) and sin(max(0, θa − θb)) from sines and cosines (pbrt-v4).
float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    if (cos_a > cos_b) return 1.0;
    return cos_a * cos_b + sin_a * sin_b;
}
float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    if (cos_a > cos_b) return 0.0;
    return sin_a * cos_b - cos_a * sin_b;
}
float light_bvh_safe_sqrt(float x) { return sqrt(max(x, 0.0)); }

// phi · cos θ' / d², times cos θ'i when n ≠ 0; see light_bounds_importance_terms in
// src/lights/light_bvh/mod.rs for the terms.
float light_bounds_importance(GpuLightNode node, vec3 p, vec3 n) {
    vec3 pc = (node.bounds_min + node.bounds_max) * 0.5;
    // The node's constants (radius, sin θo) come with it from the build (src/lights/light_bvh/mod.rs).
    float radius = node.radius;
    float radius_squared = radius * radius;
    vec3 to_p = p - pc;
    float distance_squared = dot(to_p, to_p);
    float d2 = max(max(distance_squared, radius), LIGHT_BVH_MIN_DISTANCE_SQUARED);

    vec3 wi = distance_squared > 0.0 ? to_p * (1.0 / sqrt(distance_squared)) : node.w;
    float cos_theta_w = dot(node.w, wi);
    if (light_node_two_sided(node)) cos_theta_w = abs(cos_theta_w);
    float sin_theta_w = light_bvh_safe_sqrt(1.0 - cos_theta_w * cos_theta_w);

    float cos_theta_b = distance_squared <= radius_squared
        ? -1.0
        : light_bvh_safe_sqrt(1.0 - radius_squared / distance_squared);
    float sin_theta_b = light_bvh_safe_sqrt(1.0 - cos_theta_b * cos_theta_b);

    float cos_theta_o = node.cos_theta_o;
    float sin_theta_o = node.sin_theta_o;
    float cos_theta_x = cos_sub_clamped(sin_theta_w, cos_theta_w, sin_theta_o, cos_theta_o);
    float sin_theta_x = sin_sub_clamped(sin_theta_w, cos_theta_w, sin_theta_o, cos_theta_o);
    float cos_theta_p = cos_sub_clamped(sin_theta_x, cos_theta_x, sin_theta_b, cos_theta_b);
    if (cos_theta_p <= node.cos_theta_e) return 0.0;
    float importance = node.phi * cos_theta_p / d2;
    if (n != vec3(0.0)) {
        float cos_theta_i = abs(dot(wi, n));
        float sin_theta_i = light_bvh_safe_sqrt(1.0 - cos_theta_i * cos_theta_i);
        importance *= cos_sub_clamped(sin_theta_i, cos_theta_i, sin_theta_b, cos_theta_b);
    }
    return max(importance, 0.0);
}

// One descent from the root (src/lights/light_bvh/mod.rs, light_bvh_walk): at each interior node the child
// the trail's next bit names (by_trail) or the one u falls in (u remapped after), multiplying the
// children's probabilities. False at a dead end (no light can reach p).
bool light_bvh_walk(vec3 p, vec3 n, bool by_trail, uint trail, float u, out uint light, out float pmf) {
    light = 0u;
    pmf = 0.0;
    u = clamp(u, 0.0, ONE_MINUS_EPSILON);
    uint index = 0u;
    float prob = 1.0;
    // The node at `index`: below the root, the child record read at its parent's level, so no
    // node on the path is fetched twice (64 bytes, four texels, per level saved).
    GpuLightNode node = light_node_at(0u);
    // Descends while the node (at `depth`) is interior, testing where the body ends (bvh.glsl
    // says why): a leaf is taken at depths up to MAX_LIGHT_BVH_DEPTH, as the CPU's walk does.
    uint depth = 0u;
    bool leaf = light_node_is_leaf(node);
    if (!leaf) do {
        uint second = node.child_or_light;
        GpuLightNode child0 = light_node_at(index + 1u);
        GpuLightNode child1 = light_node_at(second);
        float c0 = light_bounds_importance(child0, p, n);
        float c1 = light_bounds_importance(child1, p, n);
        float sum = c0 + c1;
        if (!(sum > 0.0)) return false;
        float p0 = c0 / sum;
        bool first = by_trail ? (trail & 1u) == 0u : u < p0;
        if (first) {
            prob *= p0;
            u = min(u / p0, ONE_MINUS_EPSILON);
            index += 1u;
            node = child0;
        } else {
            float p1 = c1 / sum;
            prob *= p1;
            u = min((u - p0) / p1, ONE_MINUS_EPSILON);
            index = second;
            node = child1;
        }
        trail >>= 1u;
        ++depth;
        leaf = light_node_is_leaf(node);
    } while (!leaf && depth <= MAX_LIGHT_BVH_DEPTH);
    if (!leaf || depth > MAX_LIGHT_BVH_DEPTH) return false;
    if (index == 0u && !(light_bounds_importance(node, p, n) > 0.0)) return false;
    light = node.child_or_light;
    pmf = prob;
    return true;
}

// Descends from the root choosing each child with probability proportional to its importance,
// remapping u after each choice. False when the tree is empty (light_count 0 is the caller's to
// check: an empty light_nodes[] buffer cannot be read) or when no light can reach p.
bool light_bvh_sample(vec3 p, vec3 n, float u, out uint light, out float pmf) {
    return light_bvh_walk(p, n, false, 0u, u, light, pmf);
}

// The probability that light_bvh_sample at (p, n) returns `light`: the same walk along the
// light's trail. 0 for a light not in the tree.
float light_bvh_pmf(vec3 p, vec3 n, uint light) {
    uint trail = light_trails[light];
    if (trail == NO_LIGHT_TRAIL) return 0.0;
    uint leaf;
    float pmf;
    return light_bvh_walk(p, n, true, trail, 0.0, leaf, pmf) ? pmf : 0.0;
}

#endif  // LIGHT_BVH_GLSL
