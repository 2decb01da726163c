//! wavetrace: a headless GPU wavefront path tracer (Vulkan) with a CPU reference integrator that
//! implements the same mathematics, so every GPU image can be checked against it.
//!
//! The library's entry points are re-exported here: load a glTF file ([`Scene`]), prepare it
//! for tracing once ([`PreparedScene`]: BVH, light tree, textures), render it with the CPU
//! reference ([`cpu::render`]) or a Vulkan device ([`GpuRenderer`]) under [`RenderSettings`],
//! and read the [`Film`]: each pixel's mean, the variance of that mean and its sample count,
//! which [`image_io`] writes as EXR or PNG and [`stats::compare_films`] tests against another
//! film. `docs/library.md` walks through it; the other modules are the engine's rooms, public
//! for the tests and tools of this repository.
//!
//! # Example
//!
//! The Cornell box, 32 × 32 pixels at 16 samples each, on the CPU reference:
//!
//! ```
//! use wavetrace::{PreparedScene, RenderSettings, Scene};
//!
//! let scene = Scene::load(std::path::Path::new("scenes/cornell-box.gltf"))?;
//! let prepared = PreparedScene::new(&scene);
//! let settings = RenderSettings { width: 32, height: 32, spp: 16, ..Default::default() };
//! let out = wavetrace::cpu::render(&prepared, &settings);
//! // Linear radiance of the pixel in the middle, and the standard error of that mean.
//! let mean = out.film.mean(16 * 32 + 16);
//! let error = out.film.variance_of_mean(16 * 32 + 16).powf(0.5);
//! assert!(mean.x > 0.0 && error.x < mean.x);
//! println!("{:.0} samples/s", out.stats.samples_per_second());
//! wavetrace::image_io::write_image(&out.film, &std::env::temp_dir().join("cornell.exr"), 0.0)?;
//! # Ok::<(), anyhow::Error>(())
//! ```
//!
//! The same on a Vulkan device (Mesa's lavapipe where there is no GPU), and the two films
//! tested for the same expectation, tile by tile:
//!
//! ```no_run
//! use wavetrace::{GpuOptions, GpuRenderer, PreparedScene, RenderSettings, Scene};
//!
//! let prepared = PreparedScene::new(&Scene::load(std::path::Path::new("scenes/cornell-box.gltf"))?);
//! let settings = RenderSettings { width: 64, height: 64, spp: 64, ..Default::default() };
//! let gpu = GpuRenderer::new(&GpuOptions::default())?;
//! let on_gpu = gpu.render(&prepared, &settings, None)?.film;
//! // An independent seed: the same seed would draw the same random numbers on the CPU.
//! let reference = wavetrace::cpu::render(&prepared, &RenderSettings { seed: 1, ..settings });
//! let verdict = wavetrace::stats::compare_films(&on_gpu, &reference.film, 8, 0.01)?;
//! assert!(verdict.passed(), "{verdict}");
//! # Ok::<(), anyhow::Error>(())
//! ```

pub mod bsdf;
pub mod bvh;
pub mod cpu;
pub mod denoise;
pub mod film;
pub mod flip;
pub mod gpu;
pub mod image_io;
pub mod kernels;
pub mod layout;
pub mod lights;
pub mod mc;
pub mod mis;
pub mod paths;
#[cfg(feature = "python")]
mod python;
pub mod render;
pub mod sampling;
pub mod scene;
pub mod shard;
pub mod sobol;
pub mod spectrum;
pub mod stats;
pub mod surface;
pub mod texture;
pub mod tlas;
pub mod verify;
pub mod view;

pub use film::Film;
pub use gpu::{GpuOptions, GpuRenderer};
pub use render::{PreparedScene, RenderOutput, RenderSettings};
pub use scene::Scene;
