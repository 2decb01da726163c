// Combined-sampling weights for two strategies (lecture, "Combined sampling"): twin of the
// two-strategy form in src/mis.rs.
#ifndef MIS_GLSL
#define MIS_GLSL

#define MIS_POWER 0u
#define MIS_BALANCE 1u
#define MIS_MAXIMUM 2u
#define MIS_AVERAGE 3u
#define MIS_LIGHT_ONLY 4u
#define MIS_BSDF_ONLY 5u

// Weight of the strategy with pdf a against the other's b at the same sample. A strategy that
// cannot produce the sample (pdf 0) leaves the other weight 1; a_is_light says a is emitter
// sampling's pdf (it picks the single-technique modes' side and wins maximum's ties); written
// with r = b/a so no power overflows; non-finite weights become 0.
float mis_weight2(uint heuristic, float beta, float a, float b, bool a_is_light) {
    if (!(b > 0.0)) return 1.0;
    if (!(a > 0.0)) return 0.0;
    float r = b / a;
    float w;
    if (heuristic == MIS_BALANCE) {
        w = 1.0 / (1.0 + r);
    } else if (heuristic == MIS_MAXIMUM) {
        w = (a > b || (a == b && a_is_light)) ? 1.0 : 0.0;
    } else if (heuristic == MIS_AVERAGE) {
        w = 0.5;
    } else if (heuristic == MIS_LIGHT_ONLY) {
        w = a_is_light ? 1.0 : 0.0;
    } else if (heuristic == MIS_BSDF_ONLY) {
        w = a_is_light ? 0.0 : 1.0;
    } else {
        w = 1.0 / (1.0 + (beta == 2.0 ? r * r : pow(r, beta)));
    }
    return (isnan(w) || isinf(w)) ? 0.0 : w;
}

#endif
