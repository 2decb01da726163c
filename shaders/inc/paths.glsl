// Path expressions (--paths): the automata of src/paths.rs, read from Binding::PathDfa (layout:
// PathExpr::gpu_table). Symbols: L 0, D 1, S 2, E 3. Without an expression every path counts.
#ifndef PATHS_GLSL
#define PATHS_GLSL

#define SYM_L 0u
#define SYM_D 1u
#define SYM_S 2u
#define SYM_E 3u

bool paths_enabled() { return SCENE_HAS(FEATURE_PATHS) && path_dfa[0] != 0u; }

// The automaton reading paths eye-first (the path tracer).
uint dfa_step_reversed(uint state, uint symbol) { return path_dfa[path_dfa[3] + 4u * state + symbol]; }
bool dfa_accepts_reversed(uint state) { return (path_dfa[2] & (1u << state)) != 0u; }

// The automaton reading paths emitter-first (light subpaths).
uint dfa_step_forward(uint state, uint symbol) { return path_dfa[4u + 4u * state + symbol]; }
bool dfa_accepts_forward(uint state) { return (path_dfa[1] & (1u << state)) != 0u; }

// Path tracer: whether the path so far (state, eye-first), then `vertex` (SYM_D for a vertex
// that samples an emitter, none = 4u), then an emitter, is accepted (src/cpu/path.rs,
// Classifier::ends_here).
bool path_ends_here(uint state, uint vertex) {
    if (!paths_enabled()) return true;
    if (vertex < 4u) state = dfa_step_reversed(state, vertex);
    return dfa_accepts_reversed(dfa_step_reversed(state, SYM_L));
}

// Light tracing: whether the light subpath so far (state, emitter-first), then `vertex` (SYM_D
// for a vertex joined to the camera, none = 4u), then the eye, is accepted.
bool light_path_ends_here(uint state, uint vertex) {
    if (!paths_enabled()) return true;
    if (vertex < 4u) state = dfa_step_forward(state, vertex);
    return dfa_accepts_forward(dfa_step_forward(state, SYM_E));
}

#endif
