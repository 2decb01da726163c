//! The film: per pixel, the sum, the sum of squares and the count of finite radiance samples
//! (`FilmPixel`, the same struct `wavefront/accumulate.comp` writes), so every image carries its
//! own variance estimate.
//!
//! Pixels are row-major, top row first: pixel (x, y) is index `x + y·width`. The pixel filter is a
//! box, so a pixel's value is the plain mean of its samples. Sums are stored in f32 (the GPU's
//! format); every statistic is computed in f64 from the stored values. Because `sum_sq` is an f32
//! running sum, the variance of a pixel whose mean is large compared with its spread is only as
//! good as f32 cancellation allows (relative error of the order of n·2⁻²⁴·mean²/variance).

use crate::layout::FilmPixel;
use glam::Vec3;

/// Per-pixel accumulators of a `width × height` image.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first: `pixels[x + y·width]`.
    pub pixels: Vec<FilmPixel>,
    /// Samples dropped because a component was NaN or ±Inf.
    pub dropped: u64,
}

impl Film {
    /// An empty film: every pixel has no samples.
    pub fn new(width: u32, height: u32) -> Film {
        let len = width as usize * height as usize;
        Film {
            width,
            height,
            pixels: vec![FilmPixel::default(); len],
            dropped: 0,
        }
    }

    /// Wraps pixels read back from the GPU film buffer (`dropped` from its counter).
    pub fn from_pixels(width: u32, height: u32, pixels: Vec<FilmPixel>, dropped: u64) -> Film {
        assert_eq!(
            pixels.len(),
            width as usize * height as usize,
            "film readback has {} pixels, expected {width}×{height}",
            pixels.len()
        );
        Film {
            width,
            height,
            pixels,
            dropped,
        }
    }

    /// Number of pixels (`width · height`).
    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// Adds one radiance sample to pixel (x + y·width); a sample with a NaN/Inf component is
    /// dropped and counted in `dropped`.
    pub fn add_sample(&mut self, pixel: usize, rgb: Vec3) {
        if !rgb.is_finite() {
            self.dropped += 1;
            return;
        }
        let p = &mut self.pixels[pixel];
        for c in 0..3 {
            p.sum[c] += rgb[c];
            p.sum_sq[c] += rgb[c] * rgb[c];
        }
        p.count += 1;
    }

    /// Adds another film's samples to this one (same size). Sums and counts add, so any split of
    /// a sample range merges into the film one render of the whole range would give, up to f32
    /// summation order.
    pub fn merge(&mut self, other: &Film) {
        assert_eq!(
            (self.width, self.height),
            (other.width, other.height),
            "merging films of different sizes"
        );
        for (p, q) in self.pixels.iter_mut().zip(&other.pixels) {
            for c in 0..3 {
                p.sum[c] += q.sum[c];
                p.sum_sq[c] += q.sum_sq[c];
            }
            p.count += q.count;
        }
        self.dropped += other.dropped;
    }

    /// The pixel's mean radiance, sum / count (0 if it has no samples).
    pub fn mean(&self, pixel: usize) -> Vec3 {
        let p = &self.pixels[pixel];
        if p.count == 0 {
            return Vec3::ZERO;
        }
        let n = p.count as f64;
        Vec3::from_array(p.sum.map(|s| (s as f64 / n) as f32))
    }

    /// Unbiased sample variance of the pixel's samples, per channel:
    /// (sum_sq − sum²/n)/(n − 1) in f64, clamped ≥ 0; 0 if n < 2.
    pub fn sample_variance(&self, pixel: usize) -> Vec3 {
        Vec3::from_array(self.sample_variance_f64(pixel).map(|v| v as f32))
    }

    /// Variance of the pixel mean, per channel: sample_variance / n (0 if n < 2).
    pub fn variance_of_mean(&self, pixel: usize) -> Vec3 {
        Vec3::from_array(self.variance_of_mean_f64(pixel).map(|v| v as f32))
    }

    /// `sample_variance` without the final rounding to f32.
    pub fn sample_variance_f64(&self, pixel: usize) -> [f64; 3] {
        let p = &self.pixels[pixel];
        if p.count < 2 {
            return [0.0; 3];
        }
        let n = p.count as f64;
        std::array::from_fn(|c| {
            let (s, q) = (p.sum[c] as f64, p.sum_sq[c] as f64);
            ((q - s * s / n) / (n - 1.0)).max(0.0)
        })
    }

    /// `variance_of_mean` without the final rounding to f32.
    pub fn variance_of_mean_f64(&self, pixel: usize) -> [f64; 3] {
        let n = self.pixels[pixel].count.max(1) as f64;
        self.sample_variance_f64(pixel).map(|v| v / n)
    }

    /// The pixel mean in f64 (sum / count, 0 if count is 0).
    pub fn mean_f64(&self, pixel: usize) -> [f64; 3] {
        let p = &self.pixels[pixel];
        if p.count == 0 {
            return [0.0; 3];
        }
        p.sum.map(|s| s as f64 / p.count as f64)
    }

    /// Finite samples accumulated over all pixels.
    pub fn total_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.count as u64).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_variance_of_known_samples() {
        let mut film = Film::new(2, 1);
        for v in [1.0, 2.0, 3.0, 4.0] {
            film.add_sample(1, Vec3::new(v, 2.0 * v, 5.0));
        }
        assert_eq!(film.mean(1), Vec3::new(2.5, 5.0, 5.0));
        // Sample variance of {1,2,3,4} is 5/3; scaled by 2 it is 20/3; a constant has 0.
        let var = film.sample_variance(1);
        assert!((var.x - 5.0 / 3.0).abs() < 1e-6 && (var.y - 20.0 / 3.0).abs() < 1e-5);
        assert_eq!(var.z, 0.0);
        assert!((film.variance_of_mean(1).x - 5.0 / 12.0).abs() < 1e-6);
        assert_eq!(film.mean(0), Vec3::ZERO);
        assert_eq!(film.sample_variance(0), Vec3::ZERO);
        assert_eq!(film.total_samples(), 4);
    }

    #[test]
    fn non_finite_samples_are_dropped_and_counted() {
        let mut film = Film::new(1, 1);
        film.add_sample(0, Vec3::new(f32::NAN, 0.0, 0.0));
        film.add_sample(0, Vec3::new(0.0, f32::INFINITY, 0.0));
        film.add_sample(0, Vec3::ONE);
        assert_eq!(film.dropped, 2);
        assert_eq!(film.total_samples(), 1);
        assert_eq!(film.mean(0), Vec3::ONE);
    }

    #[test]
    fn merge_of_a_split_equals_the_whole() {
        // Sample values that are exact in f32, so the sums do not depend on order.
        let samples: Vec<Vec3> = (0..16).map(|i| Vec3::splat(i as f32 * 0.25)).collect();
        let mut whole = Film::new(3, 2);
        let (mut a, mut b) = (Film::new(3, 2), Film::new(3, 2));
        for (i, s) in samples.iter().enumerate() {
            whole.add_sample(i % 6, *s);
            if i < 7 {
                a.add_sample(i % 6, *s)
            } else {
                b.add_sample(i % 6, *s)
            }
        }
        a.add_sample(0, Vec3::NAN);
        a.merge(&b);
        assert_eq!(a.pixels, whole.pixels);
        assert_eq!(a.dropped, 1);
    }
}

/// Adds one path's radiance to its pixel, as `accumulate.comp` does; false if it was dropped
/// for being NaN or infinite.
pub fn accumulate(acc: &mut FilmPixel, l: Vec3) -> bool {
    if !l.is_finite() {
        return false;
    }
    for c in 0..3 {
        acc.sum[c] += l[c];
        acc.sum_sq[c] += l[c] * l[c];
    }
    acc.count += 1;
    true
}
