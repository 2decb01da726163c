//! KHR_materials_iridescence's thin-film Fresnel: a dielectric film of index `film_ior` and
//! thickness d (nm) over the base, after Belcour & Barla 2017 ("A Practical Extension to
//! Microfacet Theory for the Modeling of Varying Iridescence"), exactly as the extension's
//! "Implementation" writes it (`evalIridescence`, `evalSensitivity`): Airy summation of the
//! film's reflections to second order, each order's spectral phase integrated against the
//! CIE 1931 XYZ matching functions by their Gaussian fit in Fourier space, converted to linear
//! Rec. 709 (sRGB primaries, the renderer's RGB) and clamped at 0. Schlick's approximation
//! gives each interface's reflectance. Twin of `shaders/inc/iridescence.glsl`, same names.

use glam::Vec3;
use std::f32::consts::PI;

/// F0 = ((n_t − n_i)/(n_t + n_i))² of an interface.
pub fn ior_to_fresnel0(transmitted: f32, incident: f32) -> f32 {
    let r = (transmitted - incident) / (transmitted + incident);
    r * r
}

/// The index n, against air, whose F0 is `f0` (n = (1 + √F0)/(1 − √F0)), per channel.
pub fn fresnel0_to_ior(f0: Vec3) -> Vec3 {
    let s = Vec3::new(f0.x.sqrt(), f0.y.sqrt(), f0.z.sqrt());
    (Vec3::ONE + s) / (Vec3::ONE - s)
}

fn schlick(f0: f32, cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    f0 + (1.0 - f0) * m * m * m * m * m
}

/// cos x for the film's phases (up to a few hundred radians): x less its nearest whole turns,
/// in [−π, π] (Cody & Waite's reduction: 2π as 6.28125, whose multiples up to 2¹⁶ turns are
/// exact in f32, plus the rest), then cos's Taylor series to x¹⁸ by Horner's rule (truncation
/// below 4e-9 on [−π, π], rounding a few 1e-7). The GLSL twin does the same additions and
/// products, because Vulkan holds a device's own `cos` to nothing outside [−π, π] (and to
/// 2⁻¹¹ inside): with it, GPU and CPU reflectances of one film agree to a few ulp instead of
/// to the device's cos.
pub fn film_cos(x: f32) -> f32 {
    const TURN: f32 = 2.0 * PI;
    const TURN_HI: f32 = 6.28125;
    const TURN_LO: f32 = 1.935307169e-03;
    let k = (x * (1.0 / TURN) + 0.5).floor();
    let r = (x - k * TURN_HI) - k * TURN_LO;
    let r2 = r * r;
    // (−1)^k / (2k)!, k = 9 down to 0, each the f32 nearest it.
    const C: [f32; 10] = [
        -1.561920681e-16,
        4.779477256e-14,
        -1.147074536e-11,
        2.087675588e-09,
        -2.755731998e-07,
        2.480158764e-05,
        -1.388888923e-03,
        4.166666791e-02,
        -5.000000000e-01,
        1.000000000e+00,
    ];
    let mut p = C[0];
    for &c in &C[1..] {
        p = p * r2 + c;
    }
    p
}

/// The XYZ matching functions' response to an optical path difference `opd` (nm) with phase
/// `shift` per channel, in linear Rec. 709 RGB (the extension's `evalSensitivity`: Belcour &
/// Barla 2017's Gaussian fits, normalised so that zero difference gives white).
pub fn eval_sensitivity(opd: f32, shift: Vec3) -> Vec3 {
    let phase = 2.0 * PI * opd * 1.0e-9;
    let val = [5.4856e-13f32, 4.4201e-13, 5.2481e-13];
    let pos = [1.6810e+06f32, 1.7953e+06, 2.2084e+06];
    let var = [4.3278e+09f32, 9.3046e+09, 6.6121e+09];
    let s = shift.to_array();
    let mut xyz = [0.0f32; 3];
    for k in 0..3 {
        xyz[k] = val[k]
            * (2.0 * PI * var[k]).sqrt()
            * film_cos(pos[k] * phase + s[k])
            * (-phase * phase * var[k]).exp();
    }
    xyz[0] += 9.7470e-14
        * (2.0 * PI * 4.5282e+09f32).sqrt()
        * film_cos(2.2399e+06 * phase + s[0])
        * (-4.5282e+09 * phase * phase).exp();
    let [x, y, z] = xyz.map(|v| v / 1.0685e-7);
    // XYZ → linear Rec. 709 (IEC 61966-2-1).
    Vec3::new(
        3.2404542 * x - 1.5371385 * y - 0.4985314 * z,
        -0.969266 * x + 1.8760108 * y + 0.041556 * z,
        0.0556434 * x - 0.2040259 * y + 1.0572252 * z,
    )
}

/// The thin film's RGB reflectance seen from outside (index `outside_ior`) at cosine `cos1` to
/// the (micro)normal, over a base of RGB F0 `base_f0` (against air): the extension's
/// `evalIridescence`. The film fades into the outside medium as its thickness goes to 0; total
/// internal reflection at the film gives 1.
pub fn fresnel_iridescence(
    outside_ior: f32,
    film_ior: f32,
    cos1: f32,
    thickness: f32,
    base_f0: Vec3,
) -> Vec3 {
    let t = (thickness / 0.03).clamp(0.0, 1.0);
    let film = outside_ior + (film_ior - outside_ior) * t * t * (3.0 - 2.0 * t);
    let sin2_2 = (outside_ior / film) * (outside_ior / film) * (1.0 - cos1 * cos1);
    let cos2_sq = 1.0 - sin2_2;
    if cos2_sq < 0.0 {
        return Vec3::ONE;
    }
    let cos2 = cos2_sq.sqrt();
    // First interface (outside → film).
    let r12 = schlick(ior_to_fresnel0(film, outside_ior), cos1);
    let t121 = 1.0 - r12;
    let phi12 = if film < outside_ior { PI } else { 0.0 };
    let phi21 = PI - phi12;
    // Second interface (film → base).
    let base_ior = fresnel0_to_ior(base_f0.clamp(Vec3::ZERO, Vec3::splat(0.9999)));
    let r23 = Vec3::new(
        schlick(ior_to_fresnel0(base_ior.x, film), cos2),
        schlick(ior_to_fresnel0(base_ior.y, film), cos2),
        schlick(ior_to_fresnel0(base_ior.z, film), cos2),
    );
    let phi23 = Vec3::new(
        if base_ior.x < film { PI } else { 0.0 },
        if base_ior.y < film { PI } else { 0.0 },
        if base_ior.z < film { PI } else { 0.0 },
    );
    // Phase shift and optical path difference.
    let opd = 2.0 * film * thickness * cos2;
    let phi = Vec3::splat(phi21) + phi23;
    // Compound terms.
    let r123 = (r12 * r23).clamp(Vec3::splat(1e-5), Vec3::splat(0.9999));
    let sqrt_r123 = Vec3::new(r123.x.sqrt(), r123.y.sqrt(), r123.z.sqrt());
    let rs = t121 * t121 * r23 / (Vec3::ONE - r123);
    // The m = 0 term, then the pairs of Diracs m = 1, 2.
    let mut i = Vec3::splat(r12) + rs;
    let mut cm = rs - Vec3::splat(t121);
    for m in 1..=2 {
        cm *= sqrt_r123;
        i += cm * 2.0 * eval_sensitivity(m as f32 * opd, m as f32 * phi);
    }
    i.max(Vec3::ZERO)
}
