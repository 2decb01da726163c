#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// BDPT, the connections of one strategy (s, t) = bdpt_strategy(params.depth), one thread per
// path: it joins light vertex s − 1 to camera vertex t − 1 (s = 0: the camera subpath's own
// emitter hit; s = 1: a light vertex sampled afresh with the path tracer's next-event
// numbers; t = 1: the pinhole, landing in another pixel) and weights the contribution by MIS
// over all strategies of its path (bdpt_mis_weight). s = 0 splats at once; the others queue
// their joining segment as a shadow ray, which connect_light traces and splats
// (src/cpu/bidir/bdpt.rs, connect and sample). The segment runs as on the CPU: from the light
// vertex to the pinhole's near plane for t = 1, from the camera vertex to the light vertex
// otherwise (culling makes the direction matter).
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
    uint path = gl_GlobalInvocationID.x;
    if (path >= params.batch_size) return;
    uint s, t;
    if (!bdpt_strategy(params.depth, s, t)) return;
    if (t > bdpt_camera_length(path) || (s >= 2u && s > bdpt_light_length(path))) return;
    uint pixel, sample_index;
    path_pixel_sample(path, pixel, sample_index);
    // KHR_materials_dispersion: the sample's wavelength (src/spectrum.rs), 0 for none.
    float lambda = frame.spectral != 0u ? sample_wavelength_of(frame.seed, pixel, sample_index) : 0.0;

    BdptVertex pt = bdpt_camera(path, t - 1u);
    BdptVertex qs = pt;
    BdptVertex sampled = pt;
    if (s == 1u) {
        // A fresh light vertex for this camera vertex (next event estimation's numbers).
        uint block = bounce_block(t - 2u);
        vec4 u = rng_uniform4(frame.seed, pixel, sample_index, block);
        vec2 u_point = sample_pair(pixel, sample_index, 4u * block + 1u, u.yz);
        if (!bdpt_sample_light_vertex(pixel, sample_index, u.x, u_point, qs)) return;
        sampled = qs;
    } else if (s >= 2u) {
        qs = bdpt_light(path, s - 1u);
    }
    // The materials of the two vertices beside the connection (a rolled loop: one copy of the
    // texture lookups).
    GpuMaterial mat_pt;
    GpuMaterial mat_qs;
    [[dont_unroll]] for (uint e = 0u; e < 2u; e++) {
        BdptVertex v = e == 0u ? pt : qs;
        if (!bdpt_on_surface(v) || (e == 1u && s == 0u)) continue;
        GpuMaterial m = bdpt_material(v, lambda);
        if (e == 0u) {
            mat_pt = m;
        } else {
            mat_qs = m;
        }
    }

    uint target = pixel;
    vec3 c;
    ShadowRay shadow;
    if (s == 0u) {
        // The camera subpath found an emitter.
        if (!(max_component(mat_pt.emission) > 0.0)) return;
        c = pt.beta * emitted_radiance(mat_pt, dot(pt.ng, pt.wo));
    } else {
        bool qs_surface = bdpt_kind(qs) == BDPT_VERTEX_SURFACE;
        if ((qs_surface && !connectible(mat_qs)) || (t > 1u && !connectible(mat_pt))) return;
        // w_q: from qs towards the camera end; `camera_side`: everything of the path on the
        // camera's side of qs (W_e and G for t = 1; φ at pt, its β and G otherwise).
        vec3 w_q;
        float dist;
        vec3 camera_side;
        if (t == 1u) {
            float g_we;
            if (!camera_connection(qs.p, qs.ng, bdpt_on_surface(qs), w_q, dist, target, g_we, shadow)) return;
            if (qs_surface && !camera_sees(qs.index, qs.ng, w_q)) return;
            camera_side = vec3(g_we);
        } else {
            vec3 d = qs.p - pt.p;
            dist = length(d);
            vec3 w = d / dist;
            w_q = -w;
            float g = bdpt_cos(qs, w) * bdpt_cos(pt, w) / (dist * dist);
            camera_side = pt.beta * g;
            shadow.origin = offset_ray_origin(pt.p, dot(pt.ng, w) > 0.0 ? pt.ng : -pt.ng);
            vec3 end = bdpt_on_surface(qs) ? offset_ray_origin(qs.p, dot(qs.ng, w_q) > 0.0 ? qs.ng : -qs.ng) : qs.p;
            vec3 seg = end - shadow.origin;
            shadow.t_max = length(seg);
            shadow.dir = seg / shadow.t_max;
        }
        // φ at the scattering vertices beside the connection (a rolled loop: one copy of the
        // BSDF), the emission at a light vertex.
        vec3 at_light = qs_surface ? vec3(0.0) : bdpt_emission(qs, mat_qs, w_q, dist);
        [[dont_unroll]] for (uint e = 0u; e < 2u; e++) {
            bool at_qs = e == 0u;
            if (at_qs ? !qs_surface : t == 1u) continue;
            BdptVertex v = at_qs ? qs : pt;
            vec3 f = phi(at_qs ? mat_qs : mat_pt, v.ng, v.ns, at_qs ? w_q : pt.wo, at_qs ? qs.wo : -w_q);
            if (at_qs) {
                at_light = f;
            } else {
                camera_side *= f;
            }
        }
        // KHR_materials_volume: the connection's attenuation, its medium read from either end.
        vec3 sigma = bdpt_on_surface(qs) ? volume_sigma(mat_qs, qs.ng, w_q) : vec3(0.0);
        if (t > 1u) sigma = max(sigma, volume_sigma(mat_pt, pt.ng, -w_q));
        c = qs.beta * at_light * camera_side * transmittance(sigma, dist);
    }
    if (!(max_component(c) > 0.0) || any(isinf(c)) || any(isnan(c))) return;
    if (!bdpt_path_matches(path, s, t)) return;
    float weight = bdpt_mis_weight(path, s, t, sampled, mat_qs, mat_pt);
    if (!(weight > 0.0)) return;
    if (s == 0u) {
        // KHR_materials_dispersion: a spectral sample's weight (connect_light applies it to
        // the other strategies).
        vec3 cw = c * weight;
        if (frame.spectral != 0u) cw *= wavelength_weight(lambda);
        splat_add(sample_index - params.first_sample, target, cw);
        return;
    }
    shadow.path = path;
    shadow.contribution = c * weight;
    shadow.pad = target;
    shadow_rays[queue_push_slot(COUNTER_SHADOW)] = shadow;
}

void main() {
    kernel_main();
    count_scene_fetches();
}
