// A plain frame's BSDF, Lambert's lobe alone. Twin of src/bsdf/lambert.rs; included by
// bsdf.glsl after BsdfFrame.
#ifndef LAMBERT_GLSL
#define LAMBERT_GLSL

// Lambert's f at local wi of a plain frame (BsdfFrame::eval_plain): bsdf_eval_local without its
// zero terms.
vec3 bsdf_eval_plain(BsdfFrame f, vec3 wi) {
    return bsdf_consistent(f, wi) && wi.z > 0.0 ? INV_PI * f.base : vec3(0.0);
}

// The cosine-weighted pdf at local wi of a plain frame (BsdfFrame::pdf_plain).
float bsdf_pdf_plain(BsdfFrame f, vec3 wi) {
    return bsdf_consistent(f, wi) && wi.z > 0.0 ? f.lobe_pmf.x * cosine_hemisphere_pdf(wi.z) : 0.0;
}

#endif
