// The emitter table's power CDF, as next event estimation samples it: twin of
// src/lights/emitters.rs.
#ifndef EMITTERS_GLSL
#define EMITTERS_GLSL
#include "scene_arrays.glsl"

// Emitter-table index for u by inverting the discrete CDF (src/lights/emitters.rs, sample_light).
uint sample_light(float u) {
    uint lo = 0u;
    uint hi = frame.light_count - 1u;
    if (lo < hi) do {
        uint mid = (lo + hi) / 2u;
        if (light_at(mid).cdf > u) hi = mid; else lo = mid + 1u;
    } while (lo < hi);
    return lo;
}

#endif
