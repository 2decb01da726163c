//! The fuzz target's execution (tools/fuzz, docs/security.md "Fuzzing"; tests/common/fuzz_harness.rs) on
//! every input the fuzzer found to panic, hang or allocate without bound (tests/fuzz/, each with
//! its expected outcome in tests/fuzz/expect.json) and on the hostile corpus (tests/hostile/):
//! load from memory under a 16 MiB budget, prepare, render 4×4 on the CPU. Each must render or be
//! refused with an error naming the file and the glTF object, without a panic (not even one the
//! loader's last-guard `catch_unwind` turns into an error) and with the live heap under the
//! harness's cap (the allocator aborts the test binary otherwise).
//!
//! A test binary of its own: its capped global allocator holds for the whole process.

#[path = "common/fuzz_harness.rs"]
mod fuzz_harness;

use fuzz_harness::{CappedAllocator, Outcome, BUDGET, HEAP_LIMIT};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Once;

#[global_allocator]
static ALLOCATOR: CappedAllocator = CappedAllocator;

/// Panics raised anywhere in this binary since it started, caught or not.
static PANICS: AtomicUsize = AtomicUsize::new(0);

fn count_panics() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICS.fetch_add(1, Ordering::SeqCst);
            previous(info);
        }));
    });
}

fn dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join(name)
}

/// Runs the harness on `path`; the problems found, if any.
fn check(path: &Path, expected: Option<(&str, &[String])>) -> Vec<String> {
    let bytes = std::fs::read(path).unwrap();
    let panics_before = PANICS.load(Ordering::SeqCst);
    let outcome = fuzz_harness::run(path, &bytes);
    let peak = CappedAllocator::take_peak();
    let name = path.file_name().unwrap().to_str().unwrap();
    println!("{name}: peak heap {} KiB: {outcome:?}", peak >> 10);
    let mut problems = Vec::new();
    if PANICS.load(Ordering::SeqCst) != panics_before {
        problems.push("panicked".to_owned());
    }
    if let Outcome::Refused(message) = &outcome {
        if !message.contains(name) {
            problems.push(format!("the error does not name the file: {message}"));
        }
        if message.contains("the glTF library failed") {
            problems.push(format!("a panic became the error: {message}"));
        }
    }
    if let Some((want, needles)) = expected {
        let got = match &outcome {
            Outcome::Rendered { .. } => "rendered",
            Outcome::Refused(_) => "refused",
        };
        if got != want {
            problems.push(format!("{got}, expected {want}: {outcome:?}"));
        }
        if let Outcome::Refused(message) = &outcome {
            for needle in needles {
                if !message.contains(needle.as_str()) {
                    problems.push(format!("the error lacks \"{needle}\": {message}"));
                }
            }
        }
    }
    problems
        .into_iter()
        .map(|p| format!("{name}: {p}"))
        .collect()
}

#[test]
fn every_fuzzer_finding_renders_or_is_refused_cleanly() {
    count_panics();
    let expect: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir("fuzz").join("expect.json")).unwrap())
            .unwrap();
    let cases = expect.as_array().unwrap();
    let mut failures = Vec::new();
    for case in cases {
        let file = case["file"].as_str().unwrap();
        let outcome = case["outcome"].as_str().unwrap();
        let needles: Vec<String> = case["needles"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| n.as_str().unwrap().to_owned())
            .collect();
        failures.extend(check(&dir("fuzz").join(file), Some((outcome, &needles))));
    }
    // Every input kept in tests/fuzz/ is listed.
    for entry in std::fs::read_dir(dir("fuzz")).unwrap() {
        let name = entry.unwrap().file_name().into_string().unwrap();
        if name != "expect.json" && !cases.iter().any(|c| c["file"] == name.as_str()) {
            failures.push(format!("{name}: not listed in tests/fuzz/expect.json"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn every_hostile_file_renders_or_is_refused_cleanly_from_memory() {
    count_panics();
    let mut failures = Vec::new();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir("hostile"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gltf" || e == "glb"))
        .collect();
    files.sort();
    assert!(files.len() >= 40, "the hostile corpus lost files");
    for path in files {
        failures.extend(check(&path, None));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(HEAP_LIMIT as u64 > BUDGET);
}
