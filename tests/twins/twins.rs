//! Each GLSL function the integrators share with Rust, run on the GPU (shaders/tests/twins.comp)
//! against its Rust twin on the same inputs, so a disagreement names the function, the case and
//! both values (DESIGN.md: "when they disagree, the test says where").
//!
//! Tolerances come from the precision Vulkan requires of SPIR-V instructions (Vulkan spec,
//! "Precision and Operation of SPIR-V Instructions"): integer hashing is exact; sin and cos may
//! be off by 2⁻¹¹ absolute on [−π, π], so everything downstream of a sampled angle is held to
//! 2⁻¹⁰; atan by 4096 ulp; sqrt, division and the rest by a few ulp, held to 1e-5 relative.

use crate::common;

use glam::{UVec4, Vec2, Vec3, Vec4};
use wavetrace::bsdf::microfacet::*;
use wavetrace::bsdf::{
    bsdf_albedo_estimate, bsdf_eval, bsdf_pdf, bsdf_sample, BsdfFrame, TransportMode,
};
use wavetrace::bvh::{any_triangle, closest_triangle, Ray, WideBvh};
use wavetrace::layout::{FrameParams, GpuMaterial, MATERIAL_ENERGY_COMPENSATION, MATERIAL_UNLIT};
use wavetrace::mis::mis_weight2;
use wavetrace::sampling::*;
use wavetrace::scene::{camera_ray, Camera, Projection, ThinLens};
use wavetrace::sobol::*;
use wavetrace::spectrum::*;

const CASES: u32 = 4096;
const INPUTS_PER_CASE: usize = 4;
const OUTPUTS_PER_CASE: usize = 28;
/// 2⁻¹⁰: twice the absolute error Vulkan allows sin and cos.
const ANGLE_TOL: f32 = 1.0 / 1024.0;
const ULP_TOL: f32 = 1e-5;

struct Case {
    u: Vec4,
    n: Vec3,
    wo: Vec3,
    key: UVec4,
}

fn unit_vector(u: Vec4) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The direction of case `i`'s ray through the scene (twins.comp): -wo, with x still in one case
/// of 64 and y and z in another (z subnormal), so that some subgroups walk the quantised nodes
/// in the min/max slab form (qbvh.glsl, qbvh_slabs) and the others in the sign-selected form.
fn scene_ray_dir(i: u32, wo: Vec3) -> Vec3 {
    let mut dir = -wo;
    if i % 64 == 3 {
        dir.x = 0.0;
    }
    if i % 64 == 35 {
        (dir.y, dir.z) = (0.0, 1e-40);
    }
    dir
}

fn cases() -> Vec<Case> {
    (0..CASES)
        .map(|i| {
            let u = rng_uniform4(11, i, 0, 0);
            let n = unit_vector(rng_uniform4(11, i, 1, 0));
            let w = unit_vector(rng_uniform4(11, i, 2, 0));
            let wo = if w.dot(n) < 0.0 { -w } else { w };
            let o = rng_uniform4(11, i, 3, 0) * 1.8 - Vec4::splat(0.9);
            let key = UVec4::new(o.x.to_bits(), o.y.to_bits(), o.z.to_bits(), i);
            Case { u, n, wo, key }
        })
        .collect()
}

/// The material of case `i` (twins.comp, twin_material): one block of 64 cases in 512 plain
/// diffuse (`BsdfFrame`'s plain path, which the twins shader takes per lane); the last 512
/// unlit.
fn twin_material(i: u32) -> GpuMaterial {
    let k = (i / 4) % 4;
    let m = GpuMaterial {
        base_color: [0.2, 0.5, 0.9],
        roughness: [0.0, 0.05, 0.3, 0.8][(i % 4) as usize],
        metallic: [0.0, 1.0, 0.0, 0.5][k as usize],
        transmission: [0.0, 0.0, 1.0, 0.5][k as usize],
        ior: if i % 7 == 3 { 1.0 } else { 1.5 },
        specular: if (i / 16).is_multiple_of(2) { 1.0 } else { 0.5 },
        specular_color: [[1.0; 3], [0.3, 1.8, 0.9], [40.0, 0.0, 1.0]][((i / 128) % 3) as usize],
        flags: if i / 512 == 7 { MATERIAL_UNLIT } else { 0 }
            | if (i / 5).is_multiple_of(2) {
                MATERIAL_ENERGY_COMPENSATION
            } else {
                0
            },
        clearcoat: if (i / 1024) % 2 == 1 { 0.7 } else { 0.0 },
        clearcoat_roughness: if (i / 256).is_multiple_of(2) {
            0.0
        } else {
            0.35
        },
        sheen_color: if (i / 64) % 4 == 3 {
            [0.9, 0.4, 0.7]
        } else {
            [0.0; 3]
        },
        sheen_roughness: if (i / 8).is_multiple_of(2) { 0.3 } else { 0.8 },
        anisotropy: if (i / 3) % 3 == 1 { 0.8 } else { 0.0 },
        anisotropy_direction: [0.48, 0.6, -0.64],
        iridescence: if (i / 3) % 3 == 2 { 0.9 } else { 0.0 },
        iridescence_ior: 1.6,
        iridescence_thickness: 350.0,
        diffuse_transmission: if (i / 5) % 3 == 1 { 0.6 } else { 0.0 },
        diffuse_transmission_color: [0.3, 0.9, 0.5],
        dispersion: if (i / 8) % 2 == 1 { 1.5 } else { 0.0 },
        // Half thin-walled (thicknessFactor 0, glTF's default), half a volume's boundary.
        thickness: if (i / 32) % 2 == 1 { 1.0 } else { 0.0 },
        ..Default::default()
    };
    if (i / 64) % 8 == 5 && i / 512 != 7 {
        return GpuMaterial {
            metallic: 0.0,
            transmission: 0.0,
            specular: 0.0,
            clearcoat: 0.0,
            iridescence: 0.0,
            diffuse_transmission: 0.0,
            ..m
        };
    }
    m
}

/// The camera set-ups of the camera-ray cases (twins.comp reads them as `frames[i % 3]`): a
/// turned pinhole with a near plane on a 37×23 film, a thin lens on a 16×16 film, an
/// orthographic camera on a 40×30 film.
fn twin_frames() -> Vec<FrameParams> {
    let forward = Vec3::new(0.3, -0.2, -1.0).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let camera = |projection, znear| Camera {
        position: Vec3::new(0.5, 1.0, 3.0),
        forward,
        right,
        up: right.cross(forward),
        projection,
        znear,
    };
    let perspective = Projection::Perspective {
        yfov: 0.8,
        aspect_ratio: None,
    };
    let setups = [
        (camera(perspective, 0.05), ThinLens::default(), 37, 23),
        (
            camera(perspective, 0.1),
            ThinLens {
                radius: 0.25,
                focus_distance: 3.5,
            },
            16,
            16,
        ),
        (
            camera(
                Projection::Orthographic {
                    xmag: 2.0,
                    ymag: 1.5,
                },
                0.2,
            ),
            ThinLens::default(),
            40,
            30,
        ),
    ];
    setups
        .into_iter()
        .map(|(camera, lens, width, height)| {
            let mut f = FrameParams {
                width,
                height,
                aspect: width as f32 / height as f32,
                ..Default::default()
            };
            camera.write_frame_params(lens, &mut f);
            f
        })
        .collect()
}

/// How far a sample drawn from `u` may move when the device's sin and cos of its angle are off
/// by the 2⁻¹¹ Vulkan allows: that moves the point (cos φ, sin φ) by up to √2·2⁻¹¹, as far as
/// turning φ by that many radians and scaling the radius by that fraction. `f` draws the
/// sample from (u.x, the squared radius; u.y, the angle's fraction of a turn), as the sampling
/// functions here do; the result is the most each component moves over the corners of that box
/// around `u` (to first order the most the device's sin and cos can move it: a linear map's
/// largest change over a box is at a corner), or None where a corner's sample fails or changes
/// kind (a borderline case).
fn angle_envelope(u: Vec2, f: impl Fn(Vec2) -> Option<Vec4>) -> Option<Vec4> {
    let e = std::f32::consts::SQRT_2 / 2048.0;
    let du = Vec2::new(2.0 * e * u.x, e / std::f32::consts::TAU);
    let centre = f(u)?;
    let mut envelope = Vec4::ZERO;
    for (sx, sy) in [(-1, -1), (-1, 1), (1, -1), (1, 1)] {
        let corner = (u + du * Vec2::new(sx as f32, sy as f32)).clamp(Vec2::ZERO, Vec2::ONE);
        envelope = envelope.max((f(corner)? - centre).abs());
    }
    Some(envelope)
}

/// `close` with each component's allowance widened by `envelope` (see [`angle_envelope`]).
fn close_within(a: Vec4, b: Vec4, tol: f32, envelope: Vec4) -> bool {
    (a - b)
        .abs()
        .cmple(Vec4::splat(tol) * b.abs().max(Vec4::ONE) + envelope)
        .all()
}

fn close(a: Vec4, b: Vec4, tol: f32) -> bool {
    close_within(a, b, tol, Vec4::ZERO)
}

#[test]
fn glsl_functions_equal_their_rust_twins() {
    let scene = common::prepared("cornell-box.gltf");
    let cases = cases();
    let mut inputs: Vec<Vec4> = Vec::with_capacity(cases.len() * INPUTS_PER_CASE);
    for c in &cases {
        let key = Vec4::new(
            f32::from_bits(c.key.x),
            f32::from_bits(c.key.y),
            f32::from_bits(c.key.z),
            f32::from_bits(c.key.w),
        );
        inputs.extend([c.u, c.n.extend(0.0), c.wo.extend(0.0), key]);
    }
    // After the cases: the GPU node index of the scene's quantised 4-wide root (qbvh.glsl), in
    // the node array the renderer uploads (the binary nodes, then the quantised ones).
    let gpu_bvh = scene.gpu_bvh();
    inputs.push(Vec4::new(
        f32::from_bits(gpu_bvh.instances[0].wide_root),
        0.0,
        0.0,
        0.0,
    ));
    let quant = WideBvh::collapse(&scene.bvh.nodes, &[0]).quantized();
    let outputs = vec![Vec4::ZERO; cases.len() * OUTPUTS_PER_CASE];
    let frames = twin_frames();
    let Some(gpu) = common::test_kernels() else {
        return;
    };
    let result = gpu
        .run(
            "twins",
            CASES,
            &[
                bytemuck::cast_slice(&inputs).to_vec(),
                bytemuck::cast_slice(&outputs).to_vec(),
                bytemuck::cast_slice(&gpu_bvh.nodes).to_vec(),
                bytemuck::cast_slice(&scene.triangles).to_vec(),
                bytemuck::cast_slice(&frames).to_vec(),
            ],
        )
        .unwrap_or_else(|e| panic!("{e:#}"));
    let gpu_out: Vec<Vec4> = bytemuck::pod_collect_to_vec(&result[1]);

    let mut failures = common::Disagreements::default();
    // Samples whose direction a corner of angle_envelope's box loses (it fails or changes kind).
    let mut borderline_samples = 0;
    for (i, c) in cases.iter().enumerate() {
        let g = |slot: usize| gpu_out[i * OUTPUTS_PER_CASE + slot];
        let mut check = |slot: usize, what: &str, cpu: Vec4, ok: &dyn Fn(Vec4, Vec4) -> bool| {
            if !ok(g(slot), cpu) {
                failures.add(what, || {
                    format!(
                        "{what}, case {i} (u = {}, n = {}, wo = {}): GPU {} vs CPU {cpu}",
                        c.u,
                        c.n,
                        c.wo,
                        g(slot)
                    )
                });
            }
        };
        let rng = rng_uniform4(c.key.x, c.key.y, c.key.z, c.key.w);
        check(0, "rng_uniform4", rng, &|a, b| a == b);
        let w = sample_cosine_hemisphere(Vec2::new(c.u.x, c.u.y));
        check(
            1,
            "sample_cosine_hemisphere / cosine_hemisphere_pdf",
            w.extend(cosine_hemisphere_pdf(w.z)),
            &|a, b| close(a, b, ANGLE_TOL),
        );
        let tri = sample_uniform_triangle(Vec2::new(c.u.z, c.u.w));
        let inv = invert_cosine_hemisphere_sample(w);
        check(
            2,
            "invert_cosine_hemisphere_sample / sample_uniform_triangle",
            Vec4::new(inv.x, inv.y, tri.x, tri.y),
            &|a, b| {
                // φ/2π wraps at 1: compare it on the circle.
                let dphi = (a.y - b.y).abs();
                close(
                    Vec4::new(a.x, 0.0, a.z, a.w),
                    Vec4::new(b.x, 0.0, b.z, b.w),
                    ANGLE_TOL,
                ) && dphi.min(1.0 - dphi) <= ANGLE_TOL
            },
        );
        let back = invert_uniform_triangle_sample(tri);
        check(
            3,
            "invert_uniform_triangle_sample / mis_weight2 / uniform_triangle_pdf",
            Vec4::new(
                back.x,
                back.y,
                mis_weight2(i as u32 % 6, 1.5 + (i % 3) as f32, c.u.x, c.u.y, i & 4 != 0),
                uniform_triangle_pdf(c.u.z + 0.5),
            ),
            &|a, b| close(a, b, ULP_TOL * 10.0),
        );
        let (t, bt) = build_frame(c.n);
        check(4, "build_frame (t)", t.extend(0.0), &|a, b| {
            close(a, b, ULP_TOL)
        });
        check(5, "build_frame (b)", bt.extend(0.0), &|a, b| {
            close(a, b, ULP_TOL)
        });
        let p = offset_ray_origin(c.wo * 10.0 * c.u.w, c.n);
        check(6, "offset_ray_origin", p.extend(0.0), &|a, b| {
            close(a, b, ULP_TOL)
        });
        let mut m = twin_material(i as u32);
        // Half the coated cases have a coat normal of their own (twins.comp).
        if (i / 2048) % 2 == 1 {
            m.clearcoat_normal = (c.n + 0.5 * c.wo).normalize().to_array();
        }
        let wo = if i & 32 != 0 { -c.wo } else { c.wo };
        let radiance = TransportMode::Radiance;
        let s = bsdf_sample(&m, c.n, wo, c.u.truncate(), radiance);
        // The sample: same lobe, direction within the angle tolerance; its pdf and weight
        // checked against the Rust BSDF at the GPU's direction (a GGX lobe's slope would
        // magnify the angle tolerance). A lobe choice within rounding of a boundary is skipped.
        let gs = (g(7), g(8));
        let near_boundary = BsdfFrame::new(&m, c.n, wo).is_some_and(|f| {
            // Any cumulative sum of the lobe probabilities near u.z.
            let mut cumulative = 0.0;
            f.lobe_pmf.iter().any(|&p| {
                cumulative += p;
                p > 0.0 && (c.u.z - cumulative).abs() < 1e-5
            })
        });
        match s {
            Some(s) if gs.1.w != 0.0 => {
                // The direction is drawn from u.xy (radius, angle) within the lobe u.z chose.
                let wi_envelope = angle_envelope(Vec2::new(c.u.x, c.u.y), |u| {
                    bsdf_sample(&m, c.n, wo, Vec3::new(u.x, u.y, c.u.z), radiance)
                        .filter(|t| t.delta == s.delta)
                        .map(|t| t.wi.extend(0.0))
                });
                match wi_envelope {
                    Some(envelope) => check(7, "bsdf_sample (wi)", s.wi.extend(0.0), &|a, b| {
                        close_within(a.truncate().extend(0.0), b, ANGLE_TOL, envelope)
                    }),
                    None => borderline_samples += 1,
                }
                check(
                    8,
                    "bsdf_sample (delta)",
                    Vec4::new(0.0, 0.0, 0.0, if s.delta { 2.0 } else { 1.0 }),
                    &|a, b| a.w == b.w,
                );
                if !s.delta {
                    // The GPU's world-space wi carries rounding of a few ulp, which a GGX lobe
                    // of width α magnifies about 1/α-fold near its peak: relative 1e-3 + 2⁻¹²/α.
                    let tol = 1e-3 + 1.0 / (4096.0 * m.roughness * m.roughness);
                    let gwi = gs.0.truncate();
                    let pdf = bsdf_pdf(&m, c.n, wo, gwi);
                    let weight = bsdf_eval(&m, c.n, wo, gwi, radiance) * gwi.dot(c.n).abs() / pdf;
                    check(
                        7,
                        "bsdf_sample (pdf) vs bsdf_pdf at its wi",
                        Vec4::new(0.0, 0.0, 0.0, pdf),
                        &|a, b| (a.w - b.w).abs() <= tol * b.w.abs().max(1.0),
                    );
                    check(
                        8,
                        "bsdf_sample (weight) vs bsdf_eval at its wi",
                        weight.extend(g(8).w),
                        &|a, b| close(a, b, tol),
                    );
                } else {
                    check(
                        8,
                        "bsdf_sample (delta weight)",
                        s.weight.extend(2.0),
                        &|a, b| close(a, b, ULP_TOL * 10.0),
                    );
                }
            }
            None if gs.1.w == 0.0 => {}
            _ if near_boundary => {}
            _ => check(
                8,
                "bsdf_sample (succeeded on one side only)",
                Vec4::new(
                    0.0,
                    0.0,
                    0.0,
                    s.map_or(0.0, |s| if s.delta { 2.0 } else { 1.0 }),
                ),
                &|a, b| a.w == b.w,
            ),
        }
        let wi_test = (c.u.truncate() - Vec3::splat(0.5)).normalize();
        let mode = if i & 64 != 0 {
            TransportMode::Importance
        } else {
            radiance
        };
        check(
            9,
            "bsdf_eval / bsdf_pdf",
            bsdf_eval(&m, c.n, wo, wi_test, mode).extend(bsdf_pdf(&m, c.n, wo, wi_test)),
            &|a, b| close(a, b, 1e-4),
        );
        let origin = Vec3::new(
            f32::from_bits(c.key.x),
            f32::from_bits(c.key.y),
            f32::from_bits(c.key.z),
        );
        let ray = Ray {
            origin,
            dir: scene_ray_dir(i as u32, c.wo),
        };
        let hit = scene
            .bvh
            .intersect_closest(&scene.triangles, &ray, 0.0, f32::MAX);
        // A hit as the kernel writes it (t, triangle's bits, u, v), and the same triangle with t,
        // u and v within ULP_TOL.
        let as_vec4 = |hit: Option<wavetrace::bvh::Hit>| match hit {
            Some(h) => Vec4::new(h.t, f32::from_bits(h.triangle), h.u, h.v),
            None => Vec4::new(f32::MAX, f32::from_bits(u32::MAX), 0.0, 0.0),
        };
        let same_hit = |a: Vec4, b: Vec4| {
            a.y.to_bits() == b.y.to_bits()
                && close(
                    Vec4::new(a.x, 0.0, a.z, a.w),
                    Vec4::new(b.x, 0.0, b.z, b.w),
                    ULP_TOL,
                )
        };
        check(
            10,
            "bvh_intersect_closest (t, triangle, u, v)",
            as_vec4(hit),
            &same_hit,
        );
        let t_max = c.u.z * 4.0;
        let any = scene.bvh.intersect_any(&scene.triangles, &ray, 0.0, t_max);
        check(
            11,
            "bvh_intersect_any",
            Vec4::new(any as u32 as f32, t_max, 0.0, 0.0),
            &|a, b| a == b,
        );
        // The quantised walk, against the CPU's walk of the same nodes.
        let (wide_hit, ..) = closest_triangle(
            &quant,
            0,
            &scene.triangles,
            &ray,
            0.0,
            f32::MAX,
            |_, _, _| true,
        );
        check(
            26,
            "qbvh_closest_from (t, triangle, u, v)",
            as_vec4(wide_hit),
            &same_hit,
        );
        let wide_any = any_triangle(&quant, 0, &scene.triangles, &ray, 0.0, t_max, |_, _, _| {
            true
        });
        check(
            27,
            "qbvh_any_from",
            Vec4::new(wide_any as u32 as f32, t_max, 0.0, 0.0),
            &|a, b| a == b,
        );
        let n_perm = 1 + i as u32 % 300;
        let p = permute(i as u32 % n_perm, n_perm, c.key.x);
        let strat = stratify2(
            c.key.x,
            i as u32,
            i as u32 % 64,
            64,
            c.key.y,
            Vec2::new(c.u.z, c.u.w),
        );
        check(
            12,
            "permute / stratify2",
            Vec4::new(f32::from_bits(p), strat.x, strat.y, 0.0),
            &|a, b| {
                a.x.to_bits() == b.x.to_bits()
                    && close(
                        Vec4::new(0.0, a.y, a.z, 0.0),
                        Vec4::new(0.0, b.y, b.z, 0.0),
                        ULP_TOL,
                    )
            },
        );
        // Microfacet pieces in the local frame: wo = the cosine-sampled w; anisotropic α in
        // half the cases. The GPU's pieces take the GPU's w, so the Rust twins take it too (the
        // same inputs): its sin and cos may be off by 2⁻¹¹, which steep functions of w magnify.
        let w = g(1).truncate();
        let alpha = Vec2::new(
            0.02 + c.u.w,
            if i & 2 != 0 {
                0.02 + c.u.x
            } else {
                0.02 + c.u.w
            },
        );
        let h = sample_ggx_vndf(w, alpha, Vec2::new(c.u.z, c.u.w));
        // Near the rim of its disk (u.z → 1) the sample's height √(1 − p²) is steep in p, so
        // the device's sin and cos move it by far more than 2⁻¹¹ there.
        let h_envelope = angle_envelope(Vec2::new(c.u.z, c.u.w), |u| {
            Some(sample_ggx_vndf(w, alpha, u).extend(0.0))
        })
        .unwrap_or(Vec4::ZERO);
        check(13, "sample_ggx_vndf", h.extend(0.0), &|a, b| {
            close_within(a.truncate().extend(0.0), b, ANGLE_TOL, h_envelope)
        });
        let gh = g(13).truncate();
        check(
            13,
            "ggx_vndf_pdf",
            Vec4::new(0.0, 0.0, 0.0, ggx_vndf_pdf(w, gh, alpha)),
            &|a, b| (a.w - b.w).abs() <= 1e-4 * b.w.abs().max(1.0),
        );
        let etap = if i & 1 != 0 { 1.5 } else { 1.0 / 1.5 };
        check(
            14,
            "ggx_d / ggx_lambda / ggx_visibility / fresnel_dielectric",
            Vec4::new(
                ggx_d(gh, alpha),
                ggx_lambda(w, alpha),
                ggx_visibility(w, gh, alpha),
                fresnel_dielectric(c.u.x, dielectric_f0(1.5), c.u.y, etap),
            ),
            &|a, b| close(a, b, 1e-4),
        );
        let refracted = refract_through(w, Vec3::Z, etap);
        check(
            15,
            "refract_through",
            refracted.map_or(Vec4::ZERO, |r| r.extend(1.0)),
            &|a, b| close(a, b, ANGLE_TOL),
        );
        check(
            16,
            "fresnel_conductor / bsdf_albedo_estimate",
            fresnel_conductor(Vec3::from(m.base_color), c.u.y)
                .extend(bsdf_albedo_estimate(&m, c.n, wo)),
            &|a, b| close(a, b, 1e-4),
        );
        let rr = wavetrace::mc::roulette_f32(c.u.x, c.u.y * 1.2);
        check(
            17,
            "roulette",
            Vec4::new(rr.map_or(0.0, |_| 1.0), rr.unwrap_or(1.0), 0.0, 0.0),
            &|a, b| close(a, b, ULP_TOL),
        );

        // Sobol points are integer arithmetic: bit for bit.
        let bits = |v: UVec4| {
            Vec4::new(
                f32::from_bits(v.x),
                f32::from_bits(v.y),
                f32::from_bits(v.z),
                f32::from_bits(v.w),
            )
        };
        let same_bits = |a: Vec4, b: Vec4| (0..4).all(|k| a[k].to_bits() == b[k].to_bits());
        let (s_key, s_case) = (sobol2(c.key.x), sobol2(i as u32));
        check(
            18,
            "sobol2",
            bits(UVec4::new(s_key.x, s_key.y, s_case.x, s_case.y)),
            &same_bits,
        );
        let keys = sobol_keys(c.key.x, i as u32, c.key.y);
        let shuffled = shuffled_scrambled_sobol2(i as u32 % 256, keys);
        check(
            19,
            "laine_karras_permutation / nested_uniform_scramble / shuffled_scrambled_sobol2",
            bits(UVec4::new(
                laine_karras_permutation(c.key.y, c.key.z),
                nested_uniform_scramble(c.key.z, c.key.x),
                shuffled.x,
                shuffled.y,
            )),
            &same_bits,
        );
        let pair = sobol_pair(c.key.x, i as u32, i as u32 % 64, c.key.y);
        check(
            20,
            "sobol_pair / sobol_keys",
            Vec4::new(
                pair.x,
                pair.y,
                f32::from_bits(keys.x),
                f32::from_bits(keys.w),
            ),
            &same_bits,
        );
        let disk = sample_concentric_disk(Vec2::new(c.u.x, c.u.y));
        check(
            21,
            "sample_concentric_disk / uniform_disk_pdf",
            Vec4::new(disk.x, disk.y, uniform_disk_pdf(), 0.0),
            &|a, b| close(a, b, ANGLE_TOL),
        );
        // The lens point carries the disk's angle tolerance, scaled by the lens radius (< 1).
        let frame = &frames[i % frames.len()];
        let pixel = c.key.w % (frame.width * frame.height);
        let ray = camera_ray(
            frame,
            pixel,
            Vec2::new(c.u.x, c.u.y),
            Vec2::new(c.u.z, c.u.w),
        );
        check(
            22,
            "camera_ray (origin)",
            ray.origin.extend(0.0),
            &|a, b| close(a, b, ANGLE_TOL),
        );
        check(23, "camera_ray (dir)", ray.dir.extend(0.0), &|a, b| {
            close(a, b, ANGLE_TOL)
        });
        // Spectral sampling: atanh, cosh and exp are built from exp and log, which Vulkan
        // holds to 3 + 2|x| ulp: 1e-4 relative.
        let lambda = sample_wavelength(c.u.x);
        check(
            24,
            "sample_wavelength / wavelength_pdf / dispersive_ior / is_dispersive",
            Vec4::new(
                lambda,
                wavelength_pdf(lambda),
                dispersive_ior(1.3 + c.u.y, 4.0 * c.u.z, lambda),
                if is_dispersive(&m) { 1.0 } else { 0.0 },
            ),
            &|a, b| a.w == b.w && close(a, b, 1e-4),
        );
        // The response at the GPU's wavelength (the curves are steep: 1e-4 of λ moves them).
        let gl = g(24).x;
        check(
            25,
            "wavelength_rgb / wavelength_weight",
            wavelength_rgb(gl).extend(wavelength_weight(gl).y),
            &|a, b| close(a, b, 1e-4),
        );
    }
    failures.assert_none(cases.len(), "GLSL and Rust twins disagree");
    // Such samples are rare; a run that skipped many would test little.
    assert!(
        borderline_samples < cases.len() / 50,
        "{borderline_samples} of {} BSDF samples borderline",
        cases.len()
    );
}
