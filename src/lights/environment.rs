//! Environment lighting: an equirectangular radiance map around the scene (`--env FILE.hdr|.exr`,
//! or `--environment R,G,B`, a constant one), looked up bilinearly and importance-sampled
//! through a 2-D piecewise-constant distribution. Twin of `shaders/inc/environment.glsl`, with
//! the same names.
//!
//! Directions (DESIGN.md's +Y up): the image's top row is straight up (+Y), its centre column
//! looks along −Z (ahead of a default glTF camera) and u grows towards +X; `--env-rotate`
//! turns the map about +Y (right-handed). For a direction (x, y, z) in the map's frame,
//! θ = acos(y), φ = atan2(x, −z), (u, v) = (φ/2π + ½, θ/π).
//!
//! Sampling is the lecture's inversion of the CDF in two dimensions: v from the marginal CDF
//! of the rows, then u from the chosen row's conditional CDF, each 1-D CDF piecewise linear
//! (piecewise-constant density), so P⁻¹ is a binary search and a linear remap within the bin
//! (pbrt-v4, `PiecewiseConstant2D`). The cell weights are the luminance of the bilinearly
//! filtered map averaged over the cell (so every direction the lookup can light has a positive
//! density) times sin θ at the row's centre; the density in solid angle is
//! p(u, v) / (2π² sin θ), the Jacobian of (u, v) ↦ ω. The pdf that MIS uses is computed from
//! the same CDF values the sampling inverts, so it is the density actually sampled.
//!
//! Texels are stored in Radiance's shared-exponent RGBE (8-bit mantissas, one 8-bit exponent):
//! lossless for `.hdr` files, within 2⁻⁸ of the largest channel for EXR, any range a sun
//! needs, and 4 bytes a texel, so an 8k × 4k map takes 128 MiB and its CDFs another 128 MiB.

use super::emitters::luminance;
use crate::layout::FrameParams;
use anyhow::{anyhow, bail, Context, Result};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::path::Path;
use std::sync::{Arc, OnceLock};

/// Largest environment map side, in texels.
pub const MAX_ENV_SIDE: u32 = 16384;

/// An environment map ready for both integrators.
#[derive(Clone, PartialEq)]
pub struct EnvironmentMap {
    pub width: u32,
    pub height: u32,
    /// Row-major from the top row, RGBE (`rgbe_encode`).
    pub texels: Vec<u32>,
    /// The marginal CDF over rows: entry j is the CDF at the end of row j (the last is 1; the
    /// start of row 0 is 0).
    pub marginal: Vec<f32>,
    /// Each row's conditional CDF over its columns, `width` values a row, likewise. (Leaving
    /// out the leading zeros keeps an 8k × 4k map's CDFs at 2²⁷ bytes, the storage-buffer
    /// range of lavapipe.)
    pub conditional: Vec<f32>,
    /// ∫ luminance(L) dω over the sphere (of the unscaled map): the map's weight when next event
    /// estimation chooses between the environment and the scene's emitters.
    pub power: f32,
}

impl std::fmt::Debug for EnvironmentMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "EnvironmentMap({} × {}, ∫L dω = {})",
            self.width, self.height, self.power
        )
    }
}

/// Radiance's shared-exponent encoding of non-negative RGB: the largest channel m = f·2^e
/// (f in [½, 1)) sets the exponent byte e + 128 and each channel keeps ⌊c·2^(8−e)⌋. Values below
/// 2⁻¹⁰⁰ are 0 (so the decoded scale 2^(e−136) is a normal float on every device).
pub fn rgbe_encode(c: Vec3) -> u32 {
    // (Radiance past 10³⁸ is clamped there, so the exponent byte fits.)
    let c = c.min(Vec3::splat(1e38));
    let m = c.max_element();
    if !(m >= 7.9e-31) {
        return 0;
    }
    // m = f·2^e with f in [½, 1): e from the biased exponent of a normal float.
    let e = ((m.to_bits() >> 23) & 0xff) as i32 - 126;
    let scale = f32::from_bits(((127 + 8 - e) as u32) << 23);
    let q = |x: f32| ((x.max(0.0) * scale) as u32).min(255);
    q(c.x) | q(c.y) << 8 | q(c.z) << 16 | ((e + 128) as u32) << 24
}

/// The RGB an RGBE texel stands for: mantissas × 2^(e − 136); exponent byte 0 is black.
pub fn rgbe_decode(t: u32) -> Vec3 {
    let e = t >> 24;
    if e == 0 {
        return Vec3::ZERO;
    }
    // 2^(e − 136) as a float: e ≥ 28 (values ≥ 2⁻¹⁰⁰), so it is normal.
    let scale = f32::from_bits((e + 127 - 136) << 23);
    Vec3::new(
        (t & 0xff) as f32,
        ((t >> 8) & 0xff) as f32,
        ((t >> 16) & 0xff) as f32,
    ) * scale
}

impl EnvironmentMap {
    /// A map of `width` × `height` RGB texels (row-major from the top row): encoded, with its
    /// sampling distribution. None when every texel is black (nothing to light with).
    pub fn from_rgb(width: u32, height: u32, rgb: &[Vec3]) -> Option<EnvironmentMap> {
        assert_eq!(rgb.len(), width as usize * height as usize);
        let texels: Vec<u32> = rgb.iter().map(|&c| rgbe_encode(c)).collect();
        EnvironmentMap::from_texels(width, height, texels)
    }

    fn from_texels(width: u32, height: u32, texels: Vec<u32>) -> Option<EnvironmentMap> {
        let (w, h) = (width as usize, height as usize);
        // Luminance of the texels as the lookup decodes them.
        let lum: Vec<f32> = texels.iter().map(|&t| luminance(rgbe_decode(t))).collect();
        // The bilinear lookup's mean over a cell is the texels filtered by [1/8, 3/4, 1/8] in
        // each direction (wrapping in u, clamped in v), as the lookup addresses them.
        const K: [f32; 3] = [0.125, 0.75, 0.125];
        let mut across = vec![0f32; w * h];
        for j in 0..h {
            let row = &lum[j * w..(j + 1) * w];
            for i in 0..w {
                across[j * w + i] =
                    K[0] * row[(i + w - 1) % w] + K[1] * row[i] + K[2] * row[(i + 1) % w];
            }
        }
        let mut conditional = vec![0f32; h * w];
        let mut row_sums = vec![0f64; h];
        for j in 0..h {
            let (up, down) = (j.saturating_sub(1), (j + 1).min(h - 1));
            let sin_theta = (PI * (j as f32 + 0.5) / height as f32).sin();
            let row = &mut conditional[j * w..(j + 1) * w];
            let mut running = 0f64;
            let weights: Vec<f64> = (0..w)
                .map(|i| {
                    let mean = K[0] * across[up * w + i]
                        + K[1] * across[j * w + i]
                        + K[2] * across[down * w + i];
                    (mean * sin_theta).max(0.0) as f64
                })
                .collect();
            let sum: f64 = weights.iter().sum();
            for (i, wgt) in weights.iter().enumerate() {
                running += wgt;
                row[i] = if sum > 0.0 {
                    (running / sum) as f32
                } else {
                    (i + 1) as f32 / w as f32
                };
            }
            row[w - 1] = 1.0;
            row_sums[j] = sum;
        }
        let total: f64 = row_sums.iter().sum();
        if !(total > 0.0) || !total.is_finite() {
            return None;
        }
        let mut marginal = vec![0f32; h];
        let mut running = 0f64;
        for j in 0..h {
            running += row_sums[j];
            marginal[j] = (running / total) as f32;
        }
        marginal[h - 1] = 1.0;
        // Σ mean · sin θ · Δu·Δv with dω = 2π² sin θ du dv.
        let power = (total * 2.0 * (PI as f64).powi(2) / (w * h) as f64) as f32;
        Some(EnvironmentMap {
            width,
            height,
            texels,
            marginal,
            conditional,
            power,
        })
    }

    /// Writes the map's lookup constants into `frame`: its size, the RGB `scale` on its
    /// radiance and the rotation of `degrees` about +Y (`env_pmf` is the scene's business).
    pub fn write_frame_params(&self, scale: Vec3, degrees: f32, frame: &mut FrameParams) {
        frame.env_width = self.width;
        frame.env_height = self.height;
        frame.env_scale = scale.to_array();
        let a = degrees.to_radians();
        frame.env_rotation = [a.cos(), a.sin()];
    }

    /// The map of `--environment R,G,B`: radiance 1 everywhere (the colour is the frame's
    /// scale), 16 × 8 texels so that its rows' weights follow sin θ and sampling it is close
    /// to uniform over the sphere.
    pub fn constant() -> Arc<EnvironmentMap> {
        static MAP: OnceLock<Arc<EnvironmentMap>> = OnceLock::new();
        Arc::clone(MAP.get_or_init(|| {
            Arc::new(EnvironmentMap::from_rgb(16, 8, &[Vec3::ONE; 128]).expect("not black"))
        }))
    }

    /// Reads an equirectangular Radiance `.hdr` or OpenEXR map. Errors name the file and the
    /// problem: unreadable, not HDR/EXR, too large (over `MAX_ENV_SIDE` a side, or over the
    /// memory `budget` in bytes), a non-finite texel, or black everywhere.
    pub fn load(path: &Path, budget: u64) -> Result<EnvironmentMap> {
        let shown = path.display();
        let format = match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("hdr") => image::ImageFormat::Hdr,
            Some("exr") => image::ImageFormat::OpenExr,
            _ => {
                bail!("{shown}: an environment map must be a Radiance .hdr or an OpenEXR .exr file")
            }
        };
        let open = || -> Result<image::ImageReader<std::io::BufReader<std::fs::File>>> {
            let file =
                std::fs::File::open(path).with_context(|| format!("{shown}: cannot open"))?;
            Ok(image::ImageReader::with_format(
                std::io::BufReader::new(file),
                format,
            ))
        };
        let (width, height) = open()?
            .into_dimensions()
            .map_err(|e| anyhow!("{shown}: cannot read the {format:?} header: {e}"))?;
        if width == 0 || height == 0 || width > MAX_ENV_SIDE || height > MAX_ENV_SIDE {
            bail!(
                "{shown}: {width} × {height} texels: environment maps may have 1 to {MAX_ENV_SIDE} texels a side"
            );
        }
        // Decoding as RGB f32, the RGBE texels, the CDFs and the luminance passes.
        let need = width as u64 * height as u64 * (16 + 4 + 4 + 4);
        if need > budget {
            bail!(
                "{shown}: a {width} × {height} environment map needs {} MiB to load, over the memory budget of {} MiB (--max-memory)",
                need >> 20,
                budget >> 20
            );
        }
        let mut reader = open()?;
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_ENV_SIDE);
        limits.max_image_height = Some(MAX_ENV_SIDE);
        limits.max_alloc = Some(budget);
        reader.limits(limits);
        let decoded = reader
            .decode()
            .map_err(|e| anyhow!("{shown}: cannot decode the {format:?} data: {e}"))?
            .into_rgb32f();
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for (k, p) in decoded.pixels().enumerate() {
            let c = Vec3::from(p.0);
            if !c.is_finite() || c.max_element() > 1e38 {
                bail!(
                    "{shown}: texel ({}, {}) is {c} (radiance must be finite)",
                    k % width as usize,
                    k / width as usize
                );
            }
            // Negative values (filtering ringing in some EXRs) are no light: 0.
            texels.push(rgbe_encode(c.max(Vec3::ZERO)));
        }
        drop(decoded);
        EnvironmentMap::from_texels(width, height, texels)
            .ok_or_else(|| anyhow!("{shown}: the environment map is black everywhere"))
    }
}

/// The map's frame: direction `d` turned by −`--env-rotate` about +Y (frame.env_rotation).
fn env_to_map(frame: &FrameParams, d: Vec3) -> Vec3 {
    let (c, s) = (frame.env_rotation[0], frame.env_rotation[1]);
    Vec3::new(c * d.x - s * d.z, d.y, s * d.x + c * d.z)
}

/// The world direction of the map-frame direction `d` (inverse of `env_to_map`).
fn env_from_map(frame: &FrameParams, d: Vec3) -> Vec3 {
    let (c, s) = (frame.env_rotation[0], frame.env_rotation[1]);
    Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
}

/// (u, v) in [0, 1]² of world direction `d` (unit), and sin θ.
pub fn env_direction_uv(frame: &FrameParams, d: Vec3) -> (Vec2, f32) {
    let m = env_to_map(frame, d);
    let y = m.y.clamp(-1.0, 1.0);
    let theta = y.acos();
    let phi = m.x.atan2(-m.z);
    let uv = Vec2::new(phi * (0.5 / PI) + 0.5, theta * (1.0 / PI));
    (uv, (1.0 - y * y).max(0.0).sqrt())
}

/// Radiance arriving from direction `d` (unit): the map bilinearly filtered between texel
/// centres (wrapping in u, clamped in v), times the frame's scale. Black without a map.
pub fn env_radiance(map: &EnvironmentMap, frame: &FrameParams, d: Vec3) -> Vec3 {
    let (w, h) = (frame.env_width as i32, frame.env_height as i32);
    if w == 0 {
        return Vec3::ZERO;
    }
    let (uv, _) = env_direction_uv(frame, d);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (tx, ty) = (x - x0, y - y0);
    let i0 = (x0 as i32).rem_euclid(w);
    let i1 = if i0 + 1 == w { 0 } else { i0 + 1 }; // (i0 + 1) mod w, i0 in [0, w)
    let j0 = (y0 as i32).clamp(0, h - 1);
    let j1 = (y0 as i32 + 1).clamp(0, h - 1);
    let texel = |i: i32, j: i32| rgbe_decode(map.texels[(j * w + i) as usize]);
    let top = texel(i0, j0).lerp(texel(i1, j0), tx);
    let bottom = texel(i0, j1).lerp(texel(i1, j1), tx);
    top.lerp(bottom, ty) * Vec3::from(frame.env_scale)
}

/// Bin of `u` in [0, 1) in the CDF `cdf` (entry k: the CDF at the end of bin k; the last is
/// 1): the first bin whose end exceeds u, so it has positive width. Returns the bin and the
/// CDF at its start and end.
pub fn cdf_search(cdf: &[f32], u: f32) -> (u32, f32, f32) {
    let (mut lo, mut hi) = (0usize, cdf.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if cdf[mid] > u {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    (lo as u32, cdf_start(cdf, lo), cdf[lo])
}

/// The CDF at the start of bin `k` (0 for the first).
fn cdf_start(cdf: &[f32], k: usize) -> f32 {
    if k == 0 {
        0.0
    } else {
        cdf[k - 1]
    }
}

/// Density in solid angle with which `env_sample` produces direction `d` (unit); 0 without a
/// map or straight up and down (where sin θ = 0).
pub fn env_pdf(map: &EnvironmentMap, frame: &FrameParams, d: Vec3) -> f32 {
    let (w, h) = (frame.env_width, frame.env_height);
    if w == 0 {
        return 0.0;
    }
    let (uv, sin_theta) = env_direction_uv(frame, d);
    if !(sin_theta > 0.0) {
        return 0.0;
    }
    let j = ((uv.y * h as f32) as u32).min(h - 1) as usize;
    let i = ((uv.x * w as f32) as u32).min(w - 1) as usize;
    let row = &map.conditional[j * w as usize..(j + 1) * w as usize];
    let pdf_v = (map.marginal[j] - cdf_start(&map.marginal, j)) * h as f32;
    let pdf_u = (row[i] - cdf_start(row, i)) * w as f32;
    pdf_v * pdf_u / (2.0 * PI * PI * sin_theta)
}

/// A direction drawn from the map's distribution with `u` in [0, 1)²: the row from the
/// marginal CDF with u.y, the column from that row's conditional CDF with u.x, each inverted
/// within its bin linearly (the lecture's P⁻¹). Returns the world direction and its density
/// in solid angle; None without a map or at a pole.
pub fn env_sample(map: &EnvironmentMap, frame: &FrameParams, u: Vec2) -> Option<(Vec3, f32)> {
    let (w, h) = (frame.env_width, frame.env_height);
    if w == 0 {
        return None;
    }
    let (j, v0, v1) = cdf_search(&map.marginal, u.y);
    let y = (j as f32 + ((u.y - v0) / (v1 - v0)).clamp(0.0, 1.0)) / h as f32;
    let row = &map.conditional[(j * w) as usize..((j + 1) * w) as usize];
    let (i, c0, c1) = cdf_search(row, u.x);
    let x = (i as f32 + ((u.x - c0) / (c1 - c0)).clamp(0.0, 1.0)) / w as f32;
    let theta = PI * y;
    let phi = 2.0 * PI * (x - 0.5);
    let sin_theta = theta.sin();
    if !(sin_theta > 0.0) {
        return None;
    }
    let m = Vec3::new(sin_theta * phi.sin(), theta.cos(), -sin_theta * phi.cos());
    let pdf = (v1 - v0) * h as f32 * (c1 - c0) * w as f32 / (2.0 * PI * PI * sin_theta);
    Some((env_from_map(frame, m), pdf))
}

/// The map of `RenderSettings::environment_map`'s answer, or the empty one.
pub fn map_or_none(environment: &Option<(Arc<EnvironmentMap>, Vec3)>) -> &EnvironmentMap {
    environment
        .as_ref()
        .map_or(no_environment(), |(map, _)| map.as_ref())
}

/// An empty map: what the integrators read when there is no environment (frame.env_width 0).
pub fn no_environment() -> &'static EnvironmentMap {
    static EMPTY: EnvironmentMap = EnvironmentMap {
        width: 0,
        height: 0,
        texels: Vec::new(),
        marginal: Vec::new(),
        conditional: Vec::new(),
        power: 0.0,
    };
    &EMPTY
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame_for(map: &EnvironmentMap, degrees: f32) -> FrameParams {
        let mut frame = FrameParams::default();
        map.write_frame_params(Vec3::ONE, degrees, &mut frame);
        frame
    }

    #[test]
    fn rgbe_round_trips_the_radiance_format() {
        for c in [
            Vec3::new(1.0, 0.5, 0.25),
            Vec3::new(65536.0 * 3.0, 1.0, 0.0),
            Vec3::new(1e-20, 0.0, 3e-21),
        ] {
            let d = rgbe_decode(rgbe_encode(c));
            let m = c.max_element();
            assert!((d - c).abs().max_element() <= m / 128.0, "{c} → {d}");
            assert!(d.cmple(c).all(), "truncation never rounds up: {c} → {d}");
        }
        // Values a .hdr file holds are exact.
        let exact = Vec3::new(200.0, 3.0, 129.0) * 2f32.powi(-7);
        assert_eq!(rgbe_decode(rgbe_encode(exact)), exact);
        assert_eq!(rgbe_encode(Vec3::ZERO), 0);
        assert_eq!(rgbe_decode(0), Vec3::ZERO);
    }

    #[test]
    fn directions_and_texels_agree_with_the_convention() {
        // One bright texel at the map's centre column, on the horizon row: seen along −Z.
        let (w, h) = (8u32, 4u32);
        let mut rgb = vec![Vec3::splat(0.01); (w * h) as usize];
        rgb[(w + w / 2) as usize] = Vec3::new(5.0, 0.0, 0.0);
        let map = EnvironmentMap::from_rgb(w, h, &rgb).unwrap();
        let frame = frame_for(&map, 0.0);
        // Texel (4, 1) has its centre at u = 4.5/8, v = 1.5/4: θ = 3π/8, φ = π/8.
        let (theta, phi) = (1.5 / 4.0 * PI, (4.5 / 8.0 - 0.5) * 2.0 * PI);
        let d = Vec3::new(
            theta.sin() * phi.sin(),
            theta.cos(),
            -theta.sin() * phi.cos(),
        );
        assert!((env_radiance(&map, &frame, d).x - 5.0).abs() < 1e-3);
        // Turning the map by 90° about +Y brings that texel from near −Z to near −X.
        let turned = frame_for(&map, 90.0);
        let d90 = Vec3::new(
            -theta.sin() * phi.cos(),
            theta.cos(),
            -theta.sin() * phi.sin(),
        );
        assert!(
            (env_radiance(&map, &turned, d90).x - 5.0).abs() < 1e-3,
            "{}",
            env_radiance(&map, &turned, d90)
        );
        // Up is the top row.
        let (uv, s) = env_direction_uv(&frame, Vec3::Y);
        assert!(uv.y.abs() < 1e-6 && s == 0.0);
    }

    #[test]
    fn sample_pdf_equals_pdf_of_the_direction_and_integrates_to_one() {
        let (w, h) = (13u32, 7u32);
        let rgb: Vec<Vec3> = (0..w * h)
            .map(|k| {
                let u = crate::sampling::rng_uniform4(5, k, 0, 0);
                Vec3::new(u.x, u.y, u.z) * if k % 5 == 0 { 20.0 } else { 0.3 }
            })
            .collect();
        let map = EnvironmentMap::from_rgb(w, h, &rgb).unwrap();
        let frame = frame_for(&map, 33.0);
        let mut max_rel = 0f32;
        for k in 0..4000 {
            let u = crate::sampling::rng_uniform4(6, k, 0, 0);
            let (d, pdf) = env_sample(&map, &frame, Vec2::new(u.x, u.y)).unwrap();
            assert!((d.length() - 1.0).abs() < 1e-5);
            let again = env_pdf(&map, &frame, d);
            max_rel = max_rel.max((again - pdf).abs() / pdf);
        }
        // Only samples within rounding of a cell edge may read the neighbour's density.
        assert!(max_rel < 1e-2, "{max_rel}");
        // ∫ pdf dω = 1 by a midpoint rule fine enough to resolve every cell.
        let (n_theta, n_phi) = (700, 1300);
        let mut integral = 0f64;
        for a in 0..n_theta {
            let theta = (a as f32 + 0.5) / n_theta as f32 * PI;
            for b in 0..n_phi {
                let phi = (b as f32 + 0.5) / n_phi as f32 * 2.0 * PI;
                let d = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                integral += (env_pdf(&map, &frame, d) * theta.sin()) as f64;
            }
        }
        integral *= (PI as f64 / n_theta as f64) * (2.0 * PI as f64 / n_phi as f64);
        assert!((integral - 1.0).abs() < 5e-3, "∫ pdf dω = {integral}");
    }

    #[test]
    fn every_lit_direction_has_a_density() {
        // A single lit texel: its bilinear footprint reaches the neighbouring cells, and so
        // must the density.
        let (w, h) = (6u32, 6u32);
        let mut rgb = vec![Vec3::ZERO; (w * h) as usize];
        rgb[(2 * w + 5) as usize] = Vec3::ONE;
        let map = EnvironmentMap::from_rgb(w, h, &rgb).unwrap();
        let frame = frame_for(&map, 0.0);
        for k in 0..20000 {
            let u = crate::sampling::rng_uniform4(8, k, 0, 0);
            let z = 1.0 - 2.0 * u.x;
            let r = (1.0 - z * z).sqrt();
            let phi = 2.0 * PI * u.y;
            let d = Vec3::new(r * phi.cos(), z, r * phi.sin());
            if env_radiance(&map, &frame, d).max_element() > 0.0 {
                assert!(env_pdf(&map, &frame, d) > 0.0, "{d}");
            }
        }
    }
}
