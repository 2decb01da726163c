//! `--sky`: a physical daylight sky and sun for a given sun position and turbidity.
//!
//! - **The sky** is the analytic model of Preetham, Shirley & Smits 1999 ("A Practical Analytic
//!   Model for Daylight", SIGGRAPH, Appendix A.2): luminance Y and chromaticity x, y each the
//!   zenith value times the Perez distribution F(θ, γ) / F(0, θs), F = (1 + A e^{B/cos θ})
//!   (1 + C e^{Dγ} + E cos²γ), with the paper's coefficients linear in turbidity T and its
//!   zenith formulas; xyY → XYZ → linear Rec. 709. Below the horizon lies a grey Lambertian
//!   ground of albedo [`GROUND_ALBEDO`] lit by the sky and the sun.
//! - **The sun** is a directional light (`KHR_lights_punctual`'s kind, reached by next event
//!   estimation only, so it is not seen directly nor in a perfect mirror): the extraterrestrial
//!   illuminance [`SOLAR_ILLUMINANCE_KLX`], white, attenuated along the air mass of Kasten &
//!   Young 1989 by Rayleigh scattering (optical depth 0.008735 λ^−4.08, Leckner 1978) and
//!   aerosols (Ångström: β λ^−1.3, β = 0.04608 T − 0.04586, Preetham 1999 Appendix A.1) at
//!   680, 550 and 440 nm for R, G and B. Ozone and water vapour are left out.
//! - **Units**: photometric, divided by [`UNIT_KCD`]: a radiance of 1 is 30 kcd/m², an
//!   irradiance of 1 is 30 klx, chosen so that an upward white plane under the default sun
//!   shows about 0.9, as under the studio (light grey, not clipped, at exposure 0).
//!
//! The sky is written into an ordinary equirectangular map as the studio is (`studio.rs`), so
//! the CPU and the GPU look it up and importance-sample it as any `.hdr`; the sun is an ordinary
//! punctual light. Preetham's model is used rather than Hosek & Wilkie 2012 or the Prague
//! model: theirs are fitted datasets (thousands of coefficients) that would have to be copied
//! from their reference code, where Preetham's coefficients are printed in the paper.
//!
//! Frame: +Y up; the sun's azimuth is measured about +Y from +Z (where a default camera stands,
//! so 0° lights the side of a model it sees) towards +X (the camera's right).

use super::environment::EnvironmentMap;
use super::studio::texel_direction;
use crate::layout::{GpuPunctualLight, LIGHT_DIRECTIONAL};
use anyhow::{bail, Result};
use glam::{DVec3, Vec3};
use std::f64::consts::PI;
use std::sync::Arc;

/// The map's size in texels (0.7° a texel; the sky is smooth, the sun is not in it).
pub const SKY_WIDTH: u32 = 512;
pub const SKY_HEIGHT: u32 = 256;
/// The ground's albedo (grey).
pub const GROUND_ALBEDO: f64 = 0.2;
/// Solar illuminance outside the atmosphere, klx (Darula, Kittler & Gueymard 2005: 128 klx).
pub const SOLAR_ILLUMINANCE_KLX: f64 = 128.0;
/// kcd/m² (and klx) per renderer unit.
pub const UNIT_KCD: f64 = 30.0;
/// Wavelengths (µm) the sun's transmittance is taken at for R, G and B.
const WAVELENGTHS_UM: [f64; 3] = [0.680, 0.550, 0.440];

/// Where the sun stands and how hazy the air is.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyParams {
    /// Degrees above the horizon, 0 to 90.
    pub sun_elevation: f32,
    /// Degrees about +Y from +Z towards +X.
    pub sun_azimuth: f32,
    /// Atmospheric turbidity, 2 (very clear) to 10 (hazy), the range Preetham's fit covers.
    pub turbidity: f32,
}

impl Default for SkyParams {
    fn default() -> Self {
        SkyParams {
            sun_elevation: 45.0,
            sun_azimuth: 30.0,
            turbidity: 3.0,
        }
    }
}

impl SkyParams {
    /// The unit direction towards the sun.
    pub fn sun_direction(&self) -> DVec3 {
        let (e, a) = (
            (self.sun_elevation as f64).to_radians(),
            (self.sun_azimuth as f64).to_radians(),
        );
        DVec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
    }

    fn check(&self) -> Result<()> {
        if !(0.0..=90.0).contains(&self.sun_elevation) {
            bail!(
                "--sun-elevation {}: the sky model holds for a sun from 0° (on the horizon) to 90°",
                self.sun_elevation
            );
        }
        if !self.sun_azimuth.is_finite() {
            bail!(
                "--sun-azimuth {}: expected a finite angle",
                self.sun_azimuth
            );
        }
        if !(2.0..=10.0).contains(&self.turbidity) {
            bail!(
                "--turbidity {}: the sky model holds from 2 (very clear) to 10 (hazy)",
                self.turbidity
            );
        }
        Ok(())
    }
}

/// The Perez distribution F(θ, γ) with coefficients `c` = (A, B, C, D, E) (Perez et al. 1993).
fn perez(c: [f64; 5], cos_theta: f64, gamma: f64) -> f64 {
    let [a, b, cc, d, e] = c;
    (1.0 + a * (b / cos_theta.max(1e-3)).exp())
        * (1.0 + cc * (d * gamma).exp() + e * gamma.cos().powi(2))
}

/// Preetham 1999, Appendix A.2: the Perez coefficients of Y, x and y at turbidity `t`.
fn coefficients(t: f64) -> [[f64; 5]; 3] {
    [
        [
            0.1787 * t - 1.4630,
            -0.3554 * t + 0.4275,
            -0.0227 * t + 5.3251,
            0.1206 * t - 2.5771,
            -0.0670 * t + 0.3703,
        ],
        [
            -0.0193 * t - 0.2592,
            -0.0665 * t + 0.0008,
            -0.0004 * t + 0.2125,
            -0.0641 * t - 0.8989,
            -0.0033 * t + 0.0452,
        ],
        [
            -0.0167 * t - 0.2608,
            -0.0950 * t + 0.0092,
            -0.0079 * t + 0.2102,
            -0.0441 * t - 1.6537,
            -0.0109 * t + 0.0529,
        ],
    ]
}

/// Preetham 1999, Appendix A.2: zenith luminance (kcd/m²) and chromaticity (x, y) for the sun
/// at zenith angle `theta_s` and turbidity `t`.
fn zenith(t: f64, theta_s: f64) -> [f64; 3] {
    let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta_s);
    let y_lum = (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192;
    let (t2, s) = (t * t, [theta_s.powi(3), theta_s.powi(2), theta_s, 1.0]);
    let row = |m: [[f64; 4]; 3]| {
        let dot = |r: [f64; 4]| r.iter().zip(&s).map(|(a, b)| a * b).sum::<f64>();
        t2 * dot(m[0]) + t * dot(m[1]) + dot(m[2])
    };
    let x = row([
        [0.00166, -0.00375, 0.00209, 0.0],
        [-0.02903, 0.06377, -0.03202, 0.00394],
        [0.11693, -0.21196, 0.06052, 0.25886],
    ]);
    let y = row([
        [0.00275, -0.00610, 0.00317, 0.0],
        [-0.04214, 0.08970, -0.04153, 0.00516],
        [0.15346, -0.26756, 0.06670, 0.26688],
    ]);
    [y_lum, x, y]
}

/// CIE xyY → XYZ → linear Rec. 709 (D65), negative components clipped.
fn xyy_to_rgb(y_lum: f64, x: f64, y: f64) -> DVec3 {
    let (cx, cz) = (x / y * y_lum, (1.0 - x - y) / y * y_lum);
    DVec3::new(
        3.2406 * cx - 1.5372 * y_lum - 0.4986 * cz,
        -0.9689 * cx + 1.8758 * y_lum + 0.0415 * cz,
        0.0557 * cx - 0.2040 * y_lum + 1.0570 * cz,
    )
    .max(DVec3::ZERO)
}

/// The sky's radiance (renderer units) from direction `d` (unit, y ≥ 0 above the horizon).
pub fn sky_radiance(params: &SkyParams, d: DVec3) -> DVec3 {
    let s = params.sun_direction();
    let t = params.turbidity as f64;
    let theta_s = s.y.clamp(-1.0, 1.0).acos();
    let coefficients = coefficients(t);
    let z = zenith(t, theta_s);
    let gamma = d.dot(s).clamp(-1.0, 1.0).acos();
    let [y_lum, x, y] = std::array::from_fn(|k| {
        z[k] * perez(coefficients[k], d.y, gamma) / perez(coefficients[k], 1.0, theta_s)
    });
    xyy_to_rgb(y_lum, x, y) / UNIT_KCD
}

/// The sun's irradiance on a plane facing it (renderer units, per channel).
pub fn sun_irradiance(params: &SkyParams) -> DVec3 {
    let z = 90.0 - params.sun_elevation as f64;
    // Kasten & Young 1989: relative optical air mass at zenith angle z (degrees).
    let m = 1.0 / (z.to_radians().cos() + 0.50572 * (96.07995 - z).powf(-1.6364));
    let beta = 0.04608 * params.turbidity as f64 - 0.04586;
    let t = WAVELENGTHS_UM.map(|l| (-m * (0.008735 * l.powf(-4.08) + beta * l.powf(-1.3))).exp());
    DVec3::from_array(t) * SOLAR_ILLUMINANCE_KLX / UNIT_KCD
}

/// The sky map and the sun, or an error naming the option out of range.
pub fn sky(params: &SkyParams) -> Result<(Arc<EnvironmentMap>, GpuPunctualLight)> {
    params.check()?;
    let (w, h) = (SKY_WIDTH, SKY_HEIGHT);
    let mut rgb: Vec<DVec3> = (0..h)
        .flat_map(|j| (0..w).map(move |i| (i, j)))
        .map(|(i, j)| {
            let d = texel_direction(i, j, w, h).as_dvec3();
            if d.y >= 0.0 {
                sky_radiance(params, d)
            } else {
                DVec3::ZERO
            }
        })
        .collect();
    // The ground: Lambertian, lit by the sky's upper half (the texels' solid angles,
    // sin θ dθ dφ) and the sun.
    let (dtheta, dphi) = (PI / h as f64, 2.0 * PI / w as f64);
    let mut e_sky = DVec3::ZERO;
    for j in 0..h {
        let theta = (j as f64 + 0.5) * dtheta;
        if theta.cos() <= 0.0 {
            continue;
        }
        for i in 0..w {
            e_sky += rgb[(j * w + i) as usize] * theta.cos() * theta.sin() * dtheta * dphi;
        }
    }
    let sun = sun_irradiance(params);
    let ground = GROUND_ALBEDO / PI * (e_sky + sun * params.sun_direction().y);
    for (k, c) in rgb.iter_mut().enumerate() {
        let j = k as u32 / w;
        if texel_direction(0, j, w, h).y < 0.0 {
            *c = ground;
        }
    }
    let rgb: Vec<Vec3> = rgb.iter().map(|c| c.as_vec3()).collect();
    let map = EnvironmentMap::from_rgb(w, h, &rgb)
        .ok_or_else(|| anyhow::anyhow!("--sky: the sky is black"))?;
    let light = GpuPunctualLight {
        kind: LIGHT_DIRECTIONAL,
        direction: (-params.sun_direction()).as_vec3().to_array(),
        intensity: sun.as_vec3().to_array(),
        ..GpuPunctualLight::default()
    };
    Ok((Arc::new(map), light))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The model's values at the zenith are its zenith formulas (F(0, θs) / F(0, θs) = 1), and
    /// Y_z at T = 3, sun 45° up, worked by hand: χ = (4/9 − 3/120)·π/2 = 0.65886, tan χ =
    /// 0.77428, Y_z = 7.1649 · 0.77428 − 0.6465 + 2.4192 = 7.3204 kcd/m².
    #[test]
    fn the_zenith_is_the_zenith_formula() {
        let p = SkyParams::default();
        let theta_s = (90.0f64 - 45.0).to_radians();
        let z = zenith(3.0, theta_s);
        assert!((z[0] - 7.3204).abs() < 1e-3, "{z:?}");
        let up = sky_radiance(&p, DVec3::Y);
        let want = xyy_to_rgb(z[0], z[1], z[2]) / UNIT_KCD;
        assert!((up - want).abs().max_element() < 1e-12, "{up} vs {want}");
    }

    #[test]
    fn the_sky_is_blue_and_brightest_about_the_sun() {
        let p = SkyParams::default();
        let up = sky_radiance(&p, DVec3::Y);
        assert!(up.z > up.x, "zenith {up}");
        let s = p.sun_direction();
        let near = sky_radiance(&p, (s + DVec3::new(0.0, 0.05, 0.0)).normalize());
        let away = sky_radiance(&p, DVec3::new(-s.x, s.y, -s.z).normalize());
        assert!(
            near.y > 2.0 * away.y,
            "near the sun {near}, opposite {away}"
        );
    }

    #[test]
    fn the_sun_reddens_and_dims_towards_the_horizon_and_in_haze() {
        let high = sun_irradiance(&SkyParams::default());
        let low = sun_irradiance(&SkyParams {
            sun_elevation: 5.0,
            ..SkyParams::default()
        });
        let hazy = sun_irradiance(&SkyParams {
            turbidity: 8.0,
            ..SkyParams::default()
        });
        assert!(
            high.x > high.z && low.x / low.z > high.x / high.z,
            "{high} {low}"
        );
        assert!(low.y < high.y && hazy.y < high.y, "{high} {low} {hazy}");
        // A clear sky's sun 45° up: 60–110 klx on a plane facing it.
        let klx = high.y * UNIT_KCD;
        assert!((60.0..110.0).contains(&klx), "{high}");
    }

    #[test]
    fn out_of_range_parameters_are_refused_by_option() {
        for (p, name) in [
            (
                SkyParams {
                    sun_elevation: -5.0,
                    ..SkyParams::default()
                },
                "--sun-elevation",
            ),
            (
                SkyParams {
                    sun_elevation: 95.0,
                    ..SkyParams::default()
                },
                "--sun-elevation",
            ),
            (
                SkyParams {
                    turbidity: 1.0,
                    ..SkyParams::default()
                },
                "--turbidity",
            ),
            (
                SkyParams {
                    sun_azimuth: f32::NAN,
                    ..SkyParams::default()
                },
                "--sun-azimuth",
            ),
        ] {
            let e = sky(&p).err().expect("refused");
            assert!(e.to_string().contains(name), "{e}");
        }
    }
}
