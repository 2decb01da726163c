// The glTF 2.0 metallic-roughness BSDF (Appendix B) with KHR_materials_ior, _transmission,
// _specular, _unlit, _clearcoat, _sheen, _anisotropy, _iridescence and _diffuse_transmission:
// twin of src/bsdf/ (mod.rs: the model and its conventions; gltf.rs: BsdfFrame), same names;
// the other lobes and terms have files of their own, named as in src/bsdf/ (fresnel, shading,
// clearcoat, lambert, sheen, iridescence, microfacet). Direction convention: wo points towards
// where the light goes (previous vertex), wi towards where it comes from; both point away from
// the surface; ng is the front face's geometric normal, not flipped (front = outside for
// transmission). bsdf_eval returns f without the cosine, over the non-delta lobes; bsdf_pdf is
// their mixture pdf.
#ifndef BSDF_GLSL
#define BSDF_GLSL
#include "microfacet.glsl"
#include "sheen.glsl"
#include "iridescence.glsl"
#include "energy.glsl"

#define TRANSPORT_RADIANCE 0u
#define TRANSPORT_IMPORTANCE 1u

#define LOBE_DIFFUSE 0u
#define LOBE_REFLECTION 1u
#define LOBE_TRANSMISSION 2u
#define LOBE_CLEARCOAT 3u
#define LOBE_SHEEN 4u
#define LOBE_DIFFUSE_TRANSMISSION 5u
#define LOBE_COUNT 6u

// A material seen from wo: local frame (+Z on wo's side), relative IOR, lobe probabilities.
struct BsdfFrame {
    vec3 t;
    vec3 b;
    vec3 n;
    vec3 wo;           // local, z > 0
    vec3 base;
    float metallic;
    float transmission;
    vec2 alpha;        // GGX (alpha_t, alpha_b) along t and b (anisotropic_alpha)
    float etap;        // eta on the far side / eta on wo's side (ior from either side of a thin wall)
    bool thin;         // thin-walled transmission: passes without bending, bounds no medium
    vec3 f0;           // the dielectric Fresnel's RGB F0 (specular_f0) and F90 (specular)
    float f90;
    float film;        // KHR_materials_iridescence's film: factor (0: none), index, thickness (nm)
    float film_ior;
    float film_thickness;
    float dt;          // KHR_materials_diffuse_transmission: factor (0: none), colour
    vec3 dt_color;
    vec4 lobe_pmf;     // diffuse, reflection, transmission, clearcoat (bsdf_lobe_pmf: all five)
    float sheen_pmf;   // the sheen lobe's
    float dt_pmf;      // the diffuse transmission lobe's
    float albedo_estimate;
    vec3 ng;           // geometric normal on wo's side, local
    vec3 ng_world;     // the same, world space
    float clearcoat;   // the coat's weight (0: none), alpha, world frame about N_c, wo in it
    vec2 cc_alpha;
    vec3 cc_t;
    vec3 cc_b;
    vec3 cc_n;
    vec3 cc_wo;
    vec3 sheen_color;  // the sheen: colour, max component (0: none), alpha, roughness and the
    float sheen_max;   // scaling 1 - max(colour) E(cos theta_o) of the layers below
    float sheen_alpha;
    float sheen_roughness;
    float sheen_scale_o;
    bool plain;        // Lambert's lobe alone (BsdfFrame::plain): eval, pdf and sample take its terms
    bool compensated;  // energy compensation (energy.glsl): table roughness, white E(mu_o) and
    float table_r;     // E_avg, F_ms of the dielectric and metal lobes, the dielectric layer's
    float e_o;         // albedo E^(mu_o) and E^_avg (largest channel) for the coupling
    float e_avg;
    vec3 fms_d;
    vec3 fms_m;
    float spec_o;
    float spec_avg;
};

#include "fresnel.glsl"

#include "shading.glsl"

float average3(vec3 v) {
    return (v.x + v.y + v.z) / 3.0;
}

float max3(vec3 v) {
    return max(max(v.x, v.y), v.z);
}

// No specular layer (BsdfFrame::specular_free): a dielectric with KHR_materials_specular's
// factor 0 (F0 = F90 = 0), no metal, no thin film and no total internal reflection has fd = 0 at
// every angle, so its reflection term is 0 and its diffuse lobe keeps all of 1 - max(fd) = 1; eval
// skips the Fresnel and the reflection term (the same value bit for bit: x + 0 = x).
bool bsdf_specular_free(BsdfFrame f) {
    return f.metallic == 0.0 && f.f90 == 0.0 && max3(f.f0) == 0.0 && f.film <= 0.0 && f.etap >= 1.0;
}

// Where the plain frames' path (BsdfFrame::plain: the general path's floats) is taken,
// BSDF_PLAIN_PATH(f), true only where f is plain. In the wavefront's kernels (KERNEL_INDEX,
// layout.glsl) BSDF_PLAIN_SCENE is true only where every frame they build is plain, as the
// render's features say (FEATURE_GENERAL_BSDF): then the path is that, the general path
// compiled out of the pipeline, where lavapipe runs a per-lane branch's both sides under
// masks (a subgroup vote of f.plain measured no faster there than the general path), and
// bsdf_frame_new_shading skips the Fresnel, sheen and coat blocks every frame would skip.
// Elsewhere (the twins tests) the choice is per lane.
#ifdef KERNEL_INDEX
#define BSDF_PLAIN_SCENE (!SCENE_HAS(FEATURE_GENERAL_BSDF))
#define BSDF_PLAIN_PATH(f) BSDF_PLAIN_SCENE
#else
#define BSDF_PLAIN_SCENE false
#define BSDF_PLAIN_PATH(f) (f).plain
#endif

// The frame of shading normal ns flipped with ng to wo's side and bent (BsdfFrame::new_shading):
// evaluated in the shading frame, zero where the geometric and shading sides of wi disagree.
// False where wo lies in the surface's plane.
bool bsdf_frame_new_shading(GpuMaterial m, vec3 ng, vec3 ns, vec3 wo, out BsdfFrame f) {
    float cos_g = dot(ng, wo);
    f.t = vec3(0.0); f.b = vec3(0.0); f.n = vec3(0.0); f.wo = vec3(0.0); f.base = vec3(0.0);
    f.metallic = 0.0; f.transmission = 0.0; f.alpha = vec2(0.0); f.etap = 1.0; f.thin = false; f.f0 = vec3(0.0); f.f90 = 0.0;
    f.film = 0.0; f.film_ior = 1.0; f.film_thickness = 0.0;
    f.lobe_pmf = vec4(0.0); f.sheen_pmf = 0.0; f.dt_pmf = 0.0;
    f.dt = 0.0; f.dt_color = vec3(0.0);
    f.albedo_estimate = 0.0; f.ng = vec3(0.0, 0.0, 1.0);
    f.sheen_color = vec3(0.0); f.sheen_max = 0.0; f.sheen_alpha = 1.0; f.sheen_roughness = 0.0;
    f.sheen_scale_o = 1.0;
    f.ng_world = vec3(0.0); f.clearcoat = 0.0; f.cc_alpha = vec2(0.0);
    f.cc_t = vec3(0.0); f.cc_b = vec3(0.0); f.cc_n = vec3(0.0); f.cc_wo = vec3(0.0);
    f.plain = false;
    f.compensated = false; f.table_r = 0.0; f.e_o = 1.0; f.e_avg = 1.0;
    f.fms_d = vec3(0.0); f.fms_m = vec3(0.0); f.spec_o = 0.0; f.spec_avg = 0.0;
    if (cos_g == 0.0 || isnan(cos_g) || isinf(cos_g)) return false;
    bool front = cos_g > 0.0;
    vec3 ng_wo = front ? ng : -ng;
    bool geometric = all(equal(ns, ng));
    f.n = geometric ? ng_wo : bend_shading_normal(front ? ns : -ns, ng_wo, wo);
    // The tangent: the anisotropy direction where the material has one, else any.
    bool unlit = (m.flags & MATERIAL_UNLIT) != 0u;
    float anisotropy = unlit ? 0.0 : m.anisotropy;
    anisotropic_frame(f.n, anisotropy, m.anisotropy_direction, f.t, f.b);
    f.wo = vec3(dot(wo, f.t), dot(wo, f.b), geometric ? abs(cos_g) : dot(wo, f.n));
    if (!geometric) f.ng = vec3(dot(ng_wo, f.t), dot(ng_wo, f.b), dot(ng_wo, f.n));
    // An unlit surface scatters nothing: every lobe's weight is 0.
    f.transmission = (m.metallic < 1.0 && !unlit) ? m.transmission : 0.0;
    float ior = max(m.ior, 1.0);
    // glTF's default is thin-walled: only a volume (thicknessFactor > 0) makes the mesh the
    // boundary of a medium of index ior (KHR_materials_volume, "Overview").
    f.thin = f.transmission > 0.0 && m.thickness <= 0.0;
    f.etap = (f.transmission > 0.0 && !front && !f.thin) ? 1.0 / ior : ior;
    float specular = unlit ? 0.0 : m.specular;
    f.base = unlit ? vec3(0.0) : m.base_color;
    f.metallic = unlit ? 0.0 : m.metallic;
    f.f0 = specular_f0(m.ior, m.specular_color, specular);
    f.f90 = specular;
    f.alpha = anisotropic_alpha(m.roughness * m.roughness, anisotropy);
    f.film = unlit ? 0.0 : m.iridescence;
    f.film_ior = m.iridescence_ior;
    f.film_thickness = m.iridescence_thickness;
    // Lobe albedo estimates at the macro normal (Fresnel at cos theta_o). Without a specular
    // layer fe = 0 (bsdf_specular_free) and fm has the factor metallic = 0: both terms 0.
    bool specular_free = bsdf_specular_free(f);
    vec3 fe = vec3(0.0), fm3 = vec3(0.0);
    if (!BSDF_PLAIN_SCENE && !specular_free) {
        fresnel_layers(f.wo.z, f.f0, f.f90, f.etap, f.base, f.metallic, f.film, f.film_ior, f.film_thickness, fe, fm3);
    }
    float fm = average3(fm3);
    float dielectric = 1.0 - f.metallic;
    f.dt = unlit ? 0.0 : m.diffuse_transmission;
    f.dt_color = m.diffuse_transmission_color;
    float diffuse = dielectric * (1.0 - f.transmission) * (1.0 - max3(fe));
    vec4 w = vec4(diffuse * (1.0 - f.dt) * average3(f.base),
                  dielectric * average3(fe) + f.metallic * fm,
                  dielectric * f.transmission * (1.0 - max3(fe)) * average3(f.base),
                  0.0);
    float w_sheen = 0.0;
    float w_dt = diffuse * f.dt * average3(f.dt_color);
    // The sheen: its albedo E(cos theta_o) taken from the layers below (albedo scaling).
    f.sheen_color = unlit ? vec3(0.0) : m.sheen_color;
    f.sheen_max = max3(f.sheen_color);
    f.sheen_alpha = sheen_alpha(m.sheen_roughness);
    f.sheen_roughness = m.sheen_roughness;
    if (!BSDF_PLAIN_SCENE && f.sheen_max > 0.0) {
        float e = sheen_albedo(f.wo.z, m.sheen_roughness);
        f.sheen_scale_o = max(1.0 - f.sheen_max * e, 0.0);
        w.xyz *= f.sheen_scale_o;
        w_dt *= f.sheen_scale_o;
        w_sheen = average3(f.sheen_color) * e;
    }
    // The coat: its frame about N_c and its weight clearcoat * F_c(wo.N_c) taken from the base.
    f.ng_world = ng_wo;
    f.clearcoat = unlit ? 0.0 : m.clearcoat;
    f.cc_alpha = vec2(m.clearcoat_roughness * m.clearcoat_roughness);
    f.cc_t = f.t; f.cc_b = f.b; f.cc_n = f.n; f.cc_wo = f.wo;
    if (!BSDF_PLAIN_SCENE && f.clearcoat > 0.0) {
        vec3 nc = m.clearcoat_normal;
        if (any(notEqual(nc, vec3(0.0)))) {
            f.cc_n = bend_shading_normal(front ? nc : -nc, ng_wo, wo);
            build_frame(f.cc_n, f.cc_t, f.cc_b);
            f.cc_wo = vec3(dot(wo, f.cc_t), dot(wo, f.cc_b), dot(wo, f.cc_n));
        }
        float wc = f.clearcoat * fresnel_coat(f.cc_wo.z);
        w.xyz *= 1.0 - wc;
        w_sheen *= 1.0 - wc;
        w_dt *= 1.0 - wc;
        w.w = wc;
    }
    float total = w.x + w.y + w.z + w.w + w_sheen + w_dt;
    f.lobe_pmf = total > 0.0 ? w / total : vec4(0.0);
    f.sheen_pmf = total > 0.0 ? w_sheen / total : 0.0;
    f.dt_pmf = total > 0.0 ? w_dt / total : 0.0;
    f.albedo_estimate = total;
    f.plain = specular_free && f.transmission == 0.0 && f.dt == 0.0 && f.sheen_max <= 0.0
           && f.clearcoat <= 0.0;
    f.compensated = !BSDF_PLAIN_SCENE && (m.flags & MATERIAL_ENERGY_COMPENSATION) != 0u && !unlit
                 && !specular_free && f.film <= 0.0 && f.etap >= 1.0;
    if (f.compensated) {
        f.table_r = table_roughness(f.alpha);
        vec2 ab = ggx_albedo(f.wo.z, f.table_r);
        vec2 avg = ggx_albedo_avg(f.table_r);
        f.e_o = ab.x + ab.y;
        f.e_avg = avg.x + avg.y;
        f.fms_d = fresnel_multiple(f.f0, f.f90, f.e_avg);
        f.fms_m = fresnel_multiple(f.base, 1.0, f.e_avg);
        vec3 o, a;
        specular_albedo(f.f0, f.f90, f.wo.z, f.table_r, o, a);
        f.spec_o = max3(o);
        f.spec_avg = max3(a);
    }
    return true;
}

// The dielectric and metal Fresnel terms at cosine cos_theta (BsdfFrame::fresnel).
void bsdf_fresnel(BsdfFrame f, float cos_theta, out vec3 fd, out vec3 fm) {
    fresnel_layers(cos_theta, f.f0, f.f90, f.etap, f.base, f.metallic, f.film, f.film_ior, f.film_thickness, fd, fm);
}

// The probability of choosing lobe k (BsdfFrame::lobe_pmf[k]).
float bsdf_lobe_pmf(BsdfFrame f, uint k) {
    return k == LOBE_SHEEN ? f.sheen_pmf : (k == LOBE_DIFFUSE_TRANSMISSION ? f.dt_pmf : f.lobe_pmf[k]);
}

// The frame of the geometric normal alone (BsdfFrame::new).
bool bsdf_frame_new(GpuMaterial m, vec3 ng, vec3 wo, out BsdfFrame f) {
    return bsdf_frame_new_shading(m, ng, ng, wo, f);
}

// Whether local wi lies on the same side of the geometric and the shading surface.
bool bsdf_consistent(BsdfFrame f, vec3 wi) {
    return (dot(wi, f.ng) > 0.0) == (wi.z > 0.0);
}

// |cos| between world-space wi and the shading normal (BsdfFrame::cos_theta).
float bsdf_frame_cos(BsdfFrame f, vec3 wi) {
    return abs(dot(wi, f.n));
}

vec3 bsdf_to_local(BsdfFrame f, vec3 v) {
    return vec3(dot(v, f.t), dot(v, f.b), dot(v, f.n));
}

vec3 bsdf_to_world(BsdfFrame f, vec3 v) {
    return f.t * v.x + f.b * v.y + f.n * v.z;
}

bool bsdf_is_delta(BsdfFrame f) {
    return f.alpha.x < ALPHA_DELTA;
}

// The transmission lobe is a delta where the reflection is and, through a volume's boundary,
// where |eta - 1| < ETA_DELTA: every microfacet then refracts within about |eta - 1|.alpha of
// straight through (BsdfFrame::transmission_is_delta).
#define ETA_DELTA 1e-3
bool bsdf_transmission_is_delta(BsdfFrame f) {
    return bsdf_is_delta(f) || (!f.thin && abs(f.etap - 1.0) < ETA_DELTA);
}

// A local direction mirrored through the surface plane (z negated).
vec3 bsdf_mirror(vec3 w) {
    return vec3(w.xy, -w.z);
}

// Generalised half vector of a refraction (Walter et al. 2007, eq. 16) on wo's side.
bool refraction_half_vector(BsdfFrame f, vec3 wi, out vec3 m) {
    m = normalize(f.wo + f.etap * wi);
    if (m.z < 0.0) m = -m;
    bool finite = !any(isnan(m)) && !any(isinf(m));
    return finite && dot(f.wo, m) > 0.0 && dot(wi, m) < 0.0;
}

// The sheen's albedo scaling of the layers below for a direction of cosine cos_i:
// min(1 - max(c) E(cos_o), 1 - max(c) E(cos_i)), at least 0; 1 without sheen.
float bsdf_sheen_scale(BsdfFrame f, float cos_i) {
    if (f.sheen_max <= 0.0) return 1.0;
    float e = sheen_albedo(cos_i, f.sheen_roughness);
    return min(f.sheen_scale_o, max(1.0 - f.sheen_max * e, 0.0));
}

// The thin-walled transmission lobe at local wi (wi.z < 0): the GGX reflection lobe mirrored
// through the surface, no refraction and no eta^2 (BsdfFrame::eval_thin_transmission).
vec3 bsdf_eval_thin_transmission(BsdfFrame f, vec3 wi) {
    vec3 wm = bsdf_mirror(wi);
    vec3 h = normalize(f.wo + wm);
    vec3 fd, fm;
    bsdf_fresnel(f, dot(f.wo, h), fd, fm);
    float ft = ggx_d(h, f.alpha) * ggx_visibility(f.wo, wm, f.alpha);
    return (1.0 - f.metallic) * f.transmission * (1.0 - max3(fd)) * ft * bsdf_sheen_scale(f, wi.z) * f.base;
}

// What the dielectric specular layer leaves to the layers below towards a direction of cosine
// cos_i: 1 - max(fd), or with energy compensation the albedo coupling (BsdfFrame::layers_below).
float bsdf_layers_below(BsdfFrame f, vec3 fd, float cos_i) {
    if (!f.compensated) return 1.0 - max3(fd);
    vec3 spec_i, spec_avg;
    specular_albedo(f.f0, f.f90, cos_i, f.table_r, spec_i, spec_avg);
    return albedo_coupling(f.spec_o, max3(spec_i), f.spec_avg);
}

// KHR_materials_diffuse_transmission's Lambertian lobe on the far side at local wi (wi.z < 0), F on
// the half vector of wo and wi mirrored to wo's side (BsdfFrame::eval_diffuse_transmission).
vec3 bsdf_eval_diffuse_transmission(BsdfFrame f, vec3 wi) {
    if (f.dt <= 0.0) return vec3(0.0);
    vec3 h = normalize(f.wo + vec3(wi.xy, -wi.z));
    vec3 fd = vec3(0.0), fm;
    if (!f.compensated) bsdf_fresnel(f, dot(f.wo, h), fd, fm);
    return (1.0 - f.metallic) * (1.0 - f.transmission) * f.dt * bsdf_layers_below(f, fd, wi.z) * INV_PI
         * bsdf_sheen_scale(f, wi.z) * f.dt_color;
}

// f of the non-delta lobes for local wi.
vec3 bsdf_eval_local(BsdfFrame f, vec3 wi, uint mode) {
    vec3 wo = f.wo;
    if (!bsdf_consistent(f, wi)) return vec3(0.0);
    float dielectric = 1.0 - f.metallic;
    if (wi.z > 0.0) {
        vec3 h = normalize(wo + wi);
        // Without a specular layer fd = 0: no Fresnel to evaluate and no reflection term.
        bool specular = !bsdf_specular_free(f);
        vec3 fd = vec3(0.0), fm = vec3(0.0);
        if (specular) bsdf_fresnel(f, dot(wo, h), fd, fm);
        vec3 value = dielectric * (1.0 - f.transmission) * (1.0 - f.dt) * bsdf_layers_below(f, fd, wi.z)
                   * INV_PI * f.base;
        if (specular && !bsdf_is_delta(f)) {
            float spec = ggx_d(h, f.alpha) * ggx_visibility(wo, wi, f.alpha);
            value += (dielectric * fd + f.metallic * fm) * spec;
            if (f.compensated) {
                vec2 e_i = ggx_albedo(wi.z, f.table_r);
                float ms = multiple_scattering(f.e_o, e_i.x + e_i.y, f.e_avg);
                value += (dielectric * f.fms_d + f.metallic * f.fms_m) * ms;
            }
        }
        if (f.sheen_max > 0.0) {
            value = value * bsdf_sheen_scale(f, wi.z)
                  + f.sheen_color * (charlie_d(h.z, f.sheen_alpha) * sheen_visibility(wo.z, wi.z, f.sheen_alpha));
        }
        return value;
    }
    if (wi.z < 0.0) {
        vec3 diffuse = bsdf_eval_diffuse_transmission(f, wi);
        if (f.transmission <= 0.0 || bsdf_transmission_is_delta(f)) return diffuse;
        if (f.thin) return diffuse + bsdf_eval_thin_transmission(f, wi);
        vec3 m;
        if (!refraction_half_vector(f, wi, m)) return diffuse;
        float om = dot(wo, m);
        float im = dot(wi, m);
        vec3 fd3, fm;
        bsdf_fresnel(f, om, fd3, fm);
        float fd = max3(fd3);
        float denom = f.etap * im + om;
        // Walter et al. 2007, eq. 21, for radiance (the 1/eta^2 of refraction included).
        float g2 = 4.0 * wo.z * abs(wi.z) * ggx_visibility(wo, wi, f.alpha);
        float ft = ggx_d(m, f.alpha) * g2 * abs(im * om) / (wo.z * abs(wi.z) * denom * denom);
        if (mode == TRANSPORT_IMPORTANCE) ft *= f.etap * f.etap;
        return diffuse + dielectric * f.transmission * (1.0 - fd) * ft * bsdf_sheen_scale(f, wi.z) * f.base;
    }
    return vec3(0.0);
}

// Solid-angle pdf of the non-delta lobes' mixture at local wi.
float bsdf_pdf_local(BsdfFrame f, vec3 wi) {
    vec3 wo = f.wo;
    if (!bsdf_consistent(f, wi)) return 0.0;
    if (wi.z > 0.0) {
        float pdf = f.lobe_pmf.x * cosine_hemisphere_pdf(wi.z);
        if (!bsdf_is_delta(f) && f.lobe_pmf.y > 0.0) {
            vec3 h = normalize(wo + wi);
            pdf += f.lobe_pmf.y * ggx_vndf_pdf(wo, h, f.alpha) / (4.0 * dot(wo, h));
        }
        if (f.sheen_pmf > 0.0) pdf += f.sheen_pmf * uniform_cone_pdf(0.0);
        return pdf;
    }
    if (wi.z < 0.0) {
        float diffuse = f.dt_pmf * cosine_hemisphere_pdf(-wi.z);
        if (bsdf_transmission_is_delta(f) || f.lobe_pmf.z <= 0.0) return diffuse;
        if (f.thin) {
            vec3 h = normalize(wo + bsdf_mirror(wi));
            return diffuse + f.lobe_pmf.z * ggx_vndf_pdf(wo, h, f.alpha) / (4.0 * dot(wo, h));
        }
        vec3 m;
        if (!refraction_half_vector(f, wi, m)) return diffuse;
        float denom = f.etap * dot(wi, m) + dot(wo, m);
        return diffuse + f.lobe_pmf.z * ggx_vndf_pdf(wo, m, f.alpha) * f.etap * f.etap * abs(dot(wi, m))
             / (denom * denom);
    }
    return 0.0;
}

// f.|cos| of delta lobe `lobe` at its one direction (local wi); false if there is none.
bool bsdf_delta_lobe(BsdfFrame f, uint lobe, uint mode, out vec3 wi, out vec3 value) {
    vec3 wo = f.wo;
    float dielectric = 1.0 - f.metallic;
    vec3 fd, fm;
    bsdf_fresnel(f, wo.z, fd, fm);
    if (lobe == LOBE_REFLECTION) {
        wi = vec3(-wo.x, -wo.y, wo.z);
        value = (dielectric * fd + f.metallic * fm) * bsdf_sheen_scale(f, wo.z);
        return true;
    }
    value = vec3(0.0);
    // Through a thin wall: straight on, no 1/eta^2 (nothing is entered).
    if (f.thin) {
        wi = -wo;
    } else if (!refract_through(wo, vec3(0.0, 0.0, 1.0), f.etap, wi)) {
        return false;
    }
    value = dielectric * f.transmission * (1.0 - max3(fd)) * bsdf_sheen_scale(f, wi.z) * f.base;
    if (mode == TRANSPORT_RADIANCE && !f.thin) value /= f.etap * f.etap;
    return true;
}

#include "clearcoat.glsl"

#include "lambert.glsl"

// f(wo, wi) of the non-delta lobes for world-space wi (BsdfFrame::eval).
vec3 bsdf_frame_eval(BsdfFrame f, vec3 wi, uint mode) {
    if (BSDF_PLAIN_PATH(f)) return bsdf_eval_plain(f, bsdf_to_local(f, wi));
    vec3 base = bsdf_eval_local(f, bsdf_to_local(f, wi), mode);
    if (f.clearcoat <= 0.0) return base;
    float wc = bsdf_cc_weight(f, wi, mode);
    return (1.0 - wc) * base + vec3(wc * bsdf_eval_clearcoat(f, wi, mode));
}

// The mixture pdf at world-space wi (BsdfFrame::pdf).
float bsdf_frame_pdf(BsdfFrame f, vec3 wi) {
    if (BSDF_PLAIN_PATH(f)) return bsdf_pdf_plain(f, bsdf_to_local(f, wi));
    float base = bsdf_pdf_local(f, bsdf_to_local(f, wi));
    if (f.clearcoat <= 0.0 || f.lobe_pmf.w <= 0.0) return base;
    return base + f.lobe_pmf.w * bsdf_pdf_clearcoat(f, wi);
}

// f of the non-delta lobes (without the cosine).
vec3 bsdf_eval(GpuMaterial m, vec3 ng, vec3 wo, vec3 wi, uint mode) {
    BsdfFrame f;
    if (!bsdf_frame_new(m, ng, wo, f)) return vec3(0.0);
    return bsdf_frame_eval(f, wi, mode);
}

// Pdf of bsdf_sample with respect to solid angle, over its non-delta lobes.
float bsdf_pdf(GpuMaterial m, vec3 ng, vec3 wo, vec3 wi) {
    BsdfFrame f;
    if (!bsdf_frame_new(m, ng, wo, f)) return 0.0;
    return bsdf_frame_pdf(f, wi);
}

// A non-delta sample at world wi: the mixture's pdf and f.|cos|/pdf there (BsdfFrame::weighed).
bool bsdf_weighed(BsdfFrame f, vec3 world, uint mode, out vec3 wi, out vec3 weight, out float pdf) {
    wi = world;
    weight = vec3(0.0);
    pdf = bsdf_frame_pdf(f, world);
    if (!(pdf > 0.0) || isinf(pdf)) return false;
    weight = bsdf_frame_eval(f, world, mode) * (bsdf_frame_cos(f, world) / pdf);
    return true;
}

// Samples wi from a frame (BsdfFrame::sample): u.z picks the lobe, u.xy the direction in it.
// Writes weight = f.|cos|/pdf, the pdf (a delta lobe: its probability) and whether the lobe is
// a delta; false if no direction.
bool bsdf_frame_sample(BsdfFrame f, vec3 u, uint mode,
                       out vec3 wi, out vec3 weight, out float pdf, out bool delta) {
    wi = vec3(0.0);
    weight = vec3(0.0);
    pdf = 0.0;
    delta = false;
    if (BSDF_PLAIN_PATH(f)) {
        // The diffuse lobe if it scatters anything, chosen whatever u.z; a direction on the
        // surface is no sample.
        if (!(f.lobe_pmf.x > 0.0)) return false;
        vec3 local = sample_cosine_hemisphere(u.xy);
        if (!(local.z > 0.0)) return false;
        return bsdf_weighed(f, bsdf_to_world(f, local), mode, wi, weight, pdf);
    }
    // The first lobe whose cumulative probability exceeds u.z (rounding past the last sum: the
    // last lobe that can be chosen).
    uint lobe = LOBE_COUNT;
    float cumulative = 0.0;
    for (uint k = 0u; k < LOBE_COUNT; k++) {
        float p = bsdf_lobe_pmf(f, k);
        if (p > 0.0) {
            lobe = k;
            cumulative += p;
            if (u.z < cumulative) break;
        }
    }
    if (lobe == LOBE_COUNT) return false;
    float lobe_p = bsdf_lobe_pmf(f, lobe);
    vec3 world;
    if (lobe == LOBE_CLEARCOAT) {
        vec3 wc = bsdf_cc_is_delta(f) ? vec3(-f.cc_wo.x, -f.cc_wo.y, f.cc_wo.z)
                : reflect_about(f.cc_wo, sample_ggx_vndf(f.cc_wo, f.cc_alpha, u.xy));
        world = f.cc_t * wc.x + f.cc_b * wc.y + f.cc_n * wc.z;
        if (wc.z <= 0.0 || dot(world, f.ng_world) <= 0.0) return false;
        if (bsdf_cc_is_delta(f)) {
            wi = world;
            weight = vec3(bsdf_cc_weight(f, world, mode) / lobe_p);
            pdf = lobe_p;
            delta = true;
            return true;
        }
    } else {
        vec3 local;
        if ((lobe == LOBE_REFLECTION && bsdf_is_delta(f))
            || (lobe == LOBE_TRANSMISSION && bsdf_transmission_is_delta(f))) {
            vec3 value;
            if (!bsdf_delta_lobe(f, lobe, mode, local, value) || !bsdf_consistent(f, local)) return false;
            wi = bsdf_to_world(f, local);
            float scale = f.clearcoat > 0.0 ? 1.0 - bsdf_cc_weight(f, wi, mode) : 1.0;
            weight = value * (scale / lobe_p);
            pdf = lobe_p;
            delta = true;
            return true;
        }
        if (lobe == LOBE_DIFFUSE) {
            local = sample_cosine_hemisphere(u.xy);
        } else if (lobe == LOBE_DIFFUSE_TRANSMISSION) {
            local = sample_cosine_hemisphere(u.xy) * vec3(1.0, 1.0, -1.0);
        } else if (lobe == LOBE_SHEEN) {
            local = sample_uniform_cone(u.xy, 0.0);
        } else if (lobe == LOBE_REFLECTION) {
            local = reflect_about(f.wo, sample_ggx_vndf(f.wo, f.alpha, u.xy));
        } else if (f.thin) {
            local = bsdf_mirror(reflect_about(f.wo, sample_ggx_vndf(f.wo, f.alpha, u.xy)));
        } else if (!refract_through(f.wo, sample_ggx_vndf(f.wo, f.alpha, u.xy), f.etap, local)) {
            return false;
        }
        // Each lobe keeps to its side (the mixture pdf counts each lobe only on its own side).
        bool reflects = lobe != LOBE_TRANSMISSION && lobe != LOBE_DIFFUSE_TRANSMISSION;
        if ((local.z > 0.0) != reflects || local.z == 0.0) return false;
        world = bsdf_to_world(f, local);
    }
    return bsdf_weighed(f, world, mode, wi, weight, pdf);
}

// bsdf_frame_sample for material m seen from wo.
bool bsdf_sample(GpuMaterial m, vec3 ng, vec3 wo, vec3 u, uint mode,
                 out vec3 wi, out vec3 weight, out float pdf, out bool delta) {
    BsdfFrame f;
    if (!bsdf_frame_new(m, ng, wo, f)) {
        wi = vec3(0.0);
        weight = vec3(0.0);
        pdf = 0.0;
        delta = false;
        return false;
    }
    return bsdf_frame_sample(f, u, mode, wi, weight, pdf, delta);
}

// Sum of the estimated lobe albedos seen from wo (--rr albedo's survival probability).
float bsdf_albedo_estimate(GpuMaterial m, vec3 ng, vec3 wo) {
    BsdfFrame f;
    if (!bsdf_frame_new(m, ng, wo, f)) return 0.0;
    return f.albedo_estimate;
}

#endif
