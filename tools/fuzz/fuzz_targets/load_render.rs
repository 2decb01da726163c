//! libFuzzer target: a scene file's bytes (`.glb`, or `.gltf` JSON with `data:` URIs) → load
//! under a 16 MiB memory budget → BVH build and light tables → a 4×4 CPU render at 1 spp,
//! depth 2 (tests/common/fuzz_harness.rs, shared with tests/fuzz_regressions.rs).
//!
//! A finding is a panic (libfuzzer-sys aborts on one, even inside the loader's `catch_unwind`),
//! a signal, a hang (`-timeout`), or a live Rust heap over the harness's cap (an allocation the
//! budget does not bound). A clean `Err` is a pass.

#![no_main]

#[path = "../../../tests/common/fuzz_harness.rs"]
mod fuzz_harness;

use fuzz_harness::CappedAllocator;
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

#[global_allocator]
static ALLOCATOR: CappedAllocator = CappedAllocator;

/// The scene's name: a file in an empty folder, so relative URIs resolve to nothing. One folder
/// for every fuzzing process (the harness never writes into it): a folder per process was left
/// behind by each of `-fork`'s jobs, which libFuzzer ends without running destructors.
fn source() -> &'static PathBuf {
    static SOURCE: OnceLock<PathBuf> = OnceLock::new();
    SOURCE.get_or_init(|| {
        let dir = std::env::temp_dir().join("wavetrace-fuzz");
        std::fs::create_dir_all(&dir).expect("a temporary folder");
        // One worker: the fuzzer runs with -jobs=1 on a shared machine.
        rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build_global()
            .expect("rayon's global pool");
        dir.join("input.gltf")
    })
}

fuzz_target!(|data: &[u8]| {
    fuzz_harness::run(source(), data);
});
