#version 460
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
// Turns a queue counter into indirect-dispatch arguments, adds it to a running total and zeroes
// the counters the next stage will fill: the whole batch is recorded with no host round trip.
#include "layout.glsl"
#include "bindings.glsl"

layout(local_size_x = 1) in;

void kernel_main() {
    uint count = counters[params.counter];
    dispatch_args[params.args_slot] = uvec4((count + WORKGROUP_SIZE - 1u) / WORKGROUP_SIZE, 1u, 1u, 0u);
    if (params.total_counter != 0xffffffffu) counters[params.total_counter] += count;
    for (uint k = 0u; k < 32u; ++k) {
        if ((params.clear_mask & (1u << k)) != 0u) counters[k] = 0u;
    }
}

void main() {
    kernel_main();
    count_scene_fetches();
}
