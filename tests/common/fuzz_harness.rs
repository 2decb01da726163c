#![allow(dead_code)] // each binary that includes this uses part of it
//! One execution of the fuzz target `load_render` (tools/fuzz) and of its regression test
//! (tests/fuzz_regressions.rs), shared by both: a scene file's bytes are loaded under a small
//! memory budget, prepared (BVH build, light table, light BVH) and rendered 4×4 at 1 spp,
//! depth 2, on the CPU reference integrator, with the options (instancing, camera, thin lens,
//! sampler, light sampler, AOV, a moment of the file's animations) a hash of the bytes picks.
//!
//! The process's Rust heap is capped ([`CappedAllocator`], each binary installs it as its global
//! allocator): an allocation that the loader's memory budget does not bound ends the process at
//! once with a message, so libFuzzer saves the input as a crash however lazily the operating
//! system would have committed the memory.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{Animations, Budget, LoadOptions, Moment, SceneFile};

/// The memory budget every input is loaded under: small, so that inputs reach the budget's
/// refusals quickly.
pub const BUDGET: u64 = 16 << 20;

/// The most live Rust heap the process may hold: the budget (which bounds every large
/// allocation) plus what the budget does not account: the input's own copy, decoder state, the
/// film, thread stacks' bookkeeping, libFuzzer's and the test harness's own data.
pub const HEAP_LIMIT: usize = 8 * BUDGET as usize;

/// Live bytes allocated through [`CappedAllocator`], and the most ever live.
static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

/// The system allocator, refusing (by aborting with a message) to let the live heap pass
/// [`HEAP_LIMIT`].
pub struct CappedAllocator;

impl CappedAllocator {
    /// The most live heap seen since the last call, which resets it to the live heap now.
    pub fn take_peak() -> usize {
        PEAK.swap(LIVE.load(Ordering::Relaxed), Ordering::Relaxed)
    }

    fn grow(bytes: usize) {
        let live = LIVE
            .fetch_add(bytes, Ordering::Relaxed)
            .saturating_add(bytes);
        if live > HEAP_LIMIT {
            over_limit(bytes, live);
        }
        PEAK.fetch_max(live, Ordering::Relaxed);
    }

    fn shrink(bytes: usize) {
        LIVE.fetch_sub(bytes, Ordering::Relaxed);
    }
}

/// Says which allocation passed the cap and aborts. Writes with `write(2)` from a stack buffer:
/// allocating here would re-enter the allocator.
#[cold]
fn over_limit(bytes: usize, live: usize) -> ! {
    let mut buf = [0u8; 256];
    let mut len = 0;
    let mut put = |s: &[u8]| {
        let n = s.len().min(buf.len() - len);
        buf[len..len + n].copy_from_slice(&s[..n]);
        len += n;
    };
    put(b"\nfuzz harness: an allocation of ");
    put(decimal(bytes as u64, &mut [0; 20]));
    put(b" bytes takes the live Rust heap to ");
    put(decimal(live as u64, &mut [0; 20]));
    put(b" bytes, over the cap of ");
    put(decimal(HEAP_LIMIT as u64, &mut [0; 20]));
    put(b": an allocation the memory budget does not bound\n");
    // SAFETY: writes `len` initialised bytes of `buf` to standard error.
    unsafe {
        libc::write(2, buf.as_ptr().cast(), len);
    }
    std::process::abort();
}

fn decimal(mut n: u64, digits: &mut [u8; 20]) -> &[u8] {
    let mut at = digits.len();
    loop {
        at -= 1;
        digits[at] = b'0' + (n % 10) as u8;
        n /= 10;
        if n == 0 {
            return &digits[at..];
        }
    }
}

// SAFETY: every call is forwarded to `System` unchanged; only the sizes are counted.
unsafe impl GlobalAlloc for CappedAllocator {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        Self::grow(layout.size());
        System.alloc(layout)
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        Self::grow(layout.size());
        System.alloc_zeroed(layout)
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout);
        Self::shrink(layout.size());
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if new_size > layout.size() {
            Self::grow(new_size - layout.size());
        }
        let p = System.realloc(ptr, layout, new_size);
        if p.is_null() {
            if new_size > layout.size() {
                Self::shrink(new_size - layout.size());
            }
        } else if new_size < layout.size() {
            Self::shrink(layout.size() - new_size);
        }
        p
    }
}

/// What one input came to.
#[derive(Debug)]
pub enum Outcome {
    /// Loaded and rendered: the render's dropped (NaN or infinite) samples.
    Rendered { triangles: usize, dropped: u64 },
    /// Refused with this error (`{:#}`, the whole chain).
    Refused(String),
}

/// How one input is loaded and rendered besides its bytes: chosen by a hash of the bytes, so
/// that the fuzzer reaches every option with file contents alike and an input always runs the
/// same way (here and in tests/fuzz_regressions.rs).
#[derive(Clone, Debug, PartialEq)]
pub struct Variant {
    /// `LoadOptions::instancing`.
    pub instancing: bool,
    /// Which of the file's camera instances renders (modulo their number; 0 is the default).
    pub camera: usize,
    /// A thin lens of this diameter (0: a pinhole).
    pub aperture: f32,
    pub sampler: u32,
    pub light_sampler: u32,
    pub aov: u32,
    /// Mostly the path tracer; light tracing and BDPT a quarter of the time each, with no sky,
    /// no lens and radiance (what they accept).
    pub integrator: wavetrace::render::Integrator,
    /// For a file with animations: the static pose (a quarter of the time), or every animation
    /// at this many eighths of a second, from before its first keyframe to past its last.
    pub moment: Option<u32>,
}

impl Variant {
    pub fn of(bytes: &[u8]) -> Variant {
        // FNV-1a (Fowler, Noll, Vo), 64 bits.
        let h = bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
            (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3)
        });
        use wavetrace::layout::*;
        Variant {
            instancing: h & 1 == 0,
            camera: ((h >> 1) & 7) as usize,
            aperture: if (h >> 4) & 3 == 0 { 0.05 } else { 0.0 },
            sampler: [SAMPLER_SOBOL, SAMPLER_STRATIFIED, SAMPLER_INDEPENDENT]
                [((h >> 6) % 3) as usize],
            light_sampler: if (h >> 8) & 1 == 0 {
                LIGHT_SAMPLER_BVH
            } else {
                LIGHT_SAMPLER_POWER
            },
            // Mostly radiance, the render users ask for.
            aov: match (h >> 9) & 7 {
                1 => AOV_BASE_COLOR,
                2 => AOV_NORMAL,
                3 => AOV_UV,
                4 => AOV_EMISSION,
                _ => AOV_RADIANCE,
            },
            integrator: match (h >> 12) & 3 {
                1 => wavetrace::render::Integrator::Light,
                2 => wavetrace::render::Integrator::Bdpt,
                _ => wavetrace::render::Integrator::Path,
            },
            moment: match (h >> 14) & 3 {
                0 => None,
                _ => Some(((h >> 16) % 41) as u32),
            },
        }
    }

    /// The film of every render: tiny, so that an execution's time goes to the loader and BVH.
    pub fn settings(&self) -> RenderSettings {
        let mut settings = RenderSettings {
            width: 4,
            height: 4,
            spp: 1,
            max_depth: 2,
            // A grey sky, so that misses and environment sampling run too.
            environment: glam::Vec3::splat(0.5),
            aperture: self.aperture,
            sampler: self.sampler,
            light_sampler: self.light_sampler,
            aov: self.aov,
            integrator: self.integrator,
            ..RenderSettings::default()
        };
        if self.integrator != wavetrace::render::Integrator::Path {
            settings.environment = glam::Vec3::ZERO;
            settings.aperture = 0.0;
            settings.aov = wavetrace::layout::AOV_RADIANCE;
        }
        settings
    }
}

/// Loads `bytes` as the scene file `source` (its folder is where relative URIs resolve) under
/// [`BUDGET`], prepares it and renders it as its [`Variant`] says.
pub fn run(source: &Path, bytes: &[u8]) -> Outcome {
    let variant = Variant::of(bytes);
    let options = LoadOptions {
        allow_paths: Vec::new(),
        budget: Budget::new(BUDGET),
        instancing: variant.instancing,
    };
    let file = match SceneFile::from_bytes(source, bytes.to_vec(), &options) {
        Ok(file) => file,
        Err(e) => return Outcome::Refused(format!("{e:#}")),
    };
    let moment = match variant.moment {
        Some(eighths) if !file.animations().is_empty() => Moment {
            animations: Animations::All,
            time: eighths as f32 / 8.0 - 0.5,
        },
        _ => Moment::rest(),
    };
    let mut scene = match file.scene(&moment, &options) {
        Ok(scene) => scene,
        Err(e) => return Outcome::Refused(format!("{e:#}")),
    };
    if !scene.cameras.is_empty() {
        let which = scene.cameras[variant.camera % scene.cameras.len()].index;
        if let Err(e) = scene.select_camera(&which.to_string()) {
            return Outcome::Refused(format!("{}: {e:#}", source.display()));
        }
    }
    let prepared = PreparedScene::new(&scene);
    let settings = variant.settings();
    if let Err(e) = prepared.thin_lens(&settings) {
        return Outcome::Refused(format!("{}: {e:#}", source.display()));
    }
    if let Err(e) = wavetrace::render::check(&prepared, &settings) {
        return Outcome::Refused(format!("{}: {e}", source.display()));
    }
    let output = wavetrace::cpu::render(&prepared, &settings);
    Outcome::Rendered {
        triangles: prepared.triangles.len(),
        dropped: output.film.dropped,
    }
}
