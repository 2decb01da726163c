//! From the command line to a render: the scene loaded under the options' limits, the image
//! size, the memory a render reserves, the settings, and which device `--device auto` picks.

use super::options::{DeviceKind, EnvArg, OnOff, RenderOptions, TextureLodArg};
use anyhow::{bail, Context as _, Result};
use std::mem::size_of;
use std::path::{Path, PathBuf};
use wavetrace::layout::{BvhNode, GpuTriangle, LightEntry};
use wavetrace::lights::environment::EnvironmentMap;
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{Budget, LoadOptions, Scene, SceneFile};

/// Largest image the film may hold (pixels), far above any real render.
pub(crate) const MAX_PIXELS: u64 = 1 << 26;

/// Largest side of an image in pixels.
pub(crate) const MAX_SIDE: u32 = 16384;

/// Width of an image when neither --width nor --height is given.
pub(crate) const DEFAULT_WIDTH: u32 = 512;

/// The image size from --width and --height, filling a missing one from the camera's aspect ratio
/// (width / height: a perspective camera's aspectRatio, an orthographic one's xmag / ymag) where
/// the file gives one, else making the image square.
pub(crate) fn image_size(
    width: Option<u32>,
    height: Option<u32>,
    aspect: Option<f32>,
) -> (u32, u32) {
    let aspect = aspect.filter(|a| a.is_finite() && *a > 0.0).unwrap_or(1.0) as f64;
    let scaled = |v: u32, by: f64| ((v as f64 * by).round().clamp(1.0, u32::MAX as f64)) as u32;
    match (width, height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, scaled(w, 1.0 / aspect)),
        (None, Some(h)) => (scaled(h, aspect), h),
        (None, None) => (DEFAULT_WIDTH, scaled(DEFAULT_WIDTH, 1.0 / aspect)),
    }
}

/// The committed scenes folder, from the working directory or from the source tree.
/// The scene `render` draws without one named: `scenes/cornell-box.gltf` where the working
/// folder has it (a checkout), else the same file built into the binary, written once to the
/// temporary folder (an installed wavetrace has no checkout to read it from).
pub(crate) fn default_scene() -> Result<PathBuf> {
    const CORNELL_BOX: &[u8] = include_bytes!("../../scenes/cornell-box.gltf");
    let local = Path::new("scenes/cornell-box.gltf");
    if local.is_file() {
        return Ok(local.to_path_buf());
    }
    let dir = std::env::temp_dir().join(format!(
        "wavetrace-{}-default-scene",
        env!("CARGO_PKG_VERSION")
    ));
    let path = dir.join("cornell-box.gltf");
    if std::fs::read(&path).ok().as_deref() != Some(CORNELL_BOX) {
        std::fs::create_dir_all(&dir)
            .and_then(|()| {
                // Written beside and renamed: another process never reads half of it.
                let partial = dir.join(format!(".cornell-box.gltf.{}", std::process::id()));
                std::fs::write(&partial, CORNELL_BOX)?;
                std::fs::rename(&partial, &path)
            })
            .with_context(|| format!("writing the built-in default scene to {}", path.display()))?;
    }
    Ok(path)
}

pub(crate) fn scenes_dir() -> PathBuf {
    let local = PathBuf::from("scenes");
    if local.is_dir() {
        local
    } else {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
    }
}

/// Memory per triangle of the GPU uploads: staging and device copies of the BVH nodes,
/// triangles and light table (on a CPU Vulkan device both live in host memory).
pub(crate) const GPU_BYTES_PER_TRIANGLE: u64 =
    2 * (2 * size_of::<BvhNode>() + size_of::<GpuTriangle>() + size_of::<LightEntry>()) as u64;

/// Film memory per pixel: mean and variance accumulators and the sample count, on the host and
/// (for GPU renders) on the device.
pub(crate) const FILM_BYTES_PER_PIXEL: u64 = 32;

/// Reserves the film and, on the GPU, the scene's uploads.
pub(crate) fn reserve_render_memory(
    budget: &Budget,
    triangles: usize,
    pixels: u64,
    device: DeviceKind,
) -> Result<()> {
    let copies = if device == DeviceKind::Gpu { 2 } else { 1 };
    budget.reserve(
        &format!("the film of {pixels} pixels"),
        pixels * FILM_BYTES_PER_PIXEL * copies,
    )?;
    if device == DeviceKind::Gpu {
        budget.reserve(
            &format!("the GPU uploads of {triangles} triangles"),
            triangles as u64 * GPU_BYTES_PER_TRIANGLE,
        )?;
    }
    Ok(())
}

/// A scene file opened under the options' limits (`--max-memory`, `--allow-path`), and what
/// lights it beyond its own lights, worked out with its first pose and kept for every later one.
pub(crate) struct Opened {
    pub(crate) options: LoadOptions,
    pub(crate) file: SceneFile,
    lighting: std::cell::OnceCell<Lighting>,
}

/// The environment map and the sun of `--sky`, `--env` or the default studio.
#[derive(Clone)]
struct Lighting {
    env_map: Option<std::sync::Arc<EnvironmentMap>>,
    sun: Option<wavetrace::layout::GpuPunctualLight>,
}

/// Opens `path` under the options' limits.
pub(crate) fn open(path: &Path, opts: &RenderOptions) -> Result<Opened> {
    let options = LoadOptions {
        allow_paths: opts.allow_paths.clone(),
        budget: Budget::new(
            opts.max_memory
                .unwrap_or_else(wavetrace::scene::default_memory_budget),
        ),
        instancing: !opts.no_instancing,
    };
    let file = SceneFile::open(path, &options)?;
    Ok(Opened {
        options,
        file,
        lighting: std::cell::OnceCell::new(),
    })
}

/// Loads `path` under the options' limits at the moment `--animation` and `--time` ask for and
/// reserves what rendering it on `device` will take; returns the scene and the settings the
/// options ask for, and prints the scene's notes.
pub(crate) fn prepare(
    path: &Path,
    opts: &RenderOptions,
    device: DeviceKind,
) -> Result<(Scene, PreparedScene, RenderSettings)> {
    let opened = open(path, opts)?;
    prepare_at(path, &opened, &opts.moment(), opts, device, true)
}

/// [`prepare`] of an opened file at `moment`; `notes` prints the scene's notes.
pub(crate) fn prepare_at(
    path: &Path,
    opened: &Opened,
    moment: &wavetrace::scene::Moment,
    opts: &RenderOptions,
    device: DeviceKind,
    notes: bool,
) -> Result<(Scene, PreparedScene, RenderSettings)> {
    let options = &opened.options;
    let mut scene = opened.file.scene(moment, options)?;
    if let Some(which) = &opts.camera {
        scene.select_camera(which)?;
    }
    // --orbit circles what the animation covers, the same at every moment.
    let bounds = match opts.orbit {
        Some(_) => opened
            .file
            .framing_bounds(&moment.animations, options)?
            .unwrap_or_else(|| scene.bounds()),
        None => scene.bounds(),
    };
    place_camera(&mut scene, bounds, opts).with_context(|| format!("{}", path.display()))?;
    // --sky: the sun joins the file's punctual lights before the light table is built.
    let sky = match (opened.lighting.get(), opts.sky) {
        (Some(lighting), _) => lighting.clone(),
        (None, true) => {
            let (map, sun) = wavetrace::lights::sky(&wavetrace::lights::SkyParams {
                sun_elevation: opts.sun_elevation,
                sun_azimuth: opts.sun_azimuth,
                turbidity: opts.turbidity,
            })?;
            Lighting {
                env_map: Some(map),
                sun: Some(sun),
            }
        }
        (None, false) => Lighting {
            env_map: None,
            sun: None,
        },
    };
    scene.punctual.extend(sky.sun);
    let mut prepared = PreparedScene::new(&scene);
    prepared.set_energy_compensation(opts.energy_compensation == OnOff::On);
    let (width, height) = image_size(opts.width, opts.height, scene.camera.aspect_ratio());
    if width > MAX_SIDE || height > MAX_SIDE || width as u64 * height as u64 > MAX_PIXELS {
        bail!(
            "{width}×{height} is too large (at most {MAX_SIDE} pixels a side and {MAX_PIXELS} in all); \
             render a smaller image"
        );
    }
    reserve_render_memory(
        &options.budget,
        prepared.triangles.len(),
        width as u64 * height as u64,
        device,
    )?;
    let env_map = match &opts.env {
        _ if opened.lighting.get().is_some() || opts.sky => sky.env_map.clone(),
        Some(EnvArg::File(file)) => {
            let left = options.budget.limit().saturating_sub(options.budget.used());
            let map = EnvironmentMap::load(file, left)?;
            options.budget.reserve(
                &format!("the environment map {}", file.display()),
                (map.texels.len() + map.conditional.len() + map.marginal.len()) as u64
                    * 4
                    * if device == DeviceKind::Gpu { 2 } else { 1 },
            )?;
            Some(std::sync::Arc::new(map))
        }
        Some(EnvArg::Studio) => Some(wavetrace::lights::studio()),
        // A file with no light of its own, and no word on the environment: the studio
        // (DESIGN.md, "Lighting by default").
        None if opts.environment.is_none() && !prepared.has_own_lights() => {
            let why = if prepared.lights.is_empty() {
                "the file has no lights"
            } else {
                "the file has no lights (only textured emission, which glows but is not a lamp)"
            };
            if notes {
                eprintln!(
                    "note: {}: {why}: lit by the built-in studio environment (--env none for \
                 black, --env FILE for a map of your own)",
                    path.display()
                );
            }
            Some(wavetrace::lights::studio())
        }
        Some(EnvArg::None) | None => None,
    };
    let _ = opened.lighting.set(Lighting {
        env_map: env_map.clone(),
        sun: sky.sun,
    });
    let settings = RenderSettings {
        width,
        height,
        spp: opts.spp,
        max_depth: opts.max_depth,
        seed: opts.seed,
        environment: opts.environment.unwrap_or(glam::Vec3::ZERO),
        env_map,
        env_scale: opts.env_scale,
        env_rotate: opts.env_rotate,
        mis: opts.mis.heuristic(opts.mis_beta),
        sampler: opts.sampler.code(),
        light_sampler: opts.light_sampler.code(),
        rr_mode: opts.rr.code(),
        rr_start_depth: opts.rr_depth,
        debug_flags: opts.debug_flags,
        aov: wavetrace::layout::AOV_RADIANCE,
        aperture: opts.aperture,
        focus_distance: opts.focus_distance,
        integrator: opts.integrator.integrator(),
        paths: opts.paths.clone(),
        finest_textures: opts.texture_lod == TextureLodArg::Finest,
    };
    prepared
        .thin_lens(&settings)
        .with_context(|| format!("{}", path.display()))?;
    wavetrace::render::check(&prepared, &settings)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    for note in scene.notes.iter().filter(|_| notes) {
        eprintln!("note: {}: {note}", path.display());
    }
    if notes
        && prepared.lights.is_empty()
        && settings.environment_map().is_none()
        && settings.aov == wavetrace::layout::AOV_RADIANCE
    {
        eprintln!(
            "note: {}: nothing emits light (no emissive surfaces, punctual lights or environment): the image will be black",
            path.display()
        );
    }
    Ok((scene, prepared, settings))
}

/// Refuses, before anything renders, an output the render could not write: an extension other
/// than `.exr` or `.png` (in any case), or a folder that does not exist.
pub(crate) fn check_output(output: &Path) -> Result<()> {
    let ext = output
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    if !ext
        .as_deref()
        .is_some_and(|e| wavetrace::image_io::SUPPORTED_EXTENSIONS.contains(&e))
    {
        bail!(
            "{}: the output must end in .exr, .png, .jpg, .jpeg or .hdr (or be - with --format)",
            output.display()
        );
    }
    let folder = match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        bail!(
            "{}: the folder {} does not exist (create it, or write elsewhere)",
            output.display(),
            folder.display()
        );
    }
    Ok(())
}

/// `--device auto`: a GPU (discrete, integrated or virtual) when the Vulkan loader reports a
/// usable one or `--gpu-index` names a device, else the CPU reference, which `wavetrace bench`
/// measures faster than a CPU Vulkan driver (lavapipe) on most of the committed scenes (the
/// default Cornell box by about 1.3×; lavapipe leads on two or three of the nine by up to
/// 1.16×, docs/perf-log/2026-12-02-lavapipe-scene-reads.md). Says which.
pub(crate) fn resolve_device(kind: DeviceKind, gpu_index: Option<usize>) -> DeviceKind {
    if kind != DeviceKind::Auto {
        return kind;
    }
    if gpu_index.is_some() {
        eprintln!("device auto: gpu (--gpu-index names one)");
        return DeviceKind::Gpu;
    }
    match wavetrace::gpu::list_devices() {
        Ok(devices) => match devices.iter().find(|d| d.renders() && d.kind != "cpu") {
            Some(d) => {
                eprintln!("device auto: gpu ({})", d.name);
                DeviceKind::Gpu
            }
            None => {
                let cpu_drivers: Vec<&str> = devices
                    .iter()
                    .filter(|d| d.renders())
                    .map(|d| d.name.as_str())
                    .collect();
                eprintln!(
                    "device auto: cpu (no GPU{}; the CPU reference is the faster there)",
                    if cpu_drivers.is_empty() {
                        String::new()
                    } else {
                        format!(", only the CPU Vulkan driver {}", cpu_drivers.join(", "))
                    }
                );
                DeviceKind::Cpu
            }
        },
        Err(_) => {
            eprintln!("device auto: cpu (no Vulkan driver)");
            DeviceKind::Cpu
        }
    }
}

#[cfg(test)]
mod tests {
    use super::image_size;

    #[test]
    fn missing_sides_follow_the_camera_aspect() {
        assert_eq!(image_size(None, None, None), (512, 512));
        assert_eq!(image_size(None, None, Some(2.0)), (512, 256));
        assert_eq!(image_size(Some(300), None, Some(1.5)), (300, 200));
        assert_eq!(image_size(None, Some(100), Some(1.5)), (150, 100));
        assert_eq!(image_size(Some(64), Some(48), Some(1.0)), (64, 48));
        assert_eq!(image_size(Some(64), None, Some(f32::NAN)), (64, 64));
    }
}

/// `--from`/`--look-at`/`--up`, `--orbit` and `--fov`: a camera placed by hand, or the file's
/// (or default) perspective camera with another field of view.
fn place_camera(
    scene: &mut Scene,
    bounds: (glam::Vec3, glam::Vec3),
    opts: &RenderOptions,
) -> Result<()> {
    use wavetrace::scene::{Camera, Projection};
    let yfov = opts.fov.map_or(Camera::framing_yfov(), f32::to_radians);
    if let (Some(from), Some(at)) = (opts.from, opts.look_at) {
        let up = opts.up.unwrap_or(glam::Vec3::Y);
        scene.camera = Camera::look_at(from, at, up, yfov)
            .map_err(|e| anyhow::anyhow!("--from {from} --look-at {at}: {e}"))?;
    } else if let Some((azimuth, elevation, distance)) = opts.orbit {
        scene.camera = Camera::orbit(bounds, azimuth, elevation, distance, yfov);
    } else if let Some(degrees) = opts.fov {
        match &mut scene.camera.projection {
            Projection::Perspective { yfov, .. } => *yfov = degrees.to_radians(),
            Projection::Orthographic { .. } => {
                bail!("--fov {degrees}: the camera is orthographic (it has no field of view)")
            }
        }
    }
    Ok(())
}
