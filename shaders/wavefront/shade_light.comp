#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Light tracing, stage 3: at each hit of a light subpath, queue the vertex's join to the camera
// (a shadow ray that splats if unoccluded), then sample the adjoint BSDF for the next ray and
// apply Russian roulette (src/cpu/bidir/bdpt.rs, walk in importance mode). params.depth = d: the
// hits are vertex d + 1 of their subpaths. BDPT stores each vertex instead of joining it.
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
    uint depth = params.depth;
    uint queue = depth & 1u;
    if (i >= counters[queue]) return;
    QueuedRay ray = rays[queue * params.batch_size + i];
    HitRecord hit = hit_load(i);
    if (hit.triangle == NO_HIT) return;
    PathState state = paths[ray.path];
    uint pixel, sample_index;
    path_pixel_sample(ray.path, pixel, sample_index);
    vec3 beta = state.throughput;
    if (depth == 0u && state.pad0 != 0u) {
        // A punctual light's range window, now that the distance is known.
        beta *= punctual_window(punctual_lights[state.pad0 - 1u], hit.t);
    }
    GpuTriangle tri;
    SurfacePoint sp = hit_surface(hit, tri);
    vec3 p = sp.p;
    vec3 ng = sp.ng;
    vec3 wo = -ray.dir;
    GpuMaterial raw = material_at(triangle_material(tri));
    vec3 ns;
    GpuMaterial mat = surface_material_normal(raw, sp, LOD_MAGNIFY, ns);
    // KHR_materials_dispersion: n(λ) of the sample's wavelength (src/spectrum.rs).
    if (frame.spectral != 0u) material_at_wavelength(mat, sample_wavelength_of(frame.seed, pixel, sample_index));
    // KHR_materials_volume: the segment's attenuation, its medium read from either end.
    beta *= transmittance(max(state.medium, volume_sigma(raw, ng, wo)), hit.t);

    bool bdpt = frame.integrator == INTEGRATOR_BDPT;
    uint k = depth + 1u;  // the vertex's index in its subpath
    if (bdpt) {
        // Store the vertex; connect_bdpt joins it to the camera with the other strategies.
        BdptVertex v = bdpt_endpoint(BDPT_VERTEX_SURFACE, p, ng, beta, 1.0, hit.triangle);
        v.ns = ns;
        v.wo = wo;
        v.instance = hit_instance(hit);
        v.bary = vec2(hit.u, hit.v);
        if (state.cone_width >= 0.0) {
            v.pdf_fwd = bdpt_to_area(state.cone_width, bdpt_vertices[bdpt_light_index(ray.path, k - 1u)].p, v);
        }
        bdpt_vertices[bdpt_light_index(ray.path, k)] = v;
        bdpt_set_light_length(ray.path, k + 1u);
    } else if (connectible(mat)) {
        // The join to the camera (s = d + 2 light vertices, t = 1).
        ShadowRay shadow;
        vec3 w;
        float dist;
        uint target;
        float g_we;
        if (camera_connection(p, ng, true, w, dist, target, g_we, shadow) && camera_sees(hit.triangle, ng, w)) {
            queue_camera_join(shadow, beta * phi(mat, ng, ns, w, wo) * g_we * transmittance(volume_sigma(mat, ng, w), dist), ray.path, light_path_ends_here(state.prev_specular, SYM_D));
        }
    }
    if (depth + 1u >= frame.max_depth) return;

    // The adjoint BSDF with the shading-normal correction (src/cpu/bidir/bdpt.rs, module docs).
    BsdfFrame f;
    if (!bsdf_frame_new_shading(mat, ng, ns, wo, f)) return;
    uint block = light_block(depth + 1u);
    vec4 u = rng_uniform4(frame.seed, pixel, sample_index, block);
    vec2 u_dir = sample_pair(pixel, sample_index, 4u * block, u.xy);
    vec3 wi;
    vec3 weight;
    float pdf;
    bool delta;
    if (!bsdf_frame_sample(f, vec3(u_dir, u.z), TRANSPORT_IMPORTANCE, wi, weight, pdf, delta)) return;
    float cos_gi = abs(dot(ng, wi));
    float cos_go = abs(dot(ng, wo));
    if (delta) {
        beta *= weight * bsdf_frame_cos(f, wo) * cos_gi / (cos_go * bsdf_frame_cos(f, wi));
    } else {
        beta *= phi(mat, ng, ns, wi, wo) * cos_gi / pdf;
    }
    if (bdpt) {
        // The delta flag, the ray's pdf for the next vertex, and the previous vertex's reverse
        // density given this vertex's two directions (src/cpu/bidir/bdpt.rs, walk).
        uint prev = bdpt_light_index(ray.path, k - 1u);
        if (delta) {
            bdpt_vertices[bdpt_light_index(ray.path, k)].kind |= BDPT_VERTEX_DELTA;
            bdpt_vertices[prev].pdf_rev = 1.0;
            state.cone_width = -1.0;
        } else {
            state.cone_width = pdf;
            BsdfFrame back;
            float pdf_back = bsdf_frame_new_shading(mat, ng, ns, wi, back) ? bsdf_frame_pdf(back, wo) : 0.0;
            bdpt_vertices[prev].pdf_rev = bdpt_to_area(pdf_back, p, bdpt_vertices[prev]);
        }
    }
    if (!(max_component(beta) > 0.0) || any(isinf(beta)) || any(isnan(beta))) return;
    if (depth + 1u >= frame.rr_start_depth && frame.rr_mode != RR_OFF) {
        float survive = min(max_component(beta) / state.prev_bsdf_pdf, 1.0);
        float w;
        if (!roulette(u.w, survive, w)) return;
        beta *= w;
    }
    state.throughput = beta;
    state.medium = volume_sigma(mat, ng, wi);
    if (paths_enabled()) state.prev_specular = dfa_step_forward(state.prev_specular, delta ? SYM_S : SYM_D);
    paths[ray.path] = state;
    QueuedRay next;
    next.origin = offset_ray_origin(p, dot(ng, wi) > 0.0 ? ng : -ng);
    next.path = ray.path;
    next.dir = wi;
    next.pad = 0u;
    uint next_queue = queue ^ 1u;
    rays[next_queue * params.batch_size + queue_push_slot(next_queue)] = next;
}

void main() {
    kernel_main();
    count_scene_fetches();
}
