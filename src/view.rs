//! View transforms: how a display output (PNG) shows the film's scene-linear radiance. The EXR
//! is never transformed. Each transform maps linear Rec. 709 (after `--exposure`) to display
//! linear in [0, 1], which the sRGB transfer function then encodes.
//!
//! - `standard`: clamp to [0, 1] (what wavetrace always wrote; Blender's "Standard").
//! - `khronos-pbr-neutral`: the Khronos PBR Neutral tone mapper (KhronosGroup/ToneMapping,
//!   "PBR Neutral Specification", 2024): base colours up to 0.8 lit by a white light of 1 show
//!   as themselves (less the F90 = 0.04 offset), highlights compress towards white with a small
//!   desaturation.

/// A view transform (`render --view`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum View {
    #[default]
    Standard,
    KhronosPbrNeutral,
}

impl View {
    /// Display-linear RGB in [0, 1] of scene-linear `rgb` (exposure already applied).
    pub fn apply(self, rgb: [f32; 3]) -> [f32; 3] {
        match self {
            View::Standard => rgb.map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) }),
            View::KhronosPbrNeutral => pbr_neutral(rgb).map(|c| c.clamp(0.0, 1.0)),
        }
    }
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
