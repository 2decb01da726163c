//! The Python package `wavetrace` (feature `python`; `pip install .` builds it with maturin
//! from `pyproject.toml`, the Python side in `src/python/wavetrace/`): scenes loaded once and
//! rendered many times on the CPU reference or a Vulkan device, images as numpy arrays.
//!
//! The GIL is released while a render runs; a progress callback is called from the caller's
//! thread about ten times a second. Errors are `wavetrace.WavetraceError` with the message the
//! command line prints (the file and the JSON path of the object included).

use crate::cpu::CpuBackend;
use crate::film::Film;
use crate::gpu::{GpuBackend, GpuOptions, GpuRenderer};
use crate::lights::environment::EnvironmentMap;
use crate::render::{Aov, Backend, PreparedScene, RenderSettings};
use numpy::{PyArray1, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::exceptions::PyException;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::{Arc, Mutex, OnceLock};

pyo3::create_exception!(
    wavetrace,
    WavetraceError,
    PyException,
    "A scene that cannot load, a render that fails, a bad argument: the message names the file and the problem."
);

fn error(e: anyhow::Error) -> PyErr {
    WavetraceError::new_err(format!("{e:#}"))
}

/// The process's Vulkan renderer, made on the first GPU render and kept (its pipelines too);
/// one render at a time uses it.
fn gpu() -> &'static Mutex<Option<GpuBackend>> {
    static GPU: OnceLock<Mutex<Option<GpuBackend>>> = OnceLock::new();
    GPU.get_or_init(|| Mutex::new(None))
}

/// `device="auto"`: a real GPU where the Vulkan loader lists one, else the CPU reference
/// (faster than a CPU Vulkan driver such as lavapipe), as the command line chooses.
fn resolve_device(device: &str) -> PyResult<&'static str> {
    match device {
        "cpu" => Ok("cpu"),
        "gpu" => Ok("gpu"),
        "auto" => {
            let real = crate::gpu::list_devices()
                .map(|d| d.iter().any(|d| d.usable && d.kind != "cpu"))
                .unwrap_or(false);
            Ok(if real { "gpu" } else { "cpu" })
        }
        other => Err(WavetraceError::new_err(format!(
            "device={other:?}: choose \"auto\", \"gpu\" or \"cpu\""
        ))),
    }
}

/// A glTF scene loaded and prepared for tracing once, to render any number of times.
#[pyclass(module = "wavetrace", frozen)]
struct Scene {
    path: String,
    prepared: Arc<PreparedScene>,
    env_map: Option<Arc<EnvironmentMap>>,
    aspect: f32,
}

#[pymethods]
impl Scene {
    /// Loads `path` (.gltf, .glb) through the camera `camera` (index or name; the file's first,
    /// or one framing the scene); `env` is None (a file without lights is lit by the built-in
    /// studio, as the command line does), "studio", "none" or an .hdr/.exr map.
    #[new]
    #[pyo3(signature = (path, *, camera=None, env=None))]
    fn new(
        py: Python<'_>,
        path: std::path::PathBuf,
        camera: Option<String>,
        env: Option<String>,
    ) -> PyResult<Self> {
        py.detach(|| -> anyhow::Result<Scene> {
            let mut scene = crate::scene::Scene::load(&path)?;
            if let Some(which) = &camera {
                scene.select_camera(which)?;
            }
            let prepared = PreparedScene::new(&scene);
            let env_map = match env.as_deref() {
                None if !prepared.has_own_lights() => Some(crate::lights::studio()),
                None | Some("none") => None,
                Some("studio") => Some(crate::lights::studio()),
                Some(file) => Some(Arc::new(EnvironmentMap::load(
                    std::path::Path::new(file),
                    crate::scene::default_memory_budget(),
                )?)),
            };
            Ok(Scene {
                path: path.display().to_string(),
                aspect: scene.camera.aspect_ratio().unwrap_or(1.0),
                prepared: Arc::new(prepared),
                env_map,
            })
        })
        .map_err(error)
    }

    /// Renders the scene: `spp` samples per pixel at `width` × `height` (a missing side follows
    /// the camera's aspect; 512 wide by default), the path tracer to `max_depth` bounces, on
    /// `device`; `aov` names layers to render beside the image (albedo, normal, depth,
    /// position, uv, material, instance, emission, alpha); `progress(done, total)` is called
    /// with the samples done. The same seed gives the same image on the same device.
    #[pyo3(signature = (*, width=None, height=None, spp=64, seed=0, max_depth=8, device="auto", aov=Vec::new(), progress=None))]
    #[allow(clippy::too_many_arguments)]
    fn render(
        &self,
        py: Python<'_>,
        width: Option<u32>,
        height: Option<u32>,
        spp: u32,
        seed: u32,
        max_depth: u32,
        device: &str,
        aov: Vec<String>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Render> {
        let (width, height) = match (width, height) {
            (Some(w), Some(h)) => (w, h),
            (Some(w), None) => (w, ((w as f32 / self.aspect).round() as u32).max(1)),
            (None, Some(h)) => (((h as f32 * self.aspect).round() as u32).max(1), h),
            (None, None) => (512, ((512.0 / self.aspect).round() as u32).max(1)),
        };
        if width == 0 || height == 0 || width > 16384 || height > 16384 || spp == 0 {
            return Err(WavetraceError::new_err(format!(
                "{width}×{height} at {spp} spp: sides 1 to 16384 pixels, at least 1 sample"
            )));
        }
        let layers: Vec<Aov> = aov
            .iter()
            .map(|name| {
                Aov::from_name(name).ok_or_else(|| {
                    WavetraceError::new_err(format!(
                        "aov {name:?}: one of {}",
                        Aov::ALL.map(Aov::name).join(", ")
                    ))
                })
            })
            .collect::<PyResult<_>>()?;
        let device = resolve_device(device)?;
        let settings = RenderSettings {
            width,
            height,
            spp,
            seed,
            max_depth,
            env_map: self.env_map.clone(),
            ..RenderSettings::default()
        };
        crate::render::check(&self.prepared, &settings).map_err(WavetraceError::new_err)?;
        let bar = indicatif::ProgressBar::hidden();
        bar.set_length(settings.pixel_count() * spp as u64);
        let (prepared, watched) = (self.prepared.clone(), bar.clone());
        let job = move || -> anyhow::Result<(Film, crate::render::RenderStats, Vec<(Aov, Film)>, String)> {
            let mut slot = gpu().lock().unwrap_or_else(|e| e.into_inner());
            let backend: &dyn Backend = match device {
                "gpu" => match &mut *slot {
                    Some(b) => b,
                    empty => empty.insert(GpuBackend {
                        renderer: GpuRenderer::new(&GpuOptions::default())?,
                        wavefront: None,
                    }),
                },
                _ => &CpuBackend,
            };
            let never = std::sync::atomic::AtomicBool::new(false);
            let (out, _) = backend.render_range(&prepared, &settings, 0..spp, &watched, &never)?;
            if let Some(fault) = &out.stats.fault {
                anyhow::bail!("{fault}");
            }
            let layers = layers
                .iter()
                .map(|&a| Ok((a, crate::render::aov::render_aov(backend, &prepared, &settings, a, spp)?)))
                .collect::<anyhow::Result<_>>()?;
            Ok((out.film, out.stats, layers, backend.describe()))
        };
        let worker = std::thread::spawn(job);
        // The caller's thread waits without the GIL and calls `progress` between waits.
        while !worker.is_finished() {
            py.detach(|| std::thread::sleep(std::time::Duration::from_millis(100)));
            if let Some(callback) = &progress {
                callback.call1(py, (bar.position(), bar.length().unwrap_or(0)))?;
            }
            py.check_signals()?;
        }
        let (film, stats, layers, described) = worker
            .join()
            .map_err(|_| WavetraceError::new_err("the render panicked"))?
            .map_err(error)?;
        if let Some(callback) = &progress {
            callback.call1(py, (bar.length().unwrap_or(0), bar.length().unwrap_or(0)))?;
        }
        let image = rgb_array(py, &film, |p| film.mean(p).to_array())?;
        let variance = rgb_array(py, &film, |p| film.variance_of_mean(p).to_array())?;
        let dict = PyDict::new(py);
        for (aov, layer) in &layers {
            let array = layer_array(py, *aov, layer)?;
            dict.set_item(aov.name(), array)?;
        }
        let stats_dict = PyDict::new(py);
        stats_dict.set_item("seconds", stats.seconds)?;
        stats_dict.set_item("samples", stats.samples)?;
        stats_dict.set_item("samples_per_second", stats.samples_per_second())?;
        stats_dict.set_item("rays_per_second", stats.rays_per_second())?;
        stats_dict.set_item("extension_rays", stats.extension_rays)?;
        stats_dict.set_item("shadow_rays", stats.shadow_rays)?;
        stats_dict.set_item("dropped", stats.dropped)?;
        stats_dict.set_item("device", described)?;
        Ok(Render {
            image: image.unbind(),
            variance: variance.unbind(),
            layers: dict.unbind(),
            stats: stats_dict.unbind(),
            film,
        })
    }

    /// The scene file as it was named.
    #[getter]
    fn path(&self) -> &str {
        &self.path
    }

    fn __repr__(&self) -> String {
        format!(
            "wavetrace.Scene({:?}: {} triangles, {} emitting)",
            self.path,
            self.prepared.triangles.len(),
            self.prepared.lights.len()
        )
    }
}

/// H × W × 3 float32 of a film, row 0 at the top.
fn rgb_array<'py>(
    py: Python<'py>,
    film: &Film,
    value: impl Fn(usize) -> [f32; 3],
) -> PyResult<Bound<'py, numpy::PyArray3<f32>>> {
    let flat: Vec<f32> = (0..film.len()).flat_map(&value).collect();
    PyArray1::from_vec(py, flat).reshape([film.height as usize, film.width as usize, 3])
}

/// An AOV layer as numpy: H × W × 3 (colours, directions, points), H × W × 2 (uv), H × W
/// float32 (depth, alpha) or uint32 (IDs).
fn layer_array<'py>(py: Python<'py>, aov: Aov, film: &Film) -> PyResult<Bound<'py, PyAny>> {
    use crate::image_io::LayerKind;
    let (h, w) = (film.height as usize, film.width as usize);
    let mean = |p: usize| film.mean(p).to_array();
    Ok(match aov.kind() {
        LayerKind::Uv => {
            let flat: Vec<f32> = (0..film.len())
                .flat_map(|p| [mean(p)[0], mean(p)[1]])
                .collect();
            PyArray1::from_vec(py, flat).reshape([h, w, 2])?.into_any()
        }
        LayerKind::Depth | LayerKind::Alpha => {
            let flat: Vec<f32> = (0..film.len()).map(|p| mean(p)[0]).collect();
            PyArray1::from_vec(py, flat).reshape([h, w])?.into_any()
        }
        LayerKind::Id => {
            let flat: Vec<u32> = (0..film.len()).map(|p| mean(p)[0].round() as u32).collect();
            PyArray1::from_vec(py, flat).reshape([h, w])?.into_any()
        }
        _ => rgb_array(py, film, mean)?.into_any(),
    })
}

/// One render: `image` (H × W × 3 float32, linear radiance, the mean of each pixel's samples),
/// `variance` (of that mean), `layers` (the AOVs asked for, by name) and `stats`.
#[pyclass(module = "wavetrace", frozen)]
struct Render {
    #[pyo3(get)]
    image: Py<numpy::PyArray3<f32>>,
    #[pyo3(get)]
    variance: Py<numpy::PyArray3<f32>>,
    #[pyo3(get)]
    layers: Py<PyDict>,
    #[pyo3(get)]
    stats: Py<PyDict>,
    /// The film itself (its exact sums), for `verify`.
    film: Film,
}

#[pymethods]
impl Render {
    fn __repr__(&self, py: Python<'_>) -> String {
        let shape = self.image.bind(py).shape().to_vec();
        format!(
            "wavetrace.Render(image {shape:?}, layers {:?})",
            self.layers.bind(py).keys().to_string()
        )
    }
}

/// Loads `path` and renders it once: `Scene(path, camera=, env=).render(**options)`.
#[pyfunction]
#[pyo3(signature = (path, *, camera=None, env=None, width=None, height=None, spp=64, seed=0, max_depth=8, device="auto", aov=Vec::new(), progress=None))]
#[allow(clippy::too_many_arguments)]
fn render(
    py: Python<'_>,
    path: std::path::PathBuf,
    camera: Option<String>,
    env: Option<String>,
    width: Option<u32>,
    height: Option<u32>,
    spp: u32,
    seed: u32,
    max_depth: u32,
    device: &str,
    aov: Vec<String>,
    progress: Option<Py<PyAny>>,
) -> PyResult<Render> {
    Scene::new(py, path, camera, env)?.render(
        py, width, height, spp, seed, max_depth, device, aov, progress,
    )
}

/// The verdict of the per-tile Welch test (`wavetrace compare`, `wavetrace verify`): `passed`,
/// the number of tile × channel `tests`, the `failures`, the smallest p-value `min_p`, the
/// `relative_mse` of the first image against the second, and the test's `summary` line.
/// True where the images agree.
#[pyclass(module = "wavetrace", frozen, get_all)]
struct Verdict {
    passed: bool,
    tests: usize,
    failures: usize,
    min_p: f64,
    relative_mse: f64,
    summary: String,
}

#[pymethods]
impl Verdict {
    fn __bool__(&self) -> bool {
        self.passed
    }

    fn __repr__(&self) -> String {
        format!("wavetrace.Verdict({})", self.summary)
    }
}

fn verdict(a: &Film, b: &Film, tile: u32, alpha: f64) -> anyhow::Result<Verdict> {
    let cmp = crate::stats::compare_films(a, b, tile, alpha)?;
    let e = crate::stats::image_error(a, b, crate::stats::RELATIVE_MSE_EPSILON)?;
    Ok(Verdict {
        passed: cmp.passed(),
        tests: cmp.tests,
        failures: cmp.failures.len(),
        min_p: cmp.min_p,
        relative_mse: e.relative_mse,
        summary: cmp.to_string(),
    })
}

/// Whether two EXRs written by wavetrace have the same expectation, by the per-tile Welch test
/// `wavetrace compare` runs (family-wise level `alpha`, tiles of `tile` pixels).
#[pyfunction]
#[pyo3(signature = (a, b, *, tile=8, alpha=0.01))]
fn compare(
    py: Python<'_>,
    a: std::path::PathBuf,
    b: std::path::PathBuf,
    tile: u32,
    alpha: f64,
) -> PyResult<Verdict> {
    py.detach(|| -> anyhow::Result<Verdict> {
        let fa = crate::image_io::read_film(&a)?;
        let fb = crate::image_io::read_film(&b)?;
        verdict(&fa, &fb, tile, alpha)
    })
    .map_err(error)
}

/// `wavetrace verify` of one scene: rendered on the GPU and with the CPU reference
/// (independent seeds `seed` and `seed + 1`, the same settings), then the per-tile Welch test.
#[pyfunction]
#[pyo3(signature = (path, *, camera=None, env=None, width=64, height=None, spp=256, seed=0, max_depth=8, tile=8, alpha=0.01))]
#[allow(clippy::too_many_arguments)]
fn verify(
    py: Python<'_>,
    path: std::path::PathBuf,
    camera: Option<String>,
    env: Option<String>,
    width: Option<u32>,
    height: Option<u32>,
    spp: u32,
    seed: u32,
    max_depth: u32,
    tile: u32,
    alpha: f64,
) -> PyResult<Verdict> {
    let scene = Scene::new(py, path, camera, env)?;
    let gpu = scene.render(
        py,
        width,
        height,
        spp,
        seed,
        max_depth,
        "gpu",
        Vec::new(),
        None,
    )?;
    let cpu = scene.render(
        py,
        width,
        height,
        spp,
        seed.wrapping_add(1),
        max_depth,
        "cpu",
        Vec::new(),
        None,
    )?;
    let (a, b) = (&gpu.film, &cpu.film);
    py.detach(|| verdict(a, b, tile, alpha)).map_err(error)
}

/// The mean (H × W × 3 float32) and, where the file has them, the variance of the mean of an
/// EXR written by wavetrace.
#[pyfunction]
fn read_exr<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<(Bound<'py, PyAny>, Option<Bound<'py, PyAny>>)> {
    let image = crate::image_io::read_exr(&path).map_err(error)?;
    let (h, w) = (image.height as usize, image.width as usize);
    let array = |v: &Vec<[f32; 3]>| -> PyResult<Bound<'py, PyAny>> {
        let flat: Vec<f32> = v.iter().flatten().copied().collect();
        Ok(PyArray1::from_vec(py, flat).reshape([h, w, 3])?.into_any())
    };
    let mean = array(&image.mean)?;
    let variance = image.variance.as_ref().map(array).transpose()?;
    Ok((mean, variance))
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Scene>()?;
    m.add_class::<Render>()?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    m.add_class::<Verdict>()?;
    m.add_function(wrap_pyfunction!(compare, m)?)?;
    m.add_function(wrap_pyfunction!(verify, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    m.add("WavetraceError", m.py().get_type::<WavetraceError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
