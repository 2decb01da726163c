//! Perceptual difference for references that carry no variance (another renderer's PNG or EXR):
//! NVIDIA's FLIP (Andersson, Nilsson, Akenine-Möller, Oskarsson, Åström and Fairchild, "FLIP: A
//! Difference Evaluator for Alternating Images", HPG 2020) through the `nv-flip` crate, on the
//! two images as a screen shows them — linear images tonemapped to 8-bit sRGB exactly as
//! `render -o X.png` writes them, PNG and JPEG files as they are.
//!
//! FLIP is a judgement of visibility, not a statistical test: it has no significance level, so
//! a verdict from it needs a threshold the user states (`--max-flip`). Whenever both sides
//! carry variance, the per-tile Welch test stays the verdict.

use crate::film::Film;
use crate::image_io::srgb_encode_u8;
use anyhow::{bail, Context as _, Result};
use image::RgbImage;
use std::path::Path;

/// An image as a display shows it: 8-bit sRGB, row-major RGB.
pub struct DisplayImage {
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
}

impl DisplayImage {
    /// A film's mean tonemapped as `render -o X.png` writes it (exposure 0).
    pub fn from_film(film: &Film) -> DisplayImage {
        let mut rgb = Vec::with_capacity(film.len() * 3);
        for p in 0..film.len() {
            rgb.extend(film.mean(p).to_array().map(srgb_encode_u8));
        }
        DisplayImage {
            width: film.width,
            height: film.height,
            rgb,
        }
    }

    /// Linear RGB (an EXR's R, G, B) tonemapped the same way.
    pub fn from_linear(width: u32, height: u32, linear: &[[f32; 3]]) -> DisplayImage {
        DisplayImage {
            width,
            height,
            rgb: linear.iter().flat_map(|c| c.map(srgb_encode_u8)).collect(),
        }
    }

    /// The image as a film of one sample per pixel (sRGB decoded to linear), for reports: its
    /// tonemapped PNG gives back these codes.
    pub fn to_film(&self) -> Film {
        let pixels = self
            .rgb
            .chunks_exact(3)
            .map(|c| {
                let v = [c[0], c[1], c[2]].map(srgb_decode_u8);
                crate::layout::FilmPixel {
                    sum: v,
                    sum_sq: v.map(|x| x * x),
                    count: 1,
                    ..Default::default()
                }
            })
            .collect();
        Film::from_pixels(self.width, self.height, pixels, 0)
    }

    /// Reads an image file: `.exr` (linear, tonemapped), or `.png`/`.jpg` (sRGB as stored).
    pub fn load(path: &Path) -> Result<DisplayImage> {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        match ext.as_deref() {
            Some("exr") => {
                let data = crate::image_io::read_exr(path)?;
                Ok(DisplayImage::from_linear(
                    data.width,
                    data.height,
                    &data.mean,
                ))
            }
            Some("png" | "jpg" | "jpeg") => {
                let image = image::open(path)
                    .with_context(|| format!("{}: cannot read the image", path.display()))?
                    .into_rgb8();
                Ok(DisplayImage {
                    width: image.width(),
                    height: image.height(),
                    rgb: image.into_raw(),
                })
            }
            _ => bail!(
                "{}: FLIP compares .exr, .png or .jpg images",
                path.display()
            ),
        }
    }
}

/// The linear value of an 8-bit sRGB code (IEC 61966-2-1), the inverse of `srgb_encode_u8`.
pub fn srgb_decode_u8(code: u8) -> f32 {
    let c = code as f64 / 255.0;
    (if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }) as f32
}

/// FLIP's error map of `test` against `reference` and its statistics.
pub struct FlipResult {
    pub width: u32,
    pub height: u32,
    /// Per-pixel FLIP error in [0, 1].
    pub error: Vec<f32>,
    pub mean: f64,
    pub median: f64,
    /// The weighted 99th percentile FLIP's tool reports (nv-flip's pool).
    pub p99: f64,
    pub max: f64,
}

/// FLIP at the default viewing conditions (a 0.7 m distance to a 0.7 m wide 3840-pixel monitor,
/// FLIP's 67 pixels per degree). The images must be the same size.
pub fn flip(reference: &DisplayImage, test: &DisplayImage) -> Result<FlipResult> {
    if (reference.width, reference.height) != (test.width, test.height) {
        bail!(
            "the images differ in size: {}×{} against {}×{}",
            test.width,
            test.height,
            reference.width,
            reference.height
        );
    }
    let r = nv_flip::FlipImageRgb8::with_data(reference.width, reference.height, &reference.rgb);
    let t = nv_flip::FlipImageRgb8::with_data(test.width, test.height, &test.rgb);
    let map = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let pool = nv_flip::FlipPool::from_image(&map);
    let error = map.to_vec();
    let mut sorted = error.clone();
    sorted.sort_by(f32::total_cmp);
    Ok(FlipResult {
        width: reference.width,
        height: reference.height,
        mean: pool.mean() as f64,
        median: sorted.get(sorted.len() / 2).copied().unwrap_or(0.0) as f64,
        p99: pool.get_weighted_percentile(0.99),
        max: sorted.last().copied().unwrap_or(0.0) as f64,
        error,
    })
}

/// The error map in FLIP's magma colours (black: no difference, yellow-white: the largest).
pub fn flip_heat_map(result: &FlipResult) -> RgbImage {
    let map = nv_flip::FlipImageFloat::with_data(result.width, result.height, &result.error);
    let colours = map.apply_color_lut(&nv_flip::magma_lut());
    RgbImage::from_raw(result.width, result.height, colours.to_vec())
        .expect("the colour map has the image's size")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn image(width: u32, height: u32, f: impl Fn(u32, u32) -> [u8; 3]) -> DisplayImage {
        let mut rgb = Vec::new();
        for y in 0..height {
            for x in 0..width {
                rgb.extend(f(x, y));
            }
        }
        DisplayImage { width, height, rgb }
    }

    #[test]
    fn identical_images_have_no_error_and_a_changed_patch_shows() {
        let base = image(64, 48, |x, y| [(x * 4) as u8, (y * 5) as u8, 128]);
        let same = flip(&base, &base).unwrap();
        assert_eq!(same.max, 0.0);
        // A bright square on the right half: the error is there and nowhere far from it.
        let changed = image(64, 48, |x, y| {
            if (40..52).contains(&x) && (18..30).contains(&y) {
                [255, 255, 255]
            } else {
                [(x * 4) as u8, (y * 5) as u8, 128]
            }
        });
        let r = flip(&base, &changed).unwrap();
        assert!(r.mean > 0.0 && r.max > 0.5, "mean {} max {}", r.mean, r.max);
        let at = |x: u32, y: u32| r.error[(y * 64 + x) as usize];
        assert!(at(45, 24) > 0.5);
        assert!(at(5, 5) < 0.05);
        let heat = flip_heat_map(&r);
        assert_eq!(heat.dimensions(), (64, 48));
        assert!(
            heat.get_pixel(45, 24)
                .0
                .iter()
                .map(|&c| c as u32)
                .sum::<u32>()
                > 300
        );
    }

    #[test]
    fn srgb_codes_round_trip() {
        for code in 0..=255u8 {
            assert_eq!(srgb_encode_u8(srgb_decode_u8(code)), code);
        }
    }

    #[test]
    fn sizes_must_match() {
        let a = image(8, 8, |_, _| [0; 3]);
        let b = image(8, 9, |_, _| [0; 3]);
        assert!(flip(&a, &b).is_err());
    }
}
