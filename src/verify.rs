//! The reports of `wavetrace verify`: for each scene, two films (GPU and CPU reference, or a
//! render and a stored reference) and their per-tile comparison, written as a JUnit XML file and
//! a JSON file for CI systems, and as a folder with the images, a signed z-score heat map per
//! scene and one `index.html` for people (no JavaScript: it opens from a CI artifact).

use crate::film::Film;
use crate::flip::{flip_heat_map, FlipResult};
use crate::stats::{film_mean, normal_quantile_upper, Comparison};
use anyhow::{Context as _, Result};
use image::{Rgb, RgbImage};
use serde_json::json;
use std::fmt::Write as _;
use std::path::Path;

/// One scene's verdict: what was compared and how it came out.
pub struct SceneVerdict {
    /// The scene file as the user named it.
    pub scene: String,
    /// What each side is, e.g. "GPU (llvmpipe), seed 0" and "CPU reference, seed 1".
    pub label_a: String,
    pub label_b: String,
    pub a: Film,
    pub b: Film,
    pub judgement: Judgement,
    /// Wall-clock seconds of the two renders together.
    pub seconds: f64,
    /// `--detect`: the sample count chosen for the stated bias and the power it gives.
    pub detect: Option<DetectPlan>,
    /// The settings that decided the rendered side's image (`shard::Record`'s, key and value);
    /// empty where the scene did not get that far.
    pub settings: Vec<(String, String)>,
}

/// What `verify --detect` chose for one scene.
#[derive(Clone, Copy, Debug)]
pub struct DetectPlan {
    /// The relative bias to detect.
    pub bias: f64,
    /// Samples per pixel of the pilot renders and of the final ones.
    pub pilot_spp: u32,
    pub spp: u32,
    /// Predicted probability that the test rejects when the GPU image carries the bias.
    pub power: f64,
    /// The power asked for (below it when the sample cap stopped the search).
    pub target: f64,
}

/// How a scene's two images were judged.
pub enum Judgement {
    /// The per-tile Welch test (both sides carry variance).
    Welch(Comparison),
    /// FLIP against a reference without variance, passing where the mean is at most `max`.
    Flip { result: FlipResult, max: f64 },
    /// The scene could not be judged: it failed to load or render, or its reference does not
    /// match it. A failed test case carrying the message; the other scenes still run.
    Error(String),
}

/// What the whole run was: wavetrace's version and the device of the rendered side, for the
/// JSON report.
pub struct RunInfo {
    pub version: String,
    pub device: String,
}

impl SceneVerdict {
    /// The verdict of a scene that could not be judged, with the reason.
    pub fn error(scene: String, message: String, settings: Vec<(String, String)>) -> Self {
        SceneVerdict {
            scene,
            label_a: String::new(),
            label_b: String::new(),
            a: Film::new(0, 0),
            b: Film::new(0, 0),
            judgement: Judgement::Error(message),
            seconds: 0.0,
            detect: None,
            settings,
        }
    }

    pub fn passed(&self) -> bool {
        match &self.judgement {
            Judgement::Welch(c) => c.passed(),
            Judgement::Flip { result, max } => result.mean <= *max,
            Judgement::Error(_) => false,
        }
    }

    /// The error that kept the scene from being judged, if one did.
    pub fn error_message(&self) -> Option<&str> {
        match &self.judgement {
            Judgement::Error(m) => Some(m),
            _ => None,
        }
    }

    /// The failing tile tests, worst (smallest p) first, at most `n`, one line each (none for
    /// a FLIP judgement).
    pub fn worst_tiles(&self, n: usize) -> Vec<String> {
        let Judgement::Welch(c) = &self.judgement else {
            return Vec::new();
        };
        let mut failures: Vec<_> = c.failures.iter().collect();
        failures.sort_by(|x, y| x.p.total_cmp(&y.p));
        failures
            .iter()
            .take(n)
            .map(|f| {
                let (x0, y0) = (f.tile_x * c.tile, f.tile_y * c.tile);
                format!(
                    "tile ({}, {}) = pixels x {}..{}, y {}..{}, channel {}: {:.6e} vs {:.6e} ± {:.3e}, t = {:.2}, p = {:.3e}",
                    f.tile_x,
                    f.tile_y,
                    x0,
                    (x0 + c.tile).min(c.width),
                    y0,
                    (y0 + c.tile).min(c.height),
                    ["R", "G", "B"][f.channel],
                    f.mean_a,
                    f.mean_b,
                    f.std_err,
                    f.t,
                    f.p
                )
            })
            .collect()
    }

    /// A file-name-safe name for the scene's report files.
    fn slug(&self, index: usize) -> String {
        let stem: String = Path::new(&self.scene)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default()
            .chars()
            .map(|c| {
                if c.is_ascii_alphanumeric() || c == '-' {
                    c
                } else {
                    '_'
                }
            })
            .collect();
        format!("{index:02}-{stem}")
    }
}

fn xml_escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            c if (c as u32) < 0x20 && c != '\n' && c != '\t' => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

/// JUnit XML: one test case per scene; a failure carries the worst tiles.
pub fn junit_xml(verdicts: &[SceneVerdict]) -> String {
    let errors = verdicts
        .iter()
        .filter(|v| v.error_message().is_some())
        .count();
    let failures = verdicts.iter().filter(|v| !v.passed()).count() - errors;
    let seconds: f64 = verdicts.iter().map(|v| v.seconds).sum();
    let mut x = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    let _ = writeln!(
        x,
        "<testsuites name=\"wavetrace verify\" tests=\"{}\" failures=\"{failures}\" errors=\"{errors}\" time=\"{seconds:.3}\">",
        verdicts.len()
    );
    let _ = writeln!(
        x,
        "  <testsuite name=\"wavetrace verify\" tests=\"{}\" failures=\"{failures}\" errors=\"{errors}\" skipped=\"0\" time=\"{seconds:.3}\">",
        verdicts.len()
    );
    for v in verdicts {
        let _ = write!(
            x,
            "    <testcase classname=\"wavetrace.verify\" name=\"{}\" time=\"{:.3}\"",
            xml_escape(&v.scene),
            v.seconds
        );
        if let Some(error) = v.error_message() {
            let first = error.lines().next().unwrap_or_default();
            let _ = writeln!(
                x,
                ">\n      <error message=\"{}\" type=\"SceneError\">{}</error>\n    </testcase>",
                xml_escape(first),
                xml_escape(error)
            );
        } else if v.passed() {
            x.push_str("/>\n");
        } else {
            let message = match &v.judgement {
                Judgement::Welch(c) => format!(
                    "{} of {} tile×channel Welch tests reject equality of {} and {} (family-wise α = {})",
                    c.failures.len(),
                    c.tests,
                    v.label_a,
                    v.label_b,
                    c.alpha
                ),
                Judgement::Flip { result, max } => format!(
                    "mean FLIP error of {} against {} is {:.6}, above --max-flip {max}",
                    v.label_a, v.label_b, result.mean
                ),
                Judgement::Error(m) => m.clone(),
            };
            let _ = writeln!(
                x,
                ">\n      <failure message=\"{}\" type=\"StatisticalMismatch\">{}</failure>\n    </testcase>",
                xml_escape(&message),
                xml_escape(&v.worst_tiles(10).join("\n"))
            );
        }
    }
    x.push_str("  </testsuite>\n</testsuites>\n");
    x
}

/// The version of the JSON report's layout (`json_report`): 2 added it, the run's version and
/// device, each scene's settings and errors.
pub const JSON_REPORT_VERSION: u32 = 2;

/// Every figure of the verdicts as JSON.
pub fn json_report(verdicts: &[SceneVerdict], run: &RunInfo) -> serde_json::Value {
    let scenes: Vec<serde_json::Value> = verdicts
        .iter()
        .map(|v| {
            let settings: serde_json::Map<String, serde_json::Value> = v
                .settings
                .iter()
                .map(|(k, value)| (k.clone(), json!(value)))
                .collect();
            let mut entry = scene_json(v);
            entry["settings"] = serde_json::Value::Object(settings);
            entry
        })
        .collect();
    json!({
        "report_version": JSON_REPORT_VERSION,
        "wavetrace_version": run.version,
        "device": run.device,
        "passed": verdicts.iter().all(SceneVerdict::passed),
        "scenes": scenes,
        "errors": verdicts.iter().filter(|v| v.error_message().is_some()).count(),
    })
}

/// One scene's figures.
fn scene_json(v: &SceneVerdict) -> serde_json::Value {
    if let Some(error) = v.error_message() {
        return json!({"scene": v.scene, "passed": false, "error": error});
    }
    let (mean_a, se_a) = film_mean(&v.a);
    let (mean_b, se_b) = film_mean(&v.b);
    let c = match &v.judgement {
        Judgement::Welch(c) => c,
        Judgement::Error(_) => unreachable!("answered above"),
        Judgement::Flip { result, max } => {
            return json!({
                "scene": v.scene,
                "passed": v.passed(),
                "a": {"label": v.label_a, "mean": mean_a.to_array(), "std_error": se_a.to_array()},
                "b": {"label": v.label_b, "mean": mean_b.to_array()},
                "width": result.width,
                "height": result.height,
                "flip": {"mean": result.mean, "median": result.median, "p99": result.p99,
                         "max": result.max, "max_allowed": max},
                "seconds": v.seconds,
            });
        }
    };
    json!({
        "scene": v.scene,
        "passed": v.passed(),
        "a": {"label": v.label_a, "mean": mean_a.to_array(), "std_error": se_a.to_array(),
              "samples_per_pixel": v.a.total_samples() as f64 / v.a.len().max(1) as f64},
        "b": {"label": v.label_b, "mean": mean_b.to_array(), "std_error": se_b.to_array(),
              "samples_per_pixel": v.b.total_samples() as f64 / v.b.len().max(1) as f64},
        "width": c.width,
        "height": c.height,
        "tile": c.tile,
        "tests": c.tests,
        "alpha": c.alpha,
        "per_test_alpha": c.per_test_alpha,
        "min_p": c.min_p,
        "failures": c.failures.iter().map(|f| json!({
            "tile_x": f.tile_x, "tile_y": f.tile_y, "channel": f.channel,
            "mean_a": f.mean_a, "mean_b": f.mean_b, "std_err": f.std_err, "t": f.t, "p": f.p,
        })).collect::<Vec<_>>(),
        "tile_t": c.tile_t,
        "seconds": v.seconds,
        "detect": v.detect.map(|d| json!({
            "bias": d.bias, "pilot_spp": d.pilot_spp, "spp": d.spp,
            "power": d.power, "target_power": d.target,
        })),
    })
}

/// The |t| at which a tile test rejects, in the normal approximation (the colour scale of the
/// heat map; the outlined tiles are the ones the Welch tests actually rejected).
pub fn rejection_threshold(c: &Comparison) -> f64 {
    normal_quantile_upper(0.5 * c.per_test_alpha)
}

/// The signed heat map of one comparison, one pixel per film pixel: each tile coloured by the
/// channel with the largest |t| — red where a > b, blue where a < b, full colour at the
/// rejection threshold (white beyond it) — and a yellow outline round every rejected tile.
pub fn heat_map(c: &Comparison) -> RgbImage {
    let threshold = rejection_threshold(c);
    let tiles_x = c.width.div_ceil(c.tile);
    let mut rejected = vec![false; c.tile_t.len()];
    for f in &c.failures {
        rejected[(f.tile_y * tiles_x + f.tile_x) as usize] = true;
    }
    RgbImage::from_fn(c.width, c.height, |x, y| {
        let (tx, ty) = (x / c.tile, y / c.tile);
        let tile = (ty * tiles_x + tx) as usize;
        let t = c.tile_t[tile];
        let worst = t
            .into_iter()
            .fold(0.0f64, |w, v| if v.abs() > w.abs() { v } else { w });
        let (x0, y0) = (tx * c.tile, ty * c.tile);
        let (x1, y1) = (
            (x0 + c.tile).min(c.width) - 1,
            (y0 + c.tile).min(c.height) - 1,
        );
        let edge = x == x0 || y == y0 || x == x1 || y == y1;
        if rejected[tile] && edge {
            return Rgb([255, 220, 0]);
        }
        let s = (worst.abs() / threshold).min(2.0);
        let strong = (255.0 * s.min(1.0)) as u8;
        let beyond = (255.0 * (s - 1.0).max(0.0)) as u8;
        if worst >= 0.0 {
            Rgb([strong, beyond, beyond])
        } else {
            Rgb([beyond, beyond, strong])
        }
    })
}

/// Writes `dir/index.html` and, per scene, the two images and the heat map.
pub fn write_report(dir: &Path, verdicts: &[SceneVerdict]) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut html = String::from(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>wavetrace verify</title>\n\
         <style>body{font-family:sans-serif;background:#222;color:#eee} img{image-rendering:pixelated;\
         width:256px;border:1px solid #555} td{vertical-align:top;padding:4px} .pass{color:#6d6}\
         .fail{color:#f66} table.f td{font-family:monospace;font-size:12px}</style></head><body>\n\
         <h1>wavetrace verify</h1>\n",
    );
    let passed = verdicts.iter().filter(|v| v.passed()).count();
    let _ = writeln!(html, "<p>{passed} of {} scenes agree.</p>", verdicts.len());
    for (i, v) in verdicts.iter().enumerate() {
        if let Some(error) = v.error_message() {
            let _ = writeln!(
                html,
                "<h2><span class=\"fail\">ERROR</span> {}</h2>\n<pre>{}</pre>",
                xml_escape(&v.scene),
                xml_escape(error)
            );
            continue;
        }
        let slug = v.slug(i);
        let (a_png, b_png, heat_png) = (
            format!("{slug}-a.png"),
            format!("{slug}-b.png"),
            format!("{slug}-heat.png"),
        );
        crate::image_io::write_image(&v.a, &dir.join(&a_png), 0.0)?;
        crate::image_io::write_image(&v.b, &dir.join(&b_png), 0.0)?;
        let heat = match &v.judgement {
            Judgement::Welch(c) => heat_map(c),
            Judgement::Flip { result, .. } => flip_heat_map(result),
            Judgement::Error(_) => unreachable!("written above"),
        };
        heat.save(dir.join(&heat_png))
            .with_context(|| format!("writing {}", dir.join(&heat_png).display()))?;
        let (mean_a, se_a) = film_mean(&v.a);
        let (mean_b, se_b) = film_mean(&v.b);
        let status = if v.passed() {
            "<span class=\"pass\">PASS</span>"
        } else {
            "<span class=\"fail\">FAIL</span>"
        };
        let heat_caption = match &v.judgement {
            Judgement::Welch(c) => {
                let _ = writeln!(
                    html,
                    "<h2>{status} {}</h2>\n<p>{} of {} tile×channel Welch t tests reject equality ({}×{} px, tiles of {} px; \
                     family-wise α = {}, per test {:.3e}; smallest p = {:.3e}; rejection at |t| ≈ {:.2}).</p>",
                    xml_escape(&v.scene),
                    c.failures.len(),
                    c.tests,
                    c.width,
                    c.height,
                    c.tile,
                    c.alpha,
                    c.per_test_alpha,
                    c.min_p,
                    rejection_threshold(c)
                );
                "per-tile t (red: first brighter, blue: second; yellow outline: rejected)"
            }
            Judgement::Flip { result, max } => {
                let _ = writeln!(
                    html,
                    "<h2>{status} {}</h2>\n<p>FLIP against a reference without variance ({}×{} px): mean {:.6} \
                     (pass at most {max}), median {:.6}, 99th percentile {:.6}, max {:.6}.</p>",
                    xml_escape(&v.scene),
                    result.width,
                    result.height,
                    result.mean,
                    result.median,
                    result.p99,
                    result.max
                );
                "FLIP error per pixel (magma: black none, yellow most)"
            }
            Judgement::Error(_) => unreachable!("written above"),
        };
        let _ = writeln!(
            html,
            "<table><tr><td>{}<br><img src=\"{a_png}\"></td><td>{}<br><img src=\"{b_png}\"></td>\
             <td>{heat_caption}<br><img src=\"{heat_png}\"></td></tr></table>",
            xml_escape(&v.label_a),
            xml_escape(&v.label_b)
        );
        let _ = writeln!(
            html,
            "<table class=\"f\"><tr><td></td><td>R</td><td>G</td><td>B</td></tr>\
             <tr><td>{}</td>{}</tr><tr><td>{}</td>{}</tr></table>",
            xml_escape(&v.label_a),
            (0..3)
                .map(|k| format!("<td>{:.6} ± {:.6}</td>", mean_a[k], se_a[k]))
                .collect::<String>(),
            xml_escape(&v.label_b),
            (0..3)
                .map(|k| format!("<td>{:.6} ± {:.6}</td>", mean_b[k], se_b[k]))
                .collect::<String>(),
        );
        if let Some(d) = &v.detect {
            let _ = writeln!(
                html,
                "<p>--detect {}%: {} samples per pixel on each side (pilot {}) give the test power {:.3} \
                 (asked {}) to detect a relative bias of that size.</p>",
                d.bias * 100.0,
                d.spp,
                d.pilot_spp,
                d.power,
                d.target
            );
        }
        let worst = v.worst_tiles(10);
        if !worst.is_empty() {
            let _ = writeln!(
                html,
                "<p>Worst tiles:</p><pre>{}</pre>",
                xml_escape(&worst.join("\n"))
            );
        }
    }
    html.push_str("</body></html>\n");
    let index = dir.join("index.html");
    std::fs::write(&index, html).with_context(|| format!("writing {}", index.display()))
}
