//! Writing a film to disk and reading EXR images back.
//!
//! - `.exr`: one unnamed layer: `R`, `G`, `B` (linear mean radiance; `A` with
//!   `--transparent`), `variance.R/G/B` (variance of the pixel mean), u32 `count` (finite
//!   samples) and the film's own accumulators `sum.R/G/B` and `sum_sq.R/G/B` (so that shards
//!   merge exactly, `shard.rs`); AOV layers beside them (`NAME.R`, `NAME.X`, `depth.Z`,
//!   `NAME.id`, …, [`LayerKind`]). The statistics and the depth and position layers are always
//!   f32; the beauty and the colour, normal and uv layers are f32 or f16
//!   (`--exr-precision`). Compressed with ZIP unless `--exr-compression` says otherwise. Text
//!   attributes carry the render's settings (`shard::Record`). Written to a temporary file in the
//!   same folder and renamed, so that an interrupted write never leaves a truncated image.
//! - `.png` (8 or 16 bits), `.jpg`/`.jpeg`: linear mean × 2^exposure through a view transform
//!   (`view.rs`), then the sRGB transfer function of IEC 61966-2-1, rounded to nearest; with
//!   alpha (straight, not premultiplied) where the render is transparent (PNG only).
//! - `.hdr`: Radiance RGBE of the linear mean × 2^exposure, no view transform.
//!
//! Rows run top to bottom; pixel (0, 0) is the top-left corner, as in the film.

use crate::film::Film;
use crate::layout::FilmPixel;
use crate::view::View;
use anyhow::{bail, Context};
use exr::prelude::*;
use std::path::Path;

/// Extensions `write_image` understands (lower case).
pub const SUPPORTED_EXTENSIONS: &[&str] = &["exr", "png", "jpg", "jpeg", "hdr"];

/// The sample precision of the EXR's image channels (`--exr-precision`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ExrPrecision {
    Half,
    #[default]
    Float,
}

/// How an output is encoded: the display transform of PNG and JPEG, their depth and quality,
/// the EXR's precision and compression.
#[derive(Clone, Copy, Debug)]
pub struct WriteOptions {
    /// Stops applied before the view transform (PNG, JPEG, HDR; not EXR).
    pub exposure: f32,
    pub view: View,
    /// 8 or 16 bits per PNG channel.
    pub png_bits: u8,
    /// JPEG quality, 1–100.
    pub jpeg_quality: u8,
    pub exr_precision: ExrPrecision,
    pub exr_compression: exr::compression::Compression,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions {
            exposure: 0.0,
            view: View::default(),
            png_bits: 8,
            jpeg_quality: 90,
            exr_precision: ExrPrecision::Float,
            exr_compression: exr::compression::Compression::ZIP16,
        }
    }
}

/// What an AOV layer holds, which names its EXR channels.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LayerKind {
    /// Radiance of the paths an expression matches (`--aov NAME=EXPR`): `NAME.R/G/B` and
    /// `NAME.variance.R/G/B`.
    Paths,
    /// A colour (albedo, emission): `NAME.R/G/B`.
    Color,
    /// A direction in [−1, 1] (normal): `NAME.X/Y/Z`.
    Direction,
    /// A point in scene units (position): `NAME.X/Y/Z`, always f32.
    Point,
    /// A distance in scene units: `NAME.Z`, always f32.
    Depth,
    /// Texture coordinates: `NAME.U/V`.
    Uv,
    /// An identifier, exact: u32 `NAME.id`.
    Id,
    /// Coverage: the beauty's `A` channel.
    Alpha,
}

/// An image of the same size as the beauty, written beside it.
#[derive(Clone, Debug)]
pub struct Layer {
    pub name: String,
    pub kind: LayerKind,
    pub film: Film,
}

/// Writes by extension (case-insensitive): `.exr` → linear RGB mean in channels R, G, B plus
/// "variance.R", "variance.G", "variance.B" (variance of the pixel mean, f32) and "count" (u32);
/// `.png` → 8-bit sRGB of the mean × 2^exposure through the default view transform (`exposure`
/// is ignored for EXR). Other extensions are an error naming the path and the supported ones.
pub fn write_image(film: &Film, path: &Path, exposure: f32) -> anyhow::Result<()> {
    write_image_with(film, path, exposure, &[])
}

/// [`write_image`] with text attributes (name, value) in the EXR's header (ignored for PNG).
pub fn write_image_with(
    film: &Film,
    path: &Path,
    exposure: f32,
    attributes: &[(String, String)],
) -> anyhow::Result<()> {
    write_image_layers(film, &[], path, exposure, attributes)
}

/// [`write_image_with`] and extra named images of the same size (`--aov NAME=EXPR`): in an EXR
/// as channels NAME.R, NAME.G, NAME.B, NAME.variance.R, … beside the image's; beside a PNG as
/// files STEM.NAME.png.
pub fn write_image_layers(
    film: &Film,
    layers: &[(String, Film)],
    path: &Path,
    exposure: f32,
    attributes: &[(String, String)],
) -> anyhow::Result<()> {
    let layers: Vec<Layer> = layers
        .iter()
        .map(|(name, film)| Layer {
            name: name.clone(),
            kind: LayerKind::Paths,
            film: film.clone(),
        })
        .collect();
    let options = WriteOptions {
        exposure,
        ..Default::default()
    };
    write_output(film, &layers, path, &options, attributes)
}

/// The lower-case extension of `path`, if it has one.
pub fn extension(path: &Path) -> Option<String> {
    path.extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
}

/// Writes `film` and its `layers` to `path` by its extension (case-insensitive) as `options`
/// say; the EXR's header carries `attributes`. Beside a display image (PNG, JPEG) each layer is
/// a file STEM.NAME.EXT of its own (a colour through the view transform, a normal as n/2 + 1/2,
/// uv as (u, v, 0)); depth, position and ID layers need an EXR. An `alpha` layer is the image's
/// alpha (EXR `A`, PNG alpha), not a file.
pub fn write_output(
    film: &Film,
    layers: &[Layer],
    path: &Path,
    options: &WriteOptions,
    attributes: &[(String, String)],
) -> anyhow::Result<()> {
    let ext = extension(path);
    let alpha = layers.iter().find(|l| l.kind == LayerKind::Alpha);
    let display = matches!(ext.as_deref(), Some("png" | "jpg" | "jpeg"));
    if display || ext.as_deref() == Some("hdr") {
        for layer in layers.iter().filter(|l| l.kind != LayerKind::Alpha) {
            if !display
                || matches!(
                    layer.kind,
                    LayerKind::Point | LayerKind::Depth | LayerKind::Id
                )
            {
                bail!(
                    "cannot write layer {} beside {}: write an .exr to keep it",
                    layer.name,
                    path.display()
                );
            }
            let sibling = path.with_extension(format!(
                "{}.{}",
                layer.name,
                ext.as_deref().unwrap_or("png")
            ));
            let (layer_options, encode) = match layer.kind {
                LayerKind::Paths | LayerKind::Color => (*options, Encode::View),
                _ => (*options, Encode::Data(layer.kind)),
            };
            write_display(&layer.film, None, &sibling, &layer_options, encode)
                .with_context(|| format!("writing image {}", sibling.display()))?;
        }
    }
    match ext.as_deref() {
        Some("exr") => write_exr(film, layers, path, options, attributes)
            .with_context(|| format!("writing OpenEXR image {}", path.display())),
        Some("png" | "jpg" | "jpeg") => {
            write_display(film, alpha.map(|a| &a.film), path, options, Encode::View)
                .with_context(|| format!("writing image {}", path.display()))
        }
        Some("hdr") => write_hdr(film, path, options.exposure)
            .with_context(|| format!("writing Radiance HDR image {}", path.display())),
        _ => bail!(
            "cannot write image {}: unknown extension; supported: {}",
            path.display(),
            SUPPORTED_EXTENSIONS
                .iter()
                .map(|e| format!(".{e}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}

/// An image read back from an EXR file, row-major with the top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageData {
    pub width: u32,
    pub height: u32,
    /// Linear RGB (channels R, G, B).
    pub mean: Vec<[f32; 3]>,
    /// Variance of the pixel mean (channels variance.R/G/B), if the file has all three.
    pub variance: Option<Vec<[f32; 3]>>,
    /// Samples per pixel (channel "count"), if the file has it.
    pub count: Option<Vec<u32>>,
}

/// Reads the first layer of an EXR file: channels R, G, B are required; variance.R/G/B and
/// count are returned when present. Errors name the path.
pub fn read_exr(path: &Path) -> anyhow::Result<ImageData> {
    read_exr_inner(path, "").with_context(|| format!("reading OpenEXR image {}", path.display()))
}

/// The extra layer `name` of an EXR written with `--aov NAME=EXPR` (channels NAME.R, …,
/// NAME.variance.R, …; the count is the image's).
pub fn read_exr_layer(path: &Path, name: &str) -> anyhow::Result<ImageData> {
    read_exr_inner(path, &format!("{name}."))
        .with_context(|| format!("reading layer {name} of OpenEXR image {}", path.display()))
}

/// A film rebuilt from an EXR that wavetrace wrote (mean, variance of the mean and count), for
/// comparing saved renders: sum = n·mean, sum of squares = (n − 1)·s² + n·mean², s² = n·variance.
pub fn read_film(path: &Path) -> anyhow::Result<Film> {
    let image = read_exr(path)?;
    let (Some(variance), Some(count)) = (&image.variance, &image.count) else {
        bail!(
            "{}: the EXR has no variance.R/G/B and count channels; only EXRs written by wavetrace can be compared",
            path.display()
        );
    };
    let pixels = image
        .mean
        .iter()
        .zip(variance)
        .zip(count)
        .map(|((mean, var), &n)| {
            let nf = n as f64;
            let mut p = FilmPixel {
                count: n,
                ..Default::default()
            };
            for c in 0..3 {
                let (m, v) = (mean[c] as f64, var[c] as f64);
                p.sum[c] = (nf * m) as f32;
                p.sum_sq[c] = ((nf - 1.0).max(0.0) * nf * v + nf * m * m) as f32;
            }
            p
        })
        .collect();
    Ok(Film::from_pixels(image.width, image.height, pixels, 0))
}

/// A film with its exact accumulators from the `sum.*`, `sum_sq.*` and `count` channels when
/// the file has them (written by wavetrace since shards), else rebuilt as [`read_film`] does;
/// and the file's text attributes (name, value).
pub fn read_film_exact(path: &Path) -> anyhow::Result<(Film, Vec<(String, String)>)> {
    read_film_exact_inner(path).with_context(|| format!("reading OpenEXR image {}", path.display()))
}

fn read_film_exact_inner(path: &Path) -> anyhow::Result<(Film, Vec<(String, String)>)> {
    let image = read_first_flat_layer_from_file(path)?;
    let layer = &image.layer_data;
    let attributes: Vec<(String, String)> = layer
        .attributes
        .other
        .iter()
        .chain(&image.attributes.other)
        .filter_map(|(k, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    let channel = |name: &str| find_channel(layer, name);
    let f32s = |name: &str| match channel(name) {
        Some(FlatSamples::F32(v)) => Some(v),
        _ => None,
    };
    let sums: Option<Vec<&Vec<f32>>> = [
        "sum.R", "sum.G", "sum.B", "sum_sq.R", "sum_sq.G", "sum_sq.B",
    ]
    .iter()
    .map(|n| f32s(n))
    .collect();
    let (Some(sums), Some(FlatSamples::U32(count))) = (sums, channel("count")) else {
        drop(image);
        return Ok((read_film(path)?, attributes));
    };
    let (width, height) = (layer.size.width() as u32, layer.size.height() as u32);
    let pixels = (0..count.len())
        .map(|i| FilmPixel {
            sum: [sums[0][i], sums[1][i], sums[2][i]],
            sum_sq: [sums[3][i], sums[4][i], sums[5][i]],
            count: count[i],
            ..Default::default()
        })
        .collect();
    Ok((Film::from_pixels(width, height, pixels, 0), attributes))
}

/// The channels of `film`'s mean, named `{prefix}{names[c]}`, as f32 or f16.
fn mean_channels(
    film: &Film,
    prefix: &str,
    names: &[&str],
    precision: ExrPrecision,
) -> Vec<AnyChannel<FlatSamples>> {
    names
        .iter()
        .enumerate()
        .map(|(c, name)| {
            let plane = (0..film.len()).map(|p| film.mean(p)[c]);
            let samples = match precision {
                ExrPrecision::Float => FlatSamples::F32(plane.collect()),
                ExrPrecision::Half => FlatSamples::F16(plane.map(f16::from_f32).collect()),
            };
            AnyChannel::new(format!("{prefix}{name}").as_str(), samples)
        })
        .collect()
}

/// The variance-of-the-mean channels of `film`, named `{prefix}variance.R`, … (f32).
fn variance_channels(film: &Film, prefix: &str) -> Vec<AnyChannel<FlatSamples>> {
    (0..3)
        .map(|c| {
            let plane = (0..film.len())
                .map(|p| film.variance_of_mean(p)[c])
                .collect();
            AnyChannel::new(
                format!("{prefix}variance.{}", ["R", "G", "B"][c]).as_str(),
                FlatSamples::F32(plane),
            )
        })
        .collect()
}

/// The EXR channels of an AOV layer ([`LayerKind`] names them).
fn layer_channels(layer: &Layer, precision: ExrPrecision) -> Vec<AnyChannel<FlatSamples>> {
    let prefix = format!("{}.", layer.name);
    let film = &layer.film;
    match layer.kind {
        LayerKind::Paths => {
            let mut list = mean_channels(film, &prefix, &["R", "G", "B"], precision);
            list.extend(variance_channels(film, &prefix));
            list
        }
        LayerKind::Color => mean_channels(film, &prefix, &["R", "G", "B"], precision),
        LayerKind::Direction => mean_channels(film, &prefix, &["X", "Y", "Z"], precision),
        LayerKind::Point => mean_channels(film, &prefix, &["X", "Y", "Z"], ExrPrecision::Float),
        LayerKind::Depth => mean_channels(film, &prefix, &["Z"], ExrPrecision::Float),
        LayerKind::Uv => mean_channels(film, &prefix, &["U", "V"], precision),
        LayerKind::Id => {
            let ids = (0..film.len())
                .map(|p| film.mean(p)[0].round() as u32)
                .collect();
            vec![AnyChannel::new(
                format!("{prefix}id").as_str(),
                FlatSamples::U32(ids),
            )]
        }
        LayerKind::Alpha => mean_channels(film, "", &["A"], precision),
    }
}

fn write_exr(
    film: &Film,
    layers: &[Layer],
    path: &Path,
    options: &WriteOptions,
    attributes: &[(String, String)],
) -> anyhow::Result<()> {
    let count: Vec<u32> = film.pixels.iter().map(|p| p.count).collect();
    let plane = |f: fn(&FilmPixel) -> f32| -> Vec<f32> { film.pixels.iter().map(f).collect() };
    let mut list = mean_channels(film, "", &["R", "G", "B"], options.exr_precision);
    // A lossy compression (DWA) would change the statistics too: they are left out rather
    // than written wrong, so merge and compare refuse such a file by name.
    let lossy = matches!(
        options.exr_compression,
        exr::compression::Compression::DWAA(_) | exr::compression::Compression::DWAB(_)
    );
    if !lossy {
        list.extend(variance_channels(film, ""));
    }
    for layer in layers {
        let mut channels = layer_channels(layer, options.exr_precision);
        if lossy {
            channels.retain(|c| !c.name.to_string().contains(".variance."));
        }
        list.extend(channels);
    }
    if !lossy {
        list.extend([
            AnyChannel::new("count", FlatSamples::U32(count)),
            AnyChannel::new("sum.R", FlatSamples::F32(plane(|p| p.sum[0]))),
            AnyChannel::new("sum.G", FlatSamples::F32(plane(|p| p.sum[1]))),
            AnyChannel::new("sum.B", FlatSamples::F32(plane(|p| p.sum[2]))),
            AnyChannel::new("sum_sq.R", FlatSamples::F32(plane(|p| p.sum_sq[0]))),
            AnyChannel::new("sum_sq.G", FlatSamples::F32(plane(|p| p.sum_sq[1]))),
            AnyChannel::new("sum_sq.B", FlatSamples::F32(plane(|p| p.sum_sq[2]))),
        ]);
    }
    let channels = AnyChannels::sort(SmallVec::from_vec(list));
    let size = (film.width as usize, film.height as usize);
    let mut layer_attributes = LayerAttributes::default();
    for (name, value) in attributes {
        let Some(name) = Text::new_or_none(name) else {
            bail!("the attribute name {name} is not Latin-1 text");
        };
        // Values are informative text (e.g. the scene's path): characters outside Latin-1 become '?'.
        let value: String = value
            .chars()
            .map(|c| if (c as u32) < 256 { c } else { '?' })
            .collect();
        let value = Text::new_or_panic(value);
        layer_attributes
            .other
            .insert(name, exr::meta::attribute::AttributeValue::Text(value));
    }
    let encoding = exr::image::Encoding {
        compression: options.exr_compression,
        ..exr::image::Encoding::SMALL_LOSSLESS
    };
    let layer = exr::image::Layer::new(size, layer_attributes, encoding, channels);
    // Write beside the target and rename: a reader (or a second signal) never sees half a file.
    let mut temporary = path.as_os_str().to_owned();
    temporary.push(format!(".{}.partial", std::process::id()));
    let temporary = std::path::PathBuf::from(temporary);
    let written = Image::from_layer(layer)
        .write()
        .to_file(&temporary)
        .map_err(anyhow::Error::from)
        .and_then(|()| sort_exr_header(&temporary));
    if let Err(e) = written {
        let _ = std::fs::remove_file(&temporary);
        return Err(e);
    }
    std::fs::rename(&temporary, path)?;
    Ok(())
}

/// Puts the header attributes of the single-part EXR file at `path` in name order, in place, so
/// that the same render writes the same bytes: the exr crate keeps a layer's own attributes (the
/// render's record) in a `HashMap` and writes them in its iteration order, which differs from
/// process to process. OpenEXR gives the order no meaning (a header is a run of name, type, size
/// and value, ended by an empty name), and sorting keeps the header's length, so the offset
/// table after it stays right. Files that are not single-part are left as they are.
fn sort_exr_header(path: &Path) -> anyhow::Result<()> {
    use std::io::{Read, Seek, SeekFrom, Write};
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)?;
    // The header is a few KiB: read until it ends inside what was read.
    let (mut head, mut chunk) = (Vec::new(), vec![0u8; 16 << 10]);
    let (attributes, end) = loop {
        let n = file.read(&mut chunk)?;
        head.extend_from_slice(&chunk[..n]);
        if head.len() >= 8 && !single_part_exr(&head) {
            return Ok(());
        }
        if let Some(found) = exr_header_attributes(&head) {
            break found;
        }
        if n == 0 {
            return Ok(());
        }
    };
    let mut sorted = attributes.clone();
    sorted.sort_by(|a, b| exr_attribute_name(&head, a).cmp(exr_attribute_name(&head, b)));
    let bytes: Vec<u8> = sorted
        .iter()
        .flat_map(|r| &head[r.clone()])
        .copied()
        .collect();
    let start = attributes.first().map_or(end, |r| r.start);
    debug_assert_eq!(start + bytes.len() + 1, end);
    file.seek(SeekFrom::Start(start as u64))?;
    file.write_all(&bytes)?;
    Ok(())
}

/// Whether `bytes` (at least 8) open a single-part EXR image: the magic number, and neither the
/// multi-part nor the deep bit of the version field (the tiled bit may be set).
fn single_part_exr(bytes: &[u8]) -> bool {
    const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    const MULTIPART_OR_DEEP: u32 = 0x1000 | 0x800;
    let version = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]);
    bytes[..4] == MAGIC && version & MULTIPART_OR_DEEP == 0
}

/// The byte ranges of the attributes of the single-part EXR header at the start of `bytes`, and
/// where the header ends (after its terminating empty name); `None` where `bytes` end first.
fn exr_header_attributes(bytes: &[u8]) -> Option<(Vec<std::ops::Range<usize>>, usize)> {
    let null_after = |at: usize| Some(at + bytes.get(at..)?.iter().position(|&b| b == 0)?);
    let (mut at, mut ranges) = (8, Vec::new());
    loop {
        let name_end = null_after(at)?;
        if name_end == at {
            return Some((ranges, at + 1));
        }
        let type_end = null_after(name_end + 1)?;
        let size = u32::from_le_bytes(bytes.get(type_end + 1..type_end + 5)?.try_into().ok()?);
        let end = type_end + 5 + size as usize;
        if end > bytes.len() {
            return None;
        }
        ranges.push(at..end);
        at = end;
    }
}

/// The name of the attribute at `range` of an EXR header (up to its null).
fn exr_attribute_name<'a>(bytes: &'a [u8], range: &std::ops::Range<usize>) -> &'a [u8] {
    let a = &bytes[range.clone()];
    &a[..a.iter().position(|&b| b == 0).unwrap_or(a.len())]
}

/// The samples of channel `name` of a flat layer, if it has one.
fn find_channel<'a>(
    layer: &'a exr::image::Layer<AnyChannels<FlatSamples>>,
    name: &str,
) -> Option<&'a FlatSamples> {
    layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name == *name)
        .map(|c| &c.sample_data)
}

fn read_exr_inner(path: &Path, prefix: &str) -> anyhow::Result<ImageData> {
    let image = read_first_flat_layer_from_file(path)?;
    let layer = &image.layer_data;
    let (width, height) = (layer.size.width(), layer.size.height());
    let channel = |name: &str| find_channel(layer, name);
    let rgb = |names: [&str; 3]| -> Option<Vec<[f32; 3]>> {
        let planes: Vec<Vec<f32>> = names
            .iter()
            .map(|n| channel(&format!("{prefix}{n}")).map(|s| s.values_as_f32().collect()))
            .collect::<Option<_>>()?;
        Some(
            (0..width * height)
                .map(|i| [planes[0][i], planes[1][i], planes[2][i]])
                .collect(),
        )
    };
    let Some(mean) = rgb(["R", "G", "B"]) else {
        let names: Vec<String> = layer
            .channel_data
            .list
            .iter()
            .map(|c| c.name.to_string())
            .collect();
        bail!(
            "the first layer has no {prefix}R, {prefix}G, {prefix}B channels (it has: {})",
            names.join(", ")
        );
    };
    let variance = rgb(["variance.R", "variance.G", "variance.B"]);
    let count = channel("count").map(|s| match s {
        FlatSamples::U32(v) => v.clone(),
        other => other.values_as_f32().map(|c| c as u32).collect(),
    });
    Ok(ImageData {
        width: width as u32,
        height: height as u32,
        mean,
        variance,
        count,
    })
}

/// How a display image encodes a film: radiance through the view transform, or data as it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Encode {
    View,
    Data(LayerKind),
}

/// A PNG (8 or 16 bits) or a JPEG of `film`: radiance × 2^exposure through the view transform
/// then sRGB-encoded, or data (normals as n/2 + 1/2, uv as (u, v, 0)) linear; with `alpha`,
/// an RGBA PNG whose colour is un-premultiplied (PNG's alpha is straight).
fn write_display(
    film: &Film,
    alpha: Option<&Film>,
    path: &Path,
    options: &WriteOptions,
    encode: Encode,
) -> anyhow::Result<()> {
    let jpeg = matches!(extension(path).as_deref(), Some("jpg" | "jpeg"));
    let scale = options.exposure.exp2();
    let alpha = alpha.filter(|_| !jpeg);
    let channels = if alpha.is_some() { 4 } else { 3 };
    let mut values: Vec<f64> = Vec::with_capacity(film.len() * channels);
    for p in 0..film.len() {
        let m = film.mean(p).to_array();
        let a = alpha.map(|a| a.mean(p)[0].clamp(0.0, 1.0));
        let shown = match encode {
            Encode::View => {
                // Straight alpha: the colour of the covered part of the pixel.
                let m = match a {
                    Some(a) if a > 0.0 => m.map(|c| c / a),
                    _ => m,
                };
                options.view.apply(m.map(|c| c * scale)).map(srgb_encode)
            }
            Encode::Data(LayerKind::Direction) => m.map(|c| c as f64 * 0.5 + 0.5),
            Encode::Data(_) => m.map(f64::from),
        };
        values.extend(shown.map(|c| if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) }));
        values.extend(a.map(f64::from));
    }
    let (w, h) = (film.width, film.height);
    let mismatch = "pixel buffer does not match the film size";
    if jpeg {
        let bytes: Vec<u8> = values.iter().map(|&v| (v * 255.0).round() as u8).collect();
        let file = std::io::BufWriter::new(std::fs::File::create(path)?);
        let mut encoder =
            image::codecs::jpeg::JpegEncoder::new_with_quality(file, options.jpeg_quality);
        encoder.encode(&bytes, w, h, image::ExtendedColorType::Rgb8)?;
        return Ok(());
    }
    match (options.png_bits, channels) {
        (16, 3) => {
            let words = values
                .iter()
                .map(|&v| (v * 65535.0).round() as u16)
                .collect();
            image::ImageBuffer::<image::Rgb<u16>, Vec<u16>>::from_raw(w, h, words)
                .context(mismatch)?
                .save_with_format(path, image::ImageFormat::Png)?
        }
        (16, _) => {
            let words = values
                .iter()
                .map(|&v| (v * 65535.0).round() as u16)
                .collect();
            image::ImageBuffer::<image::Rgba<u16>, Vec<u16>>::from_raw(w, h, words)
                .context(mismatch)?
                .save_with_format(path, image::ImageFormat::Png)?
        }
        (_, 3) => {
            let bytes = values.iter().map(|&v| (v * 255.0).round() as u8).collect();
            image::RgbImage::from_raw(w, h, bytes)
                .context(mismatch)?
                .save_with_format(path, image::ImageFormat::Png)?
        }
        _ => {
            let bytes = values.iter().map(|&v| (v * 255.0).round() as u8).collect();
            image::RgbaImage::from_raw(w, h, bytes)
                .context(mismatch)?
                .save_with_format(path, image::ImageFormat::Png)?
        }
    }
    Ok(())
}

/// A Radiance RGBE image of the linear mean × 2^exposure (no view transform).
fn write_hdr(film: &Film, path: &Path, exposure: f32) -> anyhow::Result<()> {
    let scale = exposure.exp2();
    let pixels: Vec<image::Rgb<f32>> = (0..film.len())
        .map(|p| {
            image::Rgb(film.mean(p).to_array().map(|c| {
                if c.is_finite() {
                    (c * scale).max(0.0)
                } else {
                    0.0
                }
            }))
        })
        .collect();
    let file = std::io::BufWriter::new(std::fs::File::create(path)?);
    image::codecs::hdr::HdrEncoder::new(file).encode(
        &pixels,
        film.width as usize,
        film.height as usize,
    )?;
    Ok(())
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value clamped to [0, 1]; NaN maps
/// to 0.
pub fn srgb_encode(linear: f32) -> f64 {
    let x = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0) as f64
    };
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// The sRGB transfer function (IEC 61966-2-1) of a linear value clamped to [0, 1], as an 8-bit
/// code rounded to nearest. NaN maps to 0.
pub fn srgb_encode_u8(linear: f32) -> u8 {
    (srgb_encode(linear) * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn temp_path(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("wavetrace-image-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir.join(name)
    }

    #[test]
    fn exr_round_trip_is_bitwise() {
        let (w, h) = (5, 3);
        let mut film = Film::new(w, h);
        for i in 0..(w * h * 7) as usize {
            let x = i as f32 * 0.37;
            film.add_sample(
                i % (w * h) as usize,
                Vec3::new(x.sin().abs(), x * 0.01, 1.0 / (1.0 + x)),
            );
        }
        let path = temp_path("round_trip.exr");
        write_image(&film, &path, 0.0).unwrap();
        let image = read_exr(&path).unwrap();
        assert_eq!((image.width, image.height), (w, h));
        let variance = image.variance.expect("variance channels");
        let count = image.count.expect("count channel");
        for p in 0..film.len() {
            let (m, v) = (film.mean(p).to_array(), film.variance_of_mean(p).to_array());
            assert_eq!(
                image.mean[p].map(f32::to_bits),
                m.map(f32::to_bits),
                "pixel {p}"
            );
            assert_eq!(
                variance[p].map(f32::to_bits),
                v.map(f32::to_bits),
                "pixel {p}"
            );
            assert_eq!(count[p], film.pixels[p].count);
        }
    }

    /// The same film and record written twice (each write a new attribute map, whose order the
    /// exr crate's `HashMap` would change) give the same bytes, and the file reads back whole.
    #[test]
    fn exr_files_of_the_same_render_are_byte_identical() {
        let mut film = Film::new(4, 2);
        for p in 0..8 {
            film.add_sample(p, Vec3::new(p as f32, 0.5, 0.25));
        }
        let record: Vec<(String, String)> = (0..16)
            .map(|k| (format!("wavetrace.key{k}"), format!("value {k}")))
            .collect();
        let (a, b) = (temp_path("same_a.exr"), temp_path("same_b.exr"));
        write_image_with(&film, &a, 0.0, &record).unwrap();
        write_image_with(&film, &b, 0.0, &record).unwrap();
        let bytes = std::fs::read(&a).unwrap();
        assert!(bytes == std::fs::read(&b).unwrap(), "two writes differ");
        let (read, attributes) = read_film_exact(&a).unwrap();
        assert!(read.pixels == film.pixels, "the film read back differs");
        for (name, value) in &record {
            assert!(
                attributes.iter().any(|(n, v)| n == name && v == value),
                "{name} lost"
            );
        }
        // The header's attributes are in name order.
        assert!(single_part_exr(&bytes));
        let (ranges, _) = exr_header_attributes(&bytes).unwrap();
        let names: Vec<&[u8]> = ranges
            .iter()
            .map(|r| exr_attribute_name(&bytes, r))
            .collect();
        assert!(names.windows(2).all(|w| w[0] < w[1]), "{names:?}");
    }

    fn write_standard(film: &Film, path: &Path, exposure: f32) {
        let options = WriteOptions {
            exposure,
            view: View::Standard,
            ..Default::default()
        };
        write_output(film, &[], path, &options, &[]).unwrap();
    }

    #[test]
    fn png_has_srgb_codes_of_known_values() {
        let below = 0.0031308_f32 * 0.999;
        let values = [0.0, 1.0, 0.5, 0.0031308, below, 2.0, -1.0];
        let expected = [0u8, 255, 188, 10, 10, 255, 0];
        // Row 0 holds the values in R; row 1 is a dimmer copy (exposure −1 applied below).
        let mut film = Film::new(values.len() as u32, 2);
        for (x, &v) in values.iter().enumerate() {
            film.add_sample(x, Vec3::new(v, 0.0, 1.0));
            film.add_sample(x + values.len(), Vec3::splat(0.25));
        }
        let path = temp_path("known.png");
        write_standard(&film, &path, 0.0);
        let decoded = image::open(&path).unwrap().to_rgb8();
        assert_eq!(decoded.dimensions(), (values.len() as u32, 2));
        for (x, &e) in expected.iter().enumerate() {
            assert_eq!(
                decoded.get_pixel(x as u32, 0).0,
                [e, 0, 255],
                "linear {}",
                values[x]
            );
        }
        // 0.25 linear is sRGB 137.
        assert_eq!(decoded.get_pixel(0, 1).0, [137; 3]);
        write_standard(&film, &path, 1.0);
        let brighter = image::open(&path).unwrap().to_rgb8();
        assert_eq!(brighter.get_pixel(0, 1).0, [188; 3]);
    }

    #[test]
    fn unknown_extension_names_path_and_formats() {
        let err = write_image(&Film::new(1, 1), Path::new("out/picture.tiff"), 0.0).unwrap_err();
        let msg = format!("{err:#}");
        assert!(
            msg.contains("out/picture.tiff") && msg.contains(".exr") && msg.contains(".png"),
            "{msg}"
        );
    }

    #[test]
    fn read_errors_name_the_path() {
        let err = read_exr(Path::new("/nonexistent/missing.exr")).unwrap_err();
        assert!(format!("{err:#}").contains("/nonexistent/missing.exr"));
    }
}
