//! `wavetrace verify` as a CI job runs it: exit status, JUnit and JSON files, the HTML report and
//! its heat maps, on every committed scene, on a deliberately biased GPU render, and against a
//! stored reference.

use std::path::PathBuf;

use crate::common;

use crate::common::wavetrace;

fn temp(name: &str) -> PathBuf {
    common::temp("verify", name)
}

/// Validates a JUnit file against `tests/schemas/junit.xsd` with xmllint (libxml2-utils).
/// `.ci/run` installs it and sets WAVETRACE_NEED_XMLLINT=1, so CI cannot skip this; elsewhere a
/// missing xmllint skips the check with a notice.
fn assert_valid_junit(file: &std::path::Path) {
    let schema = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/schemas/junit.xsd");
    let run = std::process::Command::new("xmllint")
        .arg("--noout")
        .arg("--schema")
        .arg(&schema)
        .arg(file)
        .output();
    match run {
        Ok(o) => assert!(
            o.status.success(),
            "{} does not validate against the JUnit schema:\n{}",
            file.display(),
            String::from_utf8_lossy(&o.stderr)
        ),
        Err(e) => {
            assert!(
                std::env::var("WAVETRACE_NEED_XMLLINT").is_err(),
                "xmllint is required (WAVETRACE_NEED_XMLLINT) but cannot run: {e}"
            );
            eprintln!("skipping the JUnit schema check: xmllint cannot run ({e})");
        }
    }
}

fn json(path: &PathBuf) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

#[test]
fn every_committed_scene_verifies_and_the_reports_say_so() {
    if common::skip_gpu() {
        return;
    }
    let report = temp("all");
    let (junit, json_file) = (report.join("junit.xml"), report.join("verify.json"));
    let scenes = [
        "scenes/cornell-box.gltf",
        "scenes/cornell-materials.gltf",
        "scenes/furnace.gltf",
        "scenes/veach-mis.gltf",
    ];
    let mut args = vec!["verify"];
    args.extend(scenes);
    args.extend(["--width", "32", "--spp", "128", "--report"]);
    args.push(report.to_str().unwrap());
    args.extend([
        "--junit",
        junit.to_str().unwrap(),
        "--json",
        json_file.to_str().unwrap(),
    ]);
    let o = wavetrace(&args);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(stdout.contains("4 of 4 scenes agree"), "{stdout}");
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(xml.contains("tests=\"4\" failures=\"0\""), "{xml}");
    assert_eq!(xml.matches("<testcase ").count(), 4);
    assert_valid_junit(&junit);
    let v = json(&json_file);
    assert_eq!(v["passed"], true);
    assert_eq!(v["scenes"].as_array().unwrap().len(), 4);
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    for (i, scene) in scenes.iter().enumerate() {
        let stem = std::path::Path::new(scene)
            .file_stem()
            .unwrap()
            .to_str()
            .unwrap();
        for part in ["a", "b", "heat"] {
            let png = format!("{i:02}-{stem}-{part}.png");
            assert!(html.contains(&png), "index.html does not show {png}");
            assert!(report.join(&png).is_file(), "{png} missing");
        }
    }
}

#[test]
fn a_biased_gpu_render_fails_and_the_heat_map_marks_its_tiles() {
    if common::skip_gpu() {
        return;
    }
    // --debug-flags 1 drops next event estimation on the GPU side only.
    let report = temp("biased");
    let json_file = report.join("verify.json");
    let junit = report.join("junit.xml");
    let o = wavetrace(&[
        "verify",
        "scenes/cornell-box.gltf",
        "--width",
        "32",
        "--spp",
        "64",
        "--debug-flags",
        "1",
        "--report",
        report.to_str().unwrap(),
        "--json",
        json_file.to_str().unwrap(),
        "--junit",
        junit.to_str().unwrap(),
    ]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains("failures=\"1\"") && xml.contains("<failure "),
        "{xml}"
    );
    assert_valid_junit(&junit);
    let v = json(&json_file);
    assert_eq!(v["passed"], false);
    let scene = &v["scenes"][0];
    let failures = scene["failures"].as_array().unwrap();
    assert!(!failures.is_empty());
    let tile = scene["tile"].as_u64().unwrap() as u32;
    let heat = image::open(report.join("00-cornell-box-heat.png"))
        .unwrap()
        .to_rgb8();
    let rejected: Vec<(u32, u32)> = failures
        .iter()
        .map(|f| {
            (
                f["tile_x"].as_u64().unwrap() as u32,
                f["tile_y"].as_u64().unwrap() as u32,
            )
        })
        .collect();
    let tiles = 32 / tile;
    for ty in 0..tiles {
        for tx in 0..tiles {
            let corner = heat.get_pixel(tx * tile, ty * tile).0;
            let outlined = corner == [255, 220, 0];
            assert_eq!(
                outlined,
                rejected.contains(&(tx, ty)),
                "tile ({tx}, {ty}): outline {outlined}, rejected {}",
                rejected.contains(&(tx, ty))
            );
        }
    }
}

#[test]
fn a_render_verifies_against_a_stored_reference() {
    if common::skip_gpu() {
        return;
    }
    let reference = temp("reference.exr");
    let o = wavetrace(&[
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--width",
        "32",
        "--spp",
        "128",
        "--seed",
        "7",
        "-o",
        reference.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let verify = |extra: &[&str]| {
        let mut args = vec![
            "verify",
            "scenes/cornell-box.gltf",
            "--width",
            "32",
            "--spp",
            "128",
        ];
        args.extend(["--against", reference.to_str().unwrap()]);
        args.extend(extra);
        wavetrace(&args)
    };
    assert_eq!(verify(&[]).status.code(), Some(0));
    assert_eq!(verify(&["--device", "cpu"]).status.code(), Some(0));
    // A depth-1 render is not the reference: refused by its recorded settings, the difference
    // named; with --allow-settings-mismatch the images are compared, and differ.
    let o = verify(&["--max-depth", "1"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("max_depth: the reference 8, the render 1")
            && err.contains("--allow-settings-mismatch"),
        "{err}"
    );
    let o = verify(&["--max-depth", "1", "--allow-settings-mismatch"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(1), "{out}");
    assert!(
        out.contains("tile×channel") || out.contains("tiles"),
        "{out}"
    );
    // A missing reference fails its scene (exit 1), named; the reports are still written.
    let junit = temp("missing-reference.xml");
    let o = wavetrace(&[
        "verify",
        "scenes/cornell-box.gltf",
        "--against",
        "no-such.exr",
        "--junit",
        junit.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no-such.exr"));
    assert!(std::fs::read_to_string(&junit)
        .unwrap()
        .contains("no-such.exr"));
    // --device cpu without a reference to render against is a usage error.
    let o = wavetrace(&["verify", "scenes/cornell-box.gltf", "--device", "cpu"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--against"));
}

/// A set with one scene that cannot load: that scene is a failed test case carrying its error
/// (JUnit `<error>`, a JSON entry), the other scenes are still judged, every report is written,
/// and the exit status is 1; the JSON names wavetrace's version, the device and each scene's
/// settings.
#[test]
fn a_broken_scene_fails_its_test_case_and_the_reports_are_complete() {
    if common::skip_gpu() {
        return;
    }
    let dir = temp("broken");
    std::fs::create_dir_all(&dir).unwrap();
    let broken = dir.join("broken.gltf");
    std::fs::write(
        &broken,
        r#"{"asset": {"version": "2.0"}, "meshes": [{"primitives": "#,
    )
    .unwrap();
    let (junit, json_file, report) = (
        dir.join("junit.xml"),
        dir.join("verify.json"),
        dir.join("report"),
    );
    let o = wavetrace(&[
        "verify",
        "scenes/cornell-box.gltf",
        broken.to_str().unwrap(),
        "scenes/furnace.gltf",
        "--width",
        "16",
        "--spp",
        "16",
        "--junit",
        junit.to_str().unwrap(),
        "--json",
        json_file.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert_eq!(o.status.code(), Some(1), "{out}\n{err}");
    assert!(out.contains("2 of 3 scenes agree"), "{out}");
    assert!(err.contains("broken.gltf"), "{err}");
    assert_valid_junit(&junit);
    let xml = std::fs::read_to_string(&junit).unwrap();
    assert!(
        xml.contains("tests=\"3\" failures=\"0\" errors=\"1\""),
        "{xml}"
    );
    assert!(
        xml.contains("<error message=") && xml.contains("broken.gltf"),
        "{xml}"
    );
    let v = json(&json_file);
    assert_eq!(v["report_version"], 2);
    assert!(
        v["wavetrace_version"].as_str().unwrap().contains("commit"),
        "{v}"
    );
    assert!(!v["device"].as_str().unwrap().is_empty(), "{v}");
    assert_eq!(v["passed"], false);
    assert_eq!(v["errors"], 1);
    let scenes = v["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 3);
    assert!(
        scenes[1]["error"].as_str().unwrap().contains("broken.gltf"),
        "{v}"
    );
    assert_eq!(scenes[0]["passed"], true);
    assert_eq!(scenes[0]["settings"]["max_depth"], "8");
    assert_eq!(scenes[2]["passed"], true);
    let html = std::fs::read_to_string(report.join("index.html")).unwrap();
    assert!(
        html.contains("ERROR") && html.contains("2 of 3 scenes agree"),
        "{html}"
    );
}

/// References without variance (another renderer's PNG) are judged by FLIP, and only with a
/// stated `--max-flip`; `compare --flip` reports the same figure and writes its error map.
#[test]
fn references_without_variance_are_judged_by_flip() {
    let dir = temp("flip");
    std::fs::create_dir_all(&dir).unwrap();
    let (png, exr) = (dir.join("ref.png"), dir.join("ref.exr"));
    for out in [&png, &exr] {
        let o = wavetrace(&[
            "render",
            "scenes/cornell-box.gltf",
            "--device",
            "cpu",
            "--width",
            "32",
            "--spp",
            "256",
            // FLIP shows an EXR clipped to [0, 1], as the standard view does.
            "--view",
            "standard",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let base = [
        "verify",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--width",
        "32",
        "--spp",
        "64",
        "--against",
    ];
    // Without --max-flip: an error (exit 2) that says what to do.
    let mut args = base.to_vec();
    args.push(png.to_str().unwrap());
    let o = wavetrace(&args);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--max-flip"));
    // With a generous bound it passes, with an impossible one it fails; the JSON carries FLIP.
    let json_file = dir.join("v.json");
    for (bound, code) in [("0.5", 0), ("0", 1)] {
        let mut args = base.to_vec();
        args.extend([png.to_str().unwrap(), "--max-flip", bound, "--json"]);
        args.push(json_file.to_str().unwrap());
        let o = wavetrace(&args);
        assert_eq!(
            o.status.code(),
            Some(code),
            "{}",
            String::from_utf8_lossy(&o.stdout)
        );
        let v = json(&json_file);
        let mean = v["scenes"][0]["flip"]["mean"].as_f64().unwrap();
        assert!(mean > 0.0 && mean < 0.5, "{v}");
    }
    // compare --flip: a render against itself has no error; the map is written.
    let map = dir.join("map.png");
    let o = wavetrace(&[
        "compare",
        "--flip",
        png.to_str().unwrap(),
        exr.to_str().unwrap(),
        "--flip-map",
        map.to_str().unwrap(),
        "--max-flip",
        "0",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("mean 0.000000"), "{stdout}");
    assert_eq!(image::open(&map).unwrap().width(), 32);
}

/// `verify --detect`'s power model against the rejection rate of the per-tile test over
/// repeated renders carrying exactly the stated bias (every sample of one side × (1 + δ)), on
/// the CPU in-process, with the independent sampler as `--detect` uses. The rate must match
/// the prediction within binomial noise (exact two-sided test at 10⁻³); both are printed.
#[test]
fn detect_power_matches_the_rejection_rate_of_biased_renders() {
    use statrs::distribution::{Binomial, DiscreteCDF};
    use wavetrace::render::RenderSettings;
    use wavetrace::stats::{compare_films, PowerModel};
    let scene = common::prepared("cornell-box.gltf");
    let (tile, alpha, delta) = (8, 0.01, 0.05);
    let settings = |spp, seed| RenderSettings {
        width: 16,
        height: 16,
        spp,
        max_depth: 4,
        seed,
        // As verify --detect renders: independent samples, whose variance the film estimates.
        sampler: wavetrace::layout::SAMPLER_INDEPENDENT,
        ..RenderSettings::default()
    };
    let pilot_spp = 1024;
    let pa = common::render_cpu(&scene, &settings(pilot_spp, 1)).film;
    let pb = common::render_cpu(&scene, &settings(pilot_spp, 2)).film;
    let model = PowerModel::new(&pa, &pb, pilot_spp, tile, alpha);
    // The spp where the predicted power is about one half: the most informative test.
    let (spp, predicted) = model.plan(delta, 0.5, 2, 4096);
    let runs = 120u64;
    let mut rejected = 0u64;
    for r in 0..runs as u32 {
        let mut a = common::render_cpu(&scene, &settings(spp, 100 + 2 * r)).film;
        let b = common::render_cpu(&scene, &settings(spp, 101 + 2 * r)).film;
        let k = (1.0 + delta) as f32;
        for p in &mut a.pixels {
            p.sum = p.sum.map(|s| s * k);
            p.sum_sq = p.sum_sq.map(|s| s * k * k);
        }
        if !compare_films(&a, &b, tile, alpha).unwrap().passed() {
            rejected += 1;
        }
    }
    let rate = rejected as f64 / runs as f64;
    println!("--detect {delta}: {spp} spp, predicted power {predicted:.3}, measured rejection rate {rate:.3} ({rejected}/{runs})");
    // Exact binomial tails of the count under the predicted power, each at 5·10⁻⁴ (two-sided
    // 10⁻³): too few rejections break the promise; too many would mean the bound is loose.
    let binomial = Binomial::new(predicted, runs).unwrap();
    let p_low = binomial.cdf(rejected);
    let p_high = if rejected == 0 {
        1.0
    } else {
        binomial.sf(rejected - 1)
    };
    assert!(
        p_low > 5e-4 && p_high > 5e-4,
        "the measured rejection rate {rate} does not match the predicted power {predicted} (P(K ≤ k) = {p_low:.2e}, P(K ≥ k) = {p_high:.2e})"
    );
}
