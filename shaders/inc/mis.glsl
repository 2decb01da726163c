// Combined-sampling weights for two strategies: twin of src/mis.rs.
#ifndef MIS_GLSL
#define MIS_GLSL

// Power heuristic, beta = 2: weight of the strategy with pdf a; non-finite weights become 0.
float mis_power2(float a, float b) {
    float a2 = a * a;
    float b2 = b * b;
    float w = a2 / (a2 + b2);
    return (isnan(w) || isinf(w)) ? 0.0 : w;
}

#endif
