//! The bidirectional integrators' sample loop: every pixel's camera subpath and the batch's light
//! subpaths, their splats gathered per image row in parallel and added in row order (the same
//! image bit for bit whatever the thread count), and the images of each (s, t) strategy
//! (`--bdpt-strategies`).

// `!(x > 0.0)` rejects NaN along with the non-positive, on purpose, as the GLSL twin does.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use super::bdpt::{Bidir, Strategy};
use super::light_tracing::{splat_add, splat_value};
use crate::cpu::path::RayCounts;
use crate::film::accumulate;
use crate::film::Film;
use glam::Vec3;
use indicatif::ProgressBar;
use rayon::prelude::*;

/// Per (s, t) strategy: its weighted and unweighted contributions as two films
/// (`--bdpt-strategies`). The weighted films of all strategies add up to the image; an
/// unweighted film is that strategy alone, an estimate of every path of its length that it can
/// make.
#[derive(Default)]
pub struct StrategyFilms {
    pub films: std::collections::BTreeMap<(usize, usize), (Film, Film)>,
}

/// Adds samples `samples` of every pixel to `film` with the light or bidirectional integrator:
/// per sample index, every pixel's subpaths in parallel by rows, the splats added in row order
/// (deterministic), then each pixel's own estimate plus its splats as one film sample. With
/// `strategies`, each strategy's contributions are kept apart as well.
pub fn render_samples(
    bidir: &Bidir,
    film: &mut Film,
    samples: std::ops::Range<u32>,
    progress: &ProgressBar,
    mut strategies: Option<&mut StrategyFilms>,
) -> (RayCounts, u64) {
    type Row = (Vec<Vec3>, Vec<(u32, Vec3)>, RayCounts, Vec<Strategy>);
    let width = film.width as usize;
    let rows = film.height as usize;
    let keep = strategies.is_some();
    let mut counts = RayCounts::default();
    let mut dropped = 0u64;
    let mut image = vec![Vec3::ZERO; film.len()];
    let mut splat_sums = vec![[0u64; 3]; film.len()];
    let mut per_strategy: std::collections::BTreeMap<(usize, usize), (Vec<Vec3>, Vec<Vec3>)> =
        Default::default();
    let first_sample = samples.start;
    for sample in samples {
        let results: Vec<Row> = (0..rows)
            .into_par_iter()
            .map(|row| {
                let mut scratch = (Vec::new(), Vec::new());
                let mut c = RayCounts::default();
                let mut own = Vec::with_capacity(width);
                let mut splats = Vec::new();
                let mut list = Vec::new();
                for x in 0..width {
                    let pixel = (row * width + x) as u32;
                    let out = bidir.sample(
                        pixel,
                        sample,
                        &mut scratch,
                        &mut c,
                        keep.then_some(&mut list),
                    );
                    own.push(out.own);
                    splats.extend(out.splats);
                }
                progress.inc(width as u64);
                (own, splats, c, list)
            })
            .collect();
        for (row, (own, _, c, _)) in results.iter().enumerate() {
            image[row * width..(row + 1) * width].copy_from_slice(own);
            counts = counts.merged(c);
        }
        for (_, splats, _, _) in &results {
            for &(p, c) in splats {
                splat_add(&mut splat_sums[p as usize], c);
            }
        }
        for (l, sums) in image.iter_mut().zip(&mut splat_sums) {
            *l += splat_value(sums);
            *sums = [0; 3];
        }
        for (acc, &l) in film.pixels.iter_mut().zip(&image) {
            if !accumulate(acc, l) {
                dropped += 1;
            }
        }
        if let Some(out) = strategies.as_deref_mut() {
            for buffers in per_strategy.values_mut() {
                buffers.0.fill(Vec3::ZERO);
                buffers.1.fill(Vec3::ZERO);
            }
            for (_, _, _, list) in &results {
                for &(s, t, weighted, unweighted, p) in list {
                    let b = per_strategy.entry((s, t)).or_insert_with(|| {
                        (vec![Vec3::ZERO; image.len()], vec![Vec3::ZERO; image.len()])
                    });
                    b.0[p as usize] += weighted;
                    b.1[p as usize] += unweighted;
                }
            }
            for (&st, b) in &per_strategy {
                let (fw, fu) = out.films.entry(st).or_insert_with(|| {
                    // A strategy first seen now had zero in every earlier sample.
                    let mut empty = Film::new(film.width, film.height);
                    let done = sample - first_sample;
                    for p in &mut empty.pixels {
                        p.count = done;
                    }
                    (empty.clone(), empty)
                });
                for ((pw, pu), (w, u)) in fw
                    .pixels
                    .iter_mut()
                    .zip(fu.pixels.iter_mut())
                    .zip(b.0.iter().zip(&b.1))
                {
                    accumulate(pw, *w);
                    accumulate(pu, *u);
                }
            }
        }
    }
    (counts, dropped)
}

/// Writes each strategy's weighted and unweighted image to `dir` (`s{s}-t{t}-weighted.exr`, …)
/// and the lecture's "Bidir PT example" figure, `strategies.png`: one row per number of
/// scattering vertices, one column per s, weighted images above the unweighted.
pub fn write_strategies(
    strategies: &StrategyFilms,
    dir: &std::path::Path,
    exposure: f32,
) -> anyhow::Result<()> {
    use anyhow::Context;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let Some(((_, _), (first, _))) = strategies.films.iter().next() else {
        return Ok(());
    };
    let (w, h) = (first.width, first.height);
    let mut lengths = std::collections::BTreeSet::new();
    let mut max_s = 0;
    for (&(s, t), (weighted, unweighted)) in &strategies.films {
        for (film, kind) in [(weighted, "weighted"), (unweighted, "unweighted")] {
            let name = format!("s{s}-t{t}-{kind}.exr");
            crate::image_io::write_image(film, &dir.join(&name), exposure)?;
        }
        lengths.insert(s + t - 2);
        max_s = max_s.max(s);
    }
    // The grid: for each path length k (rows, two per k: weighted, then unweighted), the
    // strategies s = 0 … k + 1 (columns), a 2-pixel gap between cells.
    let gap = 2;
    let columns = max_s as u32 + 1;
    let rows = 2 * lengths.len() as u32;
    let (gw, gh) = (columns * (w + gap) + gap, rows * (h + gap) + gap);
    let mut grid = image::RgbImage::from_pixel(gw, gh, image::Rgb([40, 40, 40]));
    let scale = exposure.exp2();
    for (row, &k) in lengths.iter().enumerate() {
        for s in 0..=k + 1 {
            let t = k + 2 - s;
            let Some((weighted, unweighted)) = strategies.films.get(&(s, t)) else {
                continue;
            };
            for (half, film) in [weighted, unweighted].into_iter().enumerate() {
                let x0 = gap + s as u32 * (w + gap);
                let y0 = gap + (2 * row as u32 + half as u32) * (h + gap);
                for y in 0..h {
                    for x in 0..w {
                        let m = film.mean((x + y * w) as usize);
                        let px = m
                            .to_array()
                            .map(|c| crate::image_io::srgb_encode_u8(c * scale));
                        grid.put_pixel(x0 + x, y0 + y, image::Rgb(px));
                    }
                }
            }
        }
    }
    let path = dir.join("strategies.png");
    grid.save(&path)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
