// Path indexing, sample placement, emission and emitter selection: twin of src/cpu/path.rs
// (camera rays: camera.glsl).
#ifndef SCENE_GLSL
#define SCENE_GLSL
#include "convert.glsl"
#include "emitters.glsl"
#include "punctual.glsl"

// Pixel and sample index of path i of the current batch (src/layout.rs, DispatchParams). The
// batch's paths go round the band's pixels in order or, in a pass of an adaptive render, round
// the frame.active_pixel_count pixels of the active list (every one of which has had the same
// number of samples, so sample = the pass's first sample + the round).
void path_pixel_sample(uint i, out uint pixel, out uint sample_index) {
    uint local_index = params.first_pixel + i;
    // A batch holds fewer than 2^22 rounds of the pixels (src/gpu/mod.rs, max_wavefront).
    if (frame.active_pixel_count == 0u) {
        uvec2 qr = div_mod(local_index, frame.band_pixel_count);
        pixel = frame.band_first_pixel + qr.y;
        sample_index = params.first_sample + qr.x;
    } else {
        uvec2 qr = div_mod(local_index, frame.active_pixel_count);
        pixel = frame.band_first_pixel + active_pixels[qr.y];
        sample_index = params.first_sample + qr.x;
    }
}

// The pair (u.x, u.y) of dimension `dimension` (block * 4 + first component) of a path's sample,
// as the frame's sampler places it: N-rooks, Owen-scrambled Sobol or u itself (src/cpu/path.rs).
vec2 sample_pair(uint pixel, uint sample_index, uint dimension, vec2 u) {
    if (SCENE_HAS(FEATURE_STRATIFIED) && frame.sampler_mode == SAMPLER_STRATIFIED) {
        return stratify2(frame.seed, pixel, sample_index, frame.spp, dimension, u);
    }
    if (SCENE_HAS(FEATURE_SOBOL) && frame.sampler_mode == SAMPLER_SOBOL) {
        return sobol_pair(frame.seed, pixel, sample_index, dimension);
    }
    return u;
}

// KHR_materials_clearcoat darkens the emission below the coat: 1 - clearcoat F_c, F_c Schlick's
// with F0 0.04 on the angle to the front-face normal (src/cpu/path.rs, coat_emission_weight).
float coat_emission_weight(GpuMaterial m, float cos_out) {
    if (m.clearcoat <= 0.0 || (m.flags & MATERIAL_UNLIT) != 0u) return 1.0;
    float c = 1.0 - min(abs(cos_out), 1.0);
    float c2 = c * c;
    return 1.0 - m.clearcoat * (0.04 + 0.96 * (c2 * c2 * c));
}

// Radiance leaving a surface of material m towards a direction with cosine cos_out to its
// front-face normal: one-sided unless the material is double-sided, darkened by a clear coat.
vec3 emitted_radiance(GpuMaterial m, float cos_out) {
    bool visible = cos_out > 0.0 || ((m.flags & MATERIAL_DOUBLE_SIDED) != 0u && cos_out < 0.0);
    return visible ? m.emission * coat_emission_weight(m, cos_out) : vec3(0.0);
}

float max_component(vec3 v) {
    return max(v.x, max(v.y, v.z));
}

#endif
