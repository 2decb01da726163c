// Reads of the scene's five large arrays: BVH nodes, triangles, their vertex indices, vertices
// and texels. A kernel (bindings.glsl, SCENE_SPLIT_BINDINGS) reads an array that is larger than
// one storage binding from up to four bindings of 2^shift elements each; the shifts are
// specialization constants chosen per scene (src/gpu/pipelines.rs, SceneSplit), 32 meaning "one
// binding", so a scene that fits compiles to the plain read and pays nothing. The test kernels
// declare only the first binding of each array and read it directly.
#ifndef SCENE_ARRAYS_GLSL
#define SCENE_ARRAYS_GLSL

#ifdef SCENE_SPLIT_BINDINGS
layout(constant_id = 0) const uint BVH_NODE_SHIFT = 32u;
layout(constant_id = 1) const uint TRIANGLE_SHIFT = 32u;
layout(constant_id = 2) const uint TRIANGLE_VERTICES_SHIFT = 32u;
layout(constant_id = 3) const uint VERTEX_SHIFT = 32u;
layout(constant_id = 4) const uint TEXEL_SHIFT = 32u;

// Element i of an array split into bindings a0..a3 of 2^shift elements. (The shift is passed in
// rather than named: an expression of specialization constants alone would compile to
// OpSpecConstantOp, which naga does not read. The driver folds it all the same once the
// function is inlined with the constant.)
#define SPLIT_READ(T, name, split_name, SHIFT, a0, a1, a2, a3) \
    T split_name(uint i, uint shift) {                     \
        if (shift >= 32u) return a0[i];                    \
        uint j = i & ((1u << shift) - 1u);                 \
        switch (i >> shift) {                              \
        case 0u: return a0[j];                             \
        case 1u: return a1[j];                             \
        case 2u: return a2[j];                             \
        default: return a3[j];                             \
        }                                                  \
    }                                                      \
    T name(uint i) { return split_name(i, SHIFT); }
SPLIT_READ(BvhNode, bvh_node_at, bvh_node_split, BVH_NODE_SHIFT, bvh_nodes, bvh_nodes1,
           bvh_nodes2, bvh_nodes3)
SPLIT_READ(GpuTriangle, triangle_at, triangle_split, TRIANGLE_SHIFT, triangles, triangles1,
           triangles2, triangles3)
SPLIT_READ(uvec4, triangle_vertices_at, triangle_vertices_split, TRIANGLE_VERTICES_SHIFT,
           triangle_vertices, triangle_vertices1, triangle_vertices2, triangle_vertices3)
SPLIT_READ(GpuVertex, vertex_at, vertex_split, VERTEX_SHIFT, vertices, vertices1, vertices2,
           vertices3)
SPLIT_READ(uint, texel_at, texel_split, TEXEL_SHIFT, texels, texels1, texels2, texels3)
#undef SPLIT_READ
#else
#define bvh_node_at(i) bvh_nodes[i]
#define triangle_at(i) triangles[i]
#define triangle_vertices_at(i) triangle_vertices[i]
#define vertex_at(i) vertices[i]
#define texel_at(i) texels[i]
#endif

#endif
