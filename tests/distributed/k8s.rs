//! The Kubernetes recipe of tools/k8s/: the Indexed Job's shard script and the merge Job's
//! script, taken from the manifests, run as local processes with JOB_COMPLETION_INDEX set
//! (CPU, a small image), and the manifests validated against the Kubernetes API schema by
//! `kubernetes-validate` (PyPI) when it is installed.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::common;

fn manifest(name: &str) -> (PathBuf, String) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tools/k8s")
        .join(name);
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (path, text)
}

/// The container's shell script: the block scalar (`- |`) under `args:`, dedented.
fn script(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let at = lines
        .iter()
        .position(|l| l.trim() == "- |")
        .expect("a `- |` block scalar with the script");
    let outer = lines[at].len() - lines[at].trim_start().len();
    let body: Vec<&str> = lines[at + 1..]
        .iter()
        .take_while(|l| l.trim().is_empty() || l.len() - l.trim_start().len() > outer)
        .copied()
        .collect();
    let indent = body[0].len() - body[0].trim_start().len();
    body.iter()
        .map(|l| l.get(indent..).unwrap_or(""))
        .collect::<Vec<_>>()
        .join("\n")
}

/// The container's environment: `- name: X` followed by `value: Y`.
fn env(text: &str) -> Vec<(String, String)> {
    let lines: Vec<&str> = text.lines().map(str::trim).collect();
    lines
        .windows(2)
        .filter_map(|w| {
            let name = w[0].strip_prefix("- name: ")?;
            let value = w[1].strip_prefix("value: ")?.trim_matches('"');
            Some((name.to_owned(), value.to_owned()))
        })
        .collect()
}

fn field(text: &str, key: &str) -> String {
    text.lines()
        .find_map(|l| l.trim().strip_prefix(&format!("{key}: ")))
        .unwrap_or_else(|| panic!("no {key}"))
        .trim()
        .to_owned()
}

fn value<'a>(env: &'a [(String, String)], name: &str) -> &'a str {
    &env.iter()
        .find(|(n, _)| n == name)
        .unwrap_or_else(|| panic!("no env {name}"))
        .1
}

/// Runs a manifest's script with its environment, overridden by `set`.
fn run(script: &str, env: &[(String, String)], set: &[(&str, String)]) {
    let bin = Path::new(env!("CARGO_BIN_EXE_wavetrace")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut cmd = Command::new("/bin/sh");
    cmd.arg("-c")
        .arg(script)
        .current_dir(env!("CARGO_MANIFEST_DIR"));
    for (k, v) in env {
        cmd.env(k, v);
    }
    for (k, v) in set {
        cmd.env(k, v);
    }
    let o = cmd.env("PATH", path).output().expect("sh runs");
    assert!(
        o.status.success(),
        "{set:?}: {}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

#[test]
fn indexed_job_commands_merge_into_the_single_render() {
    let (_, render) = manifest("render-job.yaml");
    let (_, merge) = manifest("merge-job.yaml");
    let (render_env, merge_env) = (env(&render), env(&merge));
    let shards: u32 = value(&render_env, "SHARDS").parse().unwrap();
    assert_eq!(field(&render, "completionMode"), "Indexed");
    assert_eq!(
        field(&render, "completions"),
        shards.to_string(),
        "completions = SHARDS"
    );
    assert_eq!(
        value(&merge_env, "SHARDS"),
        shards.to_string(),
        "the merge's SHARDS"
    );
    assert_eq!(value(&merge_env, "OUT_DIR"), value(&render_env, "OUT_DIR"));
    assert!(render.contains("nvidia.com/gpu: 1"), "one GPU per pod");
    // Locally: the scene from the repository, a small CPU image, the volume in a folder.
    let dir = common::temp("k8s", "volume");
    let _ = std::fs::remove_dir_all(&dir);
    let out_dir = dir.join("shards");
    let options = "--width 32 --height 32 --max-depth 4";
    let spp = 16;
    let set = |index: Option<u32>| {
        let mut s = vec![
            ("SCENE", "scenes/cornell-box.gltf".to_string()),
            ("SPP", spp.to_string()),
            ("OUT_DIR", out_dir.display().to_string()),
            ("DEVICE", "cpu".to_string()),
            ("RENDER_OPTIONS", options.to_string()),
            ("OUTPUT", dir.join("merged.exr").display().to_string()),
        ];
        if let Some(i) = index {
            s.push(("JOB_COMPLETION_INDEX", i.to_string()));
        }
        s
    };
    let shard_script = script(&render);
    for i in (0..shards).rev() {
        run(&shard_script, &render_env, &set(Some(i)));
    }
    // A pod that runs again (a retried index) finds its shard and resumes it: nothing changes.
    let first = out_dir.join("shard-1.exr");
    let copy = dir.join("shard-1-before.exr");
    std::fs::copy(&first, &copy).unwrap();
    run(&shard_script, &render_env, &set(Some(1)));
    common::assert_bitwise_equal(&first, &copy);
    run(&script(&merge), &merge_env, &set(None));
    let single = dir.join("single.exr");
    let mut args = vec![
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--spp",
        "16",
        "-o",
        single.to_str().unwrap(),
    ];
    args.extend(options.split(' '));
    let o = common::wavetrace(&args);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    common::assert_same_samples(&dir.join("merged.exr"), &single);
}

/// `kubernetes-validate` (PyPI), from WAVETRACE_KUBERNETES_VALIDATE or PATH.
fn validator() -> Option<String> {
    let tool = std::env::var("WAVETRACE_KUBERNETES_VALIDATE")
        .unwrap_or_else(|_| "kubernetes-validate".into());
    Command::new(&tool)
        .arg("--version")
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|_| tool)
}

#[test]
fn manifests_validate_against_the_kubernetes_schema() {
    let Some(tool) = validator() else {
        eprintln!(
            "skipping the Kubernetes schema check: kubernetes-validate is not installed (pip install kubernetes-validate; .ci/run does)"
        );
        return;
    };
    let validate = |path: &Path| {
        Command::new(&tool)
            .args(["--strict", "--no-warn"])
            .arg(path)
            .output()
            .unwrap()
    };
    for name in ["render-job.yaml", "merge-job.yaml", "frames-job.yaml"] {
        let (path, text) = manifest(name);
        let o = validate(&path);
        assert!(
            o.status.success(),
            "{}: {}{}",
            path.display(),
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        // The validator rejects a misspelt field: it does check.
        let broken = common::temp("k8s", &format!("broken-{name}"));
        std::fs::write(
            &broken,
            text.replacen("restartPolicy:", "restartPolice:", 1),
        )
        .unwrap();
        assert!(
            !validate(&broken).status.success(),
            "{name} with a misspelt field passed"
        );
    }
}

/// The frames Job (frames-job.yaml): every index's script run locally renders its share of an
/// animation's frames; together they write each frame once, and an index that runs again (a
/// retried pod) leaves its written frames out.
#[test]
fn indexed_frames_job_writes_every_frame_once() {
    let Some(samples) = common::gltf_samples() else {
        return;
    };
    let (_, text) = manifest("frames-job.yaml");
    let job_env = env(&text);
    let tasks: u32 = value(&job_env, "TASKS").parse().unwrap();
    assert_eq!(field(&text, "completionMode"), "Indexed");
    assert_eq!(
        field(&text, "completions"),
        tasks.to_string(),
        "completions = TASKS"
    );
    assert!(text.contains("nvidia.com/gpu: 1"), "one GPU per pod");
    let dir = common::temp("k8s", "frames");
    let _ = std::fs::remove_dir_all(&dir);
    let set = |i: u32| {
        vec![
            (
                "SCENE",
                samples
                    .join("animation/BoxAnimated.glb")
                    .display()
                    .to_string(),
            ),
            ("FRAMES", "0..11".to_string()),
            ("FPS", "6".to_string()),
            ("SPP", "2".to_string()),
            ("OUT_DIR", dir.display().to_string()),
            ("DEVICE", "cpu".to_string()),
            ("RENDER_OPTIONS", "--width 8 --height 8".to_string()),
            ("JOB_COMPLETION_INDEX", i.to_string()),
        ]
    };
    let frames_script = script(&text);
    for i in 0..tasks {
        run(&frames_script, &job_env, &set(i));
    }
    let names = |dir: &Path| -> Vec<String> {
        let mut n: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        n.sort();
        n
    };
    let want: Vec<String> = (0..=11).map(|f| format!("frame_{f:04}.png")).collect();
    assert_eq!(names(&dir), want);
    let modified = |f: &str| std::fs::metadata(dir.join(f)).unwrap().modified().unwrap();
    let before: Vec<_> = want.iter().map(|f| modified(f)).collect();
    run(&frames_script, &job_env, &set(1));
    let after: Vec<_> = want.iter().map(|f| modified(f)).collect();
    assert_eq!(before, after, "a retried index rendered its frames again");
}
