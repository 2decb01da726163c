//! Hostile glTF files (tests/hostile/, written by tools/gen_hostile.py): each must end with the
//! exit status its expectation names (never a panic or a signal), an error that names the file
//! and the JSON path of the offending object, and a process whose peak memory stays within the
//! memory budget it was given plus the program's own fixed footprint.
//!
//! A test binary of its own: a child's peak memory (wait4's ru_maxrss) counts what it inherited
//! from the test process it was forked from, which a binary of larger tests would inflate
//! (440 MiB measured in one with the real-file renders); and `tests/hostile/link-out.bin` links
//! to this file.

use std::ffi::CString;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// The budget every corpus file is loaded under.
const MAX_MEMORY: &str = "256M";
const MAX_MEMORY_BYTES: u64 = 256 << 20;
/// What the process may take beyond the budget: code, the runtime, rayon's thread stacks and
/// the allocator's slack, none of which the budget accounts. Far below the budgets the corpus
/// files try to exceed (over 1 GiB each).
const FOOTPRINT_BYTES: u64 = 96 << 20;

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile")
}

struct Run {
    status: std::process::ExitStatus,
    stderr: String,
    peak_bytes: u64,
}

/// Renders `scene` 1×1 at 1 spp on the CPU and reports the status, stderr and peak resident
/// memory of exactly this child (wait4).
#[allow(clippy::zombie_processes)] // reaped by wait4 below, which std's wait would not allow
fn render(scene: &Path, extra: &[String], tag: &str) -> Run {
    let dir = std::env::temp_dir().join(format!("wavetrace-hostile-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let err_path = dir.join(format!("{tag}.stderr"));
    let child = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args([
            "render", "--device", "cpu", "--spp", "1", "--width", "1", "--height", "1",
        ])
        .args(["--max-memory", MAX_MEMORY, "-o"])
        .arg(dir.join(format!("{tag}.png")))
        .arg(scene)
        .args(extra)
        .current_dir(corpus())
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&err_path).unwrap())
        .spawn()
        .expect("the wavetrace binary runs");
    let mut status = 0;
    // SAFETY: rusage is plain data; wait4 reaps this child only, which `child` never waits on.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let pid = child.id() as libc::pid_t;
    let reaped = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(reaped, pid, "wait4 failed");
    Run {
        status: std::process::ExitStatus::from_raw(status),
        stderr: std::fs::read_to_string(&err_path).unwrap(),
        peak_bytes: usage.ru_maxrss as u64 * 1024,
    }
}

#[test]
fn every_hostile_file_gives_its_expected_outcome_within_the_memory_budget() {
    let dir = corpus();
    let expect: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("expect.json")).unwrap()).unwrap();
    let cases = expect.as_array().unwrap();
    assert!(cases.len() >= 40, "the corpus lost files");
    let mut failures = Vec::new();
    for (k, case) in cases.iter().enumerate() {
        let file = case["file"].as_str().unwrap();
        let expected = case["exit"].as_i64().unwrap() as i32;
        let args: Vec<String> = case["args"]
            .as_array()
            .unwrap()
            .iter()
            .map(|a| a.as_str().unwrap().replace("{dir}", dir.to_str().unwrap()))
            .collect();
        let run = render(&dir.join(file), &args, &format!("case{k}"));
        let mut problems = Vec::new();
        match run.status.code() {
            Some(code) if code == expected => {}
            Some(code) => problems.push(format!("exit status {code}, expected {expected}")),
            None => problems.push(format!("killed by signal {:?}", run.status.signal())),
        }
        if run.stderr.contains("panicked") {
            problems.push("a panic was caught".into());
        }
        for needle in case["needles"].as_array().unwrap() {
            let needle = needle.as_str().unwrap();
            if !run.stderr.contains(needle) {
                problems.push(format!("the message lacks \"{needle}\""));
            }
        }
        let name = Path::new(file).file_name().unwrap().to_str().unwrap();
        if expected != 0 && !run.stderr.contains(name) {
            problems.push("the message does not name the file".into());
        }
        if run.peak_bytes > MAX_MEMORY_BYTES + FOOTPRINT_BYTES {
            problems.push(format!("peak memory {} MiB", run.peak_bytes >> 20));
        }
        println!(
            "{file}: exit {:?}, peak {} MiB: {}",
            run.status.code(),
            run.peak_bytes >> 20,
            run.stderr.trim()
        );
        if !problems.is_empty() {
            failures.push(format!(
                "{file}: {}\n  {}",
                problems.join("; "),
                run.stderr.trim()
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A named pipe, as the scene or next to it, is refused without blocking on it (the corpus cannot hold
/// one: git stores no pipes).
#[test]
fn a_named_pipe_is_refused_without_blocking() {
    let dir = std::env::temp_dir().join(format!("wavetrace-fifo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fifo = dir.join("pipe.bin");
    let c = CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a plain POSIX call on a valid C string.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let scene = std::fs::read_to_string(corpus().join("uri_symlink.gltf"))
        .unwrap()
        .replace("link-out.bin", "pipe.bin");
    std::fs::write(dir.join("pipe.gltf"), scene).unwrap();
    let run = render(&dir.join("pipe.gltf"), &[], "fifo");
    let as_scene = render(&fifo, &[], "fifo-scene");
    std::fs::remove_dir_all(&dir).ok();
    assert_eq!(as_scene.status.code(), Some(2), "{}", as_scene.stderr);
    assert!(
        as_scene.stderr.contains("not a regular file"),
        "{}",
        as_scene.stderr
    );
    assert_eq!(run.status.code(), Some(2), "{}", run.stderr);
    assert!(
        run.stderr.contains("buffers[0].uri") && run.stderr.contains("not a regular file"),
        "{}",
        run.stderr
    );
}

/// A valid scene under a budget too small for it is refused with what it would have needed.
#[test]
fn a_small_budget_refuses_with_the_memory_needed() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.gltf");
    let o = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args([
            "render", "--device", "cpu", "--spp", "1", "--width", "1", "--height", "1",
        ])
        .args([
            "--max-memory",
            "20K",
            "-o",
            "/nonexistent/never-written.png",
        ])
        .arg(&scene)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("would need") && stderr.contains("20.00 KiB (--max-memory)"),
        "{stderr}"
    );
    let bad = Command::new(env!("CARGO_BIN_EXE_wavetrace"))
        .args(["render", "--max-memory", "lots"])
        .arg(&scene)
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}

/// The corpus is exactly what tools/gen_hostile.py writes (skipped without python3).
#[test]
fn the_corpus_matches_its_generator() {
    let out = std::env::temp_dir().join(format!("wavetrace-gen-hostile-{}", std::process::id()));
    let status = Command::new("python3")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/gen_hostile.py"))
        .arg(&out)
        .status();
    let Ok(status) = status else {
        eprintln!("skipping: python3 is not installed");
        return;
    };
    assert!(status.success(), "tools/gen_hostile.py failed");
    let expect: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("expect.json")).unwrap()).unwrap();
    let mut names: Vec<String> = vec!["expect.json".into(), "quad.bin".into(), "texel.png".into()];
    names.extend(
        expect
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c["file"].as_str().unwrap().to_owned()),
    );
    for name in names {
        let generated = std::fs::read(out.join(&name)).unwrap();
        let committed = std::fs::read(corpus().join(&name)).unwrap();
        assert!(
            generated == committed,
            "tests/hostile/{name} differs from what tools/gen_hostile.py writes; run it and commit"
        );
    }
    std::fs::remove_dir_all(&out).ok();
}
