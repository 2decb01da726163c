// The two-level structure: a top-level BVH over instances (GpuInstance), each placing a
// bottom-level BVH in the world. Twin of src/tlas.rs. Needs bvh.glsl, the instances buffer and
// frame.tlas_root. A scene with one identity instance (no instancing) skips the top level. Every
// level is walked in its quantised 4-wide nodes (qbvh.glsl: the top level from
// frame.tlas_wide_root, the bottom levels from GpuInstance.wide_root), or in its binary nodes
// where it has none (src/render/prepared.rs, gpu_bvh).
#ifndef TLAS_GLSL
#define TLAS_GLSL
#include "scene_arrays.glsl"
#include "qbvh.glsl"
#include "transform.glsl"

// The alpha key of a ray inside instance k (the same triangle in two instances decides apart).
uvec4 instance_key(uvec4 key, uint k) {
    return uvec4(key.xyz, key.w ^ (k * 0x85ebca6bu));
}

// A world-space ray in instance inst's object space (src/tlas.rs, object_ray).
void instance_ray(GpuInstance inst, vec3 origin, vec3 dir, out vec3 o, out vec3 d) {
    bool identity = (inst.flags & INSTANCE_IDENTITY) != 0u;
    o = identity ? origin : transform_point(inst.world_to_object, origin);
    d = identity ? dir : transform_vector(inst.world_to_object, dir);
}

// The bottom level of instance `inst` (in its space): in its quantised 4-wide nodes, or in its
// binary ones where it has none (no triangles, or a walk that could defer more slots than
// qbvh.glsl keeps; src/render/prepared.rs, gpu_bvh).
bool blas_closest(GpuInstance inst, vec3 o, vec3 d, float t_min, uvec4 key, inout HitRecord hit) {
    return !SCENE_HAS(FEATURE_BINARY_WALK) || inst.wide_root != NO_WIDE_ROOT ? qbvh_closest_from(inst.wide_root, o, d, t_min, key, hit)
                                          : bvh_closest_from(inst.blas_root, o, d, t_min, key, hit);
}

bool blas_any(GpuInstance inst, vec3 o, vec3 d, float t_min, float t_max, uvec4 key) {
    return !SCENE_HAS(FEATURE_BINARY_WALK) || inst.wide_root != NO_WIDE_ROOT ? qbvh_any_from(inst.wide_root, o, d, t_min, t_max, key)
                                          : bvh_any_from(inst.blas_root, o, d, t_min, t_max, key);
}

// One identity instance (a scene without instancing): the top level is skipped.
bool single_identity_instance() {
    return instances.length() == 1u && (instances[0].flags & INSTANCE_IDENTITY) != 0u;
}

// A top-level leaf's instances [first, first + count) against hits closer than hit.t: updates
// hit (hit.instance names the instance) and returns true if one is closer. Directions are not
// normalised in object space, so t is the same in both spaces.
bool tlas_leaf_closest(uint first, uint count, vec3 origin, vec3 dir, float t_min, uvec4 key, inout HitRecord hit) {
    bool found = false;
    uint k = first;
    if (k < first + count) do {
        GpuInstance inst = instance_inverse_at(k);
        vec3 o, d;
        instance_ray(inst, origin, dir, o, d);
        if (blas_closest(inst, o, d, t_min, instance_key(key, k), hit)) {
            hit.instance = k;
            found = true;
        }
    } while (++k < first + count);
    return found;
}

bool tlas_leaf_any(uint first, uint count, vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key) {
    uint k = first;
    if (k < first + count) do {
        GpuInstance inst = instance_inverse_at(k);
        vec3 o, d;
        instance_ray(inst, origin, dir, o, d);
        if (blas_any(inst, o, d, t_min, t_max, instance_key(key, k))) return true;
    } while (++k < first + count);
    return false;
}

// The top level in its quantised nodes from frame.tlas_wide_root (qbvh.glsl's walks with the
// instances as leaves): the CPU's walk of the same nodes (src/tlas.rs, scene_intersect_closest
// over WideBvh<QuantNode>).
bool tlas_closest_quantised(vec3 origin, vec3 dir, float t_min, uvec4 key, inout HitRecord hit) {
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    QBVH_CLOSEST_STATE(TLAS_STACK_SIZE)
    uvec2 at = uvec2(frame.tlas_wide_root, 0u);
    float t_far = hit.t;
    for (;;) {
        bool at_leaf;
        QBVH_DESCEND_CLOSEST(at, at_leaf)
        if (at_leaf && tlas_leaf_closest(at.x & ~QBVH_LEAF, at.y, origin, dir, t_min, key, hit)) {
            t_far = hit.t;
        }
        bool popped;
        BVH_POP_ENTERED(at, popped)
        if (!popped) break;
    }
    return hit.triangle != NO_HIT;
}

bool tlas_any_quantised(vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key) {
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    QBVH_ANY_STATE(TLAS_STACK_SIZE)
    uvec2 at = uvec2(frame.tlas_wide_root, 0u);
    for (;;) {
        bool at_leaf;
        QBVH_DESCEND_ANY(at, at_leaf)
        if (at_leaf && tlas_leaf_any(at.x & ~QBVH_LEAF, at.y, origin, dir, t_min, t_max, key)) return true;
        if (sp == 0u) return false;
        BVH_POP_ANY(at)
    }
    return false;
}

// Closest hit with t in (t_min, t_max) over every instance; hit.instance names the instance.
bool scene_intersect_closest(vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key, out HitRecord hit) {
    hit = HitRecord(t_max, NO_HIT, 0.0, 0.0, 0u, 0u, 0u, 0u);
    if (instances.length() == 0u) return false;
    if (!SCENE_HAS(FEATURE_TOP_LEVEL) || single_identity_instance()) {
        return blas_closest(instances[0], origin, dir, t_min, key, hit);
    }
    if (!SCENE_HAS(FEATURE_BINARY_WALK) || frame.tlas_wide_root != NO_WIDE_ROOT) return tlas_closest_quantised(origin, dir, t_min, key, hit);
    // The top level in its binary nodes (bvh.glsl's walk with the instances as leaves).
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    uvec2 stack[BVH_STACK_SIZE];
    float stack_enter[BVH_STACK_SIZE];
    uint sp = 0u;
    BvhNode node = bvh_node_at(frame.tlas_root);
    float t_enter;
    if (!bvh_slab(node, ray, t_min, hit.t, t_enter)) return false;
    uvec2 cursor = bvh_cursor(frame.tlas_root, node);
    for (;;) {
        // While-while, as in bvh.glsl: the top level's interior nodes first, then the
        // instances of the leaves reached, lanes together.
        bool at_leaf = true;
        if (!bvh_cursor_is_leaf(cursor)) do {
            uvec2 near, far;
            float far_enter;
            uint entered = bvh_step(cursor, ray, t_min, hit.t, true, near, far, far_enter);
            if (entered == 0u) {
                at_leaf = false;
                break;
            }
            if (entered == 2u) {
                stack[sp] = far;
                stack_enter[sp] = far_enter;
                ++sp;
            }
            cursor = near;
        } while (!bvh_cursor_is_leaf(cursor));
        if (at_leaf) tlas_leaf_closest(cursor.x, bvh_cursor_count(cursor), origin, dir, t_min, key, hit);
        bool popped = false;
        if (sp > 0u) do {
            --sp;
            if (stack_enter[sp] - abs(stack_enter[sp]) * BVH_SLAB_SLACK <= hit.t) {
                cursor = stack[sp];
                popped = true;
                break;
            }
        } while (sp > 0u);
        if (!popped) break;
    }
    return hit.triangle != NO_HIT;
}

// True if anything of any instance is hit with t in (t_min, t_max).
bool scene_intersect_any(vec3 origin, vec3 dir, float t_min, float t_max, uvec4 key) {
    if (instances.length() == 0u) return false;
    if (!SCENE_HAS(FEATURE_TOP_LEVEL) || single_identity_instance()) {
        return blas_any(instances[0], origin, dir, t_min, t_max, key);
    }
    if (!SCENE_HAS(FEATURE_BINARY_WALK) || frame.tlas_wide_root != NO_WIDE_ROOT) return tlas_any_quantised(origin, dir, t_min, t_max, key);
    BvhSlabRay ray = bvh_slab_ray(origin, dir);
    uvec2 stack[BVH_STACK_SIZE];
    uint sp = 0u;
    BvhNode node = bvh_node_at(frame.tlas_root);
    float t_enter;
    if (!bvh_slab(node, ray, t_min, t_max, t_enter)) return false;
    uvec2 cursor = bvh_cursor(frame.tlas_root, node);
    for (;;) {
        // While-while, as in bvh.glsl: the top level's interior nodes first, then the
        // instances of the leaves reached, lanes together.
        bool at_leaf = true;
        if (!bvh_cursor_is_leaf(cursor)) do {
            uvec2 near, far;
            float far_enter;
            uint entered = bvh_step(cursor, ray, t_min, t_max, false, near, far, far_enter);
            if (entered == 0u) {
                at_leaf = false;
                break;
            }
            if (entered == 2u) stack[sp++] = far;
            cursor = near;
        } while (!bvh_cursor_is_leaf(cursor));
        if (at_leaf && tlas_leaf_any(cursor.x, bvh_cursor_count(cursor), origin, dir, t_min, t_max, key)) return true;
        if (sp == 0u) return false;
        cursor = stack[--sp];
    }
    return false;
}

#endif
