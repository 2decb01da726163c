// KHR_lights_punctual's point, spot and directional lights: the radiance arriving from one, a
// light's intensity along a direction, its range window and its cone. Twin of
// src/lights/punctual.rs, same names.
#ifndef PUNCTUAL_GLSL
#define PUNCTUAL_GLSL
#include "layout.glsl"

// Radiance arriving at p from punctual light l, its direction wi and distance dist (-1 for a
// directional light, at infinity): KHR_lights_punctual's range window and spot falloff (src/lights/punctual.rs,
// punctual_incident).
vec3 punctual_incident(GpuPunctualLight l, vec3 p, out vec3 wi, out float dist) {
    if (l.kind == LIGHT_DIRECTIONAL) {
        wi = -l.direction;
        dist = -1.0;
        return l.intensity;
    }
    vec3 to = l.position - p;
    float d2 = dot(to, to);
    dist = sqrt(d2);
    if (!(dist > 0.0)) {
        wi = vec3(0.0, 0.0, 1.0);
        return vec3(0.0);
    }
    wi = to / dist;
    vec3 li = l.intensity / d2;
    if (l.range > 0.0) {
        float x = dist / l.range;
        li *= clamp(1.0 - x * x * x * x, 0.0, 1.0);
    }
    if (l.kind == LIGHT_SPOT) {
        float a = clamp(dot(l.direction, -wi) * l.spot_scale + l.spot_offset, 0.0, 1.0);
        li *= a * a;
    }
    return li;
}

// Radiant intensity of a point or spot light along w: I times the spot's smooth falloff.
vec3 punctual_intensity(GpuPunctualLight l, vec3 w) {
    vec3 i = l.intensity;
    if (l.kind == LIGHT_SPOT) {
        float a = clamp(dot(l.direction, w) * l.spot_scale + l.spot_offset, 0.0, 1.0);
        i *= a * a;
    }
    return i;
}

// The range window clamp(1 - (d/range)^4, 0, 1) at distance d (1 without a range).
float punctual_window(GpuPunctualLight l, float d) {
    if (l.range > 0.0) {
        float x = d / l.range;
        return clamp(1.0 - x * x * x * x, 0.0, 1.0);
    }
    return 1.0;
}

// cos of a spot light's outer cone angle, from its falloff constants.
float spot_cos_outer(GpuPunctualLight l) {
    return clamp(-l.spot_offset / l.spot_scale, -1.0, 1.0);
}

#endif
