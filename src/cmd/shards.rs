//! `render --sample-range | --shard | --resume` and the signal handler that turns SIGINT and
//! SIGTERM into a resumable partial EXR (`wavetrace::shard`).

use super::options::{DeviceKind, MisArg, RenderArgs, RenderOptions};
use anyhow::{bail, Context as _, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::OnceLock;
use wavetrace::film::Film;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::shard::{scene_hash, Hasher64, Record, SampleRange, Shard};

/// Exit status of a render stopped by a signal after writing its partial EXR (128 + SIGINT, as
/// shells report an interrupted command).
pub const INTERRUPTED_EXIT: i32 = 130;

/// The stop flag of a render: the signal handler's ([`interrupt_flag`]) for renders of a fixed
/// sample count; renders in passes keep the default signal handling (they end at once).
pub fn stop_flag(progressive: bool) -> &'static AtomicBool {
    static NEVER: AtomicBool = AtomicBool::new(false);
    if progressive {
        &NEVER
    } else {
        interrupt_flag()
    }
}

/// The flag the signal handler sets on the first SIGINT or SIGTERM (SIGHUP too: `ctrlc`'s
/// `termination` feature); the renderers stop at the next whole sample pass. A second signal
/// ends the process at once.
pub fn interrupt_flag() -> &'static AtomicBool {
    static FLAG: AtomicBool = AtomicBool::new(false);
    static INSTALLED: OnceLock<()> = OnceLock::new();
    INSTALLED.get_or_init(|| {
        let installed = ctrlc::set_handler(|| {
            if FLAG.swap(true, Ordering::SeqCst) {
                eprintln!("interrupted again: quitting without writing");
                std::process::exit(INTERRUPTED_EXIT);
            }
            eprintln!(
                "interrupted: finishing the current samples and writing the ones done (interrupt again to quit at once)"
            );
        });
        if let Err(e) = installed {
            eprintln!("note: no signal handler ({e}): an interrupted render writes nothing");
        }
    });
    &FLAG
}

/// The record of a render: every setting that decides its image (`shard::Record`).
pub fn record(
    o: &RenderOptions,
    scene_path: &Path,
    prepared: &PreparedScene,
    settings: &RenderSettings,
    device: DeviceKind,
    moment: &wavetrace::scene::Moment,
) -> Result<Record> {
    let file =
        std::fs::read(scene_path).with_context(|| format!("reading {}", scene_path.display()))?;
    let environment = match &settings.env_map {
        Some(map) => {
            let mut h = Hasher64::default();
            h.write(&map.width.to_le_bytes());
            h.write(bytemuck::cast_slice(&map.texels));
            format!(
                "map {:016x} scale {:?} rotate {:?}",
                h.finish(),
                settings.env_scale,
                settings.env_rotate
            )
        }
        None => format!(
            "{:?},{:?},{:?}",
            settings.environment.x, settings.environment.y, settings.environment.z
        ),
    };
    let mis = match o.mis {
        MisArg::Power => format!("power {:?}", o.mis_beta),
        other => format!("{other:?}").to_lowercase(),
    };
    let lower = |v: &dyn std::fmt::Debug| format!("{v:?}").to_lowercase();
    let settings = vec![
        ("version", env!("CARGO_PKG_VERSION").to_owned()),
        (
            "scene_hash",
            format!("{:016x}", scene_hash(&file, prepared)),
        ),
        ("width", settings.width.to_string()),
        ("height", settings.height.to_string()),
        (
            "camera",
            o.camera.clone().unwrap_or_else(|| "default".into()),
        ),
        ("aperture", format!("{:?}", o.aperture)),
        (
            "focus_distance",
            o.focus_distance
                .map_or_else(|| "auto".into(), |f| format!("{f:?}")),
        ),
        ("spp", o.spp.to_string()),
        ("seed", o.seed.to_string()),
        ("device", lower(&device)),
        ("integrator", lower(&o.integrator)),
        (
            "paths",
            o.paths
                .as_ref()
                .map_or_else(|| "all".into(), |p| p.source.clone()),
        ),
        ("max_depth", o.max_depth.to_string()),
        ("sampler", lower(&o.sampler)),
        ("mis", mis),
        ("rr", lower(&o.rr)),
        ("rr_depth", o.rr_depth.to_string()),
        ("light_sampler", lower(&o.light_sampler)),
        ("environment", environment),
        (
            "aov",
            match o.aov_layers() {
                l if l.is_empty() => "none".to_owned(),
                l => l.iter().map(|a| a.name()).collect::<Vec<_>>().join(","),
            },
        ),
        ("texture_lod", lower(&o.texture_lod)),
        ("energy_compensation", lower(&o.energy_compensation)),
        (
            "sky",
            if o.sky {
                format!(
                    "sun elevation {:?} azimuth {:?} turbidity {:?}",
                    o.sun_elevation, o.sun_azimuth, o.turbidity
                )
            } else {
                "none".into()
            },
        ),
        (
            "camera_placed",
            format!(
                "from {:?} look-at {:?} up {:?} orbit {:?} fov {:?}",
                o.from, o.look_at, o.up, o.orbit, o.fov
            ),
        ),
        ("instancing", (!o.no_instancing).to_string()),
        (
            "moment",
            match &moment.animations {
                wavetrace::scene::Animations::Static => "static pose".into(),
                a => format!("{a:?} at {:?} s", moment.time).to_lowercase(),
            },
        ),
        ("debug_flags", o.debug_flags.to_string()),
    ];
    let mut settings: Vec<(String, String)> = settings
        .into_iter()
        .map(|(k, v)| (k.to_owned(), v))
        .collect();
    settings.sort();
    Ok(Record {
        settings,
        scene: scene_path.display().to_string(),
        samples: Some(SampleRange::new(0, o.spp)),
        target: Some(SampleRange::new(0, o.spp)),
        dropped: 0,
    })
}

/// What a render of a fixed sample count does: the samples it is asked for, the partial EXR it
/// continues, and the samples left to render.
pub struct Plan {
    pub target: SampleRange,
    pub partial: Option<Shard>,
    pub todo: SampleRange,
    pub output: PathBuf,
}

/// Checks the shard options against each other and against the partial EXR of `--resume`.
pub fn plan(
    args: &RenderArgs,
    record: &Record,
    progressive: bool,
    default_output: PathBuf,
) -> Result<Plan> {
    let spp = args.opts.spp;
    let sharded = args.sample_range.is_some() || args.shard.is_some() || args.resume.is_some();
    if progressive && sharded {
        bail!(
            "--target-error and --time-limit render in passes until their stop rule holds, so \
             which samples a render takes is not fixed in advance; they cannot be combined with \
             --sample-range, --shard or --resume (render shards of a fixed --spp and merge them)"
        );
    }
    let asked = match (args.sample_range, args.shard) {
        (Some(r), _) => Some(r),
        (None, Some((i, n))) => {
            if n > spp {
                bail!("--shard {i}/{n}: {n} shards of --spp {spp} leave some empty; use at most {spp} shards");
            }
            Some(SampleRange::shard(i, n, spp))
        }
        (None, None) => None,
    };
    if let Some(r) = asked {
        if r.end > spp {
            bail!("--sample-range {r}: the render has only --spp {spp} samples (0..{spp})");
        }
    }
    let output = match (&args.output, &args.resume) {
        (Some(o), _) => o.clone(),
        (None, Some(partial)) => partial.clone(),
        (None, None) => default_output,
    };
    if sharded
        && !output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
    {
        bail!(
            "{}: a shard or resumed render must be written as .exr (it keeps the samples' sums and the render's settings for merge and --resume)",
            output.display()
        );
    }
    let Some(path) = &args.resume else {
        let target = asked.unwrap_or(SampleRange::new(0, spp));
        return Ok(Plan {
            target,
            partial: None,
            todo: target,
            output,
        });
    };
    let mut partial = Shard::read(path)?;
    let held = partial.samples()?;
    let differences = partial.record.differences(record);
    if !differences.is_empty() {
        bail!(
            "{} was rendered with other settings than these (stored vs given): {}; give the \
             options of the interrupted render",
            path.display(),
            differences.join("; ")
        );
    }
    let target = partial.record.target.unwrap_or(held);
    if let Some(r) = asked {
        if r != target {
            bail!(
                "{} is a render of samples {target}, not of the {r} asked for",
                path.display()
            );
        }
    }
    if held.start != target.start || held.end > target.end {
        bail!(
            "{} holds samples {held}, which do not start its render's {target}: it cannot be continued",
            path.display()
        );
    }
    partial.film.dropped = partial.record.dropped;
    Ok(Plan {
        target,
        todo: SampleRange::new(held.end, target.end),
        partial: Some(partial),
        output,
    })
}

/// The film of the plan's samples done: the partial's followed by the new ones (rendered up to
/// `end`), and its record.
pub fn finish(plan: Plan, film: Film, end: u32, mut record: Record) -> (Film, Record) {
    let film = match plan.partial {
        Some(mut p) => {
            p.film.merge(&film);
            p.film
        }
        None => film,
    };
    record.samples = Some(SampleRange::new(plan.target.start, end));
    record.target = Some(plan.target);
    record.dropped = film.dropped;
    (film, record)
}
