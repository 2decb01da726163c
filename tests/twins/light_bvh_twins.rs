//! The GLSL twin of the light BVH (shaders/inc/light_bvh.glsl) runs on the GPU
//! (shaders/tests/light_bvh_twins.comp) against src/lights/light_bvh/mod.rs on a random scene of 500
//! lights: the sampled light and its pmf, the pmf of a given light, and the importance of a
//! given node, for random shading points, normals and random numbers. Also checks that the GLSL
//! `GpuLightNode` has the Rust struct's member offsets and size.
//!
//! Tolerances: the importance is built from dot products, square roots and divisions of O(1)
//! quantities, each a few ulp on either side (Vulkan spec, "Precision and Operation of SPIR-V
//! Instructions": sqrt and division 2.5–3 ulp), so its cosine factors agree to ~1e-6 absolute;
//! a case is compared to 1e-4 relative where every factor it multiplies is ≥ 0.02 (relative
//! error ≤ 5e-5). Cases near the importance's two steps (cos θ' = cos θe, and p on a node's
//! bounding sphere), where rounding may take either side, are skipped, and a differing light is
//! accepted when u lies within 1e-4 of the boundary of the CPU light's interval of u.

use crate::common;

use glam::{Vec3, Vec4};
use std::f32::consts::PI;
use std::mem::{offset_of, size_of};
use wavetrace::kernels::TEST_KERNELS;
use wavetrace::lights::light_bvh::*;
use wavetrace::sampling::rng_uniform4;

const CASES: u32 = 4096;
const LIGHTS: u32 = 500;
const INPUTS_PER_CASE: usize = 3;
const OUTPUTS_PER_CASE: usize = 2;
const TOLERANCE: f32 = 1e-4;

fn unit(u: Vec4) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// 500 lights in [−1, 1]³: one- and two-sided triangles, point and spot lights, powers
/// log-uniform over four decades.
fn random_lights() -> Vec<LightBounds> {
    (0..LIGHTS)
        .map(|i| {
            let a = rng_uniform4(57, i, 0, 0);
            let b = rng_uniform4(57, i, 1, 0);
            let c = rng_uniform4(57, i, 2, 0);
            let centre = a.truncate() * 2.0 - Vec3::ONE;
            let power = 10f32.powf(4.0 * a.w - 2.0);
            match (c.w * 5.0) as u32 {
                k @ 0..=2 => {
                    let size = 0.02 + 0.33 * b.w;
                    LightBounds::triangle(
                        centre,
                        centre + size * unit(b),
                        centre + size * unit(c),
                        power,
                        k == 2,
                    )
                }
                3 => LightBounds::point(centre, power),
                _ => {
                    let inner = 0.1 + 1.1 * b.w;
                    let outer = inner + 0.5 * c.z;
                    LightBounds::spot(centre, unit(b), power, inner.cos(), outer.cos())
                }
            }
        })
        .collect()
}

/// Whether rounding may change a node's importance by more than the tolerance at (p, n): near
/// one of its steps, or with a small cosine factor (whose ~1e-6 absolute error is large
/// relative to it).
fn sensitive(node: &GpuLightNode, p: Vec3, n: Vec3) -> bool {
    let t = light_bounds_importance_terms(node, p, n);
    let near_cone_step = (t.cos_theta_p - node.cos_theta_e).abs() < 1e-4;
    let near_sphere = (t.distance_squared - t.radius_squared).abs()
        <= 1e-4 * t.distance_squared.max(t.radius_squared);
    let small_factor = t.importance > 0.0 && (t.cos_theta_p < 0.02 || t.cos_theta_pi < 0.02);
    near_cone_step || near_sphere || small_factor
}

/// The nodes whose importance decides the path to `light` (the children of each interior node
/// on the trail, or the root leaf), and the interval of u that [`light_bvh_sample`] maps to the
/// light, in f64 from the same f32 probabilities.
fn path(bvh: &LightBvh, p: Vec3, n: Vec3, light: u32) -> (Vec<usize>, f64, f64) {
    let nodes = &bvh.nodes;
    let mut trail = bvh.trails[light as usize];
    let (mut index, mut lo, mut hi) = (0usize, 0.0f64, 1.0f64);
    let mut evaluated = vec![];
    if nodes[0].is_leaf() {
        evaluated.push(0);
    }
    while !nodes[index].is_leaf() {
        let second = nodes[index].child_or_light as usize;
        evaluated.extend([index + 1, second]);
        let c0 = light_bounds_importance(&nodes[index + 1], p, n);
        let c1 = light_bounds_importance(&nodes[second], p, n);
        let split = lo + (hi - lo) * (c0 / (c0 + c1)) as f64;
        if trail & 1 == 0 {
            hi = split;
            index += 1;
        } else {
            lo = split;
            index = second;
        }
        trail >>= 1;
    }
    (evaluated, lo, hi)
}

fn close(gpu: f32, cpu: f32) -> bool {
    (gpu - cpu).abs() <= TOLERANCE * gpu.abs().max(cpu.abs())
}

#[test]
fn light_bvh_functions_equal_their_rust_twins() {
    let lights = random_lights();
    let bvh = LightBvh::build(&lights);
    assert_eq!(bvh.nodes.len(), 2 * LIGHTS as usize - 1);
    let mut inputs: Vec<Vec4> = Vec::with_capacity(CASES as usize * INPUTS_PER_CASE);
    for i in 0..CASES {
        let a = rng_uniform4(58, i, 0, 0);
        let b = rng_uniform4(58, i, 1, 0);
        let c = rng_uniform4(58, i, 2, 0);
        let p = a.truncate() * 4.0 - Vec3::splat(2.0);
        let n = if i % 4 == 3 { Vec3::ZERO } else { unit(b) };
        let query = (c.x * LIGHTS as f32) as u32 % LIGHTS;
        let node = (c.y * bvh.nodes.len() as f32) as u32 % bvh.nodes.len() as u32;
        inputs.extend([
            p.extend(a.w),
            n.extend(f32::from_bits(query)),
            Vec4::new(f32::from_bits(node), 0.0, 0.0, 0.0),
        ]);
    }
    let outputs = vec![Vec4::ZERO; CASES as usize * OUTPUTS_PER_CASE];
    let Some(gpu) = common::test_kernels() else {
        return;
    };
    let result = gpu
        .run(
            "light_bvh_twins",
            CASES,
            &[
                bytemuck::cast_slice(&inputs).to_vec(),
                bytemuck::cast_slice(&outputs).to_vec(),
                bytemuck::cast_slice(&bvh.nodes).to_vec(),
                bytemuck::cast_slice(&bvh.trails).to_vec(),
            ],
        )
        .unwrap_or_else(|e| panic!("{e:#}"));
    let gpu_out: Vec<Vec4> = bytemuck::pod_collect_to_vec(&result[1]);

    let mut failures = Vec::new();
    let (mut skipped, mut boundary, mut sampled, mut compared) = (0, 0, 0, 0);
    for i in 0..CASES as usize {
        let input = |k: usize| inputs[i * INPUTS_PER_CASE + k];
        let (p, u) = (input(0).truncate(), input(0).w);
        let (n, query) = (input(1).truncate(), input(1).w.to_bits());
        let node = input(2).x.to_bits() as usize;
        let g0 = gpu_out[i * OUTPUTS_PER_CASE];
        let g1 = gpu_out[i * OUTPUTS_PER_CASE + 1];
        let mut fail = |what: String| {
            if failures.len() < 20 {
                failures.push(format!("case {i} (p {p}, n {n}, u {u}): {what}"));
            }
        };

        // light_bvh_sample.
        let cpu = light_bvh_sample(&bvh.nodes, p, n, u);
        let gpu_sample = (g0.x == 1.0).then_some((g0.y.to_bits(), g0.z));
        let path_sensitive =
            |evaluated: &[usize]| evaluated.iter().any(|&k| sensitive(&bvh.nodes[k], p, n));
        sampled += cpu.is_some() as u32;
        match (cpu, gpu_sample) {
            (None, None) => {}
            (Some((cl, cp)), Some((gl, gp))) if cl == gl => {
                if path_sensitive(&path(&bvh, p, n, cl).0) {
                    skipped += 1;
                } else {
                    compared += 1;
                    if !close(gp, cp) {
                        fail(format!(
                            "light_bvh_sample pmf of light {cl}: GPU {gp} vs CPU {cp}"
                        ));
                    }
                }
            }
            (c, g) => {
                // Another light (or none): u must lie by a boundary of either light's
                // interval, or the path to either must pass a node near a step.
                let near = [c.map(|x| x.0), g.map(|x| x.0)]
                    .into_iter()
                    .flatten()
                    .any(|l| {
                        let (evaluated, lo, hi) = path(&bvh, p, n, l);
                        let u = u as f64;
                        path_sensitive(&evaluated) || (u - lo).abs().min((hi - u).abs()) < 1e-4
                    });
                if near {
                    boundary += 1;
                } else {
                    fail(format!("light_bvh_sample: GPU {g:?} vs CPU {c:?}"));
                }
            }
        }

        // light_bvh_pmf of the query light.
        let cpu_pmf = light_bvh_pmf(&bvh.nodes, &bvh.trails, p, n, query);
        let query_sensitive = path(&bvh, p, n, query)
            .0
            .iter()
            .any(|&k| sensitive(&bvh.nodes[k], p, n));
        if !query_sensitive && !close(g0.w, cpu_pmf) {
            fail(format!(
                "light_bvh_pmf of light {query}: GPU {} vs CPU {cpu_pmf}",
                g0.w
            ));
        }

        // light_bounds_importance of the query node.
        let cpu_importance = light_bounds_importance(&bvh.nodes[node], p, n);
        if !sensitive(&bvh.nodes[node], p, n) && !close(g1.x, cpu_importance) {
            fail(format!(
                "light_bounds_importance of node {node}: GPU {} vs CPU {cpu_importance}",
                g1.x
            ));
        }
    }
    println!(
        "{sampled} cases sampled a light: {compared} compared, {skipped} skipped near a step \
         or a small factor; {boundary} cases chose another light by a decision boundary"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    // Most cases must be compared, or the test tests little.
    assert!(
        compared > CASES * 3 / 4,
        "only {compared} of {CASES} samples compared ({skipped} skipped, {boundary} on boundaries)"
    );
}

/// The GLSL struct's members and offsets, read from the SPIR-V by naga, equal the Rust
/// `#[repr(C)]` struct's (the check tests/twins/shaders.rs makes for src/layout.rs).
#[test]
fn gpu_light_node_layout_matches_glsl() {
    let (_, bytes) = TEST_KERNELS
        .iter()
        .find(|(n, _)| *n == "light_bvh_twins")
        .expect("the light_bvh_twins kernel is compiled");
    let words = ash::util::read_spv(&mut std::io::Cursor::new(bytes)).unwrap();
    let module = naga::front::spv::parse_u8_slice(
        bytemuck::cast_slice(&words),
        &naga::front::spv::Options::default(),
    )
    .unwrap();
    let (members, span) = module
        .types
        .iter()
        .find_map(|(_, ty)| match (&ty.name, &ty.inner) {
            (Some(name), naga::TypeInner::Struct { members, span }) if name == "GpuLightNode" => {
                Some((members.clone(), *span))
            }
            _ => None,
        })
        .expect("GpuLightNode in the kernel");
    let glsl: Vec<(String, usize)> = members
        .iter()
        .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
        .collect();
    let rust: Vec<(String, usize)> = [
        ("bounds_min", offset_of!(GpuLightNode, bounds_min)),
        ("phi", offset_of!(GpuLightNode, phi)),
        ("bounds_max", offset_of!(GpuLightNode, bounds_max)),
        ("cos_theta_o", offset_of!(GpuLightNode, cos_theta_o)),
        ("w", offset_of!(GpuLightNode, w)),
        ("cos_theta_e", offset_of!(GpuLightNode, cos_theta_e)),
        ("child_or_light", offset_of!(GpuLightNode, child_or_light)),
        ("flags", offset_of!(GpuLightNode, flags)),
        ("radius", offset_of!(GpuLightNode, radius)),
        ("sin_theta_o", offset_of!(GpuLightNode, sin_theta_o)),
    ]
    .into_iter()
    .map(|(n, o)| (n.to_string(), o))
    .collect();
    assert_eq!(glsl, rust);
    assert_eq!(span as usize, size_of::<GpuLightNode>());
    assert_eq!(size_of::<GpuLightNode>(), 64);
}
