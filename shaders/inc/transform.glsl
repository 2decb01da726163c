// Rows of 3x4 affine transforms (GpuInstance) applied to points, directions and normals: twin of
// transform_point, transform_vector and transform_normal in src/tlas.rs.
#ifndef TRANSFORM_GLSL
#define TRANSFORM_GLSL

// An affine point and a linear direction through the rows of a 3x4 transform.
vec3 transform_point(vec4 rows[3], vec3 p) {
    return vec3(dot(rows[0].xyz, p) + rows[0].w, dot(rows[1].xyz, p) + rows[1].w,
                dot(rows[2].xyz, p) + rows[2].w);
}
vec3 transform_vector(vec4 rows[3], vec3 v) {
    return vec3(dot(rows[0].xyz, v), dot(rows[1].xyz, v), dot(rows[2].xyz, v));
}
// The inverse transpose applied to a normal: the world-to-object rows' transpose.
vec3 transform_normal(vec4 world_to_object[3], vec3 n) {
    return world_to_object[0].xyz * n.x + world_to_object[1].xyz * n.y + world_to_object[2].xyz * n.z;
}

#endif
