//! The CI integrations (issue 60, item 4): `tools/ci/verify.sh` and `tools/ci/summary.py`, which
//! the GitHub Action (`action.yml`) and the GitLab template (`tools/ci/gitlab-ci.yml`) run, in a
//! user's repository simulated in a temporary folder — a good scene and a broken one, named by
//! a glob — as GitHub runs them: verify's exit status, the report folder, the job summary's
//! table and an `::error` annotation on the failing scene's file.

use crate::common;
use std::path::Path;
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A user's repository: scenes/good.gltf (the Cornell box) and scenes/broken.gltf.
fn user_repository() -> std::path::PathBuf {
    let repo = common::temp("ci", "user-repo");
    std::fs::create_dir_all(repo.join("scenes")).unwrap();
    std::fs::copy(
        root().join("scenes/cornell-box.gltf"),
        repo.join("scenes/good.gltf"),
    )
    .unwrap();
    std::fs::write(
        repo.join("scenes/broken.gltf"),
        b"{\"asset\": {\"version\": \"2.0\"},",
    )
    .unwrap();
    repo
}

fn verify_sh(repo: &Path, args: &[&str]) -> std::process::Output {
    Command::new("bash")
        .arg(root().join("tools/ci/verify.sh"))
        .args(args)
        .current_dir(repo)
        .env("WAVETRACE", env!("CARGO_BIN_EXE_wavetrace"))
        .env("GITHUB_ACTIONS", "true")
        .env("GITHUB_STEP_SUMMARY", repo.join("summary.md"))
        .output()
        .unwrap()
}

#[test]
fn the_action_script_reports_a_broken_scene_everywhere_github_looks() {
    if common::skip_gpu() {
        return;
    }
    let repo = user_repository();
    let o = verify_sh(
        &repo,
        &[
            "--report",
            "out",
            "--",
            "scenes/*.gltf",
            "--",
            "--width",
            "16",
            "--spp",
            "16",
        ],
    );
    let (stdout, stderr) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert_eq!(o.status.code(), Some(1), "{stdout}\n{stderr}");
    for file in ["out/index.html", "out/junit.xml", "out/verify.json"] {
        assert!(repo.join(file).is_file(), "{file} was not written");
    }
    assert!(
        stdout.contains("::error file=scenes/broken.gltf,title=wavetrace verify::error%3A")
            || stdout.contains("::error file=scenes/broken.gltf,title=wavetrace verify::error:"),
        "no annotation on the broken scene:\n{stdout}"
    );
    assert!(
        !stdout.contains("::error file=scenes/good.gltf"),
        "{stdout}"
    );
    let summary = std::fs::read_to_string(repo.join("summary.md")).unwrap();
    assert!(summary.contains("1 of 2 scenes agree"), "{summary}");
    assert!(summary.contains("| scenes/good.gltf | pass |"), "{summary}");
    assert!(
        summary.contains("| scenes/broken.gltf | error |"),
        "{summary}"
    );
    // A glob that matches nothing is a usage error.
    let o = verify_sh(&repo, &["--", "nothing/*.gltf"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no scene matches nothing/*.gltf"));
}

/// Every script and file the action and the GitLab template name exists in the repository.
#[test]
fn the_action_and_the_template_name_files_that_exist() {
    for file in ["action.yml", "tools/ci/gitlab-ci.yml"] {
        let text = std::fs::read_to_string(root().join(file)).unwrap();
        let mut named = 0;
        for prefix in ["$GITHUB_ACTION_PATH/", ".wavetrace-src/"] {
            for part in text.split(prefix).skip(1) {
                let path: String = part
                    .chars()
                    .take_while(|c| c.is_ascii_alphanumeric() || "/._-".contains(*c))
                    .collect();
                assert!(
                    root().join(&path).is_file(),
                    "{file} names {path}, which does not exist"
                );
                named += 1;
            }
        }
        assert!(named >= 2, "{file} names only {named} files");
    }
}
