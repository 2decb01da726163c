// Reads of the scene's five large arrays: BVH nodes, triangles, their vertex indices, vertices
// and texels. A kernel (bindings.glsl, SCENE_SPLIT_BINDINGS) reads an array that is larger than
// one storage binding from up to four bindings of 2^shift elements each; the shifts are
// specialization constants chosen per scene (src/gpu/bindings.rs, SceneSplit), 32 meaning "one
// binding", so a scene that fits compiles to the plain read and pays nothing. The test kernels
// declare only the first binding of each array and read it directly.
#ifndef SCENE_ARRAYS_GLSL
#define SCENE_ARRAYS_GLSL

// A quantised node from its two node records as a storage buffer holds them (their floats' bits
// are the node's words).
QuantNode quant_node_from_records(BvhNode a, BvhNode b) {
    uvec3 c = floatBitsToUint(b.bounds_min), d = floatBitsToUint(b.bounds_max);
    return QuantNode(a.bounds_min, a.offset, uvec4(floatBitsToUint(a.bounds_max), a.count),
                     uint[6](c.x, c.y, c.z, b.offset, d.x, d.y), d.z, b.count);
}

#ifdef SCENE_SPLIT_BINDINGS
layout(constant_id = 0) const uint BVH_NODE_SHIFT = 32u;
layout(constant_id = 1) const uint TRIANGLE_SHIFT = 32u;
layout(constant_id = 2) const uint TRIANGLE_VERTICES_SHIFT = 32u;
layout(constant_id = 3) const uint VERTEX_SHIFT = 32u;
layout(constant_id = 4) const uint TEXEL_SHIFT = 32u;
// 1: BVH nodes, triangles, their vertex indices, vertices, materials and light BVH nodes are read
// from storage images, 2: from the same images as sampled images (bindings.glsl;
// src/gpu/bindings.rs, SceneImage and SceneImages). On llvmpipe an image read loads each lane's
// 16 bytes at once, where a storage-buffer read is a conditional load per lane and word
// (docs/perf-log/2026-12-02-lavapipe-scene-reads.md).
layout(constant_id = 5) const uint SCENE_IMAGES = 0u;
// Texels per image row: 1 << SCENE_IMAGE_SHIFT (src/gpu/bindings.rs, SCENE_IMAGE_WIDTH).
#define SCENE_IMAGE_SHIFT 12u
// Texels this invocation fetched from the scene images (count_scene_fetches).
uint scene_fetches = 0u;
#define SCENE_TEXEL(image, a)                                                                   \
    (scene_fetches += 1u,                                                                       \
     scene_images_sampled(SCENE_IMAGES) ? texelFetch(image##_sampled, scene_texel_at(a), 0)    \
                                        : imageLoad(image, scene_texel_at(a)))
// Where texel a of a scene image lies: column, row.
ivec2 scene_texel_at(uint a) {
    return ivec2(a & ((1u << SCENE_IMAGE_SHIFT) - 1u), a >> SCENE_IMAGE_SHIFT);
}
// Whether SCENE_IMAGES says sampled images (passed in, for the reason SPLIT_READ gives).
bool scene_images_sampled(uint images) {
    return images == 2u;
}

#ifdef KERNEL_INDEX
#extension GL_KHR_shader_subgroup_arithmetic : require
#endif
// With frame.count_fetches (render --stats): adds the subgroup's fetches to its kernel's
// 64-bit count, counters[COUNTER_FETCHES + 2 KERNEL_INDEX] (low word) and the next (high word;
// src/layout.rs, counter::FETCHES), one atomicAdd per subgroup rather than per lane (the same
// integer total). Every kernel's main ends with it, where its lanes have reconverged.
void count_scene_fetches() {
#ifdef KERNEL_INDEX
    if (frame.count_fetches == 0u) return;
    uint fetched = subgroupAdd(scene_fetches);
    // The subgroup's first lane (naga reads an exclusive sum, not subgroupElect).
    if (subgroupExclusiveAdd(1u) != 0u || fetched == 0u) return;
    uint slot = COUNTER_FETCHES + 2u * KERNEL_INDEX;
    uint before = atomicAdd(counters[slot], fetched);
    if (before + fetched < before) atomicAdd(counters[slot + 1u], 1u);
#endif
}

BvhNode bvh_node_image_at(uint i) {
    uvec4 a = SCENE_TEXEL(bvh_node_image, 2u * i);
    uvec4 b = SCENE_TEXEL(bvh_node_image, 2u * i + 1u);
    BvhNode node;
    node.bounds_min = uintBitsToFloat(a.xyz);
    node.offset = a.w;
    node.bounds_max = uintBitsToFloat(b.xyz);
    node.count = b.w;
    return node;
}

// The quantised 4-wide node (QuantNode, layout.glsl) at node index i: node records i and i + 1,
// four texels read as they are stored.
QuantNode quant_node_image_at(uint i) {
    uvec4 a = SCENE_TEXEL(bvh_node_image, 2u * i);
    uvec4 b = SCENE_TEXEL(bvh_node_image, 2u * i + 1u);
    uvec4 c = SCENE_TEXEL(bvh_node_image, 2u * i + 2u);
    uvec4 d = SCENE_TEXEL(bvh_node_image, 2u * i + 3u);
    return QuantNode(uintBitsToFloat(a.xyz), a.w, b, uint[6](c.x, c.y, c.z, c.w, d.x, d.y), d.z, d.w);
}

GpuVertex vertex_image_at(uint i) {
    GpuVertex v;
    v.tangent = uintBitsToFloat(SCENE_TEXEL(vertex_image, 4u * i));
    uvec4 n = SCENE_TEXEL(vertex_image, 4u * i + 1u);
    v.normal = uintBitsToFloat(n.xyz);
    v.pad = n.w;
    v.uv = uintBitsToFloat(SCENE_TEXEL(vertex_image, 4u * i + 2u));
    v.color = uintBitsToFloat(SCENE_TEXEL(vertex_image, 4u * i + 3u));
    return v;
}

GpuLightNode light_node_image_at(uint i) {
    uvec4 a = SCENE_TEXEL(light_node_image, 4u * i);
    uvec4 b = SCENE_TEXEL(light_node_image, 4u * i + 1u);
    uvec4 c = SCENE_TEXEL(light_node_image, 4u * i + 2u);
    uvec4 d = SCENE_TEXEL(light_node_image, 4u * i + 3u);
    GpuLightNode node;
    node.bounds_min = uintBitsToFloat(a.xyz);
    node.phi = uintBitsToFloat(a.w);
    node.bounds_max = uintBitsToFloat(b.xyz);
    node.cos_theta_o = uintBitsToFloat(b.w);
    node.w = uintBitsToFloat(c.xyz);
    node.cos_theta_e = uintBitsToFloat(c.w);
    node.child_or_light = d.x;
    node.flags = d.y;
    node.radius = uintBitsToFloat(d.z);
    node.sin_theta_o = uintBitsToFloat(d.w);
    return node;
}

// An instance's texels: the last (root and flags) first; an identity placement's transforms
// are not read (every use tests INSTANCE_IDENTITY first; they are set to the identity), and
// with `forward` false neither is object_to_world (traversal needs only the inverse).
GpuInstance instance_image_read(uint i, bool forward) {
    GpuInstance inst;
    uvec4 t = SCENE_TEXEL(instance_image, 7u * i + 6u);
    inst.blas_root = t.x;
    inst.flags = t.y;
    inst.wide_root = t.z;
    inst.placement = t.w;
    for (uint r = 0u; r < 3u; ++r) {
        vec4 row = vec4(0.0);
        row[r] = 1.0;
        inst.object_to_world[r] = row;
        inst.world_to_object[r] = row;
    }
    if ((inst.flags & INSTANCE_IDENTITY) != 0u) return inst;
    for (uint r = 0u; r < 3u; ++r) {
        if (forward) inst.object_to_world[r] = uintBitsToFloat(SCENE_TEXEL(instance_image, 7u * i + r));
        inst.world_to_object[r] = uintBitsToFloat(SCENE_TEXEL(instance_image, 7u * i + 3u + r));
    }
    return inst;
}
GpuInstance instance_image_at(uint i) { return instance_image_read(i, true); }

GpuTexture texture_image_at(uint i) {
    uvec4 a = SCENE_TEXEL(texture_image, 2u * i);
    uvec4 b = SCENE_TEXEL(texture_image, 2u * i + 1u);
    return GpuTexture(a.x, a.y, a.z, a.w, b.x, b.y, b.z, b.w);
}

GpuTextureRef texture_ref_image_at(uint i) {
    GpuTextureRef r;
    r.transform = uintBitsToFloat(SCENE_TEXEL(texture_ref_image, 2u * i));
    uvec4 t = SCENE_TEXEL(texture_ref_image, 2u * i + 1u);
    r.offset = uintBitsToFloat(t.xy);
    r.texture = t.z;
    r.texcoord = t.w;
    return r;
}

LightEntry light_image_at(uint i) {
    uvec4 t = SCENE_TEXEL(light_image, i);
    return LightEntry(uintBitsToFloat(t.x), t.y, uintBitsToFloat(t.z), t.w);
}

// The 16 texels of a GpuMaterial, member by member at its std430 offsets (layout.glsl); a
// material without MATERIAL_EXTENDED is read as its first five texels and the rest are
// GpuMaterial::default()'s (src/layout.rs, GpuMaterial::image_record).
GpuMaterial material_image_at(uint i) {
    uint a = 16u * i;
    uvec4 t;
    GpuMaterial m;
    t = SCENE_TEXEL(material_image, a);
    m.base_color = uintBitsToFloat(t.xyz);
    m.flags = t.w;
    t = SCENE_TEXEL(material_image, a + 1u);
    m.emission = uintBitsToFloat(t.xyz);
    m.metallic = uintBitsToFloat(t.w);
    vec4 f = uintBitsToFloat(SCENE_TEXEL(material_image, a + 2u));
    m.roughness = f.x;
    m.ior = f.y;
    m.transmission = f.z;
    m.specular = f.w;
    t = SCENE_TEXEL(material_image, a + 3u);
    m.alpha = uintBitsToFloat(t.x);
    m.alpha_cutoff = uintBitsToFloat(t.y);
    m.normal_scale = uintBitsToFloat(t.z);
    m.base_color_texture = t.w;
    t = SCENE_TEXEL(material_image, a + 4u);
    m.metallic_roughness_texture = t.x;
    m.emissive_texture = t.y;
    m.normal_texture = t.z;
    m.transmission_texture = t.w;
    if ((m.flags & MATERIAL_EXTENDED) == 0u) {
        m.specular_color = vec3(1.0);
        m.specular_texture = NO_TEXTURE;
        m.specular_color_texture = NO_TEXTURE;
        m.clearcoat = 0.0;
        m.clearcoat_roughness = 0.0;
        m.clearcoat_texture = NO_TEXTURE;
        m.clearcoat_roughness_texture = NO_TEXTURE;
        m.clearcoat_normal_texture = NO_TEXTURE;
        m.clearcoat_normal_scale = 1.0;
        m.sheen_roughness = 0.0;
        m.clearcoat_normal = vec3(0.0);
        m.sheen_color_texture = NO_TEXTURE;
        m.sheen_color = vec3(0.0);
        m.sheen_roughness_texture = NO_TEXTURE;
        m.anisotropy_direction = vec3(0.0);
        m.anisotropy = 0.0;
        m.anisotropy_rotation = 0.0;
        m.anisotropy_texture = NO_TEXTURE;
        m.iridescence = 0.0;
        m.iridescence_ior = 1.3;
        m.iridescence_thickness_min = 100.0;
        m.iridescence_thickness = 400.0;
        m.iridescence_texture = NO_TEXTURE;
        m.iridescence_thickness_texture = NO_TEXTURE;
        m.attenuation = vec3(0.0);
        m.thickness = 0.0;
        m.diffuse_transmission_color = vec3(1.0);
        m.diffuse_transmission = 0.0;
        m.diffuse_transmission_texture = NO_TEXTURE;
        m.diffuse_transmission_color_texture = NO_TEXTURE;
        m.dispersion = 0.0;
        m.pad1 = 0u;
        return m;
    }
    t = SCENE_TEXEL(material_image, a + 5u);
    m.specular_color = uintBitsToFloat(t.xyz);
    m.specular_texture = t.w;
    t = SCENE_TEXEL(material_image, a + 6u);
    m.specular_color_texture = t.x;
    m.clearcoat = uintBitsToFloat(t.y);
    m.clearcoat_roughness = uintBitsToFloat(t.z);
    m.clearcoat_texture = t.w;
    t = SCENE_TEXEL(material_image, a + 7u);
    m.clearcoat_roughness_texture = t.x;
    m.clearcoat_normal_texture = t.y;
    m.clearcoat_normal_scale = uintBitsToFloat(t.z);
    m.sheen_roughness = uintBitsToFloat(t.w);
    t = SCENE_TEXEL(material_image, a + 8u);
    m.clearcoat_normal = uintBitsToFloat(t.xyz);
    m.sheen_color_texture = t.w;
    t = SCENE_TEXEL(material_image, a + 9u);
    m.sheen_color = uintBitsToFloat(t.xyz);
    m.sheen_roughness_texture = t.w;
    f = uintBitsToFloat(SCENE_TEXEL(material_image, a + 10u));
    m.anisotropy_direction = f.xyz;
    m.anisotropy = f.w;
    t = SCENE_TEXEL(material_image, a + 11u);
    m.anisotropy_rotation = uintBitsToFloat(t.x);
    m.anisotropy_texture = t.y;
    m.iridescence = uintBitsToFloat(t.z);
    m.iridescence_ior = uintBitsToFloat(t.w);
    t = SCENE_TEXEL(material_image, a + 12u);
    m.iridescence_thickness_min = uintBitsToFloat(t.x);
    m.iridescence_thickness = uintBitsToFloat(t.y);
    m.iridescence_texture = t.z;
    m.iridescence_thickness_texture = t.w;
    f = uintBitsToFloat(SCENE_TEXEL(material_image, a + 13u));
    m.attenuation = f.xyz;
    m.thickness = f.w;
    f = uintBitsToFloat(SCENE_TEXEL(material_image, a + 14u));
    m.diffuse_transmission_color = f.xyz;
    m.diffuse_transmission = f.w;
    t = SCENE_TEXEL(material_image, a + 15u);
    m.diffuse_transmission_texture = t.x;
    m.diffuse_transmission_color_texture = t.y;
    m.dispersion = uintBitsToFloat(t.z);
    m.pad1 = t.w;
    return m;
}

GpuTriangle triangle_image_at(uint i) {
    uvec4 a = SCENE_TEXEL(triangle_image, 3u * i);
    uvec4 b = SCENE_TEXEL(triangle_image, 3u * i + 1u);
    uvec4 c = SCENE_TEXEL(triangle_image, 3u * i + 2u);
    GpuTriangle tri;
    tri.p0 = uintBitsToFloat(a.xyz);
    tri.material = a.w;
    tri.e1 = uintBitsToFloat(b.xyz);
    tri.light_pmf = uintBitsToFloat(b.w);
    tri.e2 = uintBitsToFloat(c.xyz);
    tri.area = uintBitsToFloat(c.w);
    return tri;
}

// Element i of an array split into bindings a0..a3 of 2^shift elements. (The shift is passed in
// rather than named: an expression of specialization constants alone would compile to
// OpSpecConstantOp, which naga does not read. The driver folds it all the same once the
// function is inlined with the constant.)
#ifdef SCENE_ONE_BINDING
#define SPLIT_READ(T, name, split_name, SHIFT, a0, a1, a2, a3) \
    T split_name(uint i, uint shift) { return a0[i]; }     \
    T name(uint i) { return split_name(i, SHIFT); }
#else
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
#endif
SPLIT_READ(BvhNode, bvh_node_buffer_at, bvh_node_split, BVH_NODE_SHIFT, bvh_nodes, bvh_nodes1,
           bvh_nodes2, bvh_nodes3)
SPLIT_READ(GpuTriangle, triangle_buffer_at, triangle_split, TRIANGLE_SHIFT, triangles, triangles1,
           triangles2, triangles3)
SPLIT_READ(uvec4, triangle_vertices_buffer_at, triangle_vertices_split, TRIANGLE_VERTICES_SHIFT,
           triangle_vertices, triangle_vertices1, triangle_vertices2, triangle_vertices3)
SPLIT_READ(GpuVertex, vertex_buffer_at, vertex_split, VERTEX_SHIFT, vertices, vertices1, vertices2,
           vertices3)
SPLIT_READ(uint, texel_buffer_at, texel_split, TEXEL_SHIFT, texels, texels1, texels2, texels3)
#undef SPLIT_READ
// Element i from its image where SCENE_IMAGES is 1, else from its buffer: name_read(i, images)
// (the constant passed in for the reason SPLIT_READ gives) and name(i).
#define IMAGE_OR_BUFFER(T, name, name_read, IMAGE_READ, BUFFER_READ)                  \
    T name_read(uint i, uint images) { return images != 0u ? IMAGE_READ : BUFFER_READ; } \
    T name(uint i) { return name_read(i, SCENE_IMAGES); }
IMAGE_OR_BUFFER(BvhNode, bvh_node_at, bvh_node_read, bvh_node_image_at(i), bvh_node_buffer_at(i))
IMAGE_OR_BUFFER(QuantNode, quant_node_at, quant_node_read, quant_node_image_at(i),
                quant_node_from_records(bvh_node_buffer_at(i), bvh_node_buffer_at(i + 1u)))
IMAGE_OR_BUFFER(GpuTriangle, triangle_at, triangle_read, triangle_image_at(i), triangle_buffer_at(i))
IMAGE_OR_BUFFER(uvec4, triangle_vertices_at, triangle_vertices_read,
                SCENE_TEXEL(triangle_vertex_image, i), triangle_vertices_buffer_at(i))
IMAGE_OR_BUFFER(GpuVertex, vertex_at, vertex_read, vertex_image_at(i), vertex_buffer_at(i))
IMAGE_OR_BUFFER(GpuMaterial, material_at, material_read, material_image_at(i), materials[i])
IMAGE_OR_BUFFER(uint, texel_at, texel_read, SCENE_TEXEL(texel_image, i).x, texel_buffer_at(i))
IMAGE_OR_BUFFER(GpuInstance, instance_at, instance_read, instance_image_at(i), instances[i])
// For instance_ray (tlas.glsl): object_to_world may be left unread.
IMAGE_OR_BUFFER(GpuInstance, instance_inverse_at, instance_inverse_read,
                instance_image_read(i, false), instances[i])
IMAGE_OR_BUFFER(GpuTexture, texture_at, texture_read, texture_image_at(i), textures[i])
IMAGE_OR_BUFFER(GpuTextureRef, texture_ref_at, texture_ref_read, texture_ref_image_at(i),
                texture_refs[i])
IMAGE_OR_BUFFER(LightEntry, light_at, light_read, light_image_at(i), lights[i])
// (A macro: light_bvh.glsl reads light_nodes[] where it is not defined.)
IMAGE_OR_BUFFER(GpuLightNode, light_node_image_or_buffer_at, light_node_read,
                light_node_image_at(i), light_nodes[i])
#define light_node_at(i) light_node_image_or_buffer_at(i)
#undef IMAGE_OR_BUFFER
#else
#define bvh_node_at(i) bvh_nodes[i]
#define quant_node_at(i) quant_node_from_records(bvh_nodes[i], bvh_nodes[(i) + 1u])
#define triangle_at(i) triangles[i]
#define triangle_vertices_at(i) triangle_vertices[i]
#define vertex_at(i) vertices[i]
#define material_at(i) materials[i]
#define instance_at(i) instances[i]
#define instance_inverse_at(i) instances[i]
#define texture_at(i) textures[i]
#define texture_ref_at(i) texture_refs[i]
#define light_at(i) lights[i]
#define texel_at(i) texels[i]
#endif

#endif
