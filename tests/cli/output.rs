//! Outputs (issue 59, first slice): the view transform of a PNG against the Khronos PBR Neutral
//! specification's formulas computed here, extensions in any case, and an output that cannot be
//! written refused before anything renders.

use crate::common::{self, wavetrace};

/// The sRGB transfer function (IEC 61966-2-1) of a display-linear value, as an 8-bit code.
fn srgb8(v: f64) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let e = if v <= 0.0031308 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0).round() as u8
}

/// Khronos PBR Neutral as its specification writes it (f, p, p_n, g, c_out).
fn pbr_neutral(c: [f64; 3]) -> [f64; 3] {
    let (f90, ks, kd) = (0.04, 0.76, 0.15);
    let x = c[0].min(c[1]).min(c[2]);
    let f = if x <= 2.0 * f90 {
        x - x * x / (4.0 * f90)
    } else {
        f90
    };
    let p = (c[0] - f).max(c[1] - f).max(c[2] - f);
    if p <= ks {
        return c.map(|v| v - f);
    }
    let pn = 1.0 - (1.0 - ks) * (1.0 - ks) / (p + 1.0 - 2.0 * ks);
    let g = 1.0 / (kd * (p - pn) + 1.0);
    c.map(|v| (v - f) * pn / p * g + pn * (1.0 - g))
}

/// `wavetrace::view::pbr_neutral` against the specification on every triple of values around
/// the offset's knee (0.08), the compression's (0.76) and far above.
#[test]
fn pbr_neutral_follows_its_specification() {
    let values = [
        0.0f32, 0.01, 0.05, 0.079, 0.08, 0.1, 0.3, 0.5, 0.76, 0.8, 1.0, 2.0, 5.0, 50.0, 1000.0,
    ];
    for &r in &values {
        for &g in &values {
            for &b in &values {
                let got = wavetrace::view::pbr_neutral([r, g, b]);
                let want = pbr_neutral([r, g, b].map(f64::from));
                for i in 0..3 {
                    assert!(
                        (got[i] as f64 - want[i]).abs() < 2e-6,
                        "{:?}: {got:?} vs {want:?}",
                        [r, g, b]
                    );
                }
            }
        }
    }
}

/// Renders the Cornell box small to an EXR and to PNGs of each view (`-o` in upper case for
/// one), and checks every PNG pixel against the view's formula applied to the EXR's mean, to
/// one code value (the EXR holds f32 means, the PNG was made from the same film).
#[test]
fn png_views_follow_their_formulas() {
    let exr = common::temp("cli", "views.exr");
    let base = [
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--width",
        "24",
        "--height",
        "24",
        "--spp",
        "16",
        "--exposure",
        "1.5",
    ];
    let run = |extra: &[&str]| {
        let o = wavetrace(&[base.as_slice(), extra].concat());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    };
    run(&["-o", exr.to_str().unwrap()]);
    let image = wavetrace::image_io::read_exr(&exr).unwrap();
    let scale = 1.5f64.exp2();
    for (view, name) in [
        ("standard", "views-standard.PNG"),
        ("khronos-pbr-neutral", "views-neutral.png"),
    ] {
        let png = common::temp("cli", name);
        run(&["--view", view, "-o", png.to_str().unwrap()]);
        let shown = image::open(&png).unwrap().to_rgb8();
        let mut clipped = 0;
        for (k, (px, mean)) in shown.pixels().zip(&image.mean).enumerate() {
            let linear = mean.map(|c| c as f64 * scale);
            clipped += linear.iter().any(|&c| c > 1.0) as usize;
            let want = match view {
                "standard" => linear.map(srgb8),
                _ => pbr_neutral(linear).map(srgb8),
            };
            for c in 0..3 {
                assert!(
                    (px.0[c] as i32 - want[c] as i32).abs() <= 1,
                    "{view}: pixel {k} channel {c}: {} vs {}",
                    px.0[c],
                    want[c]
                );
            }
        }
        // The exposure makes the light and the walls near it brighter than 1: the test sees
        // the compression, not only the offset.
        assert!(clipped > 0, "no pixel above 1");
    }
}

/// Renders the Cornell box to `output`, which must be refused: returns stdout and stderr.
fn refused(output: &str) -> (String, String) {
    let o = wavetrace(&[
        "render",
        "scenes/cornell-box.gltf",
        "--device",
        "cpu",
        "--spp",
        "1",
        "--width",
        "8",
        "-o",
        output,
    ]);
    assert!(!o.status.success(), "-o {output} was accepted");
    let text = |b: &[u8]| String::from_utf8_lossy(b).into_owned();
    (text(&o.stdout), text(&o.stderr))
}

#[test]
fn an_output_that_cannot_be_written_is_refused_before_rendering() {
    let missing = common::temp("cli", "no-such-folder/out.png");
    let (out, err) = refused(missing.to_str().unwrap());
    assert!(err.contains("does not exist"), "{err}");
    assert!(!out.contains("rendering"), "it rendered before refusing");
    let (_, err) = refused("out.tiff");
    assert!(err.contains("must end in .exr or .png"), "{err}");
}
