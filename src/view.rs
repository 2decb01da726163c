//! View transforms: how a display output (PNG, JPEG) shows the film's scene-linear radiance.
//! The EXR and the Radiance HDR are never transformed. Each transform maps linear Rec. 709
//! (after `--exposure`) to display linear in [0, 1], which the sRGB transfer function then
//! encodes.
//!
//! - `standard`: clamp to [0, 1] (Blender's "Standard").
//! - `khronos-pbr-neutral` (the default, `docs/usage.md` says why): the Khronos PBR Neutral
//!   tone mapper (KhronosGroup/ToneMapping, "PBR Neutral Specification", 2024): base colours up
//!   to 0.8 lit by a white light of 1 show as themselves (less the F90 = 0.04 offset),
//!   highlights compress towards white with a small desaturation.
//! - `agx`: Troy Sobotka's AgX as Blender 4 ships it, in the closed form of Benjamin Wrensch's
//!   "Minimal AgX Implementation" (iolite engine blog, 2023): the inset matrix, a log2 encoding
//!   over [−12.47393, 4.026069] stops, his sixth-order polynomial fit of the AgX base contrast
//!   curve, the outset matrix and a 2.2 power; looks `punchy` and `golden` are his ASC CDL
//!   values for Blender's looks of those names.
//! - `filmic`: John Hable's filmic curve ("Uncharted 2: HDR Lighting", GDC 2010) per channel,
//!   his exposure bias 2 and white point 11.2. Not Blender's "Filmic", which is a lookup table
//!   (a fitted curve cannot be derived from a published formula).

/// A view transform (`render --view`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum View {
    Standard,
    #[default]
    KhronosPbrNeutral,
    Agx(Look),
    Filmic,
}

/// A look of a view transform (`render --look`): AgX's, as Blender names them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Look {
    #[default]
    None,
    Punchy,
    Golden,
}

impl View {
    /// Display-linear RGB in [0, 1] of scene-linear `rgb` (exposure already applied).
    pub fn apply(self, rgb: [f32; 3]) -> [f32; 3] {
        let out = match self {
            View::Standard => rgb,
            View::KhronosPbrNeutral => pbr_neutral(rgb),
            View::Agx(look) => agx(rgb, look),
            View::Filmic => hable_filmic(rgb),
        };
        out.map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) })
    }
}

/// AgX (Wrensch 2023's closed form of Blender 4's AgX; see the module's notes): display-linear
/// RGB of scene-linear Rec. 709 `rgb`.
pub fn agx(rgb: [f32; 3], look: Look) -> [f32; 3] {
    // The inset matrix (rows; Wrensch's GLSL mat3 is column-major).
    const INSET: [[f32; 3]; 3] = [
        [0.842479062253094, 0.0784335999999992, 0.0792237451477643],
        [0.0423282422610123, 0.878468636469772, 0.0791661274605434],
        [0.0423756549057051, 0.0784336, 0.879142973793104],
    ];
    const OUTSET: [[f32; 3]; 3] = [
        [1.19687900512017, -0.0980208811401368, -0.0990297440797205],
        [-0.0528968517574562, 1.15190312990417, -0.0989611768448433],
        [-0.0529716355144438, -0.0980434501171241, 1.15107367264116],
    ];
    const MIN_EV: f32 = -12.47393;
    const MAX_EV: f32 = 4.026069;
    let rgb = rgb.map(|c| if c.is_nan() { 0.0 } else { c.max(0.0) });
    let inset = mat3_mul(&INSET, rgb);
    let encoded = inset.map(|c| {
        let ev = if c > 0.0 {
            c.log2().clamp(MIN_EV, MAX_EV)
        } else {
            MIN_EV
        };
        (ev - MIN_EV) / (MAX_EV - MIN_EV)
    });
    // The base contrast curve, Wrensch's polynomial fit.
    let curve = encoded.map(|x| {
        let (x2, x4) = (x * x, x * x * x * x);
        15.5 * x4 * x2 - 40.14 * x4 * x + 31.96 * x4 - 6.868 * x2 * x + 0.4298 * x2 + 0.1191 * x
            - 0.00232
    });
    let looked = agx_look(curve, look);
    mat3_mul(&OUTSET, looked).map(|c| c.max(0.0).powf(2.2))
}

/// An AgX look: an ASC CDL (slope, power) and a saturation about Rec. 709 luminance, on the
/// curve's display-encoded values (Wrensch 2023).
fn agx_look(rgb: [f32; 3], look: Look) -> [f32; 3] {
    let (slope, power, saturation) = match look {
        Look::None => return rgb,
        Look::Golden => ([1.0, 0.9, 0.5], [0.8; 3], 0.8),
        Look::Punchy => ([1.0; 3], [1.35; 3], 1.4),
    };
    let luma = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    let mut out = [0.0; 3];
    for c in 0..3 {
        let v = (rgb[c] * slope[c]).max(0.0).powf(power[c]);
        out[c] = luma + saturation * (v - luma);
    }
    out
}

fn mat3_mul(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    m.map(|row| row[0] * v[0] + row[1] * v[1] + row[2] * v[2])
}

/// John Hable's filmic curve (GDC 2010) per channel: F(2x) / F(11.2) with
/// F(x) = (x(Ax + CB) + DE) / (x(Ax + B) + DF) − E/F.
pub fn hable_filmic(rgb: [f32; 3]) -> [f32; 3] {
    const EXPOSURE_BIAS: f32 = 2.0;
    const WHITE: f32 = 11.2;
    fn f(x: f32) -> f32 {
        const A: f32 = 0.15;
        const B: f32 = 0.50;
        const C: f32 = 0.10;
        const D: f32 = 0.20;
        const E: f32 = 0.02;
        const F: f32 = 0.30;
        (x * (A * x + C * B) + D * E) / (x * (A * x + B) + D * F) - E / F
    }
    let white = f(WHITE);
    rgb.map(|c| f(EXPOSURE_BIAS * if c.is_nan() { 0.0 } else { c.max(0.0) }) / white)
}

/// Khronos PBR Neutral in the form of its sample GLSL: an offset that keeps dark colours from
/// going negative, then a compression of the peak above K_s = 0.76 towards 1, and a
/// desaturation towards the new peak as it compresses (the specification's c_out, with its
/// g written as 1 − g here).
pub fn pbr_neutral(rgb: [f32; 3]) -> [f32; 3] {
    const START_COMPRESSION: f32 = 0.8 - 0.04;
    const DESATURATION: f32 = 0.15;
    let rgb = rgb.map(|c| if c.is_nan() { 0.0 } else { c.max(0.0) });
    let x = rgb[0].min(rgb[1]).min(rgb[2]);
    let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
    let color = rgb.map(|c| c - offset);
    let peak = color[0].max(color[1]).max(color[2]);
    if peak < START_COMPRESSION {
        return color;
    }
    let d = 1.0 - START_COMPRESSION;
    let new_peak = 1.0 - d * d / (peak + d - START_COMPRESSION);
    let color = color.map(|c| c * new_peak / peak);
    let g = 1.0 - 1.0 / (DESATURATION * (peak - new_peak) + 1.0);
    color.map(|c| c + g * (new_peak - c))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pbr_neutral_keeps_greys_grey_and_never_reaches_white() {
        // Grey above the knee: offset 0.04 and no compression below a peak of 0.76.
        assert_eq!(pbr_neutral([0.7; 3]), [0.7 - 0.04; 3]);
        // Highlights approach but never reach 1, monotonically, and grey stays grey.
        let mut last = 0.0;
        for k in 0..200 {
            let v = 0.8 + k as f32 * 0.5;
            let out = pbr_neutral([v; 3]);
            assert!(out[0] == out[1] && out[1] == out[2]);
            assert!(out[0] > last && out[0] < 1.0, "{v}: {out:?}");
            last = out[0];
        }
    }
}
