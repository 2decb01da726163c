//! Renders past one machine: sample ranges, the settings every EXR records, and merging shards.
//!
//! Random numbers are a pure function of (seed, pixel, sample index, dimension), so samples
//! [a, b) of a render of `spp` samples are the same numbers whichever process draws them. A
//! shard renders one range; the film's sufficient statistics (sum, sum of squares and count per
//! pixel, `film.rs`) add, so shards covering [0, spp) merge into the film one render of every
//! sample gives, up to the order of the f32 additions (each pixel's samples are summed in
//! sample order inside a shard, then the shards' sums in range order).
//!
//! Every EXR that wavetrace writes carries its render's record as text attributes named
//! `wavetrace.<key>` ([`Record`]): the settings that decide the image (scene hash, size, camera,
//! spp, seed, device, integrator, depth, sampler, MIS, RR, light sampler, environment, …),
//! the samples the file holds (`wavetrace.samples`, START..END) and the samples its render was
//! asked for (`wavetrace.target`; a render stopped early holds fewer and continues with
//! `render --resume`).

use crate::film::Film;
use anyhow::{bail, Context};
use std::fmt;
use std::path::{Path, PathBuf};

/// Prefix of the EXR attribute names of a render's record.
pub const ATTRIBUTE_PREFIX: &str = "wavetrace.";

/// A half-open range of sample indices [start, end) of a render's `--spp` samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SampleRange {
    pub start: u32,
    pub end: u32,
}

impl SampleRange {
    pub fn new(start: u32, end: u32) -> SampleRange {
        SampleRange { start, end }
    }
    pub fn len(&self) -> u32 {
        self.end.saturating_sub(self.start)
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn as_range(&self) -> std::ops::Range<u32> {
        self.start..self.end
    }

    /// Shard `index` of `count` of a render of `spp` samples: [⌊index·spp/count⌋,
    /// ⌊(index+1)·spp/count⌋), so the shards cover [0, spp) without overlap.
    pub fn shard(index: u32, count: u32, spp: u32) -> SampleRange {
        let at = |i: u32| (i as u64 * spp as u64 / count as u64) as u32;
        SampleRange::new(at(index), at(index + 1))
    }
}

impl fmt::Display for SampleRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}..{}", self.start, self.end)
    }
}

impl std::str::FromStr for SampleRange {
    type Err = String;
    /// "START..END" with START < END.
    fn from_str(text: &str) -> Result<SampleRange, String> {
        let (a, b) = text
            .trim()
            .split_once("..")
            .ok_or_else(|| format!("'{text}': expected START..END, e.g. 0..64"))?;
        let parse = |v: &str| {
            v.trim()
                .parse::<u32>()
                .map_err(|e| format!("'{text}': '{v}': {e}"))
        };
        let (start, end) = (parse(a)?, parse(b)?);
        if start >= end {
            return Err(format!(
                "'{text}': the range START..END needs START < END (END is not included)"
            ));
        }
        Ok(SampleRange { start, end })
    }
}

/// "I/N": shard I (from 0) of N.
pub fn parse_shard(text: &str) -> Result<(u32, u32), String> {
    let (i, n) = text
        .trim()
        .split_once('/')
        .ok_or_else(|| format!("'{text}': expected INDEX/COUNT, e.g. 3/8"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|e| format!("'{text}': '{v}': {e}"))
    };
    let (i, n) = (parse(i)?, parse(n)?);
    if n == 0 || i >= n {
        return Err(format!(
            "'{text}': the shard index counts from 0 and must be below the count"
        ));
    }
    Ok((i, n))
}

/// Keys of a record that describe the file rather than the render: not compared by `merge`.
const FILE_KEYS: &[&str] = &["samples", "target", "dropped", "scene"];

/// What a render was and which of its samples a file holds.
#[derive(Clone, Debug, PartialEq)]
pub struct Record {
    /// (key, value) of everything that decides the image, in writing order: two files merge
    /// only if these are equal.
    pub settings: Vec<(String, String)>,
    /// The scene file as the command line named it (informative: `scene_hash` decides).
    pub scene: String,
    /// The samples the file holds; None for renders in passes to an error target or time limit,
    /// whose pixels hold different sample counts.
    pub samples: Option<SampleRange>,
    /// The samples its render was asked for (equal to `samples` unless it was stopped early).
    pub target: Option<SampleRange>,
    /// Non-finite samples dropped.
    pub dropped: u64,
}

impl Record {
    /// The value of a setting.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.settings
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The render's `--spp` (the total of all shards).
    pub fn spp(&self) -> Option<u32> {
        self.get("spp").and_then(|v| v.parse().ok())
    }

    /// The (key, value) text attributes of the EXR, names with [`ATTRIBUTE_PREFIX`].
    pub fn attributes(&self) -> Vec<(String, String)> {
        let mut out: Vec<(String, String)> = self
            .settings
            .iter()
            .map(|(k, v)| (format!("{ATTRIBUTE_PREFIX}{k}"), v.clone()))
            .collect();
        out.push((format!("{ATTRIBUTE_PREFIX}scene"), self.scene.clone()));
        if let Some(s) = self.samples {
            out.push((format!("{ATTRIBUTE_PREFIX}samples"), s.to_string()));
        }
        if let Some(t) = self.target {
            out.push((format!("{ATTRIBUTE_PREFIX}target"), t.to_string()));
        }
        out.push((
            format!("{ATTRIBUTE_PREFIX}dropped"),
            self.dropped.to_string(),
        ));
        out
    }

    /// The record of a file's attributes (any order; names without the prefix are ignored);
    /// None if it has no `wavetrace.` attributes at all.
    pub fn from_attributes(
        path: &Path,
        attributes: &[(String, String)],
    ) -> anyhow::Result<Option<Record>> {
        let mut settings = Vec::new();
        let (mut scene, mut samples, mut target, mut dropped) = (String::new(), None, None, 0);
        let mut any = false;
        for (name, value) in attributes {
            let Some(key) = name.strip_prefix(ATTRIBUTE_PREFIX) else {
                continue;
            };
            any = true;
            // A file may hold no samples (a render stopped before its first pass): START..START.
            let range = |v: &str| {
                v.split_once("..")
                    .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
                    .filter(|(a, b)| a <= b)
                    .map(|(a, b)| SampleRange::new(a, b))
                    .with_context(|| {
                        format!(
                            "{}: attribute {name} = '{v}' is no range START..END",
                            path.display()
                        )
                    })
            };
            match key {
                "samples" => samples = Some(range(value)?),
                "target" => target = Some(range(value)?),
                "scene" => scene = value.clone(),
                "dropped" => {
                    dropped = value.parse().with_context(|| {
                        format!("{}: attribute {name} = '{value}'", path.display())
                    })?
                }
                _ => settings.push((key.to_owned(), value.clone())),
            }
        }
        debug_assert!(FILE_KEYS
            .iter()
            .all(|k| !settings.iter().any(|(s, _)| s == k)));
        settings.sort();
        Ok(any.then_some(Record {
            settings,
            scene,
            samples,
            target,
            dropped,
        }))
    }

    /// The settings in which `self` and `other` differ, as "key A vs B" phrases (sorted by key;
    /// a setting one lacks shows as "(none)").
    pub fn differences(&self, other: &Record) -> Vec<String> {
        let mut keys: Vec<&str> = self
            .settings
            .iter()
            .chain(&other.settings)
            .map(|(k, _)| k.as_str())
            .collect();
        keys.sort_unstable();
        keys.dedup();
        keys.into_iter()
            .filter_map(|k| {
                let (a, b) = (self.get(k), other.get(k));
                (a != b)
                    .then(|| format!("{k} {} vs {}", a.unwrap_or("(none)"), b.unwrap_or("(none)")))
            })
            .collect()
    }
}

/// One shard read back: its film (exact sums from the `sum.*` and `sum_sq.*` channels) and
/// record.
pub struct Shard {
    pub path: PathBuf,
    pub film: Film,
    pub record: Record,
}

impl Shard {
    /// Reads a shard written by wavetrace; errors name the file and what it lacks.
    pub fn read(path: &Path) -> anyhow::Result<Shard> {
        let (film, attributes) = crate::image_io::read_film_exact(path)?;
        let Some(record) = Record::from_attributes(path, &attributes)? else {
            bail!(
                "{}: the EXR carries no wavetrace render settings (wavetrace.* attributes): \
                 it was not written by this version of wavetrace, so it cannot be merged or resumed",
                path.display()
            );
        };
        Ok(Shard {
            path: path.to_owned(),
            film,
            record,
        })
    }

    /// The samples the file holds, or an error saying why it has no fixed range.
    pub fn samples(&self) -> anyhow::Result<SampleRange> {
        self.record.samples.with_context(|| {
            format!(
                "{}: rendered in passes to an error target or time limit (--target-error, \
                 --time-limit), so its pixels hold different samples; only renders of a fixed \
                 --spp or --sample-range merge or resume",
                self.path.display()
            )
        })
    }
}

/// Merges shards (in any order) of one render: all must have the same settings, be complete
/// (holding the samples they were asked for) and cover one run of samples without overlap or
/// gap; unless `partial`, that run must be all of [0, spp). The films add in the order of their
/// ranges, so any order of `shards` gives the same bits. Returns the film and its record.
pub fn merge(mut shards: Vec<Shard>, partial: bool) -> anyhow::Result<(Film, Record)> {
    let Some(first) = shards.first() else {
        bail!("merge needs at least one shard");
    };
    for s in &shards[1..] {
        let differences = first.record.differences(&s.record);
        if !differences.is_empty() {
            bail!(
                "{} and {} are shards of different renders: {}",
                first.path.display(),
                s.path.display(),
                differences.join("; ")
            );
        }
        if (s.film.width, s.film.height) != (first.film.width, first.film.height) {
            bail!(
                "{} is {}×{} pixels but {} is {}×{}",
                first.path.display(),
                first.film.width,
                first.film.height,
                s.path.display(),
                s.film.width,
                s.film.height
            );
        }
    }
    let spp = first
        .record
        .spp()
        .with_context(|| format!("{}: no wavetrace.spp attribute", first.path.display()))?;
    let mut ranges = Vec::with_capacity(shards.len());
    for s in &shards {
        let range = s.samples()?;
        if let Some(target) = s.record.target {
            if target != range {
                bail!(
                    "{} holds samples {range} of the {target} its render was asked for (it was \
                     stopped early): finish it first with `wavetrace render … --resume {}`",
                    s.path.display(),
                    s.path.display()
                );
            }
        }
        if range.end > spp {
            bail!(
                "{}: samples {range} lie outside the render's --spp {spp}",
                s.path.display()
            );
        }
        ranges.push(range);
    }
    let mut order: Vec<usize> = (0..shards.len()).collect();
    order.sort_by_key(|&i| (ranges[i].start, ranges[i].end));
    for pair in order.windows(2) {
        let (a, b) = (pair[0], pair[1]);
        let (ra, rb) = (ranges[a], ranges[b]);
        if rb.start < ra.end {
            bail!(
                "{} (samples {ra}) and {} (samples {rb}) overlap: samples {}..{} are in both",
                shards[a].path.display(),
                shards[b].path.display(),
                rb.start,
                ra.end.min(rb.end)
            );
        }
        if rb.start > ra.end {
            bail!(
                "samples {}..{} are in no shard: {} ends at {} and {} starts at {}",
                ra.end,
                rb.start,
                shards[a].path.display(),
                ra.end,
                shards[b].path.display(),
                rb.start
            );
        }
    }
    let union = SampleRange::new(ranges[order[0]].start, ranges[order[order.len() - 1]].end);
    if !partial && union != SampleRange::new(0, spp) {
        let mut missing = Vec::new();
        if union.start > 0 {
            missing.push(format!("0..{}", union.start));
        }
        if union.end < spp {
            missing.push(format!("{}..{spp}", union.end));
        }
        bail!(
            "samples {} of the render's {spp} are in no shard (the shards hold {union}); give \
             the missing shards, or --partial to write a shard of {union}",
            missing.join(" and ")
        );
    }
    let mut record = shards[order[0]].record.clone();
    record.samples = Some(union);
    record.target = Some(union);
    record.dropped = shards.iter().map(|s| s.record.dropped).sum();
    // Take the films out in range order and add them up.
    let mut films: Vec<Option<Film>> = shards
        .iter_mut()
        .map(|s| Some(std::mem::replace(&mut s.film, Film::new(0, 0))))
        .collect();
    let mut film = films[order[0]].take().expect("each shard once");
    for &i in &order[1..] {
        film.merge(films[i].as_ref().expect("each shard once"));
    }
    film.dropped = record.dropped;
    Ok((film, record))
}

/// A 64-bit hash of byte runs (FxHash's word step, then SplitMix64's finaliser): to tell
/// scenes apart in shard records, not a cryptographic digest.
#[derive(Clone, Copy, Debug)]
pub struct Hasher64(u64);

impl Default for Hasher64 {
    fn default() -> Self {
        Hasher64(0xcbf2_9ce4_8422_2325)
    }
}

/// Runs longer than this are hashed in pieces of this size on every core, then the pieces'
/// hashes in order (the same value whatever the threads).
const HASH_PIECE: usize = 1 << 20;

/// FxHash's step: one word into the state.
#[inline(always)]
fn hash_step(h: u64, w: u64) -> u64 {
    (h.rotate_left(5) ^ w).wrapping_mul(0x517c_c1b7_2722_0a95)
}

impl Hasher64 {
    /// Adds `bytes` (and their length, so that runs do not run together). A scene's texels are
    /// 100 MB and more (DamagedHelmet's with their mip levels: 112 MB), which one chain of
    /// dependent multiplications took 15–25 ms to hash on this machine; long runs are now
    /// hashed in pieces on every core, each piece in four chains side by side.
    pub fn write(&mut self, bytes: &[u8]) {
        if bytes.len() <= HASH_PIECE {
            self.write_run(bytes);
            return;
        }
        use rayon::prelude::*;
        let pieces: Vec<u64> = bytes
            .par_chunks(HASH_PIECE)
            .map(|piece| {
                let mut h = Hasher64::default();
                h.write_run(piece);
                h.finish()
            })
            .collect();
        self.write_run(&(bytes.len() as u64).to_le_bytes());
        self.write_run(bytemuck::cast_slice(&pieces));
    }

    /// One run: its length, then its 8-byte words in four interleaved chains (word k into
    /// chain k mod 4, whose multiplications do not wait for each other), the words after the
    /// last 32-byte block into the first chain, and the four folded into one.
    fn write_run(&mut self, bytes: &[u8]) {
        let word = |b: &[u8]| u64::from_le_bytes(b.try_into().expect("8 bytes"));
        let h = hash_step(self.0, bytes.len() as u64);
        let mut lanes = [h, h ^ 1, h ^ 2, h ^ 3];
        let mut blocks = bytes.chunks_exact(32);
        for block in &mut blocks {
            for (k, lane) in lanes.iter_mut().enumerate() {
                *lane = hash_step(*lane, word(&block[8 * k..8 * k + 8]));
            }
        }
        let mut words = blocks.remainder().chunks_exact(8);
        for w in &mut words {
            lanes[0] = hash_step(lanes[0], word(w));
        }
        let mut tail = [0u8; 8];
        tail[..words.remainder().len()].copy_from_slice(words.remainder());
        lanes[0] = hash_step(lanes[0], u64::from_le_bytes(tail));
        self.0 = lanes[1..].iter().fold(lanes[0], |h, &l| hash_step(h, l));
    }

    pub fn finish(&self) -> u64 {
        // SplitMix64's finaliser (Steele, Lea & Flood 2014).
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

/// The hash of a scene as rendered: the scene file's bytes and everything loaded from it
/// (triangles, vertices, materials, emitters, textures), so that a changed buffer or image
/// file changes it too.
pub fn scene_hash(file: &[u8], scene: &crate::render::PreparedScene) -> u64 {
    let mut h = Hasher64::default();
    h.write(file);
    h.write(bytemuck::cast_slice(&scene.triangles));
    h.write(bytemuck::cast_slice(&scene.triangle_vertices));
    h.write(bytemuck::cast_slice(&scene.vertices));
    h.write(bytemuck::cast_slice(&scene.materials));
    h.write(bytemuck::cast_slice(&scene.lights));
    h.write(bytemuck::cast_slice(&scene.punctual));
    h.write(bytemuck::cast_slice(&scene.instances));
    h.write(bytemuck::cast_slice(&scene.textures));
    h.write(bytemuck::cast_slice(&scene.texture_refs));
    h.write(bytemuck::cast_slice(scene.texels.as_slice()));
    h.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_parse_and_shards_cover_the_samples() {
        assert_eq!("3..9".parse::<SampleRange>(), Ok(SampleRange::new(3, 9)));
        assert!("9..3".parse::<SampleRange>().is_err());
        assert!("4..4".parse::<SampleRange>().is_err());
        assert!("4".parse::<SampleRange>().is_err());
        assert_eq!(parse_shard("2/5"), Ok((2, 5)));
        assert!(parse_shard("5/5").is_err() && parse_shard("0/0").is_err());
        for (spp, n) in [(64, 4), (10, 3), (3, 7), (1 << 20, 13)] {
            let mut next = 0;
            for i in 0..n {
                let r = SampleRange::shard(i, n, spp);
                assert_eq!(r.start, next, "{spp} spp, {n} shards");
                next = r.end;
            }
            assert_eq!(next, spp);
        }
    }

    #[test]
    fn records_round_trip_through_attributes() {
        let record = Record {
            settings: vec![("seed".into(), "3".into()), ("spp".into(), "16".into())],
            scene: "scenes/a.gltf".into(),
            samples: Some(SampleRange::new(0, 0)),
            target: Some(SampleRange::new(0, 8)),
            dropped: 2,
        };
        let back = Record::from_attributes(Path::new("x.exr"), &record.attributes())
            .unwrap()
            .unwrap();
        assert_eq!(back, record);
        let mut other = record.clone();
        other.settings[0].1 = "4".into();
        assert_eq!(record.differences(&other), vec!["seed 3 vs 4".to_string()]);
        assert!(Record::from_attributes(Path::new("x.exr"), &[])
            .unwrap()
            .is_none());
    }

    #[test]
    fn hashes_tell_runs_apart() {
        let hash = |runs: &[&[u8]]| {
            let mut h = Hasher64::default();
            for r in runs {
                h.write(r);
            }
            h.finish()
        };
        assert_eq!(hash(&[b"abc"]), hash(&[b"abc"]));
        assert_ne!(hash(&[b"abc"]), hash(&[b"abd"]));
        assert_ne!(hash(&[b"ab", b"c"]), hash(&[b"a", b"bc"]));
        assert_ne!(hash(&[b""]), hash(&[b"\0"]));
    }

    /// Every byte of a run counts, whichever of the four chains or parallel pieces it falls in
    /// (runs of 3 MiB and a bit are hashed in pieces, shorter ones in one), and the value does
    /// not depend on the threads.
    #[test]
    fn every_byte_of_a_long_run_changes_the_hash() {
        for len in [1usize, 7, 8, 31, 32, 33, 100, 3 * HASH_PIECE + 13] {
            let bytes: Vec<u8> = (0..len).map(|i| (i * 131 % 251) as u8).collect();
            let hash = |b: &[u8]| {
                let mut h = Hasher64::default();
                h.write(b);
                h.finish()
            };
            let base = hash(&bytes);
            let one_thread = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap()
                .install(|| hash(&bytes));
            assert_eq!(base, one_thread, "{len} bytes");
            let step = (len / 97).max(1);
            for i in (0..len).step_by(step).chain([len - 1]) {
                let mut changed = bytes.clone();
                changed[i] ^= 1;
                assert_ne!(hash(&changed), base, "byte {i} of {len}");
            }
            let mut longer = bytes.clone();
            longer.push(0);
            assert_ne!(hash(&longer), base, "a zero byte more than {len}");
        }
    }
}
