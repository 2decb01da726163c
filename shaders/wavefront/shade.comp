#version 460
#extension GL_GOOGLE_include_directive : require
// Stage 3: at each hit add MIS-weighted emission, queue one shadow ray (next event estimation),
// sample the BSDF for the continuation ray and apply Russian roulette. Twin of src/cpu/path.rs.
#include "layout.glsl"
#include "bindings.glsl"
#include "rng.glsl"
#include "sampling.glsl"
#include "bsdf.glsl"
#include "mis.glsl"
#include "scene.glsl"
#include "texture.glsl"
#include "surface.glsl"

layout(local_size_x = WORKGROUP_SIZE) in;

void main() {
    uint i = gl_GlobalInvocationID.x;
    uint depth = params.depth;
    uint queue = depth & 1u;
    if (i >= counters[queue]) return;
    QueuedRay ray = rays[queue * params.batch_size + i];
    HitRecord hit = hits[i];
    PathState state = paths[ray.path];
    uint pixel, sample_index;
    path_pixel_sample(ray.path, pixel, sample_index);
    vec3 wo = -ray.dir;

    // Escaped: environment radiance (not light-sampled yet, so BSDF sampling has full weight).
    if (hit.triangle == NO_HIT) {
        if (frame.aov == AOV_RADIANCE) state.radiance += state.throughput * frame.environment;
        paths[ray.path] = state;
        return;
    }
    GpuTriangle tri = triangles[hit.triangle];
    SurfacePoint sp = surface_point(tri, triangle_vertices[hit.triangle], hit.u, hit.v);
    surface_to_world(sp, tri, instances[hit.instance]);
    vec3 p = sp.p;
    vec3 ng = sp.ng;
    float cos_out = dot(ng, wo);
    // The ray cone's width at the hit sets the textures' level of detail.
    float cone_width = state.cone_width + frame.cone_spread * hit.t;
    state.cone_width = cone_width;
    GpuMaterial raw = materials[triangle_material(tri)];
    vec2 lod = (raw.flags & MATERIAL_TEXTURED) != 0u ? surface_lod_base(sp, cone_width, cos_out) : vec2(0.0);
    GpuMaterial mat = surface_material(raw, sp, lod);
    // --aov: a property of the first hit instead of radiance.
    if (frame.aov != AOV_RADIANCE) {
        vec3 value = mat.emission;
        if (frame.aov == AOV_BASE_COLOR) value = mat.base_color;
        if (frame.aov == AOV_NORMAL) value = surface_normal(raw, sp, lod) * 0.5 + 0.5;
        if (frame.aov == AOV_UV) value = vec3(sp.uv0, 0.0);
        state.radiance = value;
        paths[ray.path] = state;
        return;
    }

    // Direct emission, weighted against emitter sampling from the previous vertex.
    vec3 le = emitted_radiance(mat, cos_out);
    if (max_component(le) > 0.0) {
        float w = 1.0;
        if (state.prev_specular == 0u) {
            float light_pdf = tri.light_pmf * hit.t * hit.t / (abs(cos_out) * tri.area);
            w = mis_weight2(frame.mis_heuristic, frame.mis_beta, state.prev_bsdf_pdf, light_pdf, false);
        }
        state.radiance += state.throughput * w * le;
    }
    // The material seen from wo, once for every BSDF query of this vertex; none where wo grazes
    // the surface exactly (nothing scatters along it).
    BsdfFrame bsdf;
    if (depth >= frame.max_depth
        || !bsdf_frame_new_shading(mat, ng, surface_normal(raw, sp, lod), wo, bsdf)) {
        paths[ray.path] = state;
        return;
    }

    // Emitter sampling: one point on one emitting triangle, chosen by power. Delta lobes have no
    // part in it (bsdf_eval leaves them out); transmissive surfaces see lights on both sides.
    vec4 u_light = rng_uniform4(frame.seed, pixel, sample_index, bounce_block(depth));
    if (frame.light_count > 0u && (frame.debug_flags & DEBUG_NO_NEE) == 0u
        && frame.mis_heuristic != MIS_BSDF_ONLY) {
        LightEntry entry = lights[sample_light(u_light.x)];
        if ((entry.triangle & LIGHT_ENTRY_PUNCTUAL) != 0u) {
            // A delta light: reached by emitter sampling only, with weight 1 (no MIS partner).
            GpuPunctualLight pl = punctual_lights[entry.triangle & ~LIGHT_ENTRY_PUNCTUAL];
            vec3 wi;
            float dist;
            vec3 li = punctual_incident(pl, p, wi, dist);
            vec3 f = bsdf_frame_eval(bsdf, wi, TRANSPORT_RADIANCE);
            if (max_component(f) > 0.0 && max_component(li) > 0.0 && entry.pmf > 0.0) {
                ShadowRay shadow;
                shadow.origin = offset_ray_origin(p, dot(ng, wi) > 0.0 ? ng : -ng);
                shadow.path = ray.path;
                shadow.dir = wi;
                shadow.t_max = dist < 0.0 ? 3.402823466e38 : length(pl.position - shadow.origin);
                shadow.contribution = state.throughput * f * bsdf_frame_cos(bsdf, wi) * li / entry.pmf;
                shadow.pad = 0u;
                shadow_rays[atomicAdd(counters[COUNTER_SHADOW], 1u)] = shadow;
            }
        } else {
        GpuTriangle light = triangles[entry.triangle];
        vec2 b = sample_uniform_triangle(sample_pair(pixel, sample_index, 4u * bounce_block(depth) + 1u, u_light.yz));
        vec3 y = light.p0 + b.x * light.e1 + b.y * light.e2;
        vec3 light_n = normalize(cross(light.e1, light.e2));
        vec3 to_light = y - p;
        float dist2 = dot(to_light, to_light);
        float dist = sqrt(dist2);
        vec3 wi = to_light / dist;
        float cos_light = dot(light_n, -wi);
        float cos_surface = dot(ng, wi);
        // The light point's emission (its textures at level 0) where its surface exists.
        SurfacePoint light_sp = surface_point(light, triangle_vertices[entry.triangle], b.x, b.y);
        GpuMaterial light_mat = surface_material(materials[triangle_material(light)], light_sp, LOD_MAGNIFY);
        uvec4 key = alpha_key(frame.seed, pixel, sample_index, depth, true);
        vec3 light_le = triangle_present(entry.triangle, b.x, b.y, key, vec3(0.0))
            ? emitted_radiance(light_mat, cos_light) : vec3(0.0);
        // Solid-angle pdf of the light sample: pmf · (1/area) · dist² / |cos at the light|.
        float light_pdf = entry.pmf * dist2 / (abs(cos_light) * light.area);
        vec3 f = bsdf_frame_eval(bsdf, wi, TRANSPORT_RADIANCE);
        if (max_component(f) > 0.0 && max_component(light_le) > 0.0 && light_pdf > 0.0 && !isinf(light_pdf)) {
            float w = mis_weight2(frame.mis_heuristic, frame.mis_beta, light_pdf, bsdf_frame_pdf(bsdf, wi), true);
            vec3 origin = offset_ray_origin(p, cos_surface > 0.0 ? ng : -ng);
            vec3 target = offset_ray_origin(y, cos_light > 0.0 ? light_n : -light_n);
            vec3 d = target - origin;
            float t_max = length(d);
            ShadowRay shadow;
            shadow.origin = origin;
            shadow.path = ray.path;
            shadow.dir = d / t_max;
            shadow.t_max = t_max;
            shadow.contribution = state.throughput * f * bsdf_frame_cos(bsdf, wi) * light_le * (w / light_pdf);
            shadow.pad = 0u;
            shadow_rays[atomicAdd(counters[COUNTER_SHADOW], 1u)] = shadow;
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
        paths[ray.path] = state;
        return;
    }
    state.throughput *= weight;
    state.prev_bsdf_pdf = pdf;
    state.prev_specular = delta ? 1u : 0u;
    if (max_component(state.throughput) <= 0.0) {
        paths[ray.path] = state;
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
            paths[ray.path] = state;
            return;
        }
        state.throughput *= weight;
    }
    paths[ray.path] = state;

    QueuedRay next;
    next.origin = offset_ray_origin(p, dot(ng, wi) > 0.0 ? ng : -ng);
    next.path = ray.path;
    next.dir = wi;
    next.pad = 0u;
    uint next_queue = queue ^ 1u;
    rays[next_queue * params.batch_size + atomicAdd(counters[next_queue], 1u)] = next;
}
