//! The GLSL twins of texture sampling (src/texture.rs), surface attributes, materials, normal
//! maps and alpha (src/surface.rs) and the shading-normal bend (src/bsdf) run on the GPU
//! (shaders/tests/surface_twins.comp) against Rust on a synthetic textured scene: textures of
//! odd and power-of-two sizes with every wrap mode, filter and colour space, transforms with
//! rotation and scale, random vertices, triangles and materials. A disagreement names the
//! function, the case and both values.
//!
//! Tolerances come from the precision Vulkan requires (Vulkan spec, "Precision and Operation
//! of SPIR-V Instructions"): pow, log2 and the divisions inside normalize are a few ulp; the
//! sRGB decode (a pow) is held to 1e-4 absolute on values in [0, 1]; the level of detail (a
//! log2) to 1e-4. A case whose texel coordinate or level lies within 1e-3 of a rounding
//! boundary may legitimately pick a different texel or level and is skipped.

use crate::common;

use glam::{UVec4, Vec2, Vec3, Vec4};
use wavetrace::bsdf::bend_shading_normal;
use wavetrace::layout::*;
use wavetrace::sampling::rng_uniform4;
use wavetrace::surface::*;
use wavetrace::texture::*;

const CASES: u32 = 4096;
const INPUTS_PER_CASE: usize = 6;
const OUTPUTS_PER_CASE: usize = 17;

struct Synthetic {
    textures: Vec<GpuTexture>,
    refs: Vec<GpuTextureRef>,
    texels: Vec<u32>,
    vertices: Vec<GpuVertex>,
    triangles: Vec<GpuTriangle>,
    triangle_vertices: Vec<UVec4>,
    materials: Vec<GpuMaterial>,
}

fn random(i: u32, block: u32) -> Vec4 {
    rng_uniform4(23, i, block, 0)
}

fn unit(u: Vec4) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn synthetic() -> Synthetic {
    let mut texels = Vec::new();
    let mut textures = Vec::new();
    let specs = [
        (
            5,
            3,
            WRAP_REPEAT,
            WRAP_REPEAT,
            FILTER_LINEAR,
            MIN_LINEAR_MIPMAP_LINEAR,
            1,
        ),
        (
            8,
            8,
            WRAP_MIRRORED_REPEAT,
            WRAP_CLAMP_TO_EDGE,
            FILTER_NEAREST,
            MIN_NEAREST_MIPMAP_NEAREST,
            0,
        ),
        (
            1,
            1,
            WRAP_CLAMP_TO_EDGE,
            WRAP_CLAMP_TO_EDGE,
            FILTER_LINEAR,
            MIN_LINEAR,
            1,
        ),
        (
            16,
            4,
            WRAP_REPEAT,
            WRAP_MIRRORED_REPEAT,
            FILTER_LINEAR,
            MIN_LINEAR_MIPMAP_NEAREST,
            0,
        ),
        (
            7,
            9,
            WRAP_CLAMP_TO_EDGE,
            WRAP_REPEAT,
            FILTER_NEAREST,
            MIN_NEAREST_MIPMAP_LINEAR,
            1,
        ),
    ];
    for (k, &(w, h, wrap_s, wrap_t, mag, min, srgb)) in specs.iter().enumerate() {
        let mut t = GpuTexture {
            texel_offset: texels.len() as u32,
            width: w,
            height: h,
            levels: 1,
            wrap_s,
            wrap_t,
            filters: mag | (min << 4),
            srgb,
        };
        let (mut lw, mut lh) = (w, h);
        loop {
            for j in 0..lw * lh {
                let u = rng_uniform4(5, k as u32, texels.len() as u32, j);
                texels.push(u32::from_le_bytes(
                    (u * 255.0).round().to_array().map(|c| c as u8),
                ));
            }
            if lw == 1 && lh == 1 {
                break;
            }
            lw = (lw / 2).max(1);
            lh = (lh / 2).max(1);
            t.levels += 1;
        }
        textures.push(t);
    }
    let refs: Vec<GpuTextureRef> = (0..8u32)
        .map(|k| {
            let u = random(k, 90);
            let (s, c) = (u.x * 6.0).sin_cos();
            let scale = Vec2::new(0.5 + 2.0 * u.y, 0.25 + u.z);
            GpuTextureRef {
                transform: if k == 0 {
                    [1.0, 0.0, 0.0, 1.0]
                } else {
                    [c * scale.x, s * scale.y, -s * scale.x, c * scale.y]
                },
                offset: if k == 0 { [0.0; 2] } else { [u.w - 0.5, 0.3] },
                texture: k % textures.len() as u32,
                texcoord: k % 2,
            }
        })
        .collect();
    let vertices: Vec<GpuVertex> = (0..30u32)
        .map(|k| {
            let a = random(k, 91);
            let b = random(k, 92);
            let n = unit(a);
            GpuVertex {
                tangent: unit(b)
                    .extend(if b.z < 0.5 { -1.0 } else { 1.0 })
                    .to_array(),
                normal: n.to_array(),
                pad: 0,
                uv: (random(k, 93) * 4.0 - Vec4::splat(2.0)).to_array(),
                color: random(k, 94).to_array(),
            }
        })
        .collect();
    let materials: Vec<GpuMaterial> = (0..6u32)
        .map(|k| {
            let slot = |j: u32| {
                if (k + j) % 3 == 0 {
                    NO_TEXTURE
                } else {
                    (k + j) % refs.len() as u32
                }
            };
            GpuMaterial {
                base_color: [0.9, 0.6, 0.3],
                flags: [0, MATERIAL_ALPHA_MASK, MATERIAL_ALPHA_BLEND][k as usize % 3]
                    | if k == 4 { MATERIAL_UNLIT } else { 0 },
                emission: [2.0, 1.0, 0.5],
                metallic: 0.7,
                roughness: 0.4,
                transmission: 0.5,
                alpha: 0.8,
                alpha_cutoff: 0.3,
                normal_scale: 0.5 + k as f32 * 0.3,
                base_color_texture: slot(0),
                metallic_roughness_texture: slot(1),
                emissive_texture: slot(2),
                normal_texture: if k == 4 {
                    NO_TEXTURE
                } else {
                    (k + 3) % refs.len() as u32
                },
                transmission_texture: slot(4),
                specular: 0.8,
                specular_color: [1.5, 0.5, 1.0],
                specular_texture: slot(5),
                specular_color_texture: slot(6),
                clearcoat: 0.9,
                clearcoat_roughness: 0.6,
                clearcoat_texture: slot(7),
                clearcoat_roughness_texture: slot(8),
                clearcoat_normal_texture: if k == 2 { NO_TEXTURE } else { slot(9) },
                clearcoat_normal_scale: 0.7,
                sheen_color: [0.8, 0.5, 0.9],
                sheen_roughness: 0.6,
                sheen_color_texture: slot(10),
                sheen_roughness_texture: slot(11),
                anisotropy: 0.6,
                anisotropy_rotation: 0.3 * k as f32 - 0.5,
                anisotropy_texture: slot(12),
                iridescence: 0.7,
                iridescence_ior: 1.4,
                iridescence_thickness_min: 150.0,
                iridescence_thickness: 500.0,
                iridescence_texture: slot(13),
                iridescence_thickness_texture: slot(14),
                diffuse_transmission: 0.8,
                diffuse_transmission_color: [0.4, 0.7, 0.9],
                diffuse_transmission_texture: slot(15),
                diffuse_transmission_color_texture: slot(16),
                ..Default::default()
            }
        })
        .collect();
    let (mut triangles, mut triangle_vertices) = (Vec::new(), Vec::new());
    for k in 0..12u32 {
        let a = random(k, 95);
        let b = random(k, 96);
        let c = random(k, 97);
        // Flat or not, alpha-tested or not (the test bits ride in the material's top bits).
        let (flat, alpha) = [
            (0, 0),
            (TRIANGLE_FLAT, 0),
            (0, TRIANGLE_TEST_ALPHA),
            (TRIANGLE_FLAT, TRIANGLE_TEST_ALPHA),
        ][k as usize % 4];
        triangles.push(GpuTriangle {
            p0: (a.truncate() * 2.0).to_array(),
            material: k % materials.len() as u32 | alpha,
            e1: (b.truncate() - Vec3::splat(0.5)).to_array(),
            e2: (c.truncate() - Vec3::splat(0.5)).to_array(),
            ..Default::default()
        });
        let v = |x: f32| (x * 30.0) as u32 % 30;
        triangle_vertices.push(UVec4::new(v(a.w), v(b.w), v(c.w), flat));
    }
    Synthetic {
        textures,
        refs,
        texels,
        vertices,
        triangles,
        triangle_vertices,
        materials,
    }
}

fn close(a: Vec4, b: Vec4, tol: f32) -> bool {
    (a - b)
        .abs()
        .cmple(Vec4::splat(tol) * b.abs().max(Vec4::ONE))
        .all()
}

/// Whether `x` lies within `margin` of an integer (a texel or level boundary).
fn near_integer(x: f32, margin: f32) -> bool {
    (x - x.round()).abs() < margin
}

/// Whether a coordinate lies within 1e-3 texels of a texel edge or centre of a w × h level,
/// where rounding could pick another texel (clamped coordinates outside the level pin the
/// texel and cannot).
fn on_boundary(t: &GpuTexture, uv: Vec2, w: u32, h: u32) -> bool {
    let axis = |u: f32, mode: u32, n: u32| {
        let x = reduce_coordinate(u, mode) * n as f32;
        let pinned = mode == WRAP_CLAMP_TO_EDGE && (x <= 0.5 || x >= n as f32 - 0.5);
        !pinned && (near_integer(x, 1e-3) || near_integer(x - 0.5, 1e-3))
    };
    axis(uv.x, t.wrap_s, w) || axis(uv.y, t.wrap_t, h)
}

#[test]
fn texture_and_surface_functions_equal_their_rust_twins() {
    let s = synthetic();
    let data = TextureData {
        textures: &s.textures,
        refs: &s.refs,
        texels: &s.texels,
    };
    let mut inputs: Vec<Vec4> = Vec::with_capacity(CASES as usize * INPUTS_PER_CASE);
    for i in 0..CASES {
        let a = random(i, 0);
        let b = random(i, 1);
        let c = random(i, 2);
        let uv = a * 6.0 - Vec4::splat(3.0);
        let lod = Vec2::new(b.x * 16.0 - 8.0, b.y * 16.0 - 8.0);
        let level = i % 5 | ((i / 5) % 2) << 8;
        let r = i % s.refs.len() as u32;
        let bary = Vec2::new(c.x, c.y * (1.0 - c.x));
        let tri = i % s.triangles.len() as u32;
        let m = (i / 3) % s.materials.len() as u32;
        let ns = unit(random(i, 3));
        let wo = unit(random(i, 4));
        let ng = unit(random(i, 5));
        inputs.extend([
            uv,
            Vec4::new(lod.x, lod.y, f32::from_bits(r), f32::from_bits(level)),
            Vec4::new(bary.x, bary.y, f32::from_bits(tri), f32::from_bits(m)),
            ns.extend(f32::from_bits(i)),
            wo.extend(f32::from_bits(i * 7 + 1)),
            ng.extend(c.z * 0.1),
        ]);
    }
    let outputs = vec![Vec4::ZERO; CASES as usize * OUTPUTS_PER_CASE];
    let Some(gpu) = common::test_kernels() else {
        return;
    };
    let result = gpu
        .run(
            "surface_twins",
            CASES,
            &[
                bytemuck::cast_slice(&inputs).to_vec(),
                bytemuck::cast_slice(&outputs).to_vec(),
                bytemuck::cast_slice(&s.textures).to_vec(),
                bytemuck::cast_slice(&s.refs).to_vec(),
                bytemuck::cast_slice(&s.texels).to_vec(),
                bytemuck::cast_slice(&s.vertices).to_vec(),
                bytemuck::cast_slice(&s.triangles).to_vec(),
                bytemuck::cast_slice(&s.triangle_vertices).to_vec(),
                bytemuck::cast_slice(&s.materials).to_vec(),
            ],
        )
        .unwrap_or_else(|e| panic!("{e:#}"));
    let gpu_out: Vec<Vec4> = bytemuck::pod_collect_to_vec(&result[1]);

    let mut failures = common::Disagreements::default();
    let mut skipped = 0;
    for i in 0..CASES as usize {
        let input = |k: usize| inputs[i * INPUTS_PER_CASE + k];
        let (in0, in1, in2, in3, in4, in5) =
            (input(0), input(1), input(2), input(3), input(4), input(5));
        let uv = [Vec2::new(in0.x, in0.y), Vec2::new(in0.z, in0.w)];
        let lod = [in1.x, in1.y];
        let ref_index = in1.z.to_bits();
        let level_bits = in1.w.to_bits();
        let r = &s.refs[ref_index as usize];
        let t = &s.textures[r.texture as usize];
        let level = (level_bits & 255).min(t.levels - 1);
        let linear = level_bits >> 8 != 0;
        // Texel and level boundaries: a rounding difference may move the sample across them.
        let st = texture_ref_uv(r, uv);
        let lambda = texture_lod(t, r, lod[r.texcoord as usize]);
        let borderline = |uv: Vec2, w: u32, h: u32| on_boundary(t, uv, w, h);
        let any_level_borderline = (0..t.levels).any(|l| {
            let (w, h, _) = texture_level(t, l);
            borderline(st, w, h)
        }) || near_integer(lambda, 1e-3)
            || near_integer(lambda - 0.5, 1e-3)
            || lambda.abs() < 1e-3;
        let g = |slot: usize| gpu_out[i * OUTPUTS_PER_CASE + slot];
        let mut check = |slot: usize, what: &str, cpu: Vec4, tol: f32| {
            if !close(g(slot), cpu, tol) {
                failures.add(what, || {
                    format!("{what}, case {i}: GPU {} vs CPU {cpu}", g(slot))
                });
            }
        };
        if any_level_borderline {
            skipped += 1;
        } else {
            check(
                0,
                "sample_texture_ref",
                sample_texture_ref(&data, ref_index, uv, lod),
                1e-4,
            );
        }
        let (lw, lh, _) = texture_level(t, level);
        if !borderline(uv[0], lw, lh) {
            check(
                1,
                "texture_sample_level",
                texture_sample_level(&data, t, level, uv[0], linear),
                1e-4,
            );
        }
        // Every texel index wrap_texel is given, [−n, 3n) for n = 5: below −n GLSL's `%` of a
        // negative operand is undefined, and SwiftShader's differs from lavapipe's and Rust's.
        let wrapped = wrap_texel((i % 20) as i32 - 5, 5, t.wrap_t) as f32;
        check(
            2,
            "texture_lod / reduce_coordinate / wrap_texel / texture_ref_uv",
            Vec4::new(
                texture_lod(t, r, lod[0]),
                reduce_coordinate(uv[0].x, t.wrap_s),
                wrapped,
                st.x,
            ),
            1e-4,
        );

        let tri_index = in2.z.to_bits();
        let tri = &s.triangles[tri_index as usize];
        let sp = surface_point(
            tri,
            s.triangle_vertices[tri_index as usize],
            &s.vertices,
            in2.x,
            in2.y,
        );
        check(
            3,
            "surface_point (ns), surface_lod_base (set 0)",
            sp.ns.extend(surface_lod_base(&sp, 1.0, 1.0)[0]),
            1e-4,
        );
        check(
            4,
            "surface_point (uv0, uv1)",
            Vec4::new(sp.uv[0].x, sp.uv[0].y, sp.uv[1].x, sp.uv[1].y),
            1e-5,
        );
        let m = &s.materials[in2.w.to_bits() as usize];
        let wo = in4.truncate();
        let lod_sp = surface_lod_base(&sp, in5.w, sp.ng.dot(wo));
        // The material's textures are sampled at lod_sp: skip cases on a level boundary.
        let material_borderline = [
            m.base_color_texture,
            m.metallic_roughness_texture,
            m.emissive_texture,
            m.normal_texture,
            m.transmission_texture,
            m.specular_texture,
            m.specular_color_texture,
            m.clearcoat_texture,
            m.clearcoat_roughness_texture,
            m.clearcoat_normal_texture,
            m.sheen_color_texture,
            m.sheen_roughness_texture,
            m.anisotropy_texture,
            m.iridescence_texture,
            m.iridescence_thickness_texture,
            m.diffuse_transmission_texture,
            m.diffuse_transmission_color_texture,
        ]
        .into_iter()
        .filter(|&k| k != NO_TEXTURE)
        .any(|k| {
            let r = &s.refs[k as usize];
            let t = &s.textures[r.texture as usize];
            let l = texture_lod(t, r, lod_sp[r.texcoord as usize]);
            let st = texture_ref_uv(r, sp.uv);
            near_integer(l, 1e-3)
                || near_integer(l - 0.5, 1e-3)
                || l.abs() < 1e-3
                || (0..t.levels).any(|level| {
                    let (w, h, _) = texture_level(t, level);
                    on_boundary(t, st, w, h)
                })
        });
        if !material_borderline {
            let e = surface_material(&data, m, &sp, lod_sp);
            check(
                5,
                "surface_material (base colour, alpha)",
                Vec3::from(e.base_color).extend(e.alpha),
                1e-4,
            );
            check(
                6,
                "surface_material (metallic, roughness, emission.x, transmission)",
                Vec4::new(e.metallic, e.roughness, e.emission[0], e.transmission),
                1e-4,
            );
            check(
                9,
                "surface_material (specular colour, specular)",
                Vec3::from(e.specular_color).extend(e.specular),
                1e-4,
            );
            check(
                10,
                "surface_material (emission)",
                Vec3::from(e.emission).extend(0.0),
                1e-4,
            );
            check(
                11,
                "surface_material (clearcoat, clearcoat roughness)",
                Vec4::new(e.clearcoat, e.clearcoat_roughness, 0.0, 0.0),
                1e-4,
            );
            check(
                12,
                "surface_material (clearcoat normal)",
                Vec3::from(e.clearcoat_normal).extend(0.0),
                1e-3,
            );
            check(
                13,
                "surface_material (sheen colour, sheen roughness)",
                Vec3::from(e.sheen_color).extend(e.sheen_roughness),
                1e-4,
            );
            check(
                14,
                "surface_material (anisotropy direction, strength)",
                Vec3::from(e.anisotropy_direction).extend(e.anisotropy),
                1e-3,
            );
            check(
                15,
                "surface_material (iridescence, thickness)",
                Vec4::new(e.iridescence, e.iridescence_thickness, 0.0, 0.0),
                1e-4,
            );
            check(
                16,
                "surface_material (diffuse transmission colour, factor)",
                Vec3::from(e.diffuse_transmission_color).extend(e.diffuse_transmission),
                1e-4,
            );
            let key = UVec4::new(in3.w.to_bits(), in4.w.to_bits(), 7, 11);
            check(
                7,
                "surface_normal / alpha_random",
                surface_normal(&data, m, &sp, lod_sp).extend(alpha_random(key, tri_index)),
                1e-3,
            );
        }
        let ng = in5.truncate();
        let ng_wo = if ng.dot(wo) > 0.0 { ng } else { -ng };
        let ns = in3.truncate();
        let ns_side = if ns.dot(ng_wo) > 0.0 { ns } else { -ns };
        check(
            8,
            "bend_shading_normal",
            bend_shading_normal(ns_side, ng_wo, wo).extend(g(8).w),
            1e-3,
        );
        let key = UVec4::new(in3.w.to_bits(), in4.w.to_bits(), 7, 11);
        let present = triangle_present(
            &data,
            &s.triangles,
            &s.triangle_vertices,
            &s.vertices,
            &s.materials,
            tri_index,
            in2.x,
            in2.y,
            key,
            Vec3::ZERO,
        );
        // Alpha tests read level 0: a coordinate on a texel boundary or an alpha on the cutoff
        // may flip.
        if g(8).w != if present { 1.0 } else { 0.0 } {
            let tv = s.triangle_vertices[tri_index as usize];
            let tm = &s.materials[tri.material_index() as usize];
            let near = tm.base_color_texture != NO_TEXTURE && {
                let r = &s.refs[tm.base_color_texture as usize];
                let t = &s.textures[r.texture as usize];
                on_boundary(t, texture_ref_uv(r, sp.uv), t.width, t.height)
            };
            if !near {
                failures.add("triangle_present", || {
                    format!(
                        "triangle_present, case {i} (flags {}): GPU {} vs CPU {present}",
                        tv.w,
                        g(8).w
                    )
                });
            }
        }
    }
    failures.assert_none(CASES as usize, "texture and surface twins disagree");
    // The boundary skips are rare; a run that skipped most cases would test nothing.
    assert!(
        skipped < CASES / 10,
        "{skipped} of {CASES} cases skipped as borderline"
    );
}
