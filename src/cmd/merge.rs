//! `wavetrace merge`: shards of one render (any order) into the EXR of all their samples.

use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;
use wavetrace::shard::Shard;

#[derive(Args, Debug, Clone)]
pub struct MergeArgs {
    /// Shards: EXRs written by `wavetrace render --sample-range` or `--shard` (any order).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// The merged EXR.
    #[arg(short = 'o', long = "output", required = true)]
    pub output: PathBuf,
    /// Write the merge of shards that cover only part of [0, spp) (one run of samples without
    /// gaps) as a larger shard, instead of refusing.
    #[arg(long)]
    pub partial: bool,
}

/// `wavetrace merge`.
pub fn merge(args: &MergeArgs) -> Result<()> {
    let shards = args
        .shards
        .iter()
        .map(|p| Shard::read(p))
        .collect::<Result<Vec<_>>>()?;
    let n = shards.len();
    let (film, record) = wavetrace::shard::merge(shards, args.partial)?;
    if !args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
    {
        bail!("{}: merge writes .exr", args.output.display());
    }
    wavetrace::image_io::write_image_with(&film, &args.output, 0.0, &record.attributes())?;
    println!(
        "merged {n} shards: samples {} of {} spp, {}×{}, {} NaN/Inf samples dropped; wrote {}",
        record.samples.expect("merged shards have a range"),
        record.spp().unwrap_or(0),
        film.width,
        film.height,
        record.dropped,
        args.output.display()
    );
    Ok(())
}
