#version 460
#extension GL_GOOGLE_include_directive : require
// Light tracing, stage 1: per path an emitter chosen by power, a point on it and an emission
// direction (src/cpu/bidir.rs, light_subpath: a uniform direction in a punctual light's cone,
// or cosine-weighted on the emitting side); the origin's join to the camera (s = 1, t = 1)
// goes to the shadow queue and the first ray to queue 0.
#include "layout.glsl"
#include "bindings.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "bsdf.glsl"
#include "scene.glsl"
#include "texture.glsl"
#include "surface.glsl"
#include "light_tracing.glsl"
#include "paths.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= params.batch_size) return;
    uint pixel, sample_index;
    path_pixel_sample(i, pixel, sample_index);
    PathState state;
    state.throughput = vec3(0.0);
    state.prev_bsdf_pdf = 0.0;
    state.radiance = vec3(0.0);
    // --paths: the emitter-first automaton's state after L.
    state.prev_specular = paths_enabled() ? dfa_step_forward(0u, SYM_L) : 0u;
    state.cone_width = 0.0;
    state.prev_position = vec3(0.0);
    state.prev_normal = vec3(0.0);
    state.pad0 = 0u;
    paths[i] = state;
    if (frame.light_count == 0u) return;

    uint block = light_block(0u);
    vec4 u = rng_uniform4(frame.seed, pixel, sample_index, block);
    vec2 u_point = sample_pair(pixel, sample_index, 4u * block + 1u, u.yz);
    LightEntry entry = lights[sample_light(min(u.x, ONE_MINUS_EPSILON))];
    float pmf = entry.pmf * (1.0 - frame.env_pmf);
    if (!(pmf > 0.0)) return;
    vec4 ud = rng_uniform4(frame.seed, pixel, sample_index, block + 1u);
    vec2 u_dir = sample_pair(pixel, sample_index, 4u * (block + 1u), ud.xy);

    ShadowRay shadow;
    vec3 w;
    float dist;
    uint target;
    float g_we;
    vec3 dir;
    vec3 origin;
    vec3 beta;
    if ((entry.triangle & LIGHT_ENTRY_PUNCTUAL) != 0u) {
        uint index = entry.triangle & ~LIGHT_ENTRY_PUNCTUAL;
        GpuPunctualLight l = punctual_lights[index];
        if (l.kind == LIGHT_DIRECTIONAL) return;
        float beta0 = 1.0 / pmf;
        if (camera_connection(l.position, l.direction, false, w, dist, target, g_we, shadow)) {
            queue_camera_join(shadow, beta0 * punctual_intensity(l, w) * punctual_window(l, dist) * g_we, i, light_path_ends_here(state.prev_specular, 4u));
        }
        float cos_max = l.kind == LIGHT_SPOT ? spot_cos_outer(l) : -1.0;
        vec3 local = sample_uniform_cone(u_dir, cos_max);
        vec3 t, b;
        build_frame(l.direction, t, b);
        dir = t * local.x + b * local.y + l.direction * local.z;
        origin = l.position;
        float pdf_dir = l.kind == LIGHT_SPOT
            ? (dot(l.direction, dir) >= cos_max ? uniform_cone_pdf(cos_max) : 0.0)
            : 0.25 * INV_PI;
        if (!(pdf_dir > 0.0)) return;
        // The range window waits for the first hit's distance (shade_light).
        beta = beta0 * punctual_intensity(l, dir) / pdf_dir;
        state.pad0 = index + 1u;
    } else {
        GpuTriangle tri = triangles[entry.triangle];
        vec2 bary = sample_uniform_triangle(u_point);
        vec3 y = tri.p0 + bary.x * tri.e1 + bary.y * tri.e2;
        vec3 n = normalize(cross(tri.e1, tri.e2));
        uvec4 key = alpha_key(frame.seed, pixel, sample_index, ALPHA_CONNECT - 1u, true);
        if (!triangle_present(entry.triangle, bary.x, bary.y, key, vec3(0.0))) return;
        GpuMaterial mat = materials[triangle_material(tri)];
        SurfacePoint sp = surface_point(tri, triangle_vertices[entry.triangle], bary.x, bary.y);
        mat.emission = surface_emission(mat, sp, LOD_MAGNIFY);
        float beta0 = tri.area / pmf;
        if (camera_connection(y, n, true, w, dist, target, g_we, shadow)) {
            queue_camera_join(shadow, beta0 * emitted_radiance(mat, dot(n, w)) * g_we, i, light_path_ends_here(state.prev_specular, 4u));
        }
        bool both = (mat.flags & MATERIAL_DOUBLE_SIDED) != 0u;
        vec3 side = both && u.w < 0.5 ? -n : n;
        vec3 local = sample_cosine_hemisphere(u_dir);
        vec3 t, b;
        build_frame(side, t, b);
        dir = t * local.x + b * local.y + side * local.z;
        origin = offset_ray_origin(y, side);
        float c = dot(n, dir);
        float pdf_dir = both ? 0.5 * abs(c) * INV_PI : max(c, 0.0) * INV_PI;
        if (!(pdf_dir > 0.0)) return;
        beta = beta0 * emitted_radiance(mat, c) * (abs(c) / pdf_dir);
    }
    if (!(max_component(beta) > 0.0) || frame.max_depth == 0u) return;
    state.throughput = beta;
    // Russian roulette on light subpaths compares the throughput with its first value.
    state.prev_bsdf_pdf = max_component(beta);
    paths[i] = state;
    QueuedRay ray;
    ray.origin = origin;
    ray.path = i;
    ray.dir = dir;
    ray.pad = 0u;
    rays[atomicAdd(counters[COUNTER_RAYS_0], 1u)] = ray;
}
