#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Light tracing and BDPT, stage 1: per path an emitter chosen by power, a point on it and an
// emission direction (src/cpu/bidir/bdpt.rs, light_subpath: a uniform direction in a punctual
// light's cone, or cosine-weighted on the emitting side); the first ray goes to queue 0.
// Light tracing queues the origin's join to the camera (s = 1, t = 1); BDPT stores the origin
// as the light subpath's vertex 0.
#include "layout.glsl"
#include "bindings.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "bsdf.glsl"
#include "volume.glsl"
#include "scene.glsl"
#include "texture.glsl"
#include "surface.glsl"
#include "light_tracing.glsl"
#include "paths.glsl"
#include "mis.glsl"
#include "bdpt.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void kernel_main() {
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
    state.medium = vec3(0.0);
    state.wavelength = 0.0;
    paths[i] = state;
    bool bdpt = frame.integrator == INTEGRATOR_BDPT;
    if (bdpt) {
        bdpt_set_light_length(i, 0u);
        bdpt_set_camera_length(i, 1u);
    }
    if (frame.light_count == 0u) return;

    uint block = light_block(0u);
    vec4 u = rng_uniform4(frame.seed, pixel, sample_index, block);
    vec2 u_point = sample_pair(pixel, sample_index, 4u * block + 1u, u.yz);
    BdptVertex y0;
    GpuMaterial mat;
    if (!bdpt_sample_light_vertex(pixel, sample_index, u.x, u_point, y0)) return;
    bool point = bdpt_kind(y0) == BDPT_VERTEX_POINT_LIGHT;
    if (!point) mat = bdpt_material(y0, 0.0);
    if (bdpt) {
        bdpt_vertices[bdpt_light_index(i, 0u)] = y0;
        bdpt_set_light_length(i, 1u);
    } else if (!point) {
        // The origin's join to the camera (s = 1, t = 1); a point or spot light is not seen
        // directly (camera rays cannot hit a point: src/cpu/bidir/bdpt.rs, sample).
        ShadowRay shadow;
        vec3 w;
        float dist;
        uint target;
        float g_we;
        if (camera_connection(y0.p, y0.ng, !point, w, dist, target, g_we, shadow)) {
            queue_camera_join(shadow, y0.beta * emitted_radiance(mat, dot(y0.ng, w)) * g_we * transmittance(volume_sigma(mat, y0.ng, w), dist), i, light_path_ends_here(state.prev_specular, 4u));
        }
    }
    if (frame.max_depth == 0u) return;
    vec4 ud = rng_uniform4(frame.seed, pixel, sample_index, block + 1u);
    vec2 u_dir = sample_pair(pixel, sample_index, 4u * (block + 1u), ud.xy);
    // The emission direction: a uniform direction in a punctual light's cone, or
    // cosine-weighted on the emitting side (either side with probability 1/2 if both emit).
    vec3 dir;
    vec3 origin;
    vec3 beta;
    if (point) {
        GpuPunctualLight l = punctual_lights[y0.index];
        float cos_max = l.kind == LIGHT_SPOT ? spot_cos_outer(l) : -1.0;
        vec3 local = sample_uniform_cone(u_dir, cos_max);
        vec3 t, b;
        build_frame(y0.ng, t, b);
        dir = t * local.x + b * local.y + y0.ng * local.z;
        origin = y0.p;
        // The range window waits for the first hit's distance (shade_light).
        state.pad0 = y0.index + 1u;
    } else {
        bool both = (mat.flags & MATERIAL_DOUBLE_SIDED) != 0u;
        vec3 side = both && u.w < 0.5 ? -y0.ng : y0.ng;
        vec3 local = sample_cosine_hemisphere(u_dir);
        vec3 t, b;
        build_frame(side, t, b);
        dir = t * local.x + b * local.y + side * local.z;
        origin = offset_ray_origin(y0.p, side);
    }
    float pdf_dir = bdpt_emission_pdf(y0, mat, dir);
    if (!(pdf_dir > 0.0)) return;
    vec3 le = point ? punctual_intensity(punctual_lights[y0.index], dir) : bdpt_emission(y0, mat, dir, 0.0);
    beta = y0.beta * le * (bdpt_cos(y0, dir) / pdf_dir);
    // BDPT: the solid-angle pdf of the ray's direction (PathState::cone_width, unused by light
    // subpaths otherwise), for the next vertex's pdf_fwd.
    state.cone_width = pdf_dir;
    if (!(max_component(beta) > 0.0) || frame.max_depth == 0u) return;
    state.throughput = beta;
    // The medium the ray enters (an emitter's volume behind its back face; none at a point).
    if (!point) state.medium = volume_sigma(mat, y0.ng, dir);
    // Russian roulette on light subpaths compares the throughput with its first value.
    state.prev_bsdf_pdf = max_component(beta);
    paths[i] = state;
    QueuedRay ray;
    ray.origin = origin;
    ray.path = i;
    ray.dir = dir;
    ray.pad = 0u;
    rays[queue_push_slot(COUNTER_RAYS_0)] = ray;
}

void main() {
    kernel_main();
    count_scene_fetches();
}
