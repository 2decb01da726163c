//! glTF textures → [`TextureSet`]: images decoded (PNG and JPEG; WebP for EXT_texture_webp;
//! KTX2 with a Basis Universal payload for KHR_texture_basisu, transcoded to RGBA8 by the
//! pure-Rust `basisu`; from a GLB buffer view, a data URI or a file inside the allowed folders),
//! checked against a size limit and the memory budget, turned into RGBA8 mip chains, and paired
//! with their samplers and the materials' `KHR_texture_transform`s.
//!
//! One `GpuTexture` per (glTF texture, colour space) a material uses; texels are shared between
//! textures that use the same image in the same colour space. Mip levels are 2×2 box averages
//! (the last row or column of an odd-sized level folds into its neighbour's average), computed
//! in linear light for sRGB textures and on the stored values for data textures.

use super::buffers::read_image_uri;
use super::json::{json_path, label};
use super::limits::LoadOptions;
use super::model::TextureSet;
use crate::layout::{
    GpuTexture, GpuTextureRef, FILTER_LINEAR, FILTER_NEAREST, MIN_LINEAR, MIN_LINEAR_MIPMAP_LINEAR,
    MIN_LINEAR_MIPMAP_NEAREST, MIN_NEAREST, MIN_NEAREST_MIPMAP_LINEAR, MIN_NEAREST_MIPMAP_NEAREST,
    WRAP_CLAMP_TO_EDGE, WRAP_MIRRORED_REPEAT, WRAP_REPEAT,
};
use crate::texture::linear_to_srgb;
use anyhow::{anyhow, bail, Context, Result};
use glam::Vec4;
use gltf::texture::{MagFilter, MinFilter, WrappingMode};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// The largest image side wavetrace decodes (larger images are refused, not resized).
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// Where a material's texture reference came from, for messages.
pub(super) struct TextureUse<'a> {
    /// The textureInfo's JSON path, e.g. `materials[3].normalTexture`.
    pub what: String,
    /// What follows a JSON path below `what` in messages: ` (material "Brick")`, or nothing.
    pub owner: String,
    pub info: TextureInfo<'a>,
    pub srgb: bool,
}

/// The parts of a glTF textureInfo wavetrace reads.
pub(super) struct TextureInfo<'a> {
    pub texture: gltf::Texture<'a>,
    pub tex_coord: u32,
    /// KHR_texture_transform: offset, rotation (radians), scale, texCoord override.
    pub transform: Option<([f32; 2], f32, [f32; 2], Option<u32>)>,
}

pub(super) struct TextureBuilder<'a> {
    /// The images a texture's extensions name by index (none in unit tests).
    document: Option<&'a gltf::Document>,
    buffers: &'a [Vec<u8>],
    base: &'a Path,
    options: &'a LoadOptions,
    pub set: TextureSet,
    /// (texture, sRGB) → index into `set.textures`.
    textures: HashMap<(usize, bool), u32>,
    /// (image, sRGB) → (first texel, width, height, levels), and the level-0 mean.
    images: HashMap<(usize, bool), ([u32; 4], [f32; 4])>,
    /// Texture coordinate sets each primitive's material needs are checked by the loader.
    pub max_tex_coord: u32,
}

impl<'a> TextureBuilder<'a> {
    pub fn new(
        document: Option<&'a gltf::Document>,
        buffers: &'a [Vec<u8>],
        base: &'a Path,
        options: &'a LoadOptions,
    ) -> Self {
        TextureBuilder {
            document,
            buffers,
            base,
            options,
            set: TextureSet::default(),
            textures: HashMap::new(),
            images: HashMap::new(),
            max_tex_coord: 0,
        }
    }

    /// The `GpuTextureRef` index of one use of a texture by a material.
    pub fn reference(&mut self, usage: TextureUse) -> Result<u32> {
        let TextureUse {
            what,
            owner,
            info,
            srgb,
        } = usage;
        let texture = self.texture(&info.texture, srgb).with_context(|| {
            format!(
                "{what}{owner}: {}",
                label("texture", info.texture.index(), info.texture.name())
            )
        })?;
        let (mut tex_coord, mut transform, mut offset) =
            (info.tex_coord, [1.0, 0.0, 0.0, 1.0], [0.0; 2]);
        let mut tex_coord_path = "texCoord";
        if let Some((o, rotation, scale, coord)) = info.transform {
            let finite = o.iter().chain(&scale).all(|v| v.is_finite()) && rotation.is_finite();
            if !finite {
                bail!("{what}.extensions.KHR_texture_transform{owner}: offset, rotation and scale must be finite");
            }
            // uv' = T · R · S · uv (KHR_texture_transform, "Transformation").
            let (s, c) = rotation.sin_cos();
            transform = [c * scale[0], s * scale[1], -s * scale[0], c * scale[1]];
            offset = o;
            if let Some(coord) = coord {
                tex_coord = coord;
                tex_coord_path = "extensions.KHR_texture_transform.texCoord";
            }
        }
        if tex_coord > 1 {
            bail!(
                "{what}.{tex_coord_path}{owner}: {tex_coord}, wavetrace reads texture coordinate sets 0 and 1"
            );
        }
        self.max_tex_coord = self.max_tex_coord.max(tex_coord);
        self.set.refs.push(GpuTextureRef {
            transform,
            offset,
            texture,
            texcoord: tex_coord,
        });
        Ok(self.set.refs.len() as u32 - 1)
    }

    fn texture(&mut self, texture: &gltf::Texture, srgb: bool) -> Result<u32> {
        if let Some(&index) = self.textures.get(&(texture.index(), srgb)) {
            return Ok(index);
        }
        let image = self.texture_image(texture)?;
        let ([texel_offset, width, height, levels], mean) =
            match self.images.get(&(image.index(), srgb)) {
                Some(&found) => found,
                None => {
                    let decoded = self.image(&image, srgb)?;
                    self.images.insert((image.index(), srgb), decoded);
                    decoded
                }
            };
        let sampler = texture.sampler();
        let wrap = |mode: WrappingMode| match mode {
            WrappingMode::ClampToEdge => WRAP_CLAMP_TO_EDGE,
            WrappingMode::MirroredRepeat => WRAP_MIRRORED_REPEAT,
            WrappingMode::Repeat => WRAP_REPEAT,
        };
        let mag = match sampler.mag_filter() {
            Some(MagFilter::Nearest) => FILTER_NEAREST,
            _ => FILTER_LINEAR,
        };
        let min = match sampler.min_filter() {
            Some(MinFilter::Nearest) => MIN_NEAREST,
            Some(MinFilter::Linear) => MIN_LINEAR,
            Some(MinFilter::NearestMipmapNearest) => MIN_NEAREST_MIPMAP_NEAREST,
            Some(MinFilter::LinearMipmapNearest) => MIN_LINEAR_MIPMAP_NEAREST,
            Some(MinFilter::NearestMipmapLinear) => MIN_NEAREST_MIPMAP_LINEAR,
            Some(MinFilter::LinearMipmapLinear) | None => MIN_LINEAR_MIPMAP_LINEAR,
        };
        self.set.textures.push(GpuTexture {
            texel_offset,
            width,
            height,
            levels,
            wrap_s: wrap(sampler.wrap_s()),
            wrap_t: wrap(sampler.wrap_t()),
            filters: mag | (min << 4),
            srgb: srgb as u32,
        });
        self.set.means.push(mean);
        let index = self.set.textures.len() as u32 - 1;
        self.textures.insert((texture.index(), srgb), index);
        Ok(index)
    }

    /// The image a texture shows: KHR_texture_basisu's (KTX2), else EXT_texture_webp's, else
    /// its core `source` (PNG or JPEG), the order the extensions ask of a loader that reads them.
    fn texture_image(&self, texture: &gltf::Texture<'a>) -> Result<gltf::Image<'a>> {
        for extension in ["KHR_texture_basisu", "EXT_texture_webp"] {
            let Some(value) = texture.extension_value(extension) else {
                continue;
            };
            let path = format!("extensions.{extension}.source");
            let index = value
                .get("source")
                .and_then(|v| v.as_u64())
                .ok_or_else(|| anyhow!("{path}: missing, expected an image index"))?;
            return self
                .document
                .and_then(|d| d.images().nth(index as usize))
                .ok_or_else(|| anyhow!("{path}: image {index} does not exist"));
        }
        texture.source().ok_or_else(|| {
            anyhow!("source: missing, expected an image index (or KHR_texture_basisu / EXT_texture_webp)")
        })
    }

    /// Reads and decodes an image and appends its mip chain to the texels; errors name the
    /// image's JSON path.
    fn image(&mut self, image: &gltf::Image, srgb: bool) -> Result<([u32; 4], [f32; 4])> {
        let path = json_path("image", image.index());
        let owner = match image.name() {
            Some(name) if !name.is_empty() => format!(" (image {name:?})"),
            _ => String::new(),
        };
        let (bytes, mime) = match image.source() {
            gltf::image::Source::View { view, mime_type } => {
                let buffer = &self.buffers[view.buffer().index()];
                let range = view.offset()..view.offset().saturating_add(view.length());
                let bytes = buffer.get(range.clone()).ok_or_else(|| {
                    anyhow!(
                        "{path}.bufferView{owner} = {}: bytes {}..{} lie outside {} of {} bytes",
                        label("bufferView", view.index(), view.name()),
                        range.start,
                        range.end,
                        label("buffer", view.buffer().index(), view.buffer().name()),
                        buffer.len()
                    )
                })?;
                (bytes.to_vec(), Some(mime_type.to_owned()))
            }
            gltf::image::Source::Uri { uri, mime_type } => (
                read_image_uri(uri, self.base, self.options)
                    .with_context(|| format!("{path}.uri{owner}"))?,
                mime_type.map(str::to_owned),
            ),
        };
        self.decode(bytes, mime, srgb)
            .with_context(|| format!("{path}{owner}"))
    }

    /// Decodes PNG, JPEG, WebP or KTX2 (Basis Universal) bytes (`mime` as declared, for
    /// messages) and appends the mip chain to the texels.
    fn decode(
        &mut self,
        bytes: Vec<u8>,
        mime: Option<String>,
        srgb: bool,
    ) -> Result<([u32; 4], [f32; 4])> {
        let (width, height, raw, channels) = if bytes.starts_with(&KTX2_IDENTIFIER) {
            self.transcode_ktx2(bytes)?
        } else {
            self.decode_image(bytes, mime)?
        };
        let texels_level0 = width as u64 * height as u64;
        let texels = std::sync::Arc::make_mut(&mut self.set.texels);
        let first = texels.len();
        if first as u64 + texels_level0 * 2 > u32::MAX as u64 {
            bail!("the scene's textures exceed 2³² texels");
        }
        // Level 0 straight from the decoded bytes into its place, on every core.
        let levels = push_mip_chain_with(texels, width, height, srgb, |level0| {
            level0
                .par_chunks_mut(ROWS_TEXELS)
                .zip(raw.par_chunks(ROWS_TEXELS * channels))
                .for_each(|(dst, src)| copy_texels(dst, src, channels));
        });
        drop(raw);
        self.options
            .budget
            .release(texels_level0 * DECODE_BYTES_PER_TEXEL);
        let mean = mean_texel(&texels[first..first + texels_level0 as usize], srgb);
        Ok(([first as u32, width, height, levels], mean))
    }

    /// A PNG, JPEG or WebP image's level 0 as 8-bit RGB or RGBA bytes, with the texels'
    /// `DECODE_BYTES_PER_TEXEL` reserved in the budget (released by [`decode`](Self::decode)).
    fn decode_image(
        &mut self,
        bytes: Vec<u8>,
        mime: Option<String>,
    ) -> Result<(u32, u32, Vec<u8>, usize)> {
        let format = image::guess_format(&bytes).ok();
        let format = match format {
            Some(
                f @ (image::ImageFormat::Png | image::ImageFormat::Jpeg | image::ImageFormat::WebP),
            ) => f,
            other => {
                let seen = match other {
                    Some(f) => format!("{f:?}"),
                    None => "unrecognised".to_owned(),
                };
                bail!(
                    "the image's data is {seen}{}, not PNG, JPEG, WebP or KTX2 (the image \
                     formats wavetrace reads)",
                    mime.map_or_else(String::new, |m| format!(" (declared {m:?})"))
                );
            }
        };
        // The header alone: its size is checked below, in a message that states it.
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(&bytes), format);
        let mut limits = image::Limits::default();
        limits.max_alloc = Some(
            self.options
                .budget
                .limit()
                .saturating_sub(self.options.budget.used()),
        );
        reader.limits(limits);
        let (width, height) = reader
            .into_dimensions()
            .map_err(|e| anyhow!("cannot read the {format:?} header: {e}"))?;
        check_side(width, height)?;
        self.reserve_decoding(width, height, &format!("{format:?}"))?;
        let mut reader = image::ImageReader::with_format(std::io::Cursor::new(&bytes), format);
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_IMAGE_SIDE);
        limits.max_image_height = Some(MAX_IMAGE_SIDE);
        reader.limits(limits);
        let decoded = reader
            .decode()
            .map_err(|e| anyhow!("cannot decode the {format:?} data: {e}"))?;
        drop(bytes);
        // RGB8 and RGBA8 (nearly every glTF image) are read as they are; other layouts are
        // converted to RGBA8 first. An RGB8 texel gets alpha 255, as `into_rgba8` gives it.
        Ok(match decoded {
            image::DynamicImage::ImageRgb8(rgb) => (width, height, rgb.into_raw(), 3),
            other => (width, height, other.into_rgba8().into_raw(), 4),
        })
    }

    /// A KTX2 texture's level 0 (KHR_texture_basisu: ETC1S or UASTC Basis Universal, with or
    /// without Zstandard supercompression) transcoded to RGBA8, as [`decode_image`] gives it.
    /// The file's own mip levels are not read: the chain is built from level 0 like any image's.
    fn transcode_ktx2(&mut self, bytes: Vec<u8>) -> Result<(u32, u32, Vec<u8>, usize)> {
        let transcoder = basisu::Transcoder::new(&bytes).map_err(|e| {
            anyhow!("cannot read the KTX2 file: {e:?} (wavetrace reads KTX2 with a Basis Universal payload)")
        })?;
        if transcoder.is_video() || transcoder.face_count() != 1 || transcoder.layer_count() > 1 {
            bail!(
                "the KTX2 file is a {} texture, but a glTF texture is a single 2D image",
                if transcoder.face_count() != 1 {
                    "cube map"
                } else if transcoder.is_video() {
                    "video"
                } else {
                    "array"
                }
            );
        }
        let (width, height) = transcoder.base_dimensions();
        check_side(width, height)?;
        self.reserve_decoding(width, height, "KTX2")?;
        let raw = transcoder
            .transcode(0, basisu::TargetFormat::Rgba32, basisu::DecodeFlags::NONE)
            .map_err(|e| anyhow!("cannot transcode the KTX2 file's level 0: {e:?}"))?;
        if raw.len() as u64 != width as u64 * height as u64 * 4 {
            bail!(
                "the KTX2 file's level 0 transcodes to {} bytes, not the {width} × {height} × 4 \
                 its header declares",
                raw.len()
            );
        }
        Ok((width, height, raw, 4))
    }

    /// Reserves what decoding an image of `width` × `height` texels takes.
    fn reserve_decoding(&self, width: u32, height: u32, format: &str) -> Result<()> {
        // Decoding (up to 16 bytes per texel for 16-bit RGBA) and the mip chain (4/3 · 4 bytes).
        let texels = width as u64 * height as u64;
        self.options.budget.reserve(
            &format!("decoding a {width} × {height} {format} image"),
            texels * (DECODE_BYTES_PER_TEXEL + 6),
        )
    }
}

/// The 12 bytes a KTX2 file begins with (KTX 2.0 specification, §3.1 "identifier").
const KTX2_IDENTIFIER: [u8; 12] = [
    0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A,
];

/// The most bytes a texel takes while its image is decoded (16-bit RGBA).
const DECODE_BYTES_PER_TEXEL: u64 = 16;

/// Refuses images with a side of 0 or over [`MAX_IMAGE_SIDE`].
fn check_side(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 || width > MAX_IMAGE_SIDE || height > MAX_IMAGE_SIDE {
        bail!("{width} × {height} texels: wavetrace reads images of 1 to {MAX_IMAGE_SIDE} texels a side");
    }
    Ok(())
}

/// Texels from 8-bit RGBA (`channels` 4) or RGB (3, alpha 255) bytes, each layout in a loop of
/// its own, whose channel count the compiler knows.
fn copy_texels(dst: &mut [u32], src: &[u8], channels: usize) {
    if channels == 4 {
        for (t, p) in dst.iter_mut().zip(src.chunks_exact(4)) {
            *t = u32::from_le_bytes([p[0], p[1], p[2], p[3]]);
        }
    } else {
        for (t, p) in dst.iter_mut().zip(src.chunks_exact(3)) {
            *t = u32::from_le_bytes([p[0], p[1], p[2], 255]);
        }
    }
}

/// Mean RGBA of a level, linear: per channel, how many texels hold each byte (exact counts,
/// made in pieces on every core and added), then the sum of each byte's linear value times its
/// count, in byte order, over the texel count. A sum texel by texel in texel order took one
/// thread 10 ns a texel (a tenth of loading DamagedHelmet); the two sums differ only in the
/// rounding of a double, far below the single-precision mean (test
/// `mean_texel_equals_the_sum_in_texel_order`).
fn mean_texel(texels: &[u32], srgb: bool) -> [f32; 4] {
    type Counts = [[u32; 256]; 4];
    let counts = texels
        .par_chunks(1 << 16)
        .map(|piece| {
            let mut counts: Box<Counts> = Box::new([[0; 256]; 4]);
            for &t in piece {
                for (k, c) in counts.iter_mut().enumerate() {
                    c[(t >> (8 * k)) as usize & 0xff] += 1;
                }
            }
            counts
        })
        .reduce(
            || Box::new([[0; 256]; 4]),
            |mut a, b| {
                for (x, y) in a.iter_mut().flatten().zip(b.iter().flatten()) {
                    *x += y;
                }
                a
            },
        );
    let mut sum = [0f64; 4];
    for byte in 0..256u32 {
        let v = crate::texture::unpack_texel(byte * 0x0101_0101, srgb).to_array();
        for (k, s) in sum.iter_mut().enumerate() {
            *s += counts[k][byte as usize] as f64 * v[k] as f64;
        }
    }
    sum.map(|s| (s / texels.len().max(1) as f64) as f32)
}

/// [`mean_texel`] as a sum in texel order, for checking.
#[cfg(test)]
fn mean_texel_in_order(texels: &[u32], srgb: bool) -> [f32; 4] {
    let mut sum = [0f64; 4];
    for &t in texels {
        let v = crate::texture::unpack_texel(t, srgb);
        for (s, c) in sum.iter_mut().zip(v.to_array()) {
            *s += c as f64;
        }
    }
    sum.map(|s| (s / texels.len().max(1) as f64) as f32)
}

/// Texels per parallel piece of a level-0 copy.
const ROWS_TEXELS: usize = 1 << 16;

/// Appends a `width` × `height` level 0, which `fill_level0` writes in its place, and every
/// smaller level down to 1 × 1, each made from the one before where it lies; returns the number
/// of levels. The whole chain is sized once: a level made apart and then appended was written
/// twice and faulted in twice, and the appends reallocated the texels.
fn push_mip_chain_with(
    out: &mut Vec<u32>,
    width: u32,
    height: u32,
    srgb: bool,
    fill_level0: impl FnOnce(&mut [u32]),
) -> u32 {
    let mut sizes = vec![(width, height)];
    while let Some(&(w, h)) = sizes.last().filter(|&&(w, h)| w > 1 || h > 1) {
        sizes.push(((w / 2).max(1), (h / 2).max(1)));
    }
    let total: usize = sizes.iter().map(|&(w, h)| (w * h) as usize).sum();
    let first = out.len();
    // Zeroed on every core: a fresh page costs ~2 µs to fault in on this VM, and a 8192² chain
    // is 90 000 pages, which `resize`'s one memset faulted in on one thread.
    out.par_extend(rayon::iter::repeat_n(0u32, total));
    let (level0, mut rest) = out[first..].split_at_mut((width * height) as usize);
    fill_level0(level0);
    let mut source: &[u32] = level0;
    // `unpack_texel` of every byte, read from tables: the same floats.
    let [colour, alpha]: [[f32; 256]; 2] = {
        let value = |byte: u32| crate::texture::unpack_texel(byte * 0x0101_0101, srgb);
        [
            std::array::from_fn(|b| value(b as u32).x),
            std::array::from_fn(|b| value(b as u32).w),
        ]
    };
    let decode = |t: u32| {
        let byte = |k: u32| (t >> (8 * k)) as usize & 0xff;
        Vec4::new(
            colour[byte(0)],
            colour[byte(1)],
            colour[byte(2)],
            alpha[byte(3)],
        )
    };
    let encode = |v: Vec4| {
        let c = |x: f32| if srgb { srgb_unorm8(x) } else { unorm8(x) };
        u32::from_le_bytes([c(v.x), c(v.y), c(v.z), unorm8(v.w)])
    };
    for pair in sizes.windows(2) {
        let [(w, h), (nw, nh)] = [pair[0], pair[1]];
        let (next, tail) = rest.split_at_mut((nw * nh) as usize);
        // Rows in parallel: each destination texel is a function of its source texels alone.
        next.par_chunks_mut(nw as usize)
            .enumerate()
            .for_each(|(y, row)| {
                // Source rows and columns this texel averages: 2y, 2y + 1 (and 2y + 2 for the
                // last texel of an odd-sized side).
                let ys = source_span(y as u32, nh, h);
                let source_row = |sy: u32| &source[(sy * w) as usize..][..w as usize];
                let rows =
                    (ys.len() == 2).then(|| (source_row(ys.start), source_row(ys.start + 1)));
                for (x, out) in row.iter_mut().enumerate() {
                    let xs = source_span(x as u32, nw, w);
                    if let (Some((upper, lower)), 2) = (rows, xs.len()) {
                        // A 2 × 2 box (nearly every texel): the loop's sum below in its order,
                        // ((0 + a + b) + c) + d, where 0 + a is a (no texel decodes to −0).
                        let sx = xs.start as usize;
                        let sum = decode(upper[sx])
                            + decode(upper[sx + 1])
                            + decode(lower[sx])
                            + decode(lower[sx + 1]);
                        *out = encode(sum / 4.0);
                        continue;
                    }
                    let mut sum = Vec4::ZERO;
                    for sy in ys.clone() {
                        for sx in xs.clone() {
                            sum += decode(source[(sy * w + sx) as usize]);
                        }
                    }
                    let n = (xs.len() * ys.len()) as f32;
                    *out = encode(sum / n);
                }
            });
        source = next;
        rest = tail;
    }
    sizes.len() as u32
}

/// An 8-bit channel of `x` (clamped to [0, 1]): round(x·255) with halves away from zero, as
/// `f32::round` has them, without its libm call (9 % of loading DamagedHelmet). NaN gives 0.
#[inline(always)]
#[allow(clippy::manual_clamp)] // clamp keeps NaN, which the unchecked conversion must not see
fn unorm8(x: f32) -> u8 {
    // max then min: NaN becomes 0, as `clamp` and `as u32` made it.
    let y = x.max(0.0).min(1.0) * 255.0;
    // SAFETY: y is in [0, 255], so it truncates to a u32 (one instruction instead of `as`'s
    // saturating conversion, a tenth of the mip chain's instructions).
    let whole = unsafe { y.to_int_unchecked::<u32>() };
    (whole + u32::from(y - whole as f32 >= 0.5)) as u8
}

/// For each byte b in 1..=255 the least linear value x in [0, 1] with
/// unorm8(linear_to_srgb(x)) ≥ b, found by bisection over the floats' bits (the encoding is
/// monotone in x; test `srgb_unorm8_equals_the_transfer_function`).
fn srgb_unorm8_thresholds() -> [f32; 255] {
    std::array::from_fn(|k| {
        let b = k as u8 + 1;
        let (mut lo, mut hi) = (0u32, 1f32.to_bits());
        while lo < hi {
            let mid = lo + (hi - lo) / 2;
            if unorm8(linear_to_srgb(f32::from_bits(mid))) >= b {
                hi = mid;
            } else {
                lo = mid + 1;
            }
        }
        f32::from_bits(lo)
    })
}

/// Linear values below this encode to byte 0: the first threshold lies above it (checked where
/// the buckets are made).
const SRGB_ENCODE_LOW: f32 = 1.0 / 16384.0;

/// The floats in [[`SRGB_ENCODE_LOW`], 1) fall into buckets by their bits above this one: their
/// exponent and top seven mantissa bits, 1 792 buckets each less than 1 % wide, where neighbouring
/// thresholds lie at least 0.9 % apart, so a bucket holds at most two.
const SRGB_BUCKET_SHIFT: u32 = 16;

/// The thresholds, and per bucket how many of them lie at or below its least float.
struct SrgbEncode {
    thresholds: [f32; 255],
    below: Vec<u8>,
}

static SRGB_ENCODE: std::sync::LazyLock<SrgbEncode> = std::sync::LazyLock::new(|| {
    let thresholds = srgb_unorm8_thresholds();
    assert!(thresholds[0] > SRGB_ENCODE_LOW && thresholds[254] <= 1.0);
    let (lo, hi) = (
        SRGB_ENCODE_LOW.to_bits() >> SRGB_BUCKET_SHIFT,
        1f32.to_bits() >> SRGB_BUCKET_SHIFT,
    );
    let below = (lo..hi)
        .map(|k| {
            let least = f32::from_bits(k << SRGB_BUCKET_SHIFT);
            thresholds.partition_point(|&t| t <= least) as u8
        })
        .collect();
    SrgbEncode { thresholds, below }
});

/// unorm8(linear_to_srgb(x)), the byte an sRGB mip level stores for linear `x`: the number of
/// thresholds at or below x — those at or below the least float of x's bucket, read from a
/// table, and the bucket's own (at most two) counted. A binary search over the thresholds took
/// eight dependent loads and comparisons per channel, most of the mip chain of a large texture.
fn srgb_unorm8(x: f32) -> u8 {
    if x >= 1.0 {
        return 255;
    }
    // Negative, NaN (which no threshold is at or below) and tiny values.
    if !(x >= SRGB_ENCODE_LOW) {
        return 0;
    }
    let e = &*SRGB_ENCODE;
    let bucket =
        (x.to_bits() >> SRGB_BUCKET_SHIFT) - (SRGB_ENCODE_LOW.to_bits() >> SRGB_BUCKET_SHIFT);
    let mut count = e.below[bucket as usize] as usize;
    while count < 255 && e.thresholds[count] <= x {
        count += 1;
    }
    count as u8
}

/// The source indices of destination index `i` of `n` when halving a side of `size` (a range:
/// one allocation per texel was most of the mip chain's time).
fn source_span(i: u32, n: u32, size: u32) -> std::ops::Range<u32> {
    if size == 1 {
        return 0..1;
    }
    let end = if i == n - 1 && size % 2 == 1 {
        2 * i + 3
    } else {
        2 * i + 2
    };
    2 * i..end
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mean from byte counts is the mean summed texel by texel, to the bit: random texels
    /// over several pieces and one, texels all alike, sRGB and linear. (Also checked on every
    /// texture of the sample models and the 8192² terrain: the same bits.)
    #[test]
    fn mean_texel_equals_the_sum_in_texel_order() {
        let mut x = 0x9e37_79b9u32;
        let mut random = || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            x
        };
        let sets: Vec<Vec<u32>> = vec![
            (0..300_000).map(|_| random()).collect(),
            (0..1000).map(|_| random() & 0x0f3f_ff7f).collect(),
            vec![0x80ff_4020; 70_000],
            vec![0xffff_ffff; 3],
            vec![],
        ];
        for texels in &sets {
            for srgb in [false, true] {
                let (fast, slow) = (mean_texel(texels, srgb), mean_texel_in_order(texels, srgb));
                assert_eq!(
                    fast.map(f32::to_bits),
                    slow.map(f32::to_bits),
                    "{} texels, sRGB {srgb}: {fast:?} against {slow:?}",
                    texels.len()
                );
            }
        }
    }

    /// Every float in [0, 1] (and beyond, and NaN) encodes to the byte the transfer function
    /// and rounding give: the thresholds are exact, so sRGB mip levels are the bytes they were.
    #[test]
    fn srgb_unorm8_equals_the_transfer_function() {
        let one = 1f32.to_bits();
        // Every 7th float up to just past 1, and each threshold's neighbours.
        let bad = (0..=one / 7 + 1)
            .into_par_iter()
            .map(|k| k * 7)
            .chain(
                SRGB_ENCODE
                    .thresholds
                    .par_iter()
                    .flat_map_iter(|t| t.to_bits() - 2..=t.to_bits() + 2),
            )
            // Each bucket's least float and its neighbours.
            .chain(
                (SRGB_ENCODE_LOW.to_bits() >> SRGB_BUCKET_SHIFT
                    ..=1f32.to_bits() >> SRGB_BUCKET_SHIFT)
                    .into_par_iter()
                    .flat_map_iter(|k| (k << SRGB_BUCKET_SHIFT) - 1..=(k << SRGB_BUCKET_SHIFT) + 1),
            )
            .map(f32::from_bits)
            .chain(
                [
                    -1.0,
                    -0.0,
                    2.0,
                    f32::NAN,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    SRGB_ENCODE_LOW,
                ]
                .into_par_iter(),
            )
            .find_any(|&x| srgb_unorm8(x) != unorm8(linear_to_srgb(x)));
        assert_eq!(bad, None);
        for (x, byte) in [(0.0, 0), (1.0, 255), (0.5, 188), (0.0031308, 10)] {
            assert_eq!(srgb_unorm8(x), byte, "{x}");
        }
        // unorm8 is round(clamp(x, 0, 1) · 255), NaN giving 0, on every seventh float.
        let bad = (0..=u32::MAX / 7)
            .into_par_iter()
            .map(|k| f32::from_bits(7 * k))
            .find_any(|&x| unorm8(x) != (x.clamp(0.0, 1.0) * 255.0).round() as u8);
        assert_eq!(bad, None);
        for k in 0..=255u32 {
            let x = k as f32 / 255.0;
            assert_eq!(unorm8(x), (x * 255.0).round() as u8);
            assert_eq!(
                unorm8(x + 0.5 / 255.0),
                ((x + 0.5 / 255.0).min(1.0) * 255.0).round() as u8
            );
        }
    }

    /// An RGB8 image (read as it is, alpha 255) and the same image as RGBA8 with alpha 255 (read
    /// through `into_rgba8`'s layout) decode to the same texels, mip chain and mean, in sRGB and
    /// linear; a grey image (converted) too.
    #[test]
    fn rgb_and_rgba_images_decode_to_the_same_texels() {
        let (w, h) = (7u32, 5u32);
        let rgb = image::RgbImage::from_fn(w, h, |x, y| {
            image::Rgb([(x * 37 + y * 11) as u8, (x * 5 + 200) as u8, (y * 51) as u8])
        });
        let rgba = image::RgbaImage::from_fn(w, h, |x, y| {
            let p = rgb.get_pixel(x, y).0;
            image::Rgba([p[0], p[1], p[2], 255])
        });
        let grey = image::GrayImage::from_fn(w, h, |x, y| image::Luma([(x * 30 + y) as u8]));
        let grey_rgba = image::RgbaImage::from_fn(w, h, |x, y| {
            let v = grey.get_pixel(x, y).0[0];
            image::Rgba([v, v, v, 255])
        });
        let png = |img: image::DynamicImage| {
            let mut bytes = Vec::new();
            img.write_to(
                &mut std::io::Cursor::new(&mut bytes),
                image::ImageFormat::Png,
            )
            .unwrap();
            bytes
        };
        let options = LoadOptions::default();
        for srgb in [false, true] {
            for (a, b) in [
                (rgb.clone().into(), rgba.clone().into()),
                (grey.clone().into(), grey_rgba.clone().into()),
            ] {
                let decode = |img: image::DynamicImage| {
                    let mut builder = TextureBuilder::new(None, &[], Path::new("."), &options);
                    let info = builder.decode(png(img), None, srgb).unwrap();
                    (info, builder.set.texels.as_slice().to_vec())
                };
                let (got, want) = (decode(a), decode(b));
                assert_eq!(got.0 .0, want.0 .0, "srgb {srgb}");
                assert_eq!(got.0 .1.map(f32::to_bits), want.0 .1.map(f32::to_bits));
                assert_eq!(got.1, want.1, "srgb {srgb}");
            }
        }
    }

    /// Each level as the box filter's loop writes it — every source texel decoded, summed in
    /// row-major order, divided by their number and encoded — byte for byte: the 2 × 2 form the
    /// chain takes for nearly every texel reads the same four texels and adds them in that
    /// order. Odd and even sides, sRGB and linear, random texels.
    #[test]
    fn mip_chains_equal_the_box_filter_loop() {
        let mut x = 0x1234_5678u32;
        for (w, h) in [(8u32, 8u32), (7, 5), (1, 9), (6, 1), (33, 18)] {
            let level0: Vec<u32> = (0..w * h)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 17;
                    x ^= x << 5;
                    x
                })
                .collect();
            for srgb in [false, true] {
                let mut out = Vec::new();
                push_mip_chain_with(&mut out, w, h, srgb, |l| l.copy_from_slice(&level0));
                let mut expected = level0.clone();
                let (mut source, mut sw, mut sh) = (level0.clone(), w, h);
                while sw > 1 || sh > 1 {
                    let (nw, nh) = ((sw / 2).max(1), (sh / 2).max(1));
                    let mut next = Vec::new();
                    for y in 0..nh {
                        for x in 0..nw {
                            let mut sum = [0f32; 4];
                            let (ys, xs) = (source_span(y, nh, sh), source_span(x, nw, sw));
                            for sy in ys.clone() {
                                for sx in xs.clone() {
                                    let v = crate::texture::unpack_texel(
                                        source[(sy * sw + sx) as usize],
                                        srgb,
                                    );
                                    for (s, c) in sum.iter_mut().zip(v.to_array()) {
                                        *s += c;
                                    }
                                }
                            }
                            let n = (xs.len() * ys.len()) as f32;
                            let v = sum.map(|s| s / n);
                            let c = |x: f32| if srgb { srgb_unorm8(x) } else { unorm8(x) };
                            next.push(u32::from_le_bytes([
                                c(v[0]),
                                c(v[1]),
                                c(v[2]),
                                unorm8(v[3]),
                            ]));
                        }
                    }
                    expected.extend(&next);
                    (source, sw, sh) = (next, nw, nh);
                }
                assert_eq!(out, expected, "{w}×{h}, sRGB {srgb}");
            }
        }
    }

    #[test]
    fn mip_chains_halve_to_one_texel_and_keep_the_mean() {
        let (w, h) = (5u32, 3u32);
        let level0: Vec<u32> = (0..w * h)
            .map(|i| u32::from_le_bytes([(i * 17) as u8, 100, 200, 255]))
            .collect();
        let mut out = Vec::new();
        let levels = push_mip_chain_with(&mut out, w, h, false, |l| l.copy_from_slice(&level0));
        assert_eq!(levels, 3);
        assert_eq!(out.len(), 15 + 2 + 1);
        assert_eq!(&out[..15], &level0[..]);
        let top = crate::texture::unpack_texel(out[17], false);
        assert!((top.y - 100.0 / 255.0).abs() < 1e-6);
        // A power-of-two image's last level is its mean, up to 8-bit rounding at each level.
        let level0: Vec<u32> = (0..16u32)
            .map(|i| u32::from_le_bytes([(i * 13) as u8, 0, 0, 255]))
            .collect();
        let mut out = Vec::new();
        assert_eq!(
            push_mip_chain_with(&mut out, 4, 4, true, |l| l.copy_from_slice(&level0)),
            3
        );
        let top = crate::texture::unpack_texel(out[20], true);
        let mean = mean_texel(&level0, true);
        assert!((top.x - mean[0]).abs() < 3.0 / 255.0, "{top} vs {mean:?}");
    }
}
