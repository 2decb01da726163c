//! The Slurm recipe of tools/slurm/ end to end on a real cluster: submit the shard array and
//! the dependent merge job (tools/slurm/submit.sh, CPU-only: no gres, --device cpu), wait for
//! them, and check the merged EXR against one render of every sample. Needs a cluster that
//! answers `sinfo` (tools/slurm/local-cluster.sh starts one on localhost; .ci/run does);
//! without one the test prints a notice and passes.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use crate::common;

/// Whether a Slurm controller answers, with a node up.
fn cluster_up() -> bool {
    let answer = Command::new("timeout")
        .args(["10", "sinfo", "-h", "-o", "%t"])
        .output();
    match answer {
        Ok(o) if o.status.success() => {
            let states = String::from_utf8_lossy(&o.stdout).into_owned();
            states
                .lines()
                .any(|s| s.starts_with("idle") || s.starts_with("mix") || s.starts_with("alloc"))
        }
        _ => false,
    }
}

/// The job's state as `scontrol show job` reports it (for an array, one state per task).
fn job_states(id: &str) -> Vec<String> {
    let o = Command::new("scontrol")
        .args(["show", "job", id])
        .output()
        .expect("scontrol runs");
    String::from_utf8_lossy(&o.stdout)
        .split_whitespace()
        .filter_map(|w| w.strip_prefix("JobState=").map(str::to_owned))
        .collect()
}

/// Runs tools/slurm/submit.sh, CPU-only, writing into `out_dir`, with the variables `vars`;
/// returns what it printed (the job ids).
fn run_submit(out_dir: &Path, vars: &[(&str, String)]) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let o = Command::new(root.join("tools/slurm/submit.sh"))
        .envs(vars.iter().map(|(k, v)| (k, v)))
        .env("OUT_DIR", out_dir)
        .env("DEVICE", "cpu")
        .env("WAVETRACE_GRES", "")
        .env("WAVETRACE", env!("CARGO_BIN_EXE_wavetrace"))
        .output()
        .expect("submit.sh runs");
    assert!(
        o.status.success(),
        "submit.sh: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Submits the recipe (tools/slurm/submit.sh) for the Cornell box with `options`, CPU-only;
/// returns the array and merge job ids.
fn submit(out_dir: &Path, spp: u32, shards: u32, options: &str) -> (String, String) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let ids = run_submit(
        out_dir,
        &[
            (
                "SCENE",
                root.join("scenes/cornell-box.gltf").display().to_string(),
            ),
            ("SPP", spp.to_string()),
            ("SHARDS", shards.to_string()),
            ("RENDER_OPTIONS", options.to_owned()),
        ],
    );
    let ids: Vec<&str> = ids.split_whitespace().collect();
    let [array, merge] = ids[..] else {
        panic!("submit.sh printed {ids:?}, not two job ids");
    };
    println!("submitted array job {array} and merge job {merge}");
    (array.to_owned(), merge.to_owned())
}

/// The logs of a run (shard-*.log, merge.log).
fn logs(out_dir: &Path) -> String {
    let files = common::files_with_extension(out_dir, &["log"]);
    files
        .iter()
        .map(|p| {
            format!(
                "--- {}\n{}",
                p.display(),
                std::fs::read_to_string(p).unwrap_or_default()
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Waits until `log` contains `text` (`seconds` at most: a guard against a hang, not a
/// measurement), else fails with `what` and the run's logs.
fn wait_for_log(out_dir: &Path, log: &Path, text: &str, seconds: u64, what: &str) {
    let deadline = Instant::now() + Duration::from_secs(seconds);
    while !std::fs::read_to_string(log).is_ok_and(|l| l.contains(text)) {
        assert!(Instant::now() < deadline, "{what}\n{}", logs(out_dir));
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Waits for the merge job to complete (15 minutes at most: a guard against a hang, not a
/// measurement) and checks that every array task completed.
fn wait_for(out_dir: &Path, array: &str, merge: &str, shards: usize) {
    let deadline = Instant::now() + Duration::from_secs(900);
    loop {
        let states = job_states(merge);
        if states.iter().any(|s| s == "COMPLETED") {
            break;
        }
        if states.iter().any(|s| {
            [
                "FAILED",
                "CANCELLED",
                "TIMEOUT",
                "NODE_FAIL",
                "OUT_OF_MEMORY",
                "BOOT_FAIL",
            ]
            .contains(&s.as_str())
        }) {
            panic!(
                "merge job {merge}: {states:?}; array {array}: {:?}\n{}",
                job_states(array),
                logs(out_dir)
            );
        }
        assert!(
            Instant::now() < deadline,
            "the jobs did not finish in 15 minutes: merge {states:?}, array {:?}\n{}",
            job_states(array),
            logs(out_dir)
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    let tasks = job_states(array);
    assert_eq!(tasks.len(), shards, "array tasks: {tasks:?}");
    assert!(tasks.iter().all(|s| s == "COMPLETED"), "{tasks:?}");
}

/// Renders every sample here, once, and checks that the merge holds the same samples: equal
/// counts, sums within the f32 summation-order bound (common::assert_same_samples).
fn assert_merge_is_the_single_render(out_dir: &Path, spp: u32, options: &str) {
    let single = out_dir.join("single.exr");
    let spp = spp.to_string();
    let mut args = vec![
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--spp",
        &spp,
        "-o",
        single.to_str().unwrap(),
    ];
    args.extend(options.split(' '));
    let o = common::wavetrace(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    common::assert_same_samples(&out_dir.join("merged.exr"), &single);
}

fn fresh_dir(name: &str) -> std::path::PathBuf {
    let dir = common::temp("slurm", name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn slurm_array_shards_merge_into_the_single_render() {
    if !cluster_up() {
        eprintln!(
            "skipping the Slurm end-to-end test: no Slurm cluster answers sinfo (start one with tools/slurm/local-cluster.sh start)"
        );
        return;
    }
    let out_dir = fresh_dir("run");
    let options = "--width 32 --height 32 --max-depth 4";
    let (spp, shards) = (16, 4);
    let start = Instant::now();
    let (array, merge) = submit(&out_dir, spp, shards, options);
    wait_for(&out_dir, &array, &merge, shards as usize);
    println!(
        "Slurm: {shards} shards and the merge finished {:.1} s after submission",
        start.elapsed().as_secs_f64()
    );
    assert_merge_is_the_single_render(&out_dir, spp, options);
}

/// Pre-emption as Slurm does it: `scontrol requeue` of a running shard sends it SIGTERM; it
/// writes its partial shard and exits, runs again, continues the partial with --resume, and
/// the merge job (afterok on the array) waits for it.
#[test]
fn a_requeued_shard_resumes_and_the_merge_waits_for_it() {
    if !cluster_up() {
        eprintln!("skipping the Slurm requeue test: no Slurm cluster answers sinfo");
        return;
    }
    let out_dir = fresh_dir("requeue");
    let options = "--width 8 --height 8 --max-depth 4";
    // Far more samples than a shard renders in the moment before the requeue reaches it.
    let (spp, shards) = (40000, 2);
    let (array, merge) = submit(&out_dir, spp, shards, options);
    let task = format!("{array}_1");
    let log = out_dir.join("shard-1.log");
    wait_for_log(&out_dir, &log, "rendering", 300, "shard 1 did not start");
    std::thread::sleep(Duration::from_millis(300));
    let o = Command::new("scontrol")
        .args(["requeue", &task])
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "scontrol requeue {task}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    // A requeued job waits (about 2 minutes) before it is eligible again; once it is pending,
    // let it go now.
    let deadline = Instant::now() + Duration::from_secs(120);
    while job_states(&task) != ["PENDING"] {
        assert!(
            Instant::now() < deadline,
            "{task} is {:?}, not pending again after the requeue\n{}",
            job_states(&task),
            logs(&out_dir)
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    // Slurm may report the task pending while its first run is still writing the partial shard;
    // start the second run only once that is written (`stopped early` ends the first run's log),
    // as Slurm's own delay before a requeued job is eligible again would ensure.
    wait_for_log(
        &out_dir,
        &log,
        "stopped early",
        120,
        "shard 1's first run did not write its partial shard",
    );
    // (and a moment for its process to end after that last line).
    std::thread::sleep(Duration::from_secs(1));
    let o = Command::new("scontrol")
        .args(["update", &format!("JobId={task}"), "StartTime=now"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    wait_for(&out_dir, &array, &merge, shards as usize);
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(
        text.contains("stopped early"),
        "shard 1 was not stopped:\n{text}"
    );
    assert!(
        text.contains("continuing"),
        "shard 1 did not resume:\n{text}"
    );
    assert_merge_is_the_single_render(&out_dir, spp, options);
}

/// The per-frame recipe (`FRAMES=A..B tools/slurm/submit.sh`, frames.sbatch): an array whose
/// tasks render their shares of an animation's frames; every frame is written once.
#[test]
fn slurm_array_renders_each_frame_once() {
    let Some(samples) = common::gltf_samples() else {
        return;
    };
    if !cluster_up() {
        eprintln!("skipping the Slurm frames test: no Slurm cluster answers sinfo");
        return;
    }
    let out_dir = fresh_dir("frames");
    let vars = [
        (
            "SCENE",
            samples
                .join("animation/BoxAnimated.glb")
                .display()
                .to_string(),
        ),
        ("FRAMES", "0..9".into()),
        ("FPS", "5".into()),
        ("TASKS", "3".into()),
        ("SPP", "2".into()),
        ("RENDER_OPTIONS", "--width 8 --height 8".into()),
    ];
    let array = run_submit(&out_dir, &vars).trim().to_owned();
    let deadline = Instant::now() + Duration::from_secs(900);
    loop {
        let states = job_states(&array);
        if states.len() == 3 && states.iter().all(|s| s == "COMPLETED") {
            break;
        }
        assert!(
            !states
                .iter()
                .any(|s| ["FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL"].contains(&s.as_str())),
            "array {array}: {states:?}\n{}",
            logs(&out_dir)
        );
        assert!(
            Instant::now() < deadline,
            "array {array}: {states:?}\n{}",
            logs(&out_dir)
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    let frames = common::files_with_extension(&out_dir, &["png"]);
    let names: Vec<String> = frames
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let want: Vec<String> = (0..=9).map(|f| format!("frame_{f:04}.png")).collect();
    assert_eq!(names, want, "{}", logs(&out_dir));
}
