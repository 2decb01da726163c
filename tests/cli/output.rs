//! Outputs (issue 59): each view transform of a PNG against its published formulas computed
//! here (Khronos PBR Neutral, AgX with its looks, Hable's filmic), 16-bit PNG, JPEG, Radiance
//! HDR and EXR of each precision and compression read back against the film, standard output,
//! extensions in any case, and an output that cannot be written refused before anything
//! renders.

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

/// AgX as Wrensch's "Minimal AgX Implementation" (2023) writes it in GLSL, column-major
/// matrices transcribed as he prints them, with his looks (0 none, 1 golden, 2 punchy).
fn agx(c: [f64; 3], look: u32) -> [f64; 3] {
    let inset = [
        [0.842479062253094, 0.0423282422610123, 0.0423756549057051],
        [0.0784335999999992, 0.878468636469772, 0.0784336],
        [0.0792237451477643, 0.0791661274605434, 0.879142973793104],
    ];
    let outset = [
        [1.19687900512017, -0.0528968517574562, -0.0529716355144438],
        [-0.0980208811401368, 1.15190312990417, -0.0980434501171241],
        [-0.0990297440797205, -0.0989611768448433, 1.15107367264116],
    ];
    // GLSL's mat3 * vec3 with columns m[0], m[1], m[2].
    let mul = |m: &[[f64; 3]; 3], v: [f64; 3]| -> [f64; 3] {
        [0, 1, 2].map(|r| m[0][r] * v[0] + m[1][r] * v[1] + m[2][r] * v[2])
    };
    let (min_ev, max_ev) = (-12.47393, 4.026069);
    let v = mul(&inset, c)
        .map(|x| (x.max(1e-10).log2().clamp(min_ev, max_ev) - min_ev) / (max_ev - min_ev));
    let v = v.map(|x| {
        15.5 * x.powi(6) - 40.14 * x.powi(5) + 31.96 * x.powi(4) - 6.868 * x.powi(3)
            + 0.4298 * x * x
            + 0.1191 * x
            - 0.00232
    });
    let v = if look == 0 {
        v
    } else {
        let (slope, power, sat) = if look == 1 {
            ([1.0, 0.9, 0.5], 0.8, 0.8)
        } else {
            ([1.0, 1.0, 1.0], 1.35, 1.4)
        };
        let luma = 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
        [0, 1, 2].map(|k| luma + sat * ((v[k] * slope[k]).max(0.0).powf(power) - luma))
    };
    mul(&outset, v).map(|x| x.max(0.0).powf(2.2))
}

/// Hable's filmic curve as his GDC 2010 talk gives it: F(2x) / F(11.2).
fn hable(c: [f64; 3]) -> [f64; 3] {
    let f = |x: f64| {
        let (a, b, c, d, e, f) = (0.15, 0.50, 0.10, 0.20, 0.02, 0.30);
        (x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f) - e / f
    };
    c.map(|x| f(2.0 * x) / f(11.2))
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
    for (view, look, name) in [
        ("standard", "none", "views-standard.PNG"),
        ("khronos-pbr-neutral", "none", "views-neutral.png"),
        ("agx", "none", "views-agx.png"),
        ("agx", "golden", "views-agx-golden.png"),
        ("agx", "punchy", "views-agx-punchy.png"),
        ("filmic", "none", "views-filmic.png"),
    ] {
        let png = common::temp("cli", name);
        run(&["--view", view, "--look", look, "-o", png.to_str().unwrap()]);
        let shown = image::open(&png).unwrap().to_rgb8();
        let mut clipped = 0;
        for (k, (px, mean)) in shown.pixels().zip(&image.mean).enumerate() {
            let linear = mean.map(|c| c as f64 * scale);
            clipped += linear.iter().any(|&c| c > 1.0) as usize;
            let want = match (view, look) {
                ("standard", _) => linear.map(srgb8),
                ("agx", "none") => agx(linear, 0).map(srgb8),
                ("agx", "golden") => agx(linear, 1).map(srgb8),
                ("agx", _) => agx(linear, 2).map(srgb8),
                ("filmic", _) => hable(linear).map(srgb8),
                _ => pbr_neutral(linear).map(srgb8),
            };
            for c in 0..3 {
                assert!(
                    (px.0[c] as i32 - want[c] as i32).abs() <= 1,
                    "{view} {look}: pixel {k} channel {c}: {} vs {}",
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
    assert!(err.contains("must end in .exr, .png, .jpg"), "{err}");
}

/// The Cornell box small, written as `outputs/NAME` with `extra`; returns its path.
fn render_to(name: &str, extra: &[&str]) -> std::path::PathBuf {
    let out = common::temp("cli-formats", name);
    let o = wavetrace(
        &[
            &[
                "render",
                "scenes/cornell-box.gltf",
                "--device",
                "cpu",
                "--width",
                "20",
                "--height",
                "16",
                "--spp",
                "8",
                "-o",
                out.to_str().unwrap(),
            ][..],
            extra,
        ]
        .concat(),
    );
    assert!(
        o.status.success(),
        "{name}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    out
}

/// 16-bit PNGs hold the sRGB encoding of the film to one 16-bit code; JPEGs are written at
/// the quality asked for (quality 100 is closer to the PNG than quality 5); the Radiance HDR
/// holds the linear mean to RGBE's precision (a shared exponent and 8-bit mantissas, the
/// largest channel's in [128, 256): one unit is at most 2⁻⁷ of it); every extension in any
/// case.
#[test]
fn png16_jpeg_and_hdr_hold_the_film() {
    let exr = render_to("film.exr", &[]);
    let image = wavetrace::image_io::read_exr(&exr).unwrap();
    let png = render_to("deep.PNG", &["--bit-depth", "16", "--view", "standard"]);
    let deep = image::open(&png).unwrap();
    assert_eq!(deep.color(), image::ColorType::Rgb16, "not a 16-bit PNG");
    for (k, (px, mean)) in deep.to_rgb16().pixels().zip(&image.mean).enumerate() {
        for c in 0..3 {
            let v = (mean[c] as f64).clamp(0.0, 1.0);
            let e = if v <= 0.0031308 {
                12.92 * v
            } else {
                1.055 * v.powf(1.0 / 2.4) - 0.055
            };
            let want = (e * 65535.0).round() as i64;
            assert!(
                (px.0[c] as i64 - want).abs() <= 1,
                "pixel {k}: {} vs {want}",
                px.0[c]
            );
        }
    }
    let reference = image::open(render_to("eight.png", &[])).unwrap().to_rgb8();
    let error = |name: &str, quality: &str| -> f64 {
        let jpeg = image::open(render_to(name, &["--quality", quality]))
            .unwrap()
            .to_rgb8();
        assert_eq!(jpeg.dimensions(), (20, 16));
        jpeg.as_raw()
            .iter()
            .zip(reference.as_raw())
            .map(|(&a, &b)| (a as f64 - b as f64).abs())
            .sum::<f64>()
    };
    let (fine, coarse) = (error("fine.jpg", "100"), error("coarse.JPEG", "5"));
    assert!(fine < coarse, "quality 100: {fine}, quality 5: {coarse}");
    let hdr = image::open(render_to("linear.hdr", &[]))
        .unwrap()
        .to_rgb32f();
    for (k, (px, mean)) in hdr.pixels().zip(&image.mean).enumerate() {
        let top = mean.iter().cloned().fold(0.0f32, f32::max);
        for c in 0..3 {
            assert!(
                (px.0[c] - mean[c]).abs() <= top * 2f32.powi(-7) + 1e-30,
                "pixel {k}: {:?} vs {mean:?}",
                px.0
            );
        }
    }
}

/// EXRs of each precision and compression read back equal to the film: exactly in float,
/// within half precision (relative 2⁻¹¹, and the smallest normal half, 2⁻¹⁴, absolutely) in
/// half; statistics stay float, so the sums read back bit for bit whatever the precision. DWAA
/// is lossy (a DCT codec: within 5 % here), so its EXR leaves the statistics out.
#[test]
fn exr_precisions_and_compressions_read_back() {
    let exact = render_to("exact.exr", &[]);
    let film = common::read_exr_file(&exact);
    let mut sizes = Vec::new();
    for precision in ["float", "half"] {
        for compression in ["zip", "piz", "rle", "none", "dwaa"] {
            let name = format!("{precision}-{compression}.exr");
            let out = render_to(
                &name,
                &[
                    "--exr-precision",
                    precision,
                    "--exr-compression",
                    compression,
                ],
            );
            sizes.push(format!(
                "{name} {} B",
                std::fs::metadata(&out).unwrap().len()
            ));
            let image = if compression == "dwaa" {
                // Lossy: the statistics are left out rather than written wrong.
                let image = wavetrace::image_io::read_exr(&out).unwrap();
                assert!(image.variance.is_none() && image.count.is_none(), "{name}");
                image
            } else {
                let read = common::read_exr_file(&out);
                assert!(
                    read.film.pixels == film.film.pixels,
                    "{name}: the statistics differ"
                );
                read.image
            };
            for (k, (a, b)) in image.mean.iter().zip(&film.image.mean).enumerate() {
                for c in 0..3 {
                    let bound = match (precision, compression) {
                        (_, "dwaa") => 0.05 * b[c].abs() + 2e-3,
                        ("float", _) => 0.0,
                        _ => b[c].abs() * 2f32.powi(-11) + 2f32.powi(-14),
                    };
                    assert!(
                        (a[c] - b[c]).abs() <= bound,
                        "{name}: pixel {k}: {a:?} vs {b:?}"
                    );
                }
            }
        }
    }
    println!("{}", sizes.join(", "));
}

/// `-o - --format F` writes the image to standard output, and nothing else there; without
/// --format it is refused.
#[test]
fn standard_output_holds_only_the_image() {
    for (format, magic) in [
        ("png", &b"\x89PNG"[..]),
        ("exr", &[0x76, 0x2f, 0x31, 0x01][..]),
    ] {
        let o = wavetrace(&[
            "render",
            "scenes/cornell-box.gltf",
            "--device",
            "cpu",
            "--width",
            "8",
            "--spp",
            "1",
            "-o",
            "-",
            "--format",
            format,
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(
            o.stdout.starts_with(magic),
            "{format}: stdout starts {:?}",
            &o.stdout[..8.min(o.stdout.len())]
        );
        if format == "png" {
            let decoded = image::load_from_memory(&o.stdout).unwrap();
            assert_eq!(decoded.width(), 8);
        }
        assert!(String::from_utf8_lossy(&o.stderr).contains("rendering"));
    }
    let (_, err) = refused("-");
    assert!(err.contains("--format"), "{err}");
}
