// KHR_materials_volume's Beer-Lambert attenuation inside transmissive meshes: twin of
// src/bsdf/volume.rs, same names; the model and its limits are written down there.
#ifndef VOLUME_GLSL
#define VOLUME_GLSL

// The attenuation coefficient of the medium direction w enters at a surface of material m with
// front-face normal ng: the material's sigma behind its back face, else 0.
vec3 volume_sigma(GpuMaterial m, vec3 ng, vec3 w) {
    if (!SCENE_HAS(FEATURE_VOLUME)) return vec3(0.0);  // every m.attenuation is 0 or less
    return dot(ng, w) < 0.0 ? m.attenuation : vec3(0.0);
}

// exp(-sigma t); 1 where sigma is 0 (also for an infinite t).
vec3 transmittance(vec3 sigma, float t) {
    // Without attenuation every sigma is 0 (or a material's, which is 0 or less): 1 per channel.
    if (!SCENE_HAS(FEATURE_VOLUME)) return vec3(1.0);
    return vec3(sigma.x > 0.0 ? exp(-sigma.x * t) : 1.0,
                sigma.y > 0.0 ? exp(-sigma.y * t) : 1.0,
                sigma.z > 0.0 ? exp(-sigma.z * t) : 1.0);
}

#endif
