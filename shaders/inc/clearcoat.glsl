// KHR_materials_clearcoat's lobe over the base: its frame, weight, evaluation and pdf. Twin of
// src/bsdf/clearcoat.rs; included by bsdf.glsl after BsdfFrame.
#ifndef CLEARCOAT_GLSL
#define CLEARCOAT_GLSL

bool bsdf_cc_is_delta(BsdfFrame f) {
    return f.cc_alpha.x < ALPHA_DELTA;
}

vec3 bsdf_to_cc_local(BsdfFrame f, vec3 v) {
    return vec3(dot(v, f.cc_t), dot(v, f.cc_b), dot(v, f.cc_n));
}

// The coat's weight clearcoat * F_c(|V.N_c|): V is wo for radiance, wi for importance.
float bsdf_cc_weight(BsdfFrame f, vec3 wi, uint mode) {
    float v = mode == TRANSPORT_RADIANCE ? f.cc_wo.z : dot(wi, f.cc_n);
    return f.clearcoat * fresnel_coat(v);
}

// The coat's GGX lobe D.V at world wi, times |cos to N_c| / |cos to n| of the direction the
// integrator multiplies by (BsdfFrame::eval_clearcoat).
float bsdf_eval_clearcoat(BsdfFrame f, vec3 wi, uint mode) {
    vec3 wc = bsdf_to_cc_local(f, wi);
    if (bsdf_cc_is_delta(f) || wc.z <= 0.0 || dot(wi, f.ng_world) <= 0.0) return 0.0;
    vec3 h = normalize(f.cc_wo + wc);
    float spec = ggx_d(h, f.cc_alpha) * ggx_visibility(f.cc_wo, wc, f.cc_alpha);
    if (all(equal(f.cc_n, f.n))) return spec;
    float ratio = mode == TRANSPORT_RADIANCE ? wc.z / abs(dot(wi, f.n)) : f.cc_wo.z / f.wo.z;
    return (isinf(ratio) || isnan(ratio)) ? 0.0 : spec * ratio;
}

// Solid-angle pdf of the coat's visible-normal sampling at world wi.
float bsdf_pdf_clearcoat(BsdfFrame f, vec3 wi) {
    vec3 wc = bsdf_to_cc_local(f, wi);
    if (bsdf_cc_is_delta(f) || wc.z <= 0.0 || dot(wi, f.ng_world) <= 0.0) return 0.0;
    vec3 h = normalize(f.cc_wo + wc);
    return ggx_vndf_pdf(f.cc_wo, h, f.cc_alpha) / (4.0 * dot(f.cc_wo, h));
}

#endif
