#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// BDPT, the camera subpath: at each hit store the vertex (its forward density from the ray's
// pdf, the previous vertex's reverse density once this one's next direction is sampled), then
// sample the BSDF with the path tracer's random numbers and apply its Russian roulette
// (src/cpu/bidir/bdpt.rs, walk in radiance mode). params.depth = d: the hits are vertex d + 1 of
// their camera subpaths, z0 being the pinhole. No emission or emitter sampling here: every
// strategy, s = 0 included, is connect_bdpt's.
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
    uint k = depth + 1u;
    vec3 beta = state.throughput;

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

    BdptVertex v = bdpt_endpoint(BDPT_VERTEX_SURFACE, p, ng, beta, 1.0, hit.triangle);
    v.ns = ns;
    v.wo = wo;
    v.instance = hit_instance(hit);
    v.bary = vec2(hit.u, hit.v);
    // The solid-angle pdf of the ray: the pinhole's for the primary ray, else the BSDF
    // sample's (PathState::cone_width; < 0 after a delta lobe).
    float pdf_dir = state.cone_width;
    if (depth == 0u) {
        uint target;
        float we;
        if (!camera_importance(ray.dir, target, we, pdf_dir)) pdf_dir = 0.0;
    }
    BdptVertex prev = bdpt_camera(ray.path, k - 1u);
    if (pdf_dir >= 0.0) v.pdf_fwd = bdpt_to_area(pdf_dir, prev.p, v);
    bdpt_vertices[bdpt_camera_index(ray.path, k)] = v;
    bdpt_set_camera_length(ray.path, k + 1u);
    if (k + 1u >= frame.max_depth + 2u) return;

    BsdfFrame f;
    if (!bsdf_frame_new_shading(mat, ng, ns, wo, f)) return;
    uint block = bounce_block(depth) + 1u;
    float u_rr = rng_uniform4(frame.seed, pixel, sample_index, bounce_block(depth)).w;
    vec4 u = rng_uniform4(frame.seed, pixel, sample_index, block);
    vec2 u_dir = sample_pair(pixel, sample_index, 4u * block, u.xy);
    vec3 wi;
    vec3 weight;
    float pdf;
    bool delta;
    if (!bsdf_frame_sample(f, vec3(u_dir, u.z), TRANSPORT_RADIANCE, wi, weight, pdf, delta)) return;
    beta *= weight;
    if (delta) {
        bdpt_vertices[bdpt_camera_index(ray.path, k)].kind |= BDPT_VERTEX_DELTA;
        // (z0's slot holds the lengths: its reverse density is never read.)
        if (k > 1u) bdpt_vertices[bdpt_camera_index(ray.path, k - 1u)].pdf_rev = 1.0;
        state.cone_width = -1.0;
    } else {
        state.cone_width = pdf;
        BsdfFrame back;
        float pdf_back = bsdf_frame_new_shading(mat, ng, ns, wi, back) ? bsdf_frame_pdf(back, wo) : 0.0;
        if (k > 1u) bdpt_vertices[bdpt_camera_index(ray.path, k - 1u)].pdf_rev = bdpt_to_area(pdf_back, p, prev);
    }
    if (!(max_component(beta) > 0.0) || any(isinf(beta)) || any(isnan(beta))) return;
    if (depth + 1u >= frame.rr_start_depth && frame.rr_mode != RR_OFF) {
        float survive = frame.rr_mode == RR_ALBEDO ? min(f.albedo_estimate, 1.0) : min(max_component(beta), 1.0);
        float w;
        if (!roulette(u_rr, survive, w)) return;
        beta *= w;
    }
    state.throughput = beta;
    state.medium = volume_sigma(mat, ng, wi);
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
