//! `wavetrace compare`: whether two renders have the same expectation (per-tile Welch tests),
//! or how far apart they look (NVIDIA FLIP).

use super::options::{parse_alpha, parse_unit_interval};
use anyhow::{bail, Context as _, Result};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug, Clone)]
pub struct CompareArgs {
    /// First image (.exr written by wavetrace: mean, variance and count per pixel; with --flip
    /// also any .exr, .png or .jpg).
    pub a: PathBuf,
    /// Second image, e.g. the CPU reference render of the same scene with another seed (with
    /// --flip: the reference, e.g. another renderer's image).
    pub b: PathBuf,
    /// Report NVIDIA's FLIP perceptual error of A against B (as displayed: 8-bit sRGB) instead
    /// of the statistical test: for references that carry no variance.
    #[arg(long)]
    pub flip: bool,
    /// With --flip: write FLIP's error map (magma colours) to this PNG.
    #[arg(long, value_name = "FILE.png", requires = "flip")]
    pub flip_map: Option<PathBuf>,
    /// With --flip: exit 1 if the mean FLIP error exceeds E (without it, FLIP only reports).
    #[arg(long, value_name = "E", value_parser = parse_unit_interval)]
    pub max_flip: Option<f64>,
    /// Tile size in pixels: one Welch test per tile and channel.
    #[arg(long, default_value_t = 8, value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub tile: u32,
    /// Family-wise significance level, Šidák-corrected over tiles × channels.
    #[arg(long, default_value_t = 0.01, value_parser = parse_alpha)]
    pub alpha: f64,
}

/// Prints the per-tile comparison of two saved renders; true if they agree.
pub(crate) fn compare(args: &CompareArgs) -> Result<bool> {
    if args.flip {
        use wavetrace::flip::{flip, flip_heat_map, DisplayImage};
        let test = DisplayImage::load(&args.a)?;
        let reference = DisplayImage::load(&args.b)?;
        let r = flip(&reference, &test)
            .with_context(|| format!("comparing {} with {}", args.a.display(), args.b.display()))?;
        println!(
            "FLIP of {} against {}: mean {:.6}, median {:.6}, 99th percentile {:.6}, max {:.6} ({}×{} px, 8-bit sRGB, 67 pixels per degree)",
            args.a.display(),
            args.b.display(),
            r.mean,
            r.median,
            r.p99,
            r.max,
            r.width,
            r.height
        );
        if let Some(path) = &args.flip_map {
            flip_heat_map(&r)
                .save(path)
                .with_context(|| format!("writing {}", path.display()))?;
            println!("FLIP error map: {}", path.display());
        }
        return Ok(args.max_flip.is_none_or(|e| r.mean <= e));
    }
    if args.max_flip.is_some() {
        bail!("--max-flip applies to --flip");
    }
    for image in [&args.a, &args.b] {
        if !image
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
        {
            bail!(
                "{}: the statistical comparison needs EXRs written by wavetrace (mean, variance and \
                 count per pixel); compare --flip A B judges images without variance by NVIDIA's FLIP",
                image.display()
            );
        }
    }
    let a = wavetrace::image_io::read_film(&args.a)?;
    let b = wavetrace::image_io::read_film(&args.b)?;
    let cmp = wavetrace::stats::compare_films(&a, &b, args.tile, args.alpha)
        .with_context(|| format!("comparing {} with {}", args.a.display(), args.b.display()))?;
    println!("{} vs {}: {cmp}", args.a.display(), args.b.display());
    let error = wavetrace::stats::image_error(&a, &b, wavetrace::stats::RELATIVE_MSE_EPSILON)?;
    println!(
        "relative MSE = {:.6e} (mean of (A−B)²/(B² + {}), B the reference); MSE = {:.6e}",
        error.relative_mse, error.epsilon, error.mse
    );
    Ok(cmp.passed())
}
