// Bidirectional path tracing (Veach & Guibas 1995; Veach 1997, ch. 10) on the GPU: the twin of
// src/cpu/bidir/bdpt.rs (Bidir::sample_light_vertex, pdf, mis_weight, path_matches), same names
// with a bdpt_ prefix. Both subpaths of every path of a batch live in bdpt_vertices: the light
// subpath's at most max_depth + 1 vertices, then the camera subpath's at most max_depth + 2.
// The camera subpath's vertex 0 (z0, the pinhole) is rebuilt from the frame when read, so its
// slot holds the subpath lengths instead (index: light vertices, instance: camera vertices).
// Densities are in area measure (delta: 1), as in the CPU twin's module docs.
#ifndef BDPT_GLSL
#define BDPT_GLSL
#include "scene_arrays.glsl"
#include "spectrum.glsl"
// (Kernels that include it enable GL_EXT_control_flow_attributes for [[dont_unroll]].)

uint bdpt_stride() { return 2u * frame.max_depth + 3u; }
uint bdpt_light_index(uint path, uint k) { return path * bdpt_stride() + k; }
uint bdpt_camera_index(uint path, uint k) { return path * bdpt_stride() + frame.max_depth + 1u + k; }

uint bdpt_light_length(uint path) { return bdpt_vertices[bdpt_camera_index(path, 0u)].index; }
uint bdpt_camera_length(uint path) { return bdpt_vertices[bdpt_camera_index(path, 0u)].instance; }
void bdpt_set_light_length(uint path, uint n) { bdpt_vertices[bdpt_camera_index(path, 0u)].index = n; }
void bdpt_set_camera_length(uint path, uint n) { bdpt_vertices[bdpt_camera_index(path, 0u)].instance = n; }

uint bdpt_kind(BdptVertex v) { return v.kind & ~BDPT_VERTEX_DELTA; }
bool bdpt_delta(BdptVertex v) { return (v.kind & BDPT_VERTEX_DELTA) != 0u; }
bool bdpt_on_surface(BdptVertex v) {
    uint k = bdpt_kind(v);
    return k == BDPT_VERTEX_SURFACE || k == BDPT_VERTEX_AREA_LIGHT;
}
// |cos| of the vertex's side of an edge along w (the G term): 1 at a point light.
float bdpt_cos(BdptVertex v, vec3 w) {
    return bdpt_kind(v) == BDPT_VERTEX_POINT_LIGHT ? 1.0 : abs(dot(v.ng, w));
}

BdptVertex bdpt_endpoint(uint kind, vec3 p, vec3 ng, vec3 beta, float pdf_fwd, uint index) {
    BdptVertex v;
    v.p = p;
    v.kind = kind;
    v.ng = ng;
    v.pdf_fwd = pdf_fwd;
    v.ns = ng;
    v.pdf_rev = 0.0;
    v.wo = vec3(0.0);
    v.index = index;
    v.beta = beta;
    v.instance = NO_HIT;
    v.bary = vec2(0.0);
    v.pad0 = 0u;
    v.pad1 = 0u;
    return v;
}

BdptVertex bdpt_camera_vertex() {
    return bdpt_endpoint(BDPT_VERTEX_CAMERA, frame.cam_position, frame.cam_forward, vec3(1.0), 1.0, 0u);
}
BdptVertex bdpt_light(uint path, uint k) { return bdpt_vertices[bdpt_light_index(path, k)]; }
BdptVertex bdpt_camera(uint path, uint k) {
    return k == 0u ? bdpt_camera_vertex() : bdpt_vertices[bdpt_camera_index(path, k)];
}

// The material of a surface vertex with its textures at level 0, or of an emitter's own point
// (the factors with the emission resolved), rebuilt from the triangle it lies on; a surface's
// ior at the sample's wavelength `lambda` (0: none; spectrum.glsl).
GpuMaterial bdpt_material(BdptVertex v, float lambda) {
    GpuTriangle tri = triangle_at(v.index);
    if (bdpt_kind(v) == BDPT_VERTEX_AREA_LIGHT) return emitter_at(tri, v.index, v.bary);
    SurfacePoint sp = surface_point(tri, triangle_vertices_at(v.index), v.bary.x, v.bary.y);
    GpuMaterial raw = material_at(triangle_material(tri));
    surface_to_world(sp, tri, instance_at(v.instance));
    GpuMaterial m = surface_material(raw, sp, LOD_MAGNIFY);
    material_at_wavelength(m, lambda);
    return m;
}

// A light subpath's origin y0 for the numbers u (emitter) and u_point: an emitter of the table
// chosen by power (the environment's share out), a uniform point on it, β = 1/p(y0); false for
// none, a directional light, or an alpha-cut point (Bidir::sample_light_vertex). An area
// light's material is the caller's: bdpt_material(v).
bool bdpt_sample_light_vertex(uint pixel, uint sample_index, float u, vec2 u_point, out BdptVertex v) {
    v = bdpt_camera_vertex();
    if (frame.light_count == 0u) return false;
    LightEntry entry = light_at(sample_light(min(u, ONE_MINUS_EPSILON)));
    float pmf = entry.pmf * (1.0 - frame.env_pmf);
    if (!(pmf > 0.0)) return false;
    if (SCENE_HAS(FEATURE_PUNCTUAL) && (entry.triangle & LIGHT_ENTRY_PUNCTUAL) != 0u) {
        uint index = entry.triangle & ~LIGHT_ENTRY_PUNCTUAL;
        GpuPunctualLight l = punctual_lights[index];
        if (l.kind == LIGHT_DIRECTIONAL) return false;
        v = bdpt_endpoint(BDPT_VERTEX_POINT_LIGHT, l.position, l.direction, vec3(1.0 / pmf), pmf, index);
        return true;
    }
    GpuTriangle tri = triangle_at(entry.triangle);
    vec2 b = sample_uniform_triangle(u_point);
    uvec4 key = alpha_key(frame.seed, pixel, sample_index, ALPHA_CONNECT - 1u, true);
    if (!triangle_present(tri, entry.triangle, b.x, b.y, key, vec3(0.0))) return false;
    float p_a = pmf / tri.area;
    v = bdpt_endpoint(BDPT_VERTEX_AREA_LIGHT, tri.p0 + b.x * tri.e1 + b.y * tri.e2,
                      normalize(cross(tri.e1, tri.e2)), vec3(1.0 / p_a), p_a, entry.triangle);
    v.bary = b;
    return true;
}

// Radiance (or intensity) leaving light vertex v along w over a distance dist.
vec3 bdpt_emission(BdptVertex v, GpuMaterial mat, vec3 w, float dist) {
    if (bdpt_kind(v) == BDPT_VERTEX_POINT_LIGHT) {
        GpuPunctualLight l = punctual_lights[v.index];
        return punctual_intensity(l, w) * punctual_window(l, dist);
    }
    return emitted_radiance(mat, dot(v.ng, w));
}

// Solid-angle pdf of emitting along w from light vertex v: uniform in a punctual light's cone,
// cosine-weighted on the emitting side (both halves, ½ each, if double-sided).
float bdpt_emission_pdf(BdptVertex v, GpuMaterial mat, vec3 w) {
    if (bdpt_kind(v) == BDPT_VERTEX_POINT_LIGHT) {
        GpuPunctualLight l = punctual_lights[v.index];
        if (l.kind == LIGHT_SPOT) {
            float cos_outer = spot_cos_outer(l);
            return dot(v.ng, w) >= cos_outer ? uniform_cone_pdf(cos_outer) : 0.0;
        }
        return 0.25 * INV_PI;
    }
    float c = dot(v.ng, w);
    return (mat.flags & MATERIAL_DOUBLE_SIDED) != 0u ? 0.5 * abs(c) * INV_PI : max(c, 0.0) * INV_PI;
}

// The area density with which light subpaths start at emitting surface vertex v.
float bdpt_light_origin_pdf(BdptVertex v) {
    GpuTriangle tri = triangle_at(v.index);
    return (1.0 - frame.env_pmf) * tri.light_pmf / tri.area;
}

// A solid-angle pdf at `from` of the direction to `to`, as an area density at `to`.
float bdpt_to_area(float pdf_dir, vec3 from, BdptVertex to) {
    vec3 d = to.p - from;
    float r2 = dot(d, d);
    if (!(r2 > 0.0)) return 0.0;
    float pdf = pdf_dir / r2;
    if (bdpt_on_surface(to)) pdf *= abs(dot(to.ng, d)) / sqrt(r2);
    return pdf;
}

// Area density of sampling `next` from v (material mat), v having been reached from `prev`
// (has_prev): the BSDF seen from prev at surfaces, the direction pdf at endpoints.
float bdpt_pdf(BdptVertex v, GpuMaterial mat, bool has_prev, BdptVertex prev, BdptVertex next) {
    vec3 w = normalize(next.p - v.p);
    float pdf_dir = 0.0;
    uint kind = bdpt_kind(v);
    if (kind == BDPT_VERTEX_CAMERA) {
        uint pixel;
        float we;
        if (!camera_importance(w, pixel, we, pdf_dir)) pdf_dir = 0.0;
    } else if (kind == BDPT_VERTEX_SURFACE) {
        if (!has_prev) return 0.0;
        BsdfFrame f;
        if (!bsdf_frame_new_shading(mat, v.ng, v.ns, normalize(prev.p - v.p), f)) return 0.0;
        pdf_dir = bsdf_frame_pdf(f, w);
    } else {
        pdf_dir = bdpt_emission_pdf(v, mat, w);
    }
    return bdpt_to_area(pdf_dir, v.p, next);
}

// Light vertex i of strategy (s, t): the vertex sampled afresh for s = 1.
BdptVertex bdpt_lv(uint path, uint s, int i, BdptVertex sampled) {
    return (s == 1u && i == 0) ? sampled : bdpt_light(path, uint(i));
}

// One other strategy's density ratio r into the weight's sums (Bidir::mis_weight's `add`).
void bdpt_mis_add(float r, bool more_light_vertices, inout float sum, inout uint others, inout bool beaten) {
    uint h = frame.mis_heuristic;
    if (h == MIS_POWER) {
        sum += pow(r, frame.mis_beta);
    } else if (h == MIS_BALANCE) {
        sum += r;
    } else if (h == MIS_AVERAGE) {
        others += r > 0.0 ? 1u : 0u;
    } else if (h == MIS_MAXIMUM) {
        // Ties go to the strategy with fewer light vertices.
        beaten = beaten || (more_light_vertices ? r > 1.0 : r >= 1.0);
    }
}

float bdpt_ratio(float rev, float fwd) { return fwd > 0.0 ? rev / fwd : 0.0; }

// The MIS weight of strategy (s, t) over all strategies that make the same path (Veach 1997,
// §10.2, the ratio recurrence of eq. 10.9); mat_qs and mat_pt are the materials of the two
// vertices beside the connection, `sampled` stands in for y0 when s = 1.
float bdpt_mis_weight(uint path, uint s, uint t, BdptVertex sampled, GpuMaterial mat_qs, GpuMaterial mat_pt) {
    if (s + t == 2u) return 1.0;
    BdptVertex qs = sampled, pt = sampled, qsm = sampled, ptm = sampled;
    if (s > 0u) qs = bdpt_lv(path, s, int(s) - 1, sampled);
    if (t > 0u) pt = bdpt_camera(path, t - 1u);
    if (s > 1u) qsm = bdpt_lv(path, s, int(s) - 2, sampled);
    if (t > 1u) ptm = bdpt_camera(path, t - 2u);
    // The reverse densities of the four vertices beside the connection, for this path:
    // rev[0] of pt (from qs), rev[1] of pt − 1 (from pt), rev[2] of qs (from pt), rev[3] of
    // qs − 1 (from qs). One rolled loop, so the BSDF's code is there once: llvmpipe compiles a
    // kernel in time that grows much faster than its size.
    float rev[4] = float[4](0.0, 0.0, 0.0, 0.0);
    if (s == 0u) {
        rev[0] = bdpt_light_origin_pdf(pt);
        if (t > 1u) {
            BdptVertex light = pt;
            light.kind = BDPT_VERTEX_AREA_LIGHT;
            rev[1] = bdpt_to_area(bdpt_emission_pdf(light, mat_pt, normalize(ptm.p - pt.p)), pt.p, ptm);
        }
    } else {
        [[dont_unroll]] for (uint j = 0u; j < 4u; j++) {
            bool at_qs = j == 0u || j == 3u;
            bool valid = j == 0u || j == 2u || (j == 1u && t > 1u) || (j == 3u && s > 1u);
            if (!valid) continue;
            BdptVertex v = at_qs ? qs : pt;
            bool has_prev = j == 0u ? s > 1u : (j == 2u ? t > 1u : true);
            BdptVertex prev = j == 0u ? qsm : (j == 1u ? qs : (j == 2u ? ptm : pt));
            BdptVertex next = j == 0u ? pt : (j == 1u ? ptm : (j == 2u ? qs : qsm));
            rev[j] = bdpt_pdf(v, at_qs ? mat_qs : mat_pt, has_prev, prev, next);
        }
    }
    float pt_rev = rev[0], pt_minus_rev = rev[1], qs_rev = rev[2], qs_minus_rev = rev[3];

    float sum = 0.0;
    uint others = 0u;
    bool beaten = false;
    // Strategies with more light vertices: move the connection towards the camera.
    float r = 1.0;
    int i = int(t) - 1;
    if (i >= 1) do {
        BdptVertex v = i == int(t) - 1 ? pt : bdpt_camera(path, uint(i));
        float rev = i == int(t) - 1 ? pt_rev : (i + 2 == int(t) ? pt_minus_rev : v.pdf_rev);
        r *= bdpt_ratio(rev, v.pdf_fwd);
        bool delta_here = i != int(t) - 1 && bdpt_delta(v);
        bool delta_before = bdpt_delta(bdpt_camera(path, uint(i - 1)));
        if (!delta_here && !delta_before) bdpt_mis_add(r, true, sum, others, beaten);
    } while (--i >= 1);
    // Strategies with fewer light vertices.
    r = 1.0;
    i = int(s) - 1;
    if (i >= 0) do {
        BdptVertex v = bdpt_lv(path, s, i, sampled);
        float rev = i == int(s) - 1 ? qs_rev : (i + 2 == int(s) ? qs_minus_rev : v.pdf_rev);
        r *= bdpt_ratio(rev, v.pdf_fwd);
        bool delta_here = i != int(s) - 1 && bdpt_delta(v);
        bool delta_before = i > 0
            ? bdpt_delta(bdpt_lv(path, s, i - 1, sampled))
            : bdpt_kind(v) == BDPT_VERTEX_POINT_LIGHT;
        if (!delta_here && !delta_before) bdpt_mis_add(r, false, sum, others, beaten);
    } while (--i >= 0);
    uint h = frame.mis_heuristic;
    if (h == MIS_POWER || h == MIS_BALANCE) return 1.0 / (1.0 + sum);
    if (h == MIS_AVERAGE) return 1.0 / (1.0 + float(others));
    if (h == MIS_MAXIMUM) return beaten ? 0.0 : 1.0;
    return 1.0;
}

// The symbol of a vertex in a path string: S if its subpath left it along a delta lobe, D
// otherwise and where it is joined to the other subpath.
uint bdpt_symbol(BdptVertex v, bool connection) {
    return !connection && bdpt_delta(v) ? SYM_S : SYM_D;
}

// Whether the path string of strategy (s, t), emitter-first, is accepted by --paths.
bool bdpt_path_matches(uint path, uint s, uint t) {
    if (!paths_enabled()) return true;
    uint st = dfa_step_forward(0u, SYM_L);
    for (uint i = 1u; i < s; i++) st = dfa_step_forward(st, bdpt_symbol(bdpt_light(path, i), i == s - 1u));
    int first_camera = s == 0u ? int(t) - 2 : int(t) - 1;
    for (int i = first_camera; i >= 1; i--) {
        st = dfa_step_forward(st, bdpt_symbol(bdpt_camera(path, uint(i)), i == int(t) - 1));
    }
    return dfa_accepts_forward(dfa_step_forward(st, SYM_E));
}

// Strategy j of a connect_bdpt dispatch as (s, t): by path length k = s + t − 2 ≤ max_depth,
// s = 0 … k + 1; (1, 1) left to (0, 2) as on the CPU. bdpt_strategy_count in
// src/gpu/wavefront.rs counts them alike.
bool bdpt_strategy(uint j, out uint s, out uint t) {
    s = 0u;
    t = 0u;
    for (uint k = 0u; k <= frame.max_depth; k++) {
        uint n = k == 0u ? 1u : k + 2u;
        if (j < n) {
            s = j;
            t = k + 2u - j;
            return true;
        }
        j -= n;
    }
    return false;
}

#endif
