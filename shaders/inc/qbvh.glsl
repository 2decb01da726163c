// The bottom levels' walk: the binary tree collapsed to 4-wide nodes with their boxes quantised
// to a byte per plane (QuantNode, layout.glsl). Twin of the CPU's walk of the same nodes
// (src/bvh/wide.rs, WideBvh<QuantNode> as Hierarchy; src/bvh/quantized.rs): the same
// dequantised planes, the same slab test per slot (qbvh_slabs: slab4's two forms), the
// entered slots visited nearest first and the others deferred, nearest on top. A node is four
// texels for four children where the binary walk reads two per child, and every dequantised box
// contains the binary tree's, so a ray finds the same closest hit (docs/perf-log/2026-12-03-gpu-quantised-walks.md).
// Needs bvh.glsl and quant_node_at (scene_arrays.glsl).
#ifndef QBVH_GLSL
#define QBVH_GLSL
#include "bvh.glsl"

// A slot naming a leaf: its first triangle | QBVH_LEAF (src/bvh/wide.rs, LEAF).
#define QBVH_LEAF 0x80000000u
// Deferred slots kept in per-lane memory, beside the three (closest hit) or two (any hit) in
// registers (bvh.glsl): a level whose walk could defer more than both keep
// (src/bvh/quantized.rs, deferred_bound, GPU_DEFERRED_MAX = this + 2) is walked
// in its binary nodes instead (tlas.glsl). A smaller array than the 3 × 64 a 4-wide walk can need
// in the worst case: on lavapipe the array's size costs time (192 → 48 entries: extend 5–9 %
// faster against shade).
// The array is made for the scene (src/layout.rs, qbvh_stack_size; src/render/prepared.rs,
// PreparedScene::gpu_features): its levels' largest deferred_bound less the two registers, at
// least 1; the default, 48, in kernels made with every feature and the test kernels: made to
// measure because its size costs time.
layout(constant_id = 7) const uint QBVH_STACK_SIZE = 48u;
// The top level's array (tlas.glsl), made for its own bound (src/layout.rs, tlas_stack_size):
// its walk holds it while an instance's walk holds the one above, so each is sized for its own
// levels rather than both for the largest (instances.gltf: 19 slots and 16, where both were 19).
layout(constant_id = 8) const uint TLAS_STACK_SIZE = 48u;

// The node's scale per axis, 2^(e − 127) from its biased exponent e (src/bvh/quantized.rs,
// scale): made once per node, for all four slots.
vec3 qbvh_scale(QuantNode node) {
    return uintBitsToFloat(((uvec3(node.exponents_valid) >> uvec3(0u, 8u, 16u)) & 0xffu) << 23u);
}

// Slot s of `node` as the slab test reads it: origin + q · scale per plane. The product is exact
// (q < 2^8, a power-of-two scale), so the plane is one rounding whether or not the compiler fuses
// it: the CPU's float (src/bvh/quantized.rs, plane).
BvhNode qbvh_slot_box(QuantNode node, vec3 scale, uint s) {
    uint shift = 8u * s;
    uvec3 q_lo = (uvec3(node.q[0], node.q[1], node.q[2]) >> shift) & 0xffu;
    uvec3 q_hi = (uvec3(node.q[3], node.q[4], node.q[5]) >> shift) & 0xffu;
    return BvhNode(node.origin + vec3(q_lo) * scale, 0u, node.origin + vec3(q_hi) * scale, 0u);
}

// Slot s as the walk keeps it: (node index or first triangle | QBVH_LEAF, triangle count).
uvec2 qbvh_entry(QuantNode node, uint s) {
    return uvec2(node.child[s], (node.count >> (8u * s)) & 0xffu);
}

// Whether the ray enters slot s of `node` before t_far, and where (t_enter; BVH_FLT_MAX if not).
bool qbvh_slot_entered(QuantNode node, vec3 scale, uint s, BvhSlabRay ray, float t_min, float t_far,
                       out float t_enter) {
    bool used = ((node.exponents_valid >> (24u + s)) & 1u) != 0u;
    bool entered = used && bvh_slab(qbvh_slot_box(node, scale, s), ray, t_min, t_far, t_enter);
    if (!entered) t_enter = BVH_FLT_MAX;
    return entered;
}

// The four bytes of a packed word as floats, slot 0 first.
vec4 qbvh_bytes(uint w) {
    return vec4((uvec4(w) >> uvec4(0u, 8u, 16u, 24u)) & 0xffu);
}

// The sign-selected slab tests' maximum and minimum as a comparison and a select: GLSL's max and
// min cost llvmpipe a NaN check each (an unordered compare and a blend: 9 795 -> 9 717
// instructions per Cornell box sample without them, tools/instructions.py --device gpu), and no
// operand there is NaN (finite planes, origin and inverse direction; a product overflows to
// infinity at worst), so the values are max's and min's, up to the sign of a zero, which no
// comparison of the walk tells apart.
vec4 qbvh_max(vec4 a, vec4 b) { return mix(b, a, greaterThan(a, b)); }
vec4 qbvh_min(vec4 a, vec4 b) { return mix(b, a, lessThan(a, b)); }

// The slab tests of all four slots of `node`: a mask of those the ray enters before t_far
// (bit s: slot s) and where it enters each (BVH_FLT_MAX where not). Where no lane of the
// subgroup has a still axis, the sign-selected form (Williams et al. 2005; src/bvh/wide.rs,
// slab4, as the CPU takes it per ray): per axis the entry plane is the minimum where the
// direction is positive and the maximum where negative, chosen once per node for all four
// slots, so the min/max of bvh_slab select the same floats (rounding is monotone) without the
// still-axis terms; else bvh_slab per slot. The branch is uniform across the subgroup, so a SIMD
// device runs one side (lavapipe, four ABBA pairs: extend 2-7 % faster against shade on six
// scenes; connect within the spread).
uint qbvh_slabs(QuantNode node, BvhSlabRay ray, float t_min, float t_far, out vec4 t_enter) {
    vec3 scale = qbvh_scale(node);
    uint valid = node.exponents_valid >> 24u;
    if (ray.sign_form) {
        uvec3 lo = uvec3(node.q[0], node.q[1], node.q[2]);
        uvec3 hi = uvec3(node.q[3], node.q[4], node.q[5]);
        uvec3 wn = mix(lo, hi, ray.negative);
        uvec3 wf = mix(hi, lo, ray.negative);
        vec4 nx = (node.origin.x + qbvh_bytes(wn.x) * scale.x - ray.origin.x) * ray.inv_dir.x;
        vec4 ny = (node.origin.y + qbvh_bytes(wn.y) * scale.y - ray.origin.y) * ray.inv_dir.y;
        vec4 nz = (node.origin.z + qbvh_bytes(wn.z) * scale.z - ray.origin.z) * ray.inv_dir.z;
        vec4 fx = (node.origin.x + qbvh_bytes(wf.x) * scale.x - ray.origin.x) * ray.inv_dir.x;
        vec4 fy = (node.origin.y + qbvh_bytes(wf.y) * scale.y - ray.origin.y) * ray.inv_dir.y;
        vec4 fz = (node.origin.z + qbvh_bytes(wf.z) * scale.z - ray.origin.z) * ray.inv_dir.z;
        vec4 enter = qbvh_max(qbvh_max(nx, qbvh_max(ny, nz)), vec4(t_min));
        vec4 exit = qbvh_min(qbvh_min(fx, qbvh_min(fy, fz)), vec4(t_far));
        bvec4 hit = lessThanEqual(enter - abs(enter) * BVH_SLAB_SLACK, exit);
        uint mask = (uint(hit.x) | uint(hit.y) << 1u | uint(hit.z) << 2u | uint(hit.w) << 3u) & valid;
        t_enter = mix(vec4(BVH_FLT_MAX), enter, bvec4(uvec4(mask) & uvec4(1u, 2u, 4u, 8u)));
        return mask;
    }
    float t0, t1, t2, t3;
    bool h0 = qbvh_slot_entered(node, scale, 0u, ray, t_min, t_far, t0);
    bool h1 = qbvh_slot_entered(node, scale, 1u, ray, t_min, t_far, t1);
    bool h2 = qbvh_slot_entered(node, scale, 2u, ray, t_min, t_far, t2);
    bool h3 = qbvh_slot_entered(node, scale, 3u, ray, t_min, t_far, t3);
    t_enter = vec4(t0, t1, t2, t3);
    return uint(h0) | uint(h1) << 1u | uint(h2) << 2u | uint(h3) << 3u;
}

// Orders slots a and b by (entry distance, slot): src/bvh/wide.rs, by_distance, which sorts by
// distance keeping the slots' order among equals. Entries move with their slots (indexing the
// node's arrays by a slot known only at run time would put them in per-lane memory).
void qbvh_order(inout float ta, inout uint sa, inout uvec2 ea, inout float tb, inout uint sb, inout uvec2 eb) {
    if (ta > tb || (ta == tb && sa > sb)) {
        float t = ta;
        ta = tb;
        tb = t;
        uint s = sa;
        sa = sb;
        sb = s;
        uvec2 e = ea;
        ea = eb;
        eb = e;
    }
}

// The slots of `node` the ray enters before t_far, nearest first: how many (0 to 4), their
// entries e0..e3 and entry distances t0..t3 (a sorting network on four; slots not entered last:
// at BVH_FLT_MAX, and after any entered there, their slot numbers raised by 4).
uint qbvh_entered(QuantNode node, BvhSlabRay ray, float t_min, float t_far,
                  out uvec2 e0, out uvec2 e1, out uvec2 e2, out uvec2 e3,
                  out float t0, out float t1, out float t2, out float t3) {
    vec4 t;
    uint mask = qbvh_slabs(node, ray, t_min, t_far, t);
    t0 = t.x;
    t1 = t.y;
    t2 = t.z;
    t3 = t.w;
    bool h0 = (mask & 1u) != 0u, h1 = (mask & 2u) != 0u, h2 = (mask & 4u) != 0u, h3 = (mask & 8u) != 0u;
    uint entered = uint(bitCount(mask));
    e0 = qbvh_entry(node, 0u);
    e1 = qbvh_entry(node, 1u);
    e2 = qbvh_entry(node, 2u);
    e3 = qbvh_entry(node, 3u);
    uint s0 = h0 ? 0u : 4u, s1 = h1 ? 1u : 5u, s2 = h2 ? 2u : 6u, s3 = h3 ? 3u : 7u;
    qbvh_order(t0, s0, e0, t1, s1, e1);
    qbvh_order(t2, s2, e2, t3, s3, e3);
    qbvh_order(t0, s0, e0, t2, s2, e2);
    qbvh_order(t1, s1, e1, t3, s3, e3);
    qbvh_order(t1, s1, e1, t2, s2, e2);
    return entered;
}

// The walks' state and descents, as macros so that the top level (tlas.glsl) and the bottom
// levels share them with their own leaf tests (an array passed to a GLSL function is copied).
// The deferred slots: BVH_DEFER's array and the nearest in registers (three for a closest hit,
// two for an any hit: bvh.glsl).
// SIZE: QBVH_STACK_SIZE for the bottom levels, TLAS_STACK_SIZE for the top level.
#define QBVH_CLOSEST_STATE(SIZE)                     \
    uvec2 stack[SIZE];                               \
    float stack_enter[SIZE];                         \
    uint sp = 0u;                                    \
    uvec2 top = uvec2(0u), mid = uvec2(0u), below = uvec2(0u);        \
    float top_enter = 0.0, mid_enter = 0.0, below_enter = 0.0;
#define QBVH_ANY_STATE(SIZE)                         \
    uvec2 stack[SIZE];                               \
    uint sp = 0u;                                    \
    uvec2 top = uvec2(0u), below = uvec2(0u);
// While-while (Aila & Laine 2009), as in bvh.glsl: from `at`, descends through nodes until every
// lane stands on a leaf (at_leaf) or a dead end (!at_leaf), then the caller tests the leaves
// together. Closest hit: the entered slots nearest first, the farther ones deferred, farthest
// first, so the nearest of them is on top. Reads ray, t_min and t_far.
#define QBVH_DESCEND_CLOSEST(at, at_leaf)                                                           \
    {                                                                                               \
        at_leaf = true;                                                                             \
        if ((at.x & QBVH_LEAF) == 0u) do {                                                          \
            QuantNode node = quant_node_at(at.x);                                                   \
            uvec2 e0, e1, e2, e3;                                                                   \
            float t0, t1, t2, t3;                                                                   \
            uint entered = qbvh_entered(node, ray, t_min, t_far, e0, e1, e2, e3, t0, t1, t2, t3);   \
            if (entered == 0u) {                                                                    \
                at_leaf = false;                                                                    \
                break;                                                                              \
            }                                                                                       \
            if (entered > 3u) BVH_DEFER(e3, t3)                                                     \
            if (entered > 2u) BVH_DEFER(e2, t2)                                                     \
            if (entered > 1u) BVH_DEFER(e1, t1)                                                     \
            at = e0;                                                                                \
        } while ((at.x & QBVH_LEAF) == 0u);                                                         \
    }
// Any hit: the entered slots in slot order (any hit needs no order), the lowest next, each
// further one deferred over the last (src/bvh/wide.rs). Reads ray, t_min and t_max.
#define QBVH_ANY_SLOT(entered, s)                    \
    if (entered) {                                   \
        if (next) {                                  \
            BVH_DEFER_ANY(qbvh_entry(node, s))       \
        } else {                                     \
            at = qbvh_entry(node, s);                \
            next = true;                             \
        }                                            \
    }
#define QBVH_DESCEND_ANY(at, at_leaf)                                                       \
    {                                                                                       \
        at_leaf = true;                                                                     \
        if ((at.x & QBVH_LEAF) == 0u) do {                                                  \
            QuantNode node = quant_node_at(at.x);                                           \
            vec4 t_enter;                                                                   \
            uint mask = qbvh_slabs(node, ray, t_min, t_max, t_enter);                       \
            bool e0 = (mask & 1u) != 0u, e1 = (mask & 2u) != 0u;                            \
            bool e2 = (mask & 4u) != 0u, e3 = (mask & 8u) != 0u;                            \
            bool next = false;                                                              \
            QBVH_ANY_SLOT(e0, 0u)                                                           \
            QBVH_ANY_SLOT(e1, 1u)                                                           \
            QBVH_ANY_SLOT(e2, 2u)                                                           \
            QBVH_ANY_SLOT(e3, 3u)                                                           \
            if (!next) {                                                                    \
                at_leaf = false;                                                            \
                break;                                                                      \
            }                                                                               \
        } while ((at.x & QBVH_LEAF) == 0u);                                                 \
    }

// Closest hit in the bottom level whose quantised root is node `root` (NO_WIDE_ROOT: none) with t
// in (t_min, hit.t): updates hit.t, triangle, u, v and returns true if it finds one. key: the
// ray's alpha key (surface.glsl, alpha_key).
bool qbvh_closest_from(uint root, vec3 origin, vec3 dir, float t_min, uvec4 key, inout HitRecord hit) {
    if (root == NO_WIDE_ROOT) return false;
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    QBVH_CLOSEST_STATE(QBVH_STACK_SIZE)
    uvec2 at = uvec2(root, 0u);
    float t_far = hit.t;
    bool found = false;
    for (;;) {
        bool at_leaf;
        QBVH_DESCEND_CLOSEST(at, at_leaf)
        if (at_leaf && bvh_leaf_closest(at.x & ~QBVH_LEAF, at.y, origin, dir, t_min, key, t_far, hit)) {
            found = true;
        }
        // Pop the next slot the ray enters before the closest hit so far.
        bool popped;
        BVH_POP_ENTERED(at, popped)
        if (!popped) break;
    }
    return found;
}

// True if anything of the bottom level whose quantised root is node `root` is hit with t in
// (t_min, t_max).
bool qbvh_any_from(uint root, vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key) {
    if (root == NO_WIDE_ROOT) return false;
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    QBVH_ANY_STATE(QBVH_STACK_SIZE)
    uvec2 at = uvec2(root, 0u);
    for (;;) {
        bool at_leaf;
        QBVH_DESCEND_ANY(at, at_leaf)
        if (at_leaf && bvh_leaf_any(at.x & ~QBVH_LEAF, at.y, origin, dir, t_min, t_max, key)) return true;
        if (sp == 0u) return false;
        BVH_POP_ANY(at)
    }
    return false;
}

#endif
