//! The Slurm recipe of tools/slurm/ end to end on a real cluster: submit the shard array and
//! the dependent merge job (tools/slurm/submit.sh, CPU-only: no gres, --device cpu), wait for
//! them, and check the merged EXR against one render of every sample. Needs a cluster that
//! answers `sinfo` (tools/slurm/local-cluster.sh starts one on localhost; .ci/run does);
//! without one the test prints a notice and passes.

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

mod common;

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

#[test]
fn slurm_array_shards_merge_into_the_single_render() {
    if !cluster_up() {
        eprintln!(
            "skipping the Slurm end-to-end test: no Slurm cluster answers sinfo (start one with tools/slurm/local-cluster.sh start)"
        );
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out_dir = common::temp("slurm", "run");
    let _ = std::fs::remove_dir_all(&out_dir);
    std::fs::create_dir_all(&out_dir).unwrap();
    let scene = root.join("scenes/cornell-box.gltf");
    let options = "--width 32 --height 32 --max-depth 4";
    let (spp, shards) = (16, 4);
    let start = Instant::now();
    let o = Command::new(root.join("tools/slurm/submit.sh"))
        .env("SCENE", &scene)
        .env("SPP", spp.to_string())
        .env("SHARDS", shards.to_string())
        .env("OUT_DIR", &out_dir)
        .env("DEVICE", "cpu")
        .env("WAVETRACE_GRES", "")
        .env("RENDER_OPTIONS", options)
        .env("WAVETRACE", env!("CARGO_BIN_EXE_wavetrace"))
        .output()
        .expect("submit.sh runs");
    assert!(
        o.status.success(),
        "submit.sh: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let ids = String::from_utf8_lossy(&o.stdout).into_owned();
    let ids: Vec<&str> = ids.split_whitespace().collect();
    let [array, merge] = ids[..] else {
        panic!("submit.sh printed {ids:?}, not two job ids");
    };
    println!("submitted array job {array} and merge job {merge}");
    // Wait for the merge job (a guard against a hang, not a measurement).
    let deadline = Instant::now() + Duration::from_secs(900);
    loop {
        let states = job_states(merge);
        if states.iter().any(|s| s == "COMPLETED") {
            break;
        }
        let logs = || {
            std::fs::read_dir(&out_dir)
                .unwrap()
                .filter_map(|e| e.ok())
                .filter(|e| e.path().extension().is_some_and(|x| x == "log"))
                .map(|e| {
                    format!(
                        "--- {}\n{}",
                        e.path().display(),
                        std::fs::read_to_string(e.path()).unwrap_or_default()
                    )
                })
                .collect::<Vec<_>>()
                .join("\n")
        };
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
                logs()
            );
        }
        assert!(
            Instant::now() < deadline,
            "the jobs did not finish in 15 minutes: merge {states:?}, array {:?}\n{}",
            job_states(array),
            logs()
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    let elapsed = start.elapsed();
    let tasks = job_states(array);
    assert_eq!(tasks.len(), shards, "array tasks: {tasks:?}");
    assert!(tasks.iter().all(|s| s == "COMPLETED"), "{tasks:?}");
    println!(
        "Slurm: {shards} shards and the merge finished {:.1} s after submission",
        elapsed.as_secs_f64()
    );
    // One render of every sample, here.
    let single = out_dir.join("single.exr");
    let mut args = vec![
        "render".to_string(),
        scene.display().to_string(),
        "--device".into(),
        "cpu".into(),
        "--spp".into(),
        spp.to_string(),
        "-o".into(),
        single.display().to_string(),
    ];
    args.extend(options.split(' ').map(str::to_owned));
    let args: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = common::wavetrace(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let merged = out_dir.join("merged.exr");
    // The merge holds the same samples as the single render: equal counts, sums within the
    // f32 summation-order bound (common::assert_same_samples).
    common::assert_same_samples(&merged, &single);
}
