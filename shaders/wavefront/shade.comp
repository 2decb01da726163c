#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Stage 3: at each hit add MIS-weighted emission, queue one shadow ray (next event estimation),
// sample the BSDF for the continuation ray and apply Russian roulette. Twin of src/cpu/path.rs.
#include "layout.glsl"
#include "bindings.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "bsdf.glsl"
#include "volume.glsl"
#include "mis.glsl"
#include "scene.glsl"
#include "texture.glsl"
#include "surface.glsl"
#include "environment.glsl"
#include "light_bvh.glsl"
#include "paths.glsl"
#include "spectrum.glsl"

// The probability that NEE at the path's previous vertex picks emitting triangle `index` from
// the table (the environment's share left out): through the light BVH at that vertex, or its
// power share (src/cpu/path.rs, triangle_light_pmf).
float triangle_light_pmf(GpuTriangle tri, uint index, PathState state) {
    if (SCENE_HAS(FEATURE_LIGHT_BVH) && frame.light_sampler == LIGHT_SAMPLER_BVH) {
        return frame.light_bounded_cdf * light_bvh_pmf(state.prev_position, state.prev_normal, index);
    }
    return tri.light_pmf;
}

// One light sample seen from a shading point (src/cpu/path.rs, LightSample): the direction to
// the light, where the shadow ray ends (target, or at infinity), the radiance arriving and the
// solid-angle density of the sample (the pmf for a delta light, which has no MIS partner).
struct LightSample {
    vec3 wi;
    bool has_target;
    vec3 target;
    bool delta;
    vec3 radiance;
    float pdf;
    vec3 medium;  // volume_sigma at the light's end of the shadow segment
};

// Next event estimation towards the environment (src/cpu/path.rs, sample_environment).
bool sample_environment(vec2 u, out LightSample ls) {
    float pdf;
    bool found = env_sample(u, ls.wi, pdf);
    ls.has_target = false;
    ls.target = vec3(0.0);
    ls.delta = false;
    ls.radiance = found ? env_radiance(ls.wi) : vec3(0.0);
    ls.pdf = frame.env_pmf * pdf;
    ls.medium = vec3(0.0);
    return found;
}

// Next event estimation towards the emitter table (src/cpu/path.rs, sample_emitter): for u_pick
// rescaled past the environment's share, a bounded emitter through the light BVH or an entry of
// the table by power, then the punctual light it names or a point on its triangle for u_point.
bool sample_emitter(uint pixel, uint sample_index, uint depth, vec3 p, vec3 ng, float u_pick,
                    vec2 u_point, out LightSample ls) {
    ls.wi = vec3(0.0, 0.0, 1.0);
    ls.has_target = false;
    ls.target = vec3(0.0);
    ls.delta = false;
    ls.radiance = vec3(0.0);
    ls.pdf = 0.0;
    ls.medium = vec3(0.0);
    if (frame.light_count == 0u) return false;
    float keep = 1.0 - frame.env_pmf;
    float u_table = min((u_pick - frame.env_pmf) / keep, ONE_MINUS_EPSILON);
    LightEntry entry;
    float pmf;
    if (SCENE_HAS(FEATURE_LIGHT_BVH) && frame.light_sampler == LIGHT_SAMPLER_BVH
        && u_table < frame.light_bounded_cdf) {
        // A bounded emitter, by its importance to (p, ng) through the light BVH.
        float u_bvh = min(u_table / frame.light_bounded_cdf, ONE_MINUS_EPSILON);
        uint k;
        if (!light_bvh_sample(p, ng, u_bvh, k, pmf)) return false;
        entry = light_at(k);
        pmf *= frame.light_bounded_cdf;
    } else {
        entry = light_at(sample_light(u_table));
        pmf = entry.pmf;
    }
    pmf *= keep;
    if (SCENE_HAS(FEATURE_PUNCTUAL) && (entry.triangle & LIGHT_ENTRY_PUNCTUAL) != 0u) {
        GpuPunctualLight pl = punctual_lights[entry.triangle & ~LIGHT_ENTRY_PUNCTUAL];
        float dist;
        ls.radiance = punctual_incident(pl, p, ls.wi, dist);
        ls.has_target = dist >= 0.0;
        ls.target = pl.position;
        ls.delta = true;
        ls.pdf = pmf;
        return true;
    }
    GpuTriangle light = triangle_at(entry.triangle);
    vec2 b = sample_uniform_triangle(u_point);
    vec3 y = light.p0 + b.x * light.e1 + b.y * light.e2;
    vec3 light_n = normalize(cross(light.e1, light.e2));
    vec3 to_light = y - p;
    float dist2 = dot(to_light, to_light);
    ls.wi = to_light / sqrt(dist2);
    float cos_light = dot(light_n, -ls.wi);
    // The light point's emission (its textures at level 0) where its surface exists.
    GpuMaterial light_mat = emitter_at(light, entry.triangle, b);
    uvec4 key = alpha_key(frame.seed, pixel, sample_index, depth, true);
    ls.radiance = triangle_present(light, entry.triangle, b.x, b.y, key, vec3(0.0))
        ? emitted_radiance(light_mat, cos_light) : vec3(0.0);
    // The shadow ray ends just off the light's surface, on the side it leaves towards p.
    ls.has_target = true;
    ls.target = offset_ray_origin(y, cos_light > 0.0 ? light_n : -light_n);
    // Solid-angle pdf: pmf * (1/area) * dist^2 / |cos at the light|.
    ls.pdf = pmf * dist2 / (abs(cos_light) * light.area);
    ls.medium = volume_sigma(light_mat, light_n, -ls.wi);
    return true;
}

layout(local_size_x = WORKGROUP_SIZE) in;

// A path that ends at this vertex: only its radiance is read after it (connect adds its last
// shadow ray's contribution, accumulate reads it), so only that is stored — 3 words where the
// whole state is 20, each a store per lane on lavapipe.
void path_end(uint path, PathState state) {
    paths[path].radiance = state.radiance;
}

void kernel_main() {
    uint i = gl_GlobalInvocationID.x;
    uint depth = params.depth;
    uint queue = depth & 1u;
    if (i >= counters[queue]) return;
    QueuedRay ray = rays[queue * params.batch_size + i];
    HitRecord hit = hit_load(i);
    PathState state = paths[ray.path];
    uint pixel, sample_index;
    path_pixel_sample(ray.path, pixel, sample_index);
    vec3 wo = -ray.dir;

    // Escaped: the environment's radiance, weighted against sampling the environment from the
    // previous vertex (a ray that leaves into a volume and escapes crossed an infinite medium).
    if (hit.triangle == NO_HIT) {
        state.throughput *= transmittance(state.medium, 3.402823466e38);
        // --transparent: a camera ray that escapes sees nothing (alpha 0 there).
        bool hidden = depth == 0u && (frame.debug_flags & FLAG_TRANSPARENT_BACKGROUND) != 0u;
        if (frame.aov == AOV_RADIANCE && SCENE_HAS(FEATURE_ENVIRONMENT) && frame.env_width > 0u
            && !hidden && path_ends_here(state.pad0, 4u)) {
            vec3 le = env_radiance(ray.dir);
            float w = 1.0;
            if (state.prev_specular == 0u) {
                float light_pdf = frame.env_pmf * env_pdf(ray.dir);
                w = mis_weight2(frame.mis_heuristic, frame.mis_beta, state.prev_bsdf_pdf, light_pdf, false);
            }
            state.radiance += state.throughput * w * le;
        }
        path_end(ray.path, state);
        return;
    }
    GpuTriangle tri;
    SurfacePoint sp = hit_surface(hit, tri);
    vec3 p = sp.p;
    vec3 ng = sp.ng;
    float cos_out = dot(ng, wo);
    // The ray cone's width at the hit sets the textures' level of detail.
    float cone_width = state.cone_width + frame.cone_spread * hit.t;
    state.cone_width = cone_width;
    GpuMaterial raw = material_at(triangle_material(tri));
    // KHR_materials_volume: the segment's attenuation, its medium read from either end.
    state.throughput *= transmittance(max(state.medium, volume_sigma(raw, ng, wo)), hit.t);
    // The footprint of this sample's stratum of the pixel, not the whole pixel's.
    vec2 lod = SCENE_HAS(FEATURE_TEXTURES) && (raw.flags & MATERIAL_TEXTURED) != 0u
             ? surface_lod_base(sp, cone_width, cos_out) - sample_footprint_levels(sample_index) : vec2(0.0);
    vec3 ns;
    GpuMaterial mat = surface_material_normal(raw, sp, lod, ns);
    // --aov: a property of the first hit instead of radiance.
    if (frame.aov != AOV_RADIANCE) {
        vec3 value = mat.emission;
        if (frame.aov == AOV_BASE_COLOR) value = mat.base_color;
        if (frame.aov == AOV_NORMAL) value = ns;
        if (frame.aov == AOV_UV) value = vec3(sp.uv0, 0.0);
        // The camera ray starts on the near plane: its distance from the eye (the lens point;
        // an orthographic camera's film plane) is added back.
        if (frame.aov == AOV_DEPTH) value = vec3(hit.t + frame.cam_znear / dot(ray.dir, frame.cam_forward));
        if (frame.aov == AOV_POSITION) value = p;
        if (frame.aov == AOV_MATERIAL) value = vec3(float(triangle_material(tri) + 1u));
        // Without a top level the one placement is the baked geometry.
        if (frame.aov == AOV_INSTANCE)
            value = vec3(float((SCENE_HAS(FEATURE_TOP_LEVEL) ? instance_at(hit.instance).placement : 0u) + 1u));
        if (frame.aov == AOV_ALPHA) value = vec3(1.0);
        state.radiance = value;
        path_end(ray.path, state);
        return;
    }

    // Direct emission, weighted against emitter sampling from the previous vertex.
    vec3 le = emitted_radiance(mat, cos_out);
    if (max_component(le) > 0.0 && path_ends_here(state.pad0, 4u)) {
        float w = 1.0;
        if (state.prev_specular == 0u) {
            float pmf = triangle_light_pmf(tri, hit.triangle, state);
            float light_pdf = pmf * (1.0 - frame.env_pmf) * hit.t * hit.t / (abs(cos_out) * tri.area);
            w = mis_weight2(frame.mis_heuristic, frame.mis_beta, state.prev_bsdf_pdf, light_pdf, false);
        }
        state.radiance += state.throughput * w * le;
    }
    // KHR_materials_dispersion: the path turns spectral at its first dispersive vertex, before
    // the vertex's emitter sample (src/spectrum.rs).
    if (depth < frame.max_depth && SCENE_HAS(FEATURE_DISPERSION) && is_dispersive(mat)) {
        if (state.wavelength == 0.0) {
            state.wavelength = sample_wavelength_of(frame.seed, pixel, sample_index);
            state.throughput *= wavelength_weight(state.wavelength);
        }
        material_at_wavelength(mat, state.wavelength);
    }
    // The material seen from wo, once for every BSDF query of this vertex; none where wo grazes
    // the surface exactly (nothing scatters along it).
    BsdfFrame bsdf;
    if (depth >= frame.max_depth
        || !bsdf_frame_new_shading(mat, ng, ns, wo, bsdf)) {
        path_end(ray.path, state);
        return;
    }

    // Emitter sampling: the environment with probability env_pmf, else one emitter of the table
    // chosen by power (one point on its triangle, or a punctual light). Delta lobes have no
    // part in it (bsdf_eval leaves them out); transmissive surfaces see lights on both sides.
    vec4 u_light = rng_uniform4(frame.seed, pixel, sample_index, bounce_block(depth));
    if ((frame.light_count > 0u || frame.env_pmf > 0.0) && path_ends_here(state.pad0, SYM_D)
        && (frame.debug_flags & DEBUG_NO_NEE) == 0u
        && frame.mis_heuristic != MIS_BSDF_ONLY) {
        vec2 u_point = sample_pair(pixel, sample_index, 4u * bounce_block(depth) + 1u, u_light.yz);
        LightSample ls;
        bool found = u_light.x < frame.env_pmf
            ? sample_environment(u_point, ls)
            : sample_emitter(pixel, sample_index, depth, p, ng, u_light.x, u_point, ls);
        if (found) {
            vec3 f = bsdf_frame_eval(bsdf, ls.wi, TRANSPORT_RADIANCE);
            if (max_component(f) > 0.0 && max_component(ls.radiance) > 0.0 && ls.pdf > 0.0 && !isinf(ls.pdf)) {
                // A delta light has no MIS partner (no BSDF sample can reach it): weight 1.
                float w = ls.delta ? 1.0
                    : mis_weight2(frame.mis_heuristic, frame.mis_beta, ls.pdf, bsdf_frame_pdf(bsdf, ls.wi), true);
                ShadowRay shadow;
                shadow.origin = offset_ray_origin(p, dot(ng, ls.wi) > 0.0 ? ng : -ng);
                shadow.path = ray.path;
                if (ls.has_target) {
                    vec3 d = ls.target - shadow.origin;
                    shadow.t_max = length(d);
                    shadow.dir = d / shadow.t_max;
                } else {
                    shadow.dir = ls.wi;
                    shadow.t_max = 3.402823466e38;
                }
                // The shadow segment's attenuation, its medium read from either end.
                vec3 tr = transmittance(max(volume_sigma(mat, ng, ls.wi), ls.medium), shadow.t_max);
                shadow.contribution = state.throughput * f * bsdf_frame_cos(bsdf, ls.wi) * ls.radiance * tr * (w / ls.pdf);
                shadow.pad = 0u;
                shadow_rays[queue_push_slot(COUNTER_SHADOW)] = shadow;
            }
        }
    }

    // BSDF sampling of the continuation ray: u.xy the direction, u.z the lobe.
    vec4 u_bsdf = rng_uniform4(frame.seed, pixel, sample_index, bounce_block(depth) + 1u);
    vec2 u_dir = sample_pair(pixel, sample_index, 4u * (bounce_block(depth) + 1u), u_bsdf.xy);
    vec3 wi;
    vec3 weight;
    float pdf;
    bool delta;
    if (!bsdf_frame_sample(bsdf, vec3(u_dir, u_bsdf.z), TRANSPORT_RADIANCE, wi, weight, pdf, delta)) {
        path_end(ray.path, state);
        return;
    }
    state.throughput *= weight;
    if (paths_enabled()) state.pad0 = dfa_step_reversed(state.pad0, delta ? SYM_S : SYM_D);
    state.prev_bsdf_pdf = pdf;
    state.prev_specular = delta ? 1u : 0u;
    state.prev_position = p;
    state.prev_normal = ng;
    state.medium = volume_sigma(mat, ng, wi);
    if (max_component(state.throughput) <= 0.0) {
        path_end(ray.path, state);
        return;
    }

    // Stopping criterion: Russian roulette keeps the estimate unbiased by dividing survivors by
    // their survival probability (lecture, "Russian roulette for integral equations"): by
    // throughput, or by the surface's albedo (the subcritical set-up P = ∫K).
    if (depth + 1u >= frame.rr_start_depth && frame.rr_mode != RR_OFF) {
        float survive = frame.rr_mode == RR_ALBEDO
            ? min(bsdf.albedo_estimate, 1.0)
            : min(max_component(state.throughput), 1.0);
        float weight;
        if (!roulette(u_light.w, survive, weight)) {
            path_end(ray.path, state);
            return;
        }
        state.throughput *= weight;
    }
    path_store(ray.path, state);

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
