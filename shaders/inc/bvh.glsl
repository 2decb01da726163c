// Closest-hit and any-hit BVH traversal: the twin of src/bvh/binary.rs (same maths, same names).
// Needs layout.glsl and, declared by the including kernel (bindings.glsl), the buffers
//   readonly buffer BvhNodes { BvhNode bvh_nodes[]; };
//   readonly buffer Triangles { GpuTriangle triangles[]; };   (in BVH order)
// Nodes are depth-first: an interior node's left child is the next node. The BVH of an empty
// scene is one node with inverted bounds (min > max), which every ray misses.
#ifndef BVH_GLSL
#define BVH_GLSL
#extension GL_KHR_shader_subgroup_vote : require
#include "scene_arrays.glsl"

// Loops whose trip count varies per lane are written `if (c) do { ... } while (c);`, not
// `while (c) { ... }` or `for`: llvmpipe runs a loop's body under its lanes' mask until no lane is
// left, checked where the body ends, so a loop that tests its condition first runs the whole
// body's arithmetic once more, in the trip in which the last lanes leave; tested at the end, the
// loop ends with them. The same bits either way. Counted (tools/instructions.py --device gpu,
// Cornell box 64², 5 December 2026): the walks' loops so written took lavapipe from 10 350 to
// 9 807 instructions per sample.
// Traversal stack entries; the build bounds leaf depth by it (bvh::MAX_DEPTH).
#define BVH_STACK_SIZE 64
// Relative slack of the slab test, keeping culling conservative against rounding (bvh::SLAB_SLACK).
#define BVH_SLAB_SLACK (1.0 / 4096.0)
#define BVH_FLT_MAX 3.402823466e38
#define BVH_FLT_MIN 1.175494351e-38

// The any-hit test: a kernel that defines BVH_ANY_HIT (and includes surface.glsl) honours
// alpha cut-outs and stochastic transparency (surface.rs); others accept every hit.
bool bvh_accept(GpuTriangle tri, uint i, float u, float v, uvec4 key, vec3 dir) {
#ifdef BVH_ANY_HIT
    return triangle_present(tri, i, u, v, key, dir);
#else
    return true;
#endif
}

// Möller–Trumbore ray/triangle test (Möller & Trumbore 1997), double-sided: true for a hit with
// t in (t_min, t_max); u, v are the barycentric weights of p1, p2. NaN fails every test.
bool intersect_triangle(GpuTriangle tri, vec3 origin, vec3 dir, float t_min, float t_max,
                        out float t, out float u, out float v) {
    t = 0.0;
    u = 0.0;
    v = 0.0;
    vec3 pvec = cross(dir, tri.e2);
    float det = dot(tri.e1, pvec);
    if (det == 0.0) return false;
    float inv_det = 1.0 / det;
    vec3 tvec = origin - tri.p0;
    u = dot(tvec, pvec) * inv_det;
    if (!(u >= 0.0 && u <= 1.0)) return false;
    vec3 qvec = cross(tvec, tri.e1);
    v = dot(dir, qvec) * inv_det;
    if (!(v >= 0.0 && u + v <= 1.0)) return false;
    t = dot(tri.e2, qvec) * inv_det;
    return t > t_min && t < t_max;
}

// A ray prepared for slab tests: axes it does not move along (zero or subnormal direction
// components, `still`) are handled exactly, so no infinity or 0·∞ = NaN ever arises.
struct BvhSlabRay {
    vec3 origin;
    vec3 inv_dir;  // 0 on still axes
    bvec3 still;
    bvec3 negative;  // per axis, whether the ray enters through the max plane
    bool sign_form;  // no lane of the subgroup has a still axis (qbvh_slabs)
};

BvhSlabRay bvh_slab_ray(vec3 origin, vec3 dir) {
    BvhSlabRay ray;
    ray.origin = origin;
    ray.still = lessThan(abs(dir), vec3(BVH_FLT_MIN));
    ray.inv_dir = mix(1.0 / mix(dir, vec3(1.0), ray.still), vec3(0.0), ray.still);
    ray.negative = lessThan(dir, vec3(0.0));
    ray.sign_form = subgroupAll(!any(ray.still));
    return ray;
}

// Slab test (Kay & Kajiya 1986): true if the node's box overlaps (t_min, t_max), with
// t_enter = the distance at which the ray enters it.
bool bvh_slab(BvhNode node, BvhSlabRay ray, float t_min, float t_max, out float t_enter) {
    vec3 t0 = (node.bounds_min - ray.origin) * ray.inv_dir;
    vec3 t1 = (node.bounds_max - ray.origin) * ray.inv_dir;
    // A still axis admits every t if the origin lies within the slab, none otherwise.
    vec3 outside = max(node.bounds_min - ray.origin, ray.origin - node.bounds_max);
    vec3 still_near = mix(vec3(-BVH_FLT_MAX), vec3(BVH_FLT_MAX), greaterThan(outside, vec3(0.0)));
    vec3 near = mix(min(t0, t1), still_near, ray.still);
    vec3 far = mix(max(t0, t1), -still_near, ray.still);
    t_enter = max(max(near.x, max(near.y, near.z)), t_min);
    float t_exit = min(min(far.x, min(far.y, far.z)), t_max);
    return t_enter - abs(t_enter) * BVH_SLAB_SLACK <= t_exit;
}

// A node to visit, as the traversal needs it once its box has been tested (src/bvh/binary.rs, Cursor):
// an interior node's children (left, right) or a leaf's primitives (first, count |
// BVH_CURSOR_LEAF). A deferred node is kept as its cursor, made from the record fetched with its
// sibling, so visiting it later fetches nothing.
#define BVH_CURSOR_LEAF 0x80000000u

uvec2 bvh_cursor(uint index, BvhNode node) {
    return bvh_node_is_leaf(node)
        ? uvec2(bvh_node_first_triangle(node), node.count | BVH_CURSOR_LEAF)
        : uvec2(index + 1u, bvh_node_right_child(node));
}

bool bvh_cursor_is_leaf(uvec2 cursor) { return (cursor.y & BVH_CURSOR_LEAF) != 0u; }

uint bvh_cursor_count(uvec2 cursor) { return cursor.y & ~BVH_CURSOR_LEAF; }

// One step down from the interior node `cursor` names (src/bvh/binary.rs, step): how many of its
// children the ray enters before t_far (0, 1 or 2), the one to visit next (`near`) and, when
// both, the one to defer (`far`, entered at `far_enter`). By distance, the nearer child first
// (closest hit); else the left child first (any hit).
uint bvh_step(uvec2 cursor, BvhSlabRay ray, float t_min, float t_far, bool by_distance,
              out uvec2 near, out uvec2 far, out float far_enter) {
    BvhNode left = bvh_node_at(cursor.x);
    BvhNode right = bvh_node_at(cursor.y);
    float dl, dr;
    bool hit_left = bvh_slab(left, ray, t_min, t_far, dl);
    bool hit_right = bvh_slab(right, ray, t_min, t_far, dr);
    uvec2 cl = bvh_cursor(cursor.x, left);
    uvec2 cr = bvh_cursor(cursor.y, right);
    bool left_first = hit_left && (!hit_right || !by_distance || dl <= dr);
    near = left_first ? cl : cr;
    far = left_first ? cr : cl;
    far_enter = left_first ? dr : dl;
    return uint(hit_left) + uint(hit_right);
}

bool bvh_is_empty() {
    return bvh_node_at(0).bounds_min.x > bvh_node_at(0).bounds_max.x;
}

// The deferred entries of a closest-hit walk (this file's and qbvh.glsl's): the top three in
// registers (top, mid, below, with the distances at which the ray enters them), the rest in
// stack[0 .. sp - 3), which a CPU Vulkan device keeps in per-lane memory (a third register took
// extend 4–8 % against shade on lavapipe, four ABBA pairs on four scenes: a 4-wide node defers
// up to three slots at once). Macros over those names: an array passed to a function would be
// copied.
#define BVH_DEFER(e, t_enter)                       \
    {                                               \
        if (sp >= 3u) {                             \
            stack[sp - 3u] = below;                 \
            stack_enter[sp - 3u] = below_enter;     \
        }                                           \
        below = mid;                                \
        below_enter = mid_enter;                    \
        mid = top;                                  \
        mid_enter = top_enter;                      \
        top = (e);                                  \
        top_enter = (t_enter);                      \
        ++sp;                                       \
    }
// Pops entries until one the ray enters before t_far: into `to`, `popped` says whether any.
#define BVH_POP_ENTERED(to, popped)                                           \
    {                                                                         \
        popped = false;                                                       \
        if (sp > 0u) do {                                                     \
            uvec2 next = top;                                                 \
            float next_enter = top_enter;                                     \
            top = mid;                                                        \
            top_enter = mid_enter;                                            \
            mid = below;                                                      \
            mid_enter = below_enter;                                          \
            if (sp >= 4u) {                                                   \
                below = stack[sp - 4u];                                       \
                below_enter = stack_enter[sp - 4u];                           \
            }                                                                 \
            --sp;                                                             \
            if (next_enter - abs(next_enter) * BVH_SLAB_SLACK <= t_far) {     \
                to = next;                                                    \
                popped = true;                                                \
                break;                                                        \
            }                                                                 \
        } while (sp > 0u);                                                    \
    }
// The same without distances, for any hit, with the top two in registers (a third made the
// shadow rays' walk no faster on lavapipe: connect against shade +1 to +7 %, four ABBA pairs).
#define BVH_DEFER_ANY(e)                       \
    {                                          \
        if (sp >= 2u) stack[sp - 2u] = below;  \
        below = top;                           \
        top = (e);                             \
        ++sp;                                  \
    }
#define BVH_POP_ANY(to)                            \
    {                                              \
        to = top;                                  \
        top = below;                               \
        if (sp >= 3u) below = stack[sp - 3u];      \
        --sp;                                      \
    }

// A leaf's triangles [first, first + count) against hits closer than t_far: updates t_far and
// hit (t, triangle, u, v) and returns true if one is closer. The top two material bits say
// whether a hit needs an any-hit test.
bool bvh_leaf_closest(uint first, uint count, vec3 origin, vec3 dir, float t_min, uvec4 key,
                      inout float t_far, inout HitRecord hit) {
    bool found = false;
    uint i = first;
    if (i < first + count) do {
        float t, u, v;
        GpuTriangle tri = triangle_at(i);
        if (intersect_triangle(tri, origin, dir, t_min, t_far, t, u, v)
            && ((tri.material >> 30u) == 0u || bvh_accept(tri, i, u, v, key, dir))) {
            t_far = t;
            hit.t = t;
            hit.triangle = i;
            hit.u = u;
            hit.v = v;
            found = true;
        }
    } while (++i < first + count);
    return found;
}

// Whether any of a leaf's triangles [first, first + count) is hit with t in (t_min, t_max).
bool bvh_leaf_any(uint first, uint count, vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key) {
    uint i = first;
    if (i < first + count) do {
        float t, u, v;
        GpuTriangle tri = triangle_at(i);
        if (intersect_triangle(tri, origin, dir, t_min, t_max, t, u, v)
            && ((tri.material >> 30u) == 0u || bvh_accept(tri, i, u, v, key, dir))) return true;
    } while (++i < first + count);
    return false;
}

// Closest hit with t in (t_min, t_max). On a miss returns false with hit.triangle = NO_HIT.
// Closest hit in the subtree rooted at node `root` (node and triangle indices absolute) with t in
// (t_min, hit.t): updates hit.t, triangle, u, v and returns true if it finds one. key: the ray's
// alpha key (surface.glsl, alpha_key).
bool bvh_closest_from(uint root, vec3 origin, vec3 dir, float t_min, uvec4 key, inout HitRecord hit) {
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    // Deferred nodes with the distance at which the ray enters them: the top two in registers
    // (top, below), the rest in stack[0 .. sp - 2), which a CPU Vulkan device keeps in memory.
    uvec2 stack[BVH_STACK_SIZE];
    float stack_enter[BVH_STACK_SIZE];
    uint sp = 0u;
    uvec2 top = uvec2(0u), mid = uvec2(0u), below = uvec2(0u);
    float top_enter = 0.0, mid_enter = 0.0, below_enter = 0.0;
    BvhNode node = bvh_node_at(root);
    float t_far = hit.t;
    bool found = false;
    float t_enter;
    if (!bvh_slab(node, ray, t_min, t_far, t_enter)) return false;
    uvec2 cursor = bvh_cursor(root, node);
    for (;;) {
        // While-while (Aila & Laine 2009): descend through interior nodes until every
        // lane of a SIMD group stands on a leaf or a dead end, then test the leaves together.
        bool at_leaf = true;
        if (!bvh_cursor_is_leaf(cursor)) do {
            // Descend into the nearer child; keep the farther for later when both are entered.
            uvec2 near, far;
            float far_enter;
            uint entered = bvh_step(cursor, ray, t_min, t_far, true, near, far, far_enter);
            if (entered == 0u) {
                at_leaf = false;
                break;
            }
            if (entered == 2u) BVH_DEFER(far, far_enter)
            cursor = near;
        } while (!bvh_cursor_is_leaf(cursor));
        if (at_leaf && bvh_leaf_closest(cursor.x, bvh_cursor_count(cursor), origin, dir, t_min, key,
                                        t_far, hit)) {
            found = true;
        }
        // Pop the next node the ray enters before the closest hit so far.
        bool popped;
        BVH_POP_ENTERED(cursor, popped)
        if (!popped) break;
    }
    return found;
}

// Closest hit with t in (t_min, t_max) in the BVH rooted at node 0. On a miss returns false with
// hit.triangle = NO_HIT.
bool bvh_intersect_closest(vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key, out HitRecord hit) {
    hit = HitRecord(t_max, NO_HIT, 0.0, 0.0, 0u, 0u, 0u, 0u);
    if (bvh_is_empty()) return false;
    return bvh_closest_from(0u, origin, dir, t_min, key, hit);
}

// True if anything in the subtree rooted at `root` is hit with t in (t_min, t_max) (shadow rays;
// exits at the first hit).
bool bvh_any_from(uint root, vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key) {
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    // As in bvh_closest_from: the top two deferred nodes in registers.
    uvec2 stack[BVH_STACK_SIZE];
    uint sp = 0u;
    uvec2 top = uvec2(0u), below = uvec2(0u);
    BvhNode node = bvh_node_at(root);
    float t_enter;
    if (!bvh_slab(node, ray, t_min, t_max, t_enter)) return false;
    uvec2 cursor = bvh_cursor(root, node);
    for (;;) {
        // While-while (Aila & Laine 2009): descend through interior nodes until every
        // lane of a SIMD group stands on a leaf or a dead end, then test the leaves together.
        bool at_leaf = true;
        if (!bvh_cursor_is_leaf(cursor)) do {
            uvec2 near, far;
            float far_enter;
            uint entered = bvh_step(cursor, ray, t_min, t_max, false, near, far, far_enter);
            if (entered == 0u) {
                at_leaf = false;
                break;
            }
            if (entered == 2u) BVH_DEFER_ANY(far)
            cursor = near;
        } while (!bvh_cursor_is_leaf(cursor));
        if (at_leaf && bvh_leaf_any(cursor.x, bvh_cursor_count(cursor), origin, dir, t_min, t_max, key)) {
            return true;
        }
        if (sp == 0u) return false;
        BVH_POP_ANY(cursor)
    }
    return false;
}

// bvh_any_from the BVH rooted at node 0.
bool bvh_intersect_any(vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key) {
    if (bvh_is_empty()) return false;
    return bvh_any_from(0u, origin, dir, t_min, t_max, key);
}

#endif
