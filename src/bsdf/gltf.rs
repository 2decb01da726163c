//! The glTF 2.0 metallic-roughness BSDF of one vertex ([`BsdfFrame`]): the base's diffuse,
//! specular, metal, transmission, diffuse-transmission and sheen lobes, their evaluation, pdf and
//! sampling, and the clear coat layered on top (`clearcoat.rs`). Twin of `shaders/inc/bsdf.glsl`.

use super::energy::{
    albedo_coupling, fresnel_multiple, ggx_albedo, ggx_albedo_avg, multiple_scattering,
    specular_albedo, table_roughness,
};
use super::fresnel::{fresnel_coat, fresnel_layers, ThinFilm};
use super::lambert::LambertFrame;
use super::lobes::{
    average, no_specular_layer, BsdfSample, TransportMode, ETA_DELTA, LOBE_CLEARCOAT, LOBE_COUNT,
    LOBE_DIFFUSE, LOBE_DIFFUSE_TRANSMISSION, LOBE_REFLECTION, LOBE_SHEEN, LOBE_TRANSMISSION,
};
use super::microfacet::*;
use super::shading::{anisotropic_alpha, bend_shading_normal, Shading};
use super::sheen::{charlie_d, sheen_albedo, sheen_alpha, sheen_visibility};
use crate::layout::{GpuMaterial, MATERIAL_ENERGY_COMPENSATION};
use crate::sampling::{
    build_frame, cosine_hemisphere_pdf, sample_cosine_hemisphere, sample_uniform_cone,
    uniform_cone_pdf,
};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

/// A material seen from `wo`: the local frame with +Z on `wo`'s side, the relative index of
/// refraction and the lobe selection probabilities.
#[derive(Clone, Copy, Debug)]
pub struct BsdfFrame {
    pub(super) t: Vec3,
    pub(super) b: Vec3,
    pub(super) n: Vec3,
    /// `wo` in the local frame (z > 0).
    pub(super) wo: Vec3,
    pub(super) base: Vec3,
    pub(super) metallic: f32,
    pub(super) transmission: f32,
    /// GGX α along `t` and `b` ([`anisotropic_alpha`]).
    pub(super) alpha: Vec2,
    /// η on the far side / η on `wo`'s side (1 for opaque surfaces' geometry); ior from either
    /// side of a thin-walled surface.
    pub(super) etap: f32,
    /// A thin-walled transmissive surface (KHR_materials_transmission without
    /// KHR_materials_volume, or thicknessFactor 0): an infinitely thin shell that transmits
    /// without bending and bounds no medium ([`eval_thin_transmission`](Self::eval_thin_transmission)).
    pub(super) thin: bool,
    /// The dielectric Fresnel's RGB F0 ([`specular_f0`]) and F90 (specular).
    pub(super) f0: Vec3,
    pub(super) f90: f32,
    /// KHR_materials_iridescence's thin film over the base ([`fresnel_layers`]).
    pub(super) film: ThinFilm,
    /// KHR_materials_diffuse_transmission: its factor (0: none) and colour.
    pub(super) dt: f32,
    pub(super) dt_color: Vec3,
    /// Probabilities of choosing the diffuse, reflection, transmission, clearcoat and sheen
    /// lobes.
    pub lobe_pmf: [f32; LOBE_COUNT],
    /// Sum of the lobe albedo estimates (before normalising to `lobe_pmf`).
    pub albedo_estimate: f32,
    /// The geometric normal on `wo`'s side, in the local frame: a direction reflects or
    /// transmits by the side of the geometric surface it lies on.
    pub(super) ng: Vec3,
    /// The same in world space.
    pub(super) ng_world: Vec3,
    /// The clearcoat layer: its weight (0: none), α, world frame about N_c (on `wo`'s side) and
    /// `wo` in that frame.
    pub(super) clearcoat: f32,
    pub(super) cc_alpha: Vec2,
    pub(super) cc_t: Vec3,
    pub(super) cc_b: Vec3,
    pub(super) cc_n: Vec3,
    pub(super) cc_wo: Vec3,
    /// The sheen layer: its colour, max component (0: none), α and roughness (the albedo
    /// table's axis), and the scaling 1 − max(colour)·E(cos θo) of the layers below.
    pub(super) sheen_color: Vec3,
    pub(super) sheen_max: f32,
    pub(super) sheen_alpha: f32,
    pub(super) sheen_roughness: f32,
    pub(super) sheen_scale_o: f32,
    /// A plain diffuse surface: no metal, specular layer, thin film, transmission, diffuse
    /// transmission, sheen or coat, so Lambert's lobe alone (`lobe_pmf` 1 for it and 0 for the
    /// others; all 0 where the base colour is black or the surface unlit).
    /// [`eval`](Self::eval), [`pdf`](Self::pdf) and [`sample`](Self::sample) then take the
    /// diffuse lobe's terms alone: the same floats as the general path, whose other terms are
    /// each an exact 0 added or an exact 1 multiplied (test
    /// `plain_diffuse_frames_equal_the_general_path`). A Lambertian scene (the Cornell box
    /// Mitsuba renders with its `diffuse` BSDF) spends much of a vertex in the BSDF otherwise.
    pub(super) plain: bool,
    /// Energy compensation (`energy.rs`): on where the material asks for it and the base has a
    /// specular layer with Schlick's Fresnel outside a volume; the table roughness, the white
    /// lobe's E(μo) and E_avg, F_ms of the dielectric and the metal lobes, and the dielectric
    /// specular layer's albedo Ê(μo) and Ê_avg (its largest channel) for the coupling.
    pub(super) compensated: bool,
    pub(super) table_r: f32,
    pub(super) e_o: f32,
    pub(super) e_avg: f32,
    pub(super) fms_d: Vec3,
    pub(super) fms_m: Vec3,
    pub(super) spec_o: f32,
    pub(super) spec_avg: f32,
}

impl BsdfFrame {
    /// The frame of the geometric normal (no shading normal). None where `wo` lies in the
    /// surface's plane (no light leaves along it).
    pub fn new(m: &GpuMaterial, ng: Vec3, wo: Vec3) -> Option<BsdfFrame> {
        BsdfFrame::new_shading(m, ng, ng, wo)
    }

    /// The frame of shading normal `ns` (unit, either side), flipped with the geometric normal
    /// `ng` to `wo`'s side and bent by [`bend_shading_normal`]. The BSDF is evaluated in it,
    /// but whether a direction reflects or transmits is decided by the geometric surface, and
    /// where the two disagree the BSDF is zero, so no light leaks through a surface whose
    /// shading normal tilts over its horizon (Veach 1997, §5.3; pbrt-v3 §9.1).
    pub fn new_shading(m: &GpuMaterial, ng: Vec3, ns: Vec3, wo: Vec3) -> Option<BsdfFrame> {
        let Shading {
            cos_g,
            front,
            ng_wo,
            n,
            t,
            b,
            ng_local,
            unlit,
            anisotropy,
        } = Shading::new(m, ng, ns, wo)?;
        let wo_local = Vec3::new(
            wo.dot(t),
            wo.dot(b),
            if ns == ng { cos_g.abs() } else { wo.dot(n) },
        );
        // An unlit surface scatters nothing: every lobe's weight is 0.
        let transmission = if m.metallic < 1.0 && !unlit {
            m.transmission
        } else {
            0.0
        };
        let ior = m.ior.max(1.0);
        // glTF's default is thin-walled: only a volume (thicknessFactor > 0) makes the mesh the
        // boundary of a medium of index ior (KHR_materials_volume, "Overview").
        let thin = transmission > 0.0 && m.thickness <= 0.0;
        let etap = if transmission > 0.0 && !front && !thin {
            1.0 / ior
        } else {
            ior
        };
        let (base, metallic, specular) = if unlit {
            (Vec3::ZERO, 0.0, 0.0)
        } else {
            (Vec3::from(m.base_color), m.metallic, m.specular)
        };
        let f0 = specular_f0(m.ior, Vec3::from(m.specular_color), specular);
        let f90 = specular;
        let film = ThinFilm {
            factor: if unlit { 0.0 } else { m.iridescence },
            ior: m.iridescence_ior,
            thickness: m.iridescence_thickness,
        };
        // Lobe albedo estimates at the macro normal (Fresnel at cos θo). Without a specular
        // layer fe = 0 (see `specular_free`) and fm has the factor metallic = 0: both terms 0.
        let specular_free = no_specular_layer(metallic, f0, f90, &film, etap);
        let (fe, fm) = if specular_free {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            fresnel_layers(wo_local.z, f0, f90, etap, base, metallic, &film)
        };
        let fm = average(fm);
        let dielectric = 1.0 - metallic;
        let dt = if unlit { 0.0 } else { m.diffuse_transmission };
        let dt_color = Vec3::from(m.diffuse_transmission_color);
        let diffuse = dielectric * (1.0 - transmission) * (1.0 - fe.max_element());
        let mut w = [
            diffuse * (1.0 - dt) * average(base),
            dielectric * average(fe) + metallic * fm,
            dielectric * transmission * (1.0 - fe.max_element()) * average(base),
            0.0,
            0.0,
            diffuse * dt * average(dt_color),
        ];
        // The sheen: its albedo E(cos θo) taken from the layers below (albedo scaling).
        let sheen_color = if unlit {
            Vec3::ZERO
        } else {
            Vec3::from(m.sheen_color)
        };
        let sheen_max = sheen_color.max_element();
        let mut sheen_scale_o = 1.0;
        if sheen_max > 0.0 {
            let e = sheen_albedo(wo_local.z, m.sheen_roughness);
            sheen_scale_o = (1.0 - sheen_max * e).max(0.0);
            for k in [0, 1, 2, LOBE_DIFFUSE_TRANSMISSION] {
                w[k] *= sheen_scale_o;
            }
            w[LOBE_SHEEN] = average(sheen_color) * e;
        }
        // The coat: its frame about N_c (the base's normal unless the hit gave its own), and
        // its weight clearcoat · F_c(wo·N_c) taken from the base lobes' estimates.
        let clearcoat = if unlit { 0.0 } else { m.clearcoat };
        let (mut cc_t, mut cc_b, mut cc_n, mut cc_wo) = (t, b, n, wo_local);
        if clearcoat > 0.0 {
            let nc = Vec3::from(m.clearcoat_normal);
            if nc != Vec3::ZERO {
                cc_n = bend_shading_normal(if front { nc } else { -nc }, ng_wo, wo);
                (cc_t, cc_b) = build_frame(cc_n);
                cc_wo = Vec3::new(wo.dot(cc_t), wo.dot(cc_b), wo.dot(cc_n));
            }
            let wc = clearcoat * fresnel_coat(cc_wo.z);
            for k in [0, 1, 2, LOBE_DIFFUSE_TRANSMISSION] {
                w[k] *= 1.0 - wc;
            }
            w[LOBE_SHEEN] *= 1.0 - wc;
            w[LOBE_CLEARCOAT] = wc;
        }
        let total = w.iter().sum::<f32>();
        let lobe_pmf = if total > 0.0 {
            w.map(|x| x / total)
        } else {
            [0.0; LOBE_COUNT]
        };
        let plain = specular_free
            && transmission == 0.0
            && dt == 0.0
            && sheen_max <= 0.0
            && clearcoat <= 0.0;
        let alpha = anisotropic_alpha(m.roughness * m.roughness, anisotropy);
        let compensated = m.flags & MATERIAL_ENERGY_COMPENSATION != 0
            && !unlit
            && !specular_free
            && film.factor <= 0.0
            && etap >= 1.0;
        let (mut table_r, mut e_o, mut e_avg) = (0.0, 1.0, 1.0);
        let (mut fms_d, mut fms_m) = (Vec3::ZERO, Vec3::ZERO);
        let (mut spec_o, mut spec_avg) = (0.0, 0.0);
        if compensated {
            table_r = table_roughness(alpha);
            let ab = ggx_albedo(wo_local.z, table_r);
            let avg = ggx_albedo_avg(table_r);
            (e_o, e_avg) = (ab.x + ab.y, avg.x + avg.y);
            fms_d = fresnel_multiple(f0, f90, e_avg);
            fms_m = fresnel_multiple(base, 1.0, e_avg);
            let (o, a) = specular_albedo(f0, f90, wo_local.z, table_r);
            (spec_o, spec_avg) = (o.max_element(), a.max_element());
        }
        Some(BsdfFrame {
            t,
            b,
            n,
            wo: wo_local,
            base,
            metallic,
            transmission,
            alpha,
            etap,
            thin,
            f0,
            f90,
            film,
            dt,
            dt_color,
            lobe_pmf,
            albedo_estimate: total,
            ng: ng_local,
            ng_world: ng_wo,
            clearcoat,
            cc_alpha: Vec2::splat(m.clearcoat_roughness * m.clearcoat_roughness),
            cc_t,
            cc_b,
            cc_n,
            cc_wo,
            sheen_color,
            sheen_max,
            sheen_alpha: sheen_alpha(m.sheen_roughness),
            sheen_roughness: m.sheen_roughness,
            sheen_scale_o,
            plain,
            compensated,
            table_r,
            e_o,
            e_avg,
            fms_d,
            fms_m,
            spec_o,
            spec_avg,
        })
    }

    /// A [`plain`](Self::plain) frame as the [`LambertFrame`] it is: its eval, pdf and sample
    /// are [`eval_local`](Self::eval_local)'s, [`pdf_local`](Self::pdf_local)'s and the diffuse
    /// lobe's sample with their zero terms left out.
    pub(super) fn lambert(&self) -> LambertFrame {
        LambertFrame {
            t: self.t,
            b: self.b,
            n: self.n,
            ng: self.ng,
            base: self.base,
            pmf: self.lobe_pmf[LOBE_DIFFUSE],
            albedo_estimate: self.albedo_estimate,
        }
    }

    /// Whether local `wi` lies on the same side of the geometric and the shading surface.
    pub(super) fn consistent(&self, wi: Vec3) -> bool {
        (wi.dot(self.ng) > 0.0) == (wi.z > 0.0)
    }

    /// |cos| between world-space `wi` and the shading normal: the cosine of the rendering
    /// equation.
    pub fn cos_theta(&self, wi: Vec3) -> f32 {
        wi.dot(self.n).abs()
    }

    pub(super) fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    pub(super) fn to_world(&self, v: Vec3) -> Vec3 {
        self.t * v.x + self.b * v.y + self.n * v.z
    }

    /// No specular layer: a dielectric with KHR_materials_specular's factor 0 (F0 = F90 = 0),
    /// no metal, no thin film and no total internal reflection (η ≥ 1) has fd = 0 at every
    /// angle, so its reflection term is 0 and its diffuse lobe keeps all of 1 − max(fd);
    /// [`eval_local`](Self::eval_local) skips the Fresnel and the reflection term (the same value
    /// bit for bit: x + 0 = x).
    pub(super) fn specular_free(&self) -> bool {
        no_specular_layer(self.metallic, self.f0, self.f90, &self.film, self.etap)
    }

    pub(super) fn is_delta(&self) -> bool {
        self.alpha.x < ALPHA_DELTA
    }

    /// Whether the transmission lobe is a delta: where the reflection is, and where the two
    /// sides' indices match, |η − 1| < [`ETA_DELTA`]: the generalised half vector of wo and a
    /// direction wi is ∝ wo + η·wi (Walter et al. 2007, eq. 16), so every microfacet refracts
    /// within about |η − 1|·α of straight through, whatever the roughness (an ior of 1 passes
    /// a sharp image, as KHR_materials_transmission's TransmissionRoughnessTest shows).
    /// A thin-walled surface's transmission is a delta only where its reflection is.
    pub(super) fn transmission_is_delta(&self) -> bool {
        self.is_delta() || (!self.thin && (self.etap - 1.0).abs() < ETA_DELTA)
    }

    /// The generalised half vector of a refraction (Walter et al. 2007, eq. 16), on `wo`'s side;
    /// None if wo and wi do not lie on the sides of it that refraction requires.
    pub(super) fn refraction_half_vector(&self, wi: Vec3) -> Option<Vec3> {
        let mut m = (self.wo + self.etap * wi).normalize();
        if m.z < 0.0 {
            m = -m;
        }
        (m.is_finite() && self.wo.dot(m) > 0.0 && wi.dot(m) < 0.0).then_some(m)
    }

    /// The dielectric and metal Fresnel terms at cosine `cos` ([`fresnel_layers`]).
    pub(super) fn fresnel(&self, cos: f32) -> (Vec3, Vec3) {
        fresnel_layers(
            cos,
            self.f0,
            self.f90,
            self.etap,
            self.base,
            self.metallic,
            &self.film,
        )
    }

    /// f of the non-delta lobes for local `wi`.
    pub(super) fn eval_local(&self, wi: Vec3, mode: TransportMode) -> Vec3 {
        let wo = self.wo;
        if !self.consistent(wi) {
            return Vec3::ZERO;
        }
        let dielectric = 1.0 - self.metallic;
        if wi.z > 0.0 {
            let h = (wo + wi).normalize();
            // Without a specular layer fd = 0: no Fresnel to evaluate and no reflection term.
            let specular = !self.specular_free();
            let (fd, fm) = if specular {
                self.fresnel(wo.dot(h))
            } else {
                (Vec3::ZERO, Vec3::ZERO)
            };
            let mut f = dielectric
                * (1.0 - self.transmission)
                * (1.0 - self.dt)
                * self.layers_below(fd, wi.z)
                * FRAC_1_PI
                * self.base;
            if specular && !self.is_delta() {
                let spec = ggx_d(h, self.alpha) * ggx_visibility(wo, wi, self.alpha);
                f += (dielectric * fd + self.metallic * fm) * spec;
                if self.compensated {
                    let e_i = ggx_albedo(wi.z, self.table_r);
                    let ms = multiple_scattering(self.e_o, e_i.x + e_i.y, self.e_avg);
                    f += (dielectric * self.fms_d + self.metallic * self.fms_m) * ms;
                }
            }
            if self.sheen_max > 0.0 {
                f = f * self.sheen_scale(wi.z)
                    + self.sheen_color
                        * (charlie_d(h.z, self.sheen_alpha)
                            * sheen_visibility(wo.z, wi.z, self.sheen_alpha));
            }
            f
        } else if wi.z < 0.0 {
            let diffuse = self.eval_diffuse_transmission(wi);
            if self.transmission <= 0.0 || self.transmission_is_delta() {
                return diffuse;
            }
            if self.thin {
                return diffuse + self.eval_thin_transmission(wi);
            }
            let Some(m) = self.refraction_half_vector(wi) else {
                return diffuse;
            };
            let (om, im) = (wo.dot(m), wi.dot(m));
            let fd = self.fresnel(om).0.max_element();
            let denom = self.etap * im + om;
            // Walter et al. 2007, eq. 21, for radiance (the 1/η² of refraction included).
            let g2 = 4.0 * wo.z * wi.z.abs() * ggx_visibility(wo, wi, self.alpha);
            let mut ft =
                ggx_d(m, self.alpha) * g2 * (im * om).abs() / (wo.z * wi.z.abs() * denom * denom);
            if mode == TransportMode::Importance {
                ft *= self.etap * self.etap;
            }
            diffuse
                + dielectric
                    * self.transmission
                    * (1.0 - fd)
                    * ft
                    * self.sheen_scale(wi.z)
                    * self.base
        } else {
            Vec3::ZERO
        }
    }

    /// The thin-walled transmission lobe at local `wi` (wi.z < 0): the GGX reflection lobe
    /// mirrored through the surface, dielectric · transmission · (1 − max F(wo·h)) · D(h) ·
    /// V(wo, wi') · c with wi' = `wi` mirrored to `wo`'s side and h the half vector of wo and
    /// wi' (KHR_materials_transmission, "Thin-walled": the light passes the shell without
    /// bending; roughness blurs it about the straight-through −wo). No refraction, so no η²:
    /// symmetric in wo and wi, and the same in both transport modes.
    pub(super) fn eval_thin_transmission(&self, wi: Vec3) -> Vec3 {
        let (wo, wm) = (self.wo, mirror(wi));
        let h = (wo + wm).normalize();
        let fd = self.fresnel(wo.dot(h)).0.max_element();
        let ft = ggx_d(h, self.alpha) * ggx_visibility(wo, wm, self.alpha);
        (1.0 - self.metallic)
            * self.transmission
            * (1.0 - fd)
            * ft
            * self.sheen_scale(wi.z)
            * self.base
    }

    /// KHR_materials_diffuse_transmission's Lambertian lobe on the far side at local `wi`
    /// (wi.z < 0): (1 − metallic)(1 − transmission)·dt·(1 − max F)·dtColor/π, F on the half
    /// vector of `wo` and `wi` mirrored to `wo`'s side (symmetric in the two, as the thin
    /// surface is), under the sheen's scaling.
    pub(super) fn eval_diffuse_transmission(&self, wi: Vec3) -> Vec3 {
        if self.dt <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (self.wo + Vec3::new(wi.x, wi.y, -wi.z)).normalize();
        let fd = if self.compensated {
            Vec3::ZERO
        } else {
            self.fresnel(self.wo.dot(h)).0
        };
        (1.0 - self.metallic)
            * (1.0 - self.transmission)
            * self.dt
            * self.layers_below(fd, wi.z)
            * FRAC_1_PI
            * self.sheen_scale(wi.z)
            * self.dt_color
    }

    /// Solid-angle pdf of the non-delta lobes' mixture at local `wi`.
    pub(super) fn pdf_local(&self, wi: Vec3) -> f32 {
        let wo = self.wo;
        if !self.consistent(wi) {
            return 0.0;
        }
        let [p_diffuse, p_reflection, p_transmission, _, p_sheen, p_dt] = self.lobe_pmf;
        if wi.z > 0.0 {
            let mut pdf = p_diffuse * cosine_hemisphere_pdf(wi.z);
            if !self.is_delta() && p_reflection > 0.0 {
                let h = (wo + wi).normalize();
                // dω_h/dω_i = 1 / (4 |wo·h|) (Walter et al. 2007, eq. 14).
                pdf += p_reflection * ggx_vndf_pdf(wo, h, self.alpha) / (4.0 * wo.dot(h));
            }
            if p_sheen > 0.0 {
                pdf += p_sheen * uniform_cone_pdf(0.0);
            }
            pdf
        } else if wi.z < 0.0 {
            let diffuse = p_dt * cosine_hemisphere_pdf(-wi.z);
            if self.transmission_is_delta() || p_transmission <= 0.0 {
                return diffuse;
            }
            if self.thin {
                let h = (wo + mirror(wi)).normalize();
                return diffuse
                    + p_transmission * ggx_vndf_pdf(wo, h, self.alpha) / (4.0 * wo.dot(h));
            }
            let Some(m) = self.refraction_half_vector(wi) else {
                return diffuse;
            };
            let denom = self.etap * wi.dot(m) + wo.dot(m);
            // dω_m/dω_i = η² |wi·m| / (wo·m + η wi·m)² (Walter et al. 2007, eq. 17).
            diffuse
                + p_transmission
                    * ggx_vndf_pdf(wo, m, self.alpha)
                    * self.etap
                    * self.etap
                    * wi.dot(m).abs()
                    / (denom * denom)
        } else {
            0.0
        }
    }

    /// f·|cos| of the delta lobe `lobe` at its one direction, and that direction.
    pub(super) fn delta_lobe(&self, lobe: usize, mode: TransportMode) -> Option<(Vec3, Vec3)> {
        let wo = self.wo;
        let dielectric = 1.0 - self.metallic;
        let (fd, fm) = self.fresnel(wo.z);
        if lobe == LOBE_REFLECTION {
            let value = dielectric * fd + self.metallic * fm;
            Some((
                Vec3::new(-wo.x, -wo.y, wo.z),
                value * self.sheen_scale(wo.z),
            ))
        } else {
            // Through a thin wall: straight on, no 1/η² (nothing is entered).
            let wi = if self.thin {
                -wo
            } else {
                refract_through(wo, Vec3::Z, self.etap)?
            };
            let mut value = dielectric
                * self.transmission
                * (1.0 - fd.max_element())
                * self.sheen_scale(wi.z)
                * self.base;
            if mode == TransportMode::Radiance && !self.thin {
                value /= self.etap * self.etap;
            }
            Some((wi, value))
        }
    }

    /// What the dielectric specular layer leaves to the layers below it (diffuse, diffuse
    /// transmission) towards a direction of cosine `cos_i`: the specification's 1 − max(F),
    /// `fd` on the half vector, or with energy compensation the albedo coupling
    /// (1 − Ê(μo))(1 − Ê(μi)) / (1 − Ê_avg) (`energy.rs`).
    pub(super) fn layers_below(&self, fd: Vec3, cos_i: f32) -> f32 {
        if !self.compensated {
            return 1.0 - fd.max_element();
        }
        let (spec_i, _) = specular_albedo(self.f0, self.f90, cos_i, self.table_r);
        albedo_coupling(self.spec_o, spec_i.max_element(), self.spec_avg)
    }

    /// The sheen's albedo scaling of the layers below for a direction of cosine `cos_i`:
    /// min(1 − max(sheenColor)·E(cos θo), 1 − max(sheenColor)·E(cos θi)), at least 0; 1 without
    /// sheen.
    pub(super) fn sheen_scale(&self, cos_i: f32) -> f32 {
        if self.sheen_max <= 0.0 {
            return 1.0;
        }
        let e = sheen_albedo(cos_i, self.sheen_roughness);
        self.sheen_scale_o.min((1.0 - self.sheen_max * e).max(0.0))
    }

    /// f(wo, wi) of the non-delta lobes for world-space `wi` ([`bsdf_eval`] with this frame).
    pub fn eval(&self, wi: Vec3, mode: TransportMode) -> Vec3 {
        if self.plain {
            return self.lambert().eval(wi);
        }
        let base = self.eval_local(self.to_local(wi), mode);
        if self.clearcoat <= 0.0 {
            return base;
        }
        let wc = self.cc_weight(wi, mode);
        (1.0 - wc) * base + Vec3::splat(wc * self.eval_clearcoat(wi, mode))
    }

    /// The mixture pdf at world-space `wi` ([`bsdf_pdf`] with this frame).
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if self.plain {
            return self.lambert().pdf(wi);
        }
        let base = self.pdf_local(self.to_local(wi));
        if self.clearcoat <= 0.0 || self.lobe_pmf[LOBE_CLEARCOAT] <= 0.0 {
            return base;
        }
        base + self.lobe_pmf[LOBE_CLEARCOAT] * self.pdf_clearcoat(wi)
    }

    /// Samples one lobe with `u.z`, then a direction in it with `u.xy` ([`bsdf_sample`]).
    pub fn sample(&self, u: Vec3, mode: TransportMode) -> Option<BsdfSample> {
        if self.plain {
            return self.lambert().sample(u);
        }
        // The first lobe whose cumulative probability exceeds u.z (rounding past the last
        // sum: the last lobe that can be chosen).
        let (mut lobe, mut cumulative) = (LOBE_COUNT, 0.0);
        for (i, &p) in self.lobe_pmf.iter().enumerate() {
            if p > 0.0 {
                lobe = i;
                cumulative += p;
                if u.z < cumulative {
                    break;
                }
            }
        }
        if lobe == LOBE_COUNT {
            return None;
        }
        let lobe_p = self.lobe_pmf[lobe];
        let uv = Vec2::new(u.x, u.y);
        let world = if lobe == LOBE_CLEARCOAT {
            let wc = if self.cc_is_delta() {
                Vec3::new(-self.cc_wo.x, -self.cc_wo.y, self.cc_wo.z)
            } else {
                reflect_about(self.cc_wo, sample_ggx_vndf(self.cc_wo, self.cc_alpha, uv))
            };
            let wi = self.cc_t * wc.x + self.cc_b * wc.y + self.cc_n * wc.z;
            if wc.z <= 0.0 || wi.dot(self.ng_world) <= 0.0 {
                return None;
            }
            if self.cc_is_delta() {
                // The mirror about N_c: f·|cos| = clearcoat · F_c, the same V·N_c either way.
                return Some(BsdfSample {
                    wi,
                    weight: Vec3::splat(self.cc_weight(wi, mode) / lobe_p),
                    pdf: lobe_p,
                    delta: true,
                });
            }
            wi
        } else {
            let delta = match lobe {
                LOBE_REFLECTION => self.is_delta(),
                LOBE_TRANSMISSION => self.transmission_is_delta(),
                _ => false,
            };
            if delta {
                let (wi, value) = self.delta_lobe(lobe, mode)?;
                if !self.consistent(wi) {
                    return None;
                }
                let world = self.to_world(wi);
                let scale = if self.clearcoat > 0.0 {
                    1.0 - self.cc_weight(world, mode)
                } else {
                    1.0
                };
                return Some(BsdfSample {
                    wi: world,
                    weight: value * (scale / lobe_p),
                    pdf: lobe_p,
                    delta: true,
                });
            }
            let wi = match lobe {
                LOBE_DIFFUSE => sample_cosine_hemisphere(uv),
                LOBE_DIFFUSE_TRANSMISSION => {
                    sample_cosine_hemisphere(uv) * Vec3::new(1.0, 1.0, -1.0)
                }
                // Charlie has no closed-form sampler: uniform directions, as Conty Estevez &
                // Kulla 2017 suggest (the lobe peaks towards grazing, where cosine sampling is
                // sparse).
                LOBE_SHEEN => sample_uniform_cone(uv, 0.0),
                LOBE_REFLECTION => reflect_about(self.wo, sample_ggx_vndf(self.wo, self.alpha, uv)),
                _ if self.thin => mirror(reflect_about(
                    self.wo,
                    sample_ggx_vndf(self.wo, self.alpha, uv),
                )),
                _ => refract_through(self.wo, sample_ggx_vndf(self.wo, self.alpha, uv), self.etap)?,
            };
            // Each lobe keeps to its side: a reflection below or a refraction above the surface
            // is no sample (the mixture pdf counts each lobe only on its own side).
            let reflects = lobe != LOBE_TRANSMISSION && lobe != LOBE_DIFFUSE_TRANSMISSION;
            if (wi.z > 0.0) != reflects || wi.z == 0.0 {
                return None;
            }
            self.to_world(wi)
        };
        self.weighed(world, mode)
    }

    /// A non-delta sample at world-space `wi`: the mixture's pdf and f·|cos|/pdf there.
    pub(super) fn weighed(&self, wi: Vec3, mode: TransportMode) -> Option<BsdfSample> {
        let pdf = self.pdf(wi);
        if pdf.is_nan() || pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.eval(wi, mode) * (self.cos_theta(wi) / pdf),
            pdf,
            delta: false,
        })
    }
}

/// A local direction mirrored through the surface plane (z negated).
fn mirror(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

/// f(wo, wi) of the non-delta lobes (without the cosine).
pub fn bsdf_eval(m: &GpuMaterial, ng: Vec3, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
    match BsdfFrame::new(m, ng, wo) {
        Some(frame) => frame.eval(wi, mode),
        None => Vec3::ZERO,
    }
}

/// Pdf of [`bsdf_sample`] with respect to solid angle, over its non-delta lobes.
pub fn bsdf_pdf(m: &GpuMaterial, ng: Vec3, wo: Vec3, wi: Vec3) -> f32 {
    match BsdfFrame::new(m, ng, wo) {
        Some(frame) => frame.pdf(wi),
        None => 0.0,
    }
}

/// Samples `wi` from three uniform numbers: `u.z` picks the lobe, `u.xy` the direction in it.
/// None if no direction results (a black material, total internal reflection of the sampled
/// microfacet, a direction below the surface).
pub fn bsdf_sample(
    m: &GpuMaterial,
    ng: Vec3,
    wo: Vec3,
    u: Vec3,
    mode: TransportMode,
) -> Option<BsdfSample> {
    BsdfFrame::new(m, ng, wo)?.sample(u, mode)
}

/// Sum of the estimated lobe albedos seen from `wo` (the lecture's subcritical survival
/// probability P = ∫K for `--rr albedo`); 0 where `wo` grazes the surface.
pub fn bsdf_albedo_estimate(m: &GpuMaterial, ng: Vec3, wo: Vec3) -> f32 {
    BsdfFrame::new(m, ng, wo).map_or(0.0, |f| f.albedo_estimate)
}
