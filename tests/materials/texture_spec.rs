//! (Over 900 lines: one test per clause of the glTF texture specification, sharing the scenes they build.)
//! Textures against their specifications, on the CPU and (where there is one) the GPU.
//!
//! Every expectation is computed here from the definitions — glTF 2.0 "Texture Data" and
//! "Materials" (texture coordinates with (0, 0) at the image's top-left texel, base colour =
//! factor × sRGB texture × COLOR_0, emission = factor × sRGB texture, normal maps, alpha modes,
//! double-sided materials), the KHR_texture_transform extension, texel wrapping and filtering
//! as Vulkan defines them (Vulkan spec, "Wrapping Operation" and "Texel Filtering"), the sRGB
//! transfer function of IEC 61966-2-1 — and from the files themselves, read with serde_json
//! (accessors, node transforms) and the `image` crate (texels). Nothing is compared with an
//! earlier render.
//!
//! 1. Exact lookups (`synthetic_*`): a glTF written here, emissive quads textured with a random
//!    8 × 4 sRGB PNG under the file's orthographic camera, which gives every texel an integer
//!    block of pixels, for every wrap mode with coordinates outside [0, 1], KHR_texture_transform
//!    (offset, rotation, scale, all three, texCoord override) and texCoord 1. With NEAREST every
//!    pixel lies inside one texel, so its value is that texel's, exactly. With LINEAR the
//!    expectation is the bilinear reconstruction averaged over the pixel's box (the film's
//!    filter), with pixels centred on texel centres and on the half-way points. Rendered as
//!    radiance at max depth 0 and as `--aov emission`, through the library and the command line.
//! 2. The Khronos sample models (`sample_*`) in ../shared/gltf-samples/valid (skipped with a
//!    notice where it is absent), rendered with `--aov base-color | emission | normal | uv`
//!    through orthographic cameras set here, or the file's own camera (MultiUVTest). A pixel
//!    oracle traces the file's triangles through the pixel's corners, edge midpoints and centre;
//!    where all nine meet the same surfaces and no other triangle's image overlaps the pixel
//!    (unless wholly behind), it bounds the pixel by the texels that any conforming filter may
//!    read there (`footprint`): nearest, bilinear and trilinear filtering all fall inside, and
//!    the bound is exact where the footprint is uniform ("pinned" pixels; every test asserts
//!    that enough of them lie where the model's features are). Each model also has an assertion
//!    of its documented intent: the TextureTransformTest arrows point at their green marker;
//!    no red cross shows in a TextureSettingsTest square; a channel that COLOR_0 zeroes is 0;
//!    MultiUVTest's emission never shows the white "not supported" words; BLEND coverage is
//!    binomial in alpha; normal-mapped bumps bulge outward on mirrored UVs as the geometric
//!    ones do.
//!
//! TextureSettingsTest's single-sided row checks back-face culling of single-sided
//! materials (material.doubleSided): its back-facing quad's red cross must never show.
//!
//! Tolerances: a decoded texel is held to 1e-4 absolute (the precision Vulkan requires of pow,
//! as in tests/twins/surface_twins.rs); where a pixel's samples legitimately differ, to Student-t
//! multiples of the film's own standard error of the pixel mean (Bonferroni over the
//! comparisons), or to a binomial distribution (BLEND coverage); the oracle's intervals are
//! exact bounds.

use crate::common::{render_cpu, render_gpu, temp, wavetrace};
use glam::{DMat4, DQuat, DVec2, DVec3, DVec4, Vec3};
use serde_json::{json, Value};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use wavetrace::film::Film;
use wavetrace::layout::{AOV_BASE_COLOR, AOV_EMISSION, AOV_NORMAL, AOV_RADIANCE, AOV_UV};
use wavetrace::render::{PreparedScene, RenderSettings};
use wavetrace::scene::{Camera, Projection, Scene};
use wavetrace::stats::student_t_two_sided_p;

// glTF sampler enumerations (glTF 2.0, sampler.magFilter/minFilter/wrapS/wrapT).
const NEAREST: u32 = 9728;
const LINEAR: u32 = 9729;
const REPEAT: u32 = 10497;
const MIRRORED_REPEAT: u32 = 33648;
const CLAMP_TO_EDGE: u32 = 33071;

/// A decoded texel's precision: the sRGB decode is a pow, which Vulkan requires to be as exact
/// as exp2(y·log2 x) (a few ulp); 1e-4 absolute on values up to 1, as tests/twins/surface_twins.rs.
const FLOAT_TOL: f64 = 1e-4;

/// Family-wise significance of the statistical assertions of one test.
const ALPHA: f64 = 1e-3;

// ---------------------------------------------------------------------------------------------
// Specification maths, written here independently of src/texture.rs.

/// sRGB-encoded value in [0, 1] → linear (IEC 61966-2-1).
fn srgb_decode(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Texel index `i` of a side of `n` texels under a glTF wrap mode (Vulkan spec, "Wrapping
/// Operation": repeat is i mod n, mirrored repeat (n − 1) − mirror((i mod 2n) − n), clamp to
/// edge clamps to [0, n − 1]).
fn wrap_index(i: i64, n: i64, mode: u32) -> i64 {
    match mode {
        CLAMP_TO_EDGE => i.clamp(0, n - 1),
        MIRRORED_REPEAT => {
            let t = i.rem_euclid(2 * n);
            if t >= n {
                2 * n - 1 - t
            } else {
                t
            }
        }
        REPEAT => i.rem_euclid(n),
        other => panic!("unknown wrap mode {other}"),
    }
}

/// KHR_texture_transform as uv' = m·uv + o (m row-major): uv' = T·R·S·uv, S = diag(scale), T
/// the offset and R the rotation by `rotation` radians "counter-clockwise in UV space" (u right,
/// v down): u' = cos·u + sin·v, v' = −sin·u + cos·v. The extension's GLSL listing writes R as
/// mat3(cos, sin, 0, −sin, cos, 0, 0, 0, 1), which read column-major is the opposite rotation;
/// the sample model TextureTransformTest settles the direction — its green marker is "the
/// correct rotation" and its red one "the rotation applied in the opposite direction" — and
/// KhronosGroup/glTF issue #1563 and PR #1624 record the listing's error.
fn texture_transform(offset: [f64; 2], rotation: f64, scale: [f64; 2]) -> ([f64; 4], [f64; 2]) {
    let (s, c) = rotation.sin_cos();
    (
        [c * scale[0], s * scale[1], -s * scale[0], c * scale[1]],
        offset,
    )
}

fn apply_transform(m: &[f64; 4], o: &[f64; 2], uv: DVec2) -> DVec2 {
    DVec2::new(
        m[0] * uv.x + m[1] * uv.y + o[0],
        m[2] * uv.x + m[3] * uv.y + o[1],
    )
}

/// ∫_{−∞}^{y} of the tent max(0, 1 − |x|) dx.
fn tent_integral(y: f64) -> f64 {
    if y <= -1.0 {
        0.0
    } else if y <= 0.0 {
        0.5 * (y + 1.0) * (y + 1.0)
    } else if y <= 1.0 {
        1.0 - 0.5 * (1.0 - y) * (1.0 - y)
    } else {
        1.0
    }
}

/// Weights of the texels along one axis in the mean over the texel-space interval [a, b] of a
/// texture reconstructed by nearest filtering (the texel containing the point) or by bilinear
/// filtering (Vulkan: texel i weighs the tent centred on i + ½, one texel wide each side).
fn axis_weights(a: f64, b: f64, linear: bool) -> Vec<(i64, f64)> {
    assert!(b > a);
    let mut out = Vec::new();
    for i in (a - 2.0).floor() as i64..=(b + 2.0).ceil() as i64 {
        let centre = i as f64 + 0.5;
        let w = if linear {
            (tent_integral(b - centre) - tent_integral(a - centre)) / (b - a)
        } else {
            ((b.min(i as f64 + 1.0) - a.max(i as f64)).max(0.0)) / (b - a)
        };
        if w > 0.0 {
            out.push((i, w));
        }
    }
    out
}

/// The Student t quantile t with P(|T_df| > t) = p, by bisection of the library's p-value.
fn student_t_quantile(p: f64, df: f64) -> f64 {
    let (mut lo, mut hi) = (0.0, 1e6);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if student_t_two_sided_p(mid, df) > p {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// The standard normal quantile z with P(Z > z) = p (bisection of erfc through the t
/// distribution with infinitely many degrees of freedom).
fn normal_quantile(p: f64) -> f64 {
    student_t_quantile(2.0 * p, f64::INFINITY)
}

// ---------------------------------------------------------------------------------------------
// A small glTF reader (JSON with serde_json, buffers from the GLB chunk, data: URIs or files).

struct Img {
    w: i64,
    h: i64,
    px: Vec<[u8; 4]>,
}

impl Img {
    fn decode(bytes: &[u8]) -> Img {
        let image = image::load_from_memory(bytes)
            .expect("an image of a sample model decodes")
            .to_rgba8();
        Img {
            w: image.width() as i64,
            h: image.height() as i64,
            px: image.pixels().map(|p| p.0).collect(),
        }
    }

    fn at(&self, i: i64, j: i64) -> [u8; 4] {
        self.px[(j * self.w + i) as usize]
    }
}

struct Doc {
    json: Value,
    buffers: Vec<Vec<u8>>,
    images: HashMap<usize, Rc<Img>>,
}

fn base64_decode(s: &str) -> Vec<u8> {
    use base64::Engine;
    base64::engine::general_purpose::STANDARD
        .decode(s)
        .expect("valid base64")
}

fn usize_of(v: &Value) -> usize {
    v.as_u64()
        .unwrap_or_else(|| panic!("expected an index, got {v}")) as usize
}

fn f64s(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("expected numbers, got {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

impl Doc {
    fn open(path: &Path) -> Doc {
        let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let (json, bin): (Value, Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
            let u32_at =
                |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
            let json_len = u32_at(12);
            let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
            let at = 20 + json_len;
            let bin = (at + 8 <= bytes.len()).then(|| bytes[at + 8..at + 8 + u32_at(at)].to_vec());
            (json, bin)
        } else {
            (serde_json::from_slice(&bytes).unwrap(), None)
        };
        let dir = path.parent().unwrap();
        let buffers = json["buffers"]
            .as_array()
            .map(|buffers| {
                buffers
                    .iter()
                    .map(|b| match b["uri"].as_str() {
                        None => bin.clone().expect("a GLB BIN chunk"),
                        Some(uri) if uri.starts_with("data:") => {
                            base64_decode(uri.split_once(',').unwrap().1)
                        }
                        Some(uri) => std::fs::read(dir.join(uri)).unwrap(),
                    })
                    .collect()
            })
            .unwrap_or_default();
        let mut doc = Doc {
            json,
            buffers,
            images: HashMap::new(),
        };
        let count = doc.json["images"].as_array().map_or(0, |a| a.len());
        for i in 0..count {
            let image = &doc.json["images"][i];
            let bytes = if let Some(view) = image.get("bufferView") {
                doc.view(usize_of(view)).0.to_vec()
            } else {
                let uri = image["uri"].as_str().unwrap();
                match uri.split_once(',') {
                    Some((head, data)) if uri.starts_with("data:") => {
                        assert!(head.ends_with(";base64"));
                        base64_decode(data)
                    }
                    _ => std::fs::read(dir.join(uri)).unwrap(),
                }
            };
            doc.images.insert(i, Rc::new(Img::decode(&bytes)));
        }
        doc
    }

    fn view(&self, index: usize) -> (&[u8], Option<usize>) {
        let v = &self.json["bufferViews"][index];
        let start = v["byteOffset"].as_u64().unwrap_or(0) as usize;
        let len = usize_of(&v["byteLength"]);
        let buffer = &self.buffers[usize_of(&v["buffer"])];
        (
            &buffer[start..start + len],
            v["byteStride"].as_u64().map(|s| s as usize),
        )
    }

    /// An accessor's elements as f64; normalized integers map to [0, 1] (unsigned) or [−1, 1]
    /// (signed), as glTF 2.0 defines accessor.normalized.
    fn accessor(&self, index: usize) -> Vec<Vec<f64>> {
        let a = &self.json["accessors"][index];
        assert!(
            a.get("sparse").is_none(),
            "sparse accessors are not read here"
        );
        let count = usize_of(&a["count"]);
        let comps = match a["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            other => panic!("accessor type {other}"),
        };
        let kind = a["componentType"].as_u64().unwrap();
        let normalized = a["normalized"].as_bool().unwrap_or(false);
        let size = match kind {
            5120 | 5121 => 1,
            5122 | 5123 => 2,
            5125 | 5126 => 4,
            other => panic!("componentType {other}"),
        };
        let (data, stride) = self.view(usize_of(&a["bufferView"]));
        let offset = a["byteOffset"].as_u64().unwrap_or(0) as usize;
        let stride = stride.unwrap_or(size * comps);
        (0..count)
            .map(|i| {
                (0..comps)
                    .map(|c| {
                        let at = offset + i * stride + c * size;
                        let b = &data[at..at + size];
                        match (kind, normalized) {
                            (5126, _) => f32::from_le_bytes(b.try_into().unwrap()) as f64,
                            (5121, true) => b[0] as f64 / 255.0,
                            (5121, false) => b[0] as f64,
                            (5123, true) => {
                                u16::from_le_bytes(b.try_into().unwrap()) as f64 / 65535.0
                            }
                            (5123, false) => u16::from_le_bytes(b.try_into().unwrap()) as f64,
                            (5125, _) => u32::from_le_bytes(b.try_into().unwrap()) as f64,
                            (5120, true) => (b[0] as i8 as f64 / 127.0).max(-1.0),
                            (5122, true) => (i16::from_le_bytes(b.try_into().unwrap()) as f64
                                / 32767.0)
                                .max(-1.0),
                            (k, n) => panic!("componentType {k} normalized {n}"),
                        }
                    })
                    .collect()
            })
            .collect()
    }

    /// World matrices of the nodes of the default scene, depth first (glTF 2.0
    /// "Transformations": `matrix`, or T·R·S with the rotation a unit quaternion (x, y, z, w)).
    fn world_nodes(&self) -> Vec<(usize, DMat4)> {
        fn local(n: &Value) -> DMat4 {
            if let Some(m) = n.get("matrix") {
                return DMat4::from_cols_slice(&f64s(m));
            }
            let t = n
                .get("translation")
                .map_or(DVec3::ZERO, |v| DVec3::from_slice(&f64s(v)));
            let r = n.get("rotation").map_or(DQuat::IDENTITY, |v| {
                let q = f64s(v);
                DQuat::from_xyzw(q[0], q[1], q[2], q[3])
            });
            let s = n
                .get("scale")
                .map_or(DVec3::ONE, |v| DVec3::from_slice(&f64s(v)));
            DMat4::from_scale_rotation_translation(s, r, t)
        }
        fn walk(doc: &Doc, node: usize, parent: DMat4, out: &mut Vec<(usize, DMat4)>) {
            let n = &doc.json["nodes"][node];
            let world = parent * local(n);
            out.push((node, world));
            for c in n["children"].as_array().into_iter().flatten() {
                walk(doc, usize_of(c), world, out);
            }
        }
        let scene = self.json["scene"].as_u64().unwrap_or(0) as usize;
        let mut out = Vec::new();
        for n in self.json["scenes"][scene]["nodes"].as_array().unwrap() {
            walk(self, usize_of(n), DMat4::IDENTITY, &mut out);
        }
        out
    }

    fn node_by_name(&self, name: &str) -> (usize, DMat4) {
        self.world_nodes()
            .into_iter()
            .find(|(n, _)| self.json["nodes"][*n]["name"].as_str() == Some(name))
            .unwrap_or_else(|| panic!("no node {name:?}"))
    }

    /// A textureInfo (glTF 2.0) with its sampler and KHR_texture_transform.
    fn texture_ref(&self, info: &Value) -> Option<TexRef> {
        if info.is_null() {
            return None;
        }
        let texture = &self.json["textures"][usize_of(&info["index"])];
        let img = self.images[&usize_of(&texture["source"])].clone();
        let sampler = texture
            .get("sampler")
            .map(|s| self.json["samplers"][usize_of(s)].clone())
            .unwrap_or(Value::Null);
        let code = |key: &str, default: u32| sampler[key].as_u64().map_or(default, |v| v as u32);
        let min = sampler["minFilter"].as_u64().map(|v| v as u32);
        let mut set = info["texCoord"].as_u64().unwrap_or(0) as usize;
        let (mut m, mut o) = ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0]);
        let ext = &info["extensions"]["KHR_texture_transform"];
        if !ext.is_null() {
            let pair = |key: &str, default: [f64; 2]| {
                ext.get(key).map_or(default, |v| {
                    let v = f64s(v);
                    [v[0], v[1]]
                })
            };
            (m, o) = texture_transform(
                pair("offset", [0.0, 0.0]),
                ext["rotation"].as_f64().unwrap_or(0.0),
                pair("scale", [1.0, 1.0]),
            );
            if let Some(s) = ext["texCoord"].as_u64() {
                set = s as usize;
            }
        }
        Some(TexRef {
            img,
            wrap: [code("wrapS", REPEAT), code("wrapT", REPEAT)],
            // Without a minFilter the implementation chooses; assume mip levels may be read.
            mipmapped: !matches!(min, Some(NEAREST | LINEAR)),
            set,
            m,
            o,
        })
    }
}

// ---------------------------------------------------------------------------------------------
// What a filter may return over a footprint.

#[derive(Clone)]
struct TexRef {
    img: Rc<Img>,
    wrap: [u32; 2],
    mipmapped: bool,
    /// TEXCOORD_n set, after KHR_texture_transform's texCoord override.
    set: usize,
    m: [f64; 4],
    o: [f64; 2],
}

/// The least and greatest texel (per channel, encoded as stored) that a conforming filter can
/// read for texture coordinates in the convex hull of `uvs`, plus one texel each side for
/// rounding. Bilinear filtering at level k reads the two level-k texels around x/2^k − ½; the
/// levels read are those up to ⌊λ⌋ + 1 (trilinear) for the level of detail λ, which is ≤ 0
/// (magnification: level 0 only) unless the footprint's longest extent s exceeds one texel:
/// the ray-cone λ (Akenine-Möller et al. 2021) is log2 of the footprint's width in texels at
/// the texture's isotropic density, at most log2 s for the isotropic UV maps of these models,
/// plus `lod_slack` for the cone's approximation of a perspective pixel. A mip texel averages
/// texels of its block and is rounded back to 8 bits; a value between two stored integers
/// rounds to one between them, so the range holds.
struct Footprint {
    lo: [u8; 4],
    hi: [u8; 4],
}

fn footprint(t: &TexRef, uvs: &[DVec2], lod_slack: f64) -> Option<Footprint> {
    let (w, h) = (t.img.w as f64, t.img.h as f64);
    let mut lo = DVec2::splat(f64::INFINITY);
    let mut hi = DVec2::splat(f64::NEG_INFINITY);
    for &uv in uvs {
        let q = apply_transform(&t.m, &t.o, uv) * DVec2::new(w, h);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let lambda = (hi - lo).max_element().max(1e-12).log2() + lod_slack + 1e-3;
    let top = if t.mipmapped && lambda > 0.0 {
        lambda.floor() as i32 + 1
    } else {
        0
    };
    let power_of_two = |n: i64| n & (n - 1) == 0;
    if top > 0 && !(power_of_two(t.img.w) && power_of_two(t.img.h)) {
        return None;
    }
    let mut range = [(i64::MAX, i64::MIN); 2];
    for k in 0..=top {
        let b = 2f64.powi(k);
        for axis in 0..2 {
            let start = ((lo[axis] / b - 0.5).floor() * b) as i64 - 1;
            let end = (((hi[axis] / b - 0.5).floor() + 2.0) * b) as i64 + 1;
            range[axis] = (range[axis].0.min(start), range[axis].1.max(end));
        }
    }
    if range.iter().any(|r| r.1 - r.0 > 160) {
        return None;
    }
    let mut out = Footprint {
        lo: [255; 4],
        hi: [0; 4],
    };
    for j in range[1].0..range[1].1 {
        let jj = wrap_index(j, t.img.h, t.wrap[1]);
        for i in range[0].0..range[0].1 {
            let texel = t.img.at(wrap_index(i, t.img.w, t.wrap[0]), jj);
            for (c, &v) in texel.iter().enumerate() {
                out.lo[c] = out.lo[c].min(v);
                out.hi[c] = out.hi[c].max(v);
            }
        }
    }
    Some(out)
}

impl Footprint {
    /// Channel `c` as an interval of decoded values (sRGB or linear).
    fn channel(&self, c: usize, srgb: bool) -> (f64, f64) {
        let (lo, hi) = (self.lo[c] as f64 / 255.0, self.hi[c] as f64 / 255.0);
        if srgb {
            (srgb_decode(lo), srgb_decode(hi))
        } else {
            (lo, hi)
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The scene as the specification describes it, and a pixel oracle.

#[derive(Clone, Copy, PartialEq, Debug)]
enum AlphaMode {
    Opaque,
    Mask(f64),
    Blend,
}

struct Mat {
    name: String,
    base: DVec4,
    base_tex: Option<TexRef>,
    emissive: DVec3,
    emissive_tex: Option<TexRef>,
    normal_tex: Option<TexRef>,
    normal_scale: f64,
    alpha: AlphaMode,
    double_sided: bool,
}

impl Mat {
    /// glTF's default material: base colour 1, no emission, opaque, single-sided.
    fn default_material() -> Mat {
        Mat {
            name: "default".into(),
            base: DVec4::ONE,
            base_tex: None,
            emissive: DVec3::ZERO,
            emissive_tex: None,
            normal_tex: None,
            normal_scale: 1.0,
            alpha: AlphaMode::Opaque,
            double_sided: false,
        }
    }

    fn from_json(doc: &Doc, m: &Value) -> Mat {
        let pbr = &m["pbrMetallicRoughness"];
        let base = pbr
            .get("baseColorFactor")
            .map_or(DVec4::ONE, |v| DVec4::from_slice(&f64s(v)));
        let emissive = m
            .get("emissiveFactor")
            .map_or(DVec3::ZERO, |v| DVec3::from_slice(&f64s(v)));
        let strength = m["extensions"]["KHR_materials_emissive_strength"]["emissiveStrength"]
            .as_f64()
            .unwrap_or(1.0);
        let cutoff = m["alphaCutoff"].as_f64().unwrap_or(0.5);
        Mat {
            name: m["name"].as_str().unwrap_or("").to_owned(),
            base,
            base_tex: doc.texture_ref(&pbr["baseColorTexture"]),
            emissive: emissive * strength,
            emissive_tex: doc.texture_ref(&m["emissiveTexture"]),
            normal_tex: doc.texture_ref(&m["normalTexture"]),
            normal_scale: m["normalTexture"]["scale"].as_f64().unwrap_or(1.0),
            alpha: match m["alphaMode"].as_str().unwrap_or("OPAQUE") {
                "MASK" => AlphaMode::Mask(cutoff),
                "BLEND" => AlphaMode::Blend,
                _ => AlphaMode::Opaque,
            },
            double_sided: m["doubleSided"].as_bool().unwrap_or(false),
        }
    }
}

/// A world-space triangle with its vertex attributes, counter-clockwise from its front.
struct Tri {
    p: [DVec3; 3],
    /// Unit NORMALs, or None (flat: the geometric normal).
    n: Option<[DVec3; 3]>,
    /// TANGENT xyz (world) and w.
    t: Option<[DVec4; 3]>,
    uv: [[DVec2; 3]; 2],
    color: [DVec4; 3],
    material: usize,
}

impl Tri {
    fn geometric_normal(&self) -> DVec3 {
        (self.p[1] - self.p[0])
            .cross(self.p[2] - self.p[0])
            .normalize()
    }

    fn uv_at(&self, set: usize, b: [f64; 3]) -> DVec2 {
        self.uv[set][0] * b[0] + self.uv[set][1] * b[1] + self.uv[set][2] * b[2]
    }

    fn color_at(&self, b: [f64; 3]) -> DVec4 {
        self.color[0] * b[0] + self.color[1] * b[1] + self.color[2] * b[2]
    }

    /// The shading normal of glTF 2.0 (material.normalTexture: scaled tangent-space normal
    /// (2·texel − 1)·(scale, scale, 1) in the frame T, B = w·(N × T), N) at barycentrics `b`,
    /// for the tangent-space vector `m`. T is made orthogonal to N first (Gram–Schmidt), which
    /// glTF leaves to the implementation; it changes nothing where the file's tangents are
    /// orthogonal to its normals. Without a normal map `m` = (0, 0, 1).
    fn shading_normal(&self, b: [f64; 3], m: DVec3) -> DVec3 {
        let n = match &self.n {
            Some(n) => (n[0] * b[0] + n[1] * b[1] + n[2] * b[2]).normalize(),
            None => self.geometric_normal(),
        };
        if m == DVec3::Z {
            return n;
        }
        let t4 = self.t.expect("a normal map needs tangents here");
        let t4 = t4[0] * b[0] + t4[1] * b[1] + t4[2] * b[2];
        let t = t4.truncate();
        let t = (t - n * n.dot(t)).normalize();
        let bitangent = n.cross(t) * if t4.w < 0.0 { -1.0 } else { 1.0 };
        (t * m.x + bitangent * m.y + n * m.z).normalize()
    }
}

fn intersect(o: DVec3, d: DVec3, p: &[DVec3; 3]) -> Option<(f64, [f64; 3])> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det.abs() < 1e-300 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = o - p[0];
    let u = tv.dot(pv) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qv = tv.cross(e1);
    let v = d.dot(qv) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(qv) * inv;
    (t > 1e-9).then_some((t, [1.0 - u - v, u, v]))
}

/// A view: glTF's projections (glTF 2.0 "Cameras", "Projection Matrices") for a film of w × h
/// pixels, the vertical extent kept (`half` is ymag, or tan(yfov/2)); pixel (0, 0) top-left.
#[derive(Clone, Copy)]
struct View {
    pos: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    ortho: bool,
    half: f64,
    w: u32,
    h: u32,
}

impl View {
    /// An orthographic view along `forward` of the rectangle centred on `centre`, `ymag`
    /// half-height, from 50 units back.
    fn ortho(centre: DVec3, forward: DVec3, up: DVec3, ymag: f64, w: u32, h: u32) -> View {
        let forward = forward.normalize();
        let right = forward.cross(up).normalize();
        View {
            pos: centre - forward * 50.0,
            forward,
            right,
            up: right.cross(forward),
            ortho: true,
            half: ymag,
            w,
            h,
        }
    }

    /// An orthographic view of the rectangle [x0, x1] × [y0, y1] of the plane z = const seen
    /// from `side` (+1: from +Z looking −Z; −1: from −Z) at `density` pixels per unit.
    fn ortho_rect(x: [f64; 2], y: [f64; 2], side: f64, density: f64) -> View {
        let w = ((x[1] - x[0]) * density).round() as u32;
        let h = ((y[1] - y[0]) * density).round() as u32;
        View::ortho(
            DVec3::new(0.5 * (x[0] + x[1]), 0.5 * (y[0] + y[1]), 0.0),
            DVec3::new(0.0, 0.0, -side),
            DVec3::Y,
            0.5 * h as f64 / density,
            w,
            h,
        )
    }

    /// Levels of detail the ray cone may add to log2 of the footprint (see [`footprint`]).
    fn lod_slack(&self) -> f64 {
        if self.ortho {
            0.0
        } else {
            0.5
        }
    }

    fn aspect(&self) -> f64 {
        self.w as f64 / self.h as f64
    }

    fn ray(&self, x: f64, y: f64) -> (DVec3, DVec3) {
        let sx = (2.0 * x / self.w as f64 - 1.0) * self.aspect();
        let sy = 1.0 - 2.0 * y / self.h as f64;
        let offset = (self.right * sx + self.up * sy) * self.half;
        if self.ortho {
            (self.pos + offset, self.forward)
        } else {
            (self.pos, (self.forward + offset).normalize())
        }
    }

    /// Film position (continuous pixels) of a world point, if it is in front.
    fn project(&self, p: DVec3) -> Option<DVec2> {
        let d = p - self.pos;
        let scale = if self.ortho {
            self.half
        } else {
            let z = d.dot(self.forward);
            if z <= 1e-9 {
                return None;
            }
            z * self.half
        };
        let sx = d.dot(self.right) / scale / self.aspect();
        let sy = d.dot(self.up) / scale;
        Some(DVec2::new(
            (sx + 1.0) * 0.5 * self.w as f64,
            (1.0 - sy) * 0.5 * self.h as f64,
        ))
    }

    /// World point on the view's centre plane of film position (x, y) (orthographic views).
    fn world(&self, x: f64, y: f64) -> DVec3 {
        assert!(self.ortho);
        self.ray(x, y).0 + self.forward * 50.0
    }

    /// The renderer's camera for this view (orthographic only; perspective views come from
    /// the file).
    fn camera(&self) -> Camera {
        assert!(self.ortho);
        let v = |d: DVec3| Vec3::new(d.x as f32, d.y as f32, d.z as f32);
        Camera {
            position: v(self.pos),
            forward: v(self.forward),
            right: v(self.right),
            up: v(self.up),
            projection: Projection::Orthographic {
                xmag: (self.half * self.aspect()) as f32,
                ymag: self.half as f32,
            },
            znear: 0.0,
        }
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Quantity {
    BaseColor,
    Emission,
    /// The shading normal as n/2 + 1/2.
    Normal,
}

/// What the specification says about one pixel: an interval per channel, and the triangle the
/// pixel shows (None: the rays leave the scene).
#[derive(Clone, Copy)]
struct PixelExpectation {
    iv: [[f64; 2]; 3],
    tri: Option<usize>,
}

impl PixelExpectation {
    fn tight(&self) -> bool {
        self.iv.iter().all(|c| c[1] - c[0] <= 2e-3)
    }
    fn mid(&self) -> [f64; 3] {
        self.iv.map(|c| 0.5 * (c[0] + c[1]))
    }
}

struct Oracle {
    tris: Vec<Tri>,
    mats: Vec<Mat>,
    /// glTF 2.0, material.doubleSided: "When this value is false, back-face culling is enabled".
    cull_single_sided_back_faces: bool,
}

/// Probe offsets inside a pixel: corners, edge midpoints and centre.
const PROBES: [f64; 3] = [0.0, 0.5, 1.0];

impl Oracle {
    fn open(path: &Path) -> (Doc, Oracle) {
        let doc = Doc::open(path);
        let mut mats: Vec<Mat> = doc.json["materials"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|m| Mat::from_json(&doc, m))
            .collect();
        mats.push(Mat::default_material());
        let default = mats.len() - 1;
        let mut tris = Vec::new();
        for (node, world) in doc.world_nodes() {
            let Some(mesh) = doc.json["nodes"][node].get("mesh") else {
                continue;
            };
            let normal_matrix = world.inverse().transpose();
            let mirrored = world.determinant() < 0.0;
            for prim in doc.json["meshes"][usize_of(mesh)]["primitives"]
                .as_array()
                .unwrap()
            {
                assert_eq!(prim["mode"].as_u64().unwrap_or(4), 4, "triangles only");
                let attr = &prim["attributes"];
                let read = |name: &str| attr.get(name).map(|a| doc.accessor(usize_of(a)));
                let pos = read("POSITION").unwrap();
                let normals = read("NORMAL");
                let tangents = read("TANGENT");
                let uvs = [read("TEXCOORD_0"), read("TEXCOORD_1")];
                let colors = read("COLOR_0");
                let indices: Vec<usize> = match prim.get("indices") {
                    Some(i) => doc
                        .accessor(usize_of(i))
                        .iter()
                        .map(|v| v[0] as usize)
                        .collect(),
                    None => (0..pos.len()).collect(),
                };
                let material = prim.get("material").map_or(default, usize_of);
                for tri in indices.chunks(3) {
                    let mut v = [tri[0], tri[1], tri[2]];
                    // A negative determinant turns the winding (glTF 2.0 "Meshes": "the determinant of
                    // the node's global transform defines the winding order").
                    if mirrored {
                        v.swap(1, 2);
                    }
                    let p = v.map(|i| world.transform_point3(DVec3::from_slice(&pos[i])));
                    let n = normals.as_ref().map(|n| {
                        v.map(|i| {
                            normal_matrix
                                .transform_vector3(DVec3::from_slice(&n[i]))
                                .normalize()
                        })
                    });
                    let t = tangents.as_ref().map(|t| {
                        v.map(|i| {
                            world
                                .transform_vector3(DVec3::from_slice(&t[i][..3]))
                                .extend(t[i][3])
                        })
                    });
                    let uv = uvs.clone().map(|set| {
                        v.map(|i| {
                            set.as_ref()
                                .map_or(DVec2::ZERO, |s| DVec2::from_slice(&s[i]))
                        })
                    });
                    let color = v.map(|i| {
                        colors.as_ref().map_or(DVec4::ONE, |c| {
                            let c = &c[i];
                            DVec4::new(c[0], c[1], c[2], if c.len() > 3 { c[3] } else { 1.0 })
                        })
                    });
                    tris.push(Tri {
                        p,
                        n,
                        t,
                        uv,
                        color,
                        material,
                    });
                }
            }
        }
        (
            doc,
            Oracle {
                tris,
                mats,
                cull_single_sided_back_faces: true,
            },
        )
    }

    fn material(&self, name: &str) -> usize {
        self.mats
            .iter()
            .position(|m| m.name == name)
            .unwrap_or_else(|| panic!("no material {name:?}"))
    }

    /// Triangles that may cover each pixel of `view` (film-space bounding boxes, one pixel of
    /// margin).
    fn bins(&self, view: &View) -> Vec<Vec<u32>> {
        let (w, h) = (view.w as i64, view.h as i64);
        let mut bins = vec![Vec::new(); (w * h) as usize];
        for (k, tri) in self.tris.iter().enumerate() {
            let projected: Option<Vec<DVec2>> = tri.p.iter().map(|&p| view.project(p)).collect();
            let (x0, x1, y0, y1) = match projected {
                Some(q) => {
                    let lo = q.iter().fold(DVec2::INFINITY, |a, &b| a.min(b));
                    let hi = q.iter().fold(DVec2::NEG_INFINITY, |a, &b| a.max(b));
                    (
                        (lo.x.floor() as i64 - 1).max(0),
                        (hi.x.floor() as i64 + 1).min(w - 1),
                        (lo.y.floor() as i64 - 1).max(0),
                        (hi.y.floor() as i64 + 1).min(h - 1),
                    )
                }
                None => (0, w - 1, 0, h - 1),
            };
            for y in y0..=y1 {
                for x in x0..=x1 {
                    bins[(y * w + x) as usize].push(k as u32);
                }
            }
        }
        bins
    }

    /// Surfaces along a ray, nearest first: (t, triangle, barycentrics).
    fn hits(&self, candidates: &[u32], o: DVec3, d: DVec3) -> Vec<(f64, usize, [f64; 3])> {
        let mut out: Vec<(f64, usize, [f64; 3])> = candidates
            .iter()
            .filter_map(|&k| {
                let tri = &self.tris[k as usize];
                let (t, b) = intersect(o, d, &tri.p)?;
                let back = d.dot((tri.p[1] - tri.p[0]).cross(tri.p[2] - tri.p[0])) > 0.0;
                if back
                    && self.cull_single_sided_back_faces
                    && !self.mats[tri.material].double_sided
                {
                    return None;
                }
                Some((t, k as usize, b))
            })
            .collect();
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }

    /// The alpha of material `m` on triangle `tri` over the probes `b`, as an interval
    /// (factor × texture × COLOR_0, glTF 2.0 "Alpha Coverage").
    fn alpha_range(
        &self,
        m: &Mat,
        tri: &Tri,
        b: &[[f64; 3]],
        lod_slack: f64,
    ) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (m.base.w, m.base.w);
        let vc: Vec<f64> = b.iter().map(|&b| tri.color_at(b).w).collect();
        lo *= vc.iter().cloned().fold(f64::INFINITY, f64::min);
        hi *= vc.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        if let Some(t) = &m.base_tex {
            let uvs: Vec<DVec2> = b.iter().map(|&b| tri.uv_at(t.set, b)).collect();
            let (a, z) = footprint(t, &uvs, lod_slack)?.channel(3, false);
            lo *= a;
            hi *= z;
        }
        Some((lo, hi))
    }

    /// Whether triangle `k`'s image overlaps pixel (x, y) (separating axes: the square's two,
    /// the triangle's three edge normals).
    fn overlaps(&self, view: &View, k: usize, x: u32, y: u32) -> bool {
        let Some(q) = self.tris[k]
            .p
            .iter()
            .map(|&p| view.project(p))
            .collect::<Option<Vec<DVec2>>>()
        else {
            return true;
        };
        let square = [
            DVec2::new(x as f64, y as f64),
            DVec2::new(x as f64 + 1.0, y as f64),
            DVec2::new(x as f64, y as f64 + 1.0),
            DVec2::new(x as f64 + 1.0, y as f64 + 1.0),
        ];
        let mut axes = vec![DVec2::X, DVec2::Y];
        for i in 0..3 {
            axes.push((q[(i + 1) % 3] - q[i]).perp());
        }
        axes.iter().all(|&a| {
            let span = |pts: &[DVec2]| {
                pts.iter()
                    .map(|p| p.dot(a))
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                        (l.min(v), h.max(v))
                    })
            };
            let (t, s) = (span(&q), span(&square));
            t.0 <= s.1 + 1e-9 && s.0 <= t.1 + 1e-9
        })
    }

    /// Whether triangle `a` lies wholly farther from the view than triangle `b`.
    fn behind(&self, view: &View, a: usize, b: usize) -> bool {
        let depth = |k: usize| self.tris[k].p.map(|p| (p - view.pos).dot(view.forward));
        let (da, db) = (depth(a), depth(b));
        da.iter().cloned().fold(f64::INFINITY, f64::min)
            > db.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
    }

    /// The surfaces along each probe ray of pixel (x, y), nearest first.
    #[allow(clippy::type_complexity)]
    fn probe_hits(
        &self,
        view: &View,
        candidates: &[u32],
        x: u32,
        y: u32,
    ) -> Vec<Vec<(f64, usize, [f64; 3])>> {
        PROBES
            .iter()
            .flat_map(|&oy| PROBES.iter().map(move |&ox| (ox, oy)))
            .map(|(ox, oy)| {
                let (o, d) = view.ray(x as f64 + ox, y as f64 + oy);
                self.hits(candidates, o, d)
            })
            .collect()
    }

    /// The probes' hit lists of pixel (x, y) and the surface all of them show, if they agree:
    /// Some((Some((triangle, barycentrics per probe)), lists)) for a surface, Some((None, …))
    /// where every probe leaves the scene, None where the pixel is open (probes on different
    /// surfaces, a MASK cutoff inside the footprint, a BLEND surface in front).
    ///
    /// The probes include the pixel's corners, so a convex triangle that all of them meet
    /// covers the pixel; any other triangle whose image overlaps the pixel must lie wholly
    /// behind the surface shown (or the pixel is open).
    #[allow(clippy::type_complexity)]
    fn surface(
        &self,
        view: &View,
        candidates: &[u32],
        x: u32,
        y: u32,
    ) -> Option<Option<(usize, Vec<[f64; 3]>)>> {
        let lists = self.probe_hits(view, candidates, x, y);
        let mut layers: Vec<usize> = Vec::new();
        let clean = |layers: &[usize], shown: Option<usize>| {
            candidates.iter().all(|&c| {
                let c = c as usize;
                layers.contains(&c)
                    || !self.overlaps(view, c, x, y)
                    || shown.is_some_and(|s| self.behind(view, c, s))
            })
        };
        let mut layer = 0;
        loop {
            let here: Vec<Option<&(f64, usize, [f64; 3])>> =
                lists.iter().map(|l| l.get(layer)).collect();
            if here.iter().all(|h| h.is_none()) {
                return clean(&layers, None).then_some(None);
            }
            let first = here[0]?;
            if here.iter().any(|h| h.map(|h| h.1) != Some(first.1)) {
                return None;
            }
            let tri = &self.tris[first.1];
            let m = &self.mats[tri.material];
            let b: Vec<[f64; 3]> = here.iter().map(|h| h.unwrap().2).collect();
            layers.push(first.1);
            let shown = |b| clean(&layers, Some(first.1)).then_some(Some((first.1, b)));
            match m.alpha {
                AlphaMode::Opaque => return shown(b),
                AlphaMode::Blend => return None,
                AlphaMode::Mask(cutoff) => {
                    let (lo, hi) = self.alpha_range(m, tri, &b, view.lod_slack())?;
                    if lo >= cutoff + 1e-6 {
                        return shown(b);
                    }
                    if hi >= cutoff - 1e-6 {
                        return None;
                    }
                    layer += 1;
                }
            }
        }
    }

    fn pixel(
        &self,
        view: &View,
        candidates: &[u32],
        x: u32,
        y: u32,
        q: Quantity,
    ) -> Option<PixelExpectation> {
        let Some((k, b)) = self.surface(view, candidates, x, y)? else {
            return Some(PixelExpectation {
                iv: [[0.0; 2]; 3],
                tri: None,
            });
        };
        let tri = &self.tris[k];
        let m = &self.mats[tri.material];
        let range = |f: &dyn Fn([f64; 3]) -> f64| {
            b.iter()
                .map(|&b| f(b))
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
                    (l.min(v), h.max(v))
                })
        };
        let uvs = |t: &TexRef| -> Vec<DVec2> { b.iter().map(|&b| tri.uv_at(t.set, b)).collect() };
        let mut iv = [[0.0; 2]; 3];
        match q {
            Quantity::BaseColor | Quantity::Emission => {
                let (factor, tex) = if q == Quantity::BaseColor {
                    (m.base.truncate(), &m.base_tex)
                } else {
                    (m.emissive, &m.emissive_tex)
                };
                let fp = match tex {
                    Some(t) => Some(footprint(t, &uvs(t), view.lod_slack())?),
                    None => None,
                };
                for (c, out) in iv.iter_mut().enumerate() {
                    let (tl, th) = fp.as_ref().map_or((1.0, 1.0), |f| f.channel(c, true));
                    let (vl, vh) = if q == Quantity::BaseColor {
                        range(&|b| tri.color_at(b)[c])
                    } else {
                        (1.0, 1.0)
                    };
                    *out = [factor[c] * tl * vl, factor[c] * th * vh];
                }
            }
            Quantity::Normal => {
                // The tangent-space vector from the middle of the footprint's texel range; any
                // texel of the footprint lies within `d` of it, and normalising moves a vector
                // of length ≥ r by at most 2·d/r.
                let (mid, d) = match &m.normal_tex {
                    Some(t) => {
                        let fp = footprint(t, &uvs(t), view.lod_slack())?;
                        let s = m.normal_scale;
                        let ch = |c: usize| fp.channel(c, false);
                        let axis = |c: usize, scale: f64| {
                            let (l, h) = ch(c);
                            ((l + h - 1.0) * scale, (h - l) * scale)
                        };
                        let (x, dx) = axis(0, s);
                        let (y, dy) = axis(1, s);
                        let (z, dz) = axis(2, 1.0);
                        (DVec3::new(x, y, z), DVec3::new(dx, dy, dz).length())
                    }
                    None => (DVec3::Z, 0.0),
                };
                let r = mid.length() - d;
                if r < 0.5 {
                    return None;
                }
                let slack = 2.0 * d / r;
                let normals: Vec<DVec3> = b.iter().map(|&b| tri.shading_normal(b, mid)).collect();
                for (c, out) in iv.iter_mut().enumerate() {
                    let (lo, hi) = normals
                        .iter()
                        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), n| {
                            (l.min(n[c]), h.max(n[c]))
                        });
                    *out = [lo - slack, hi + slack];
                }
            }
        }
        Some(PixelExpectation { iv, tri: Some(k) })
    }

    fn expect(&self, view: &View, q: Quantity) -> Expected {
        let bins = self.bins(view);
        let px = (0..view.h)
            .flat_map(|y| (0..view.w).map(move |x| (x, y)))
            .map(|(x, y)| self.pixel(view, &bins[(y * view.w + x) as usize], x, y, q))
            .collect();
        Expected {
            w: view.w,
            h: view.h,
            px,
        }
    }
}

struct Expected {
    w: u32,
    h: u32,
    px: Vec<Option<PixelExpectation>>,
}

impl Expected {
    fn at(&self, x: u32, y: u32) -> Option<PixelExpectation> {
        self.px[(y * self.w + x) as usize]
    }
}

/// The outcome of comparing a film with an oracle's expectation.
#[derive(Default)]
struct Outcome {
    compared: usize,
    tight: usize,
    failures: Vec<String>,
}

impl Outcome {
    fn assert_passed(&self, what: &str) {
        println!(
            "{what}: {} pixels compared, {} of them pinned to 2e-3",
            self.compared, self.tight
        );
        assert!(
            self.failures.is_empty(),
            "{what}: {} of {} pixels outside what the specification allows, e.g.:\n{}",
            self.failures.len(),
            self.compared,
            self.failures
                .iter()
                .take(12)
                .cloned()
                .collect::<Vec<_>>()
                .join("\n")
        );
    }
}

fn mean(film: &Film, x: u32, y: u32) -> [f64; 3] {
    film.mean_f64((y * film.width + x) as usize)
}

/// Every pixel for which the oracle has an expectation (and `keep` holds) must lie in its
/// interval, within the float tolerance.
fn compare(exp: &Expected, film: &Film, keep: impl Fn(u32, u32) -> bool) -> Outcome {
    assert_eq!((exp.w, exp.h), (film.width, film.height));
    let mut out = Outcome::default();
    for y in 0..exp.h {
        for x in 0..exp.w {
            let Some(e) = exp.at(x, y) else { continue };
            if !keep(x, y) {
                continue;
            }
            out.compared += 1;
            out.tight += e.tight() as usize;
            let got = mean(film, x, y);
            let bad = (0..3).any(|c| {
                let tol = FLOAT_TOL * (1.0 + got[c].abs());
                !(got[c] >= e.iv[c][0] - tol && got[c] <= e.iv[c][1] + tol)
            });
            if bad {
                out.failures.push(format!(
                    "  pixel ({x}, {y}): got [{:.5}, {:.5}, {:.5}], allowed {:?} (triangle {:?})",
                    got[0],
                    got[1],
                    got[2],
                    e.iv.map(|c| [(c[0] * 1e5).round() / 1e5, (c[1] * 1e5).round() / 1e5]),
                    e.tri
                ));
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Rendering.

fn samples_dir() -> Option<PathBuf> {
    crate::common::gltf_samples()
}

/// Renders `path` on the CPU and (where there is one) on the GPU with independent seeds,
/// through `camera` if given (else the file's first camera); returns (device, film) pairs.
fn renders(
    path: &Path,
    camera: Option<Camera>,
    size: (u32, u32),
    spp: u32,
    aov: u32,
) -> Vec<(&'static str, Film)> {
    renders_without(path, &[], camera, size, spp, aov)
}

/// [`renders`] of the scene without the triangles of the materials named in `drop`.
fn renders_without(
    path: &Path,
    drop: &[&str],
    camera: Option<Camera>,
    (width, height): (u32, u32),
    spp: u32,
    aov: u32,
) -> Vec<(&'static str, Film)> {
    let mut scene = Scene::load(path).unwrap_or_else(|e| panic!("{}: {e:#}", path.display()));
    if let Some(camera) = camera {
        scene.camera = camera;
    }
    let materials = scene.materials.clone();
    scene
        .triangles
        .retain(|t| !drop.contains(&materials[t.material as usize].name.as_str()));
    let prepared = PreparedScene::new(&scene);
    let settings = |seed| RenderSettings {
        width,
        height,
        spp,
        max_depth: 0,
        seed,
        aov,
        ..RenderSettings::default()
    };
    let cpu = render_cpu(&prepared, &settings(2));
    assert_eq!(cpu.film.dropped, 0, "CPU dropped NaN/Inf samples");
    let mut out = vec![("CPU", cpu.film)];
    if let Some(gpu) = render_gpu(&prepared, &settings(1), None) {
        assert_eq!(gpu.film.dropped, 0, "GPU dropped NaN/Inf samples");
        out.push(("GPU", gpu.film));
    }
    out
}

// ---------------------------------------------------------------------------------------------
// 1. Exact lookups on a synthetic scene.

/// Side of a pixel in the synthetic scene's world units.
const PIXEL: f64 = 1.0 / 16.0;
/// The synthetic texture: 8 × 4 texels.
const TW: i64 = 8;
const TH: i64 = 4;
const EMISSIVE_FACTOR: [f64; 3] = [1.0, 0.75, 0.5];

struct Case {
    name: &'static str,
    /// Film rectangle: top-left pixel and size.
    at: (u32, u32),
    size: (u32, u32),
    /// TEXCOORD_0 and TEXCOORD_1 at the top-left and bottom-right corners (affine between).
    uv: [[DVec2; 2]; 2],
    wrap: [u32; 2],
    linear: bool,
    /// textureInfo.texCoord and the KHR_texture_transform object, if any.
    tex_coord: usize,
    transform: Option<Value>,
}

impl Case {
    fn uv_at(&self, set: usize, x: f64, y: f64) -> DVec2 {
        let [a, b] = self.uv[set];
        let fx = (x - self.at.0 as f64) / self.size.0 as f64;
        let fy = (y - self.at.1 as f64) / self.size.1 as f64;
        DVec2::new(a.x + fx * (b.x - a.x), a.y + fy * (b.y - a.y))
    }

    /// The set read and the transform applied, as the specification says.
    fn lookup(&self) -> (usize, [f64; 4], [f64; 2]) {
        match &self.transform {
            None => (self.tex_coord, [1.0, 0.0, 0.0, 1.0], [0.0, 0.0]),
            Some(t) => {
                let pair = |key: &str, d: [f64; 2]| {
                    t.get(key).map_or(d, |v| {
                        let v = f64s(v);
                        [v[0], v[1]]
                    })
                };
                let (m, o) = texture_transform(
                    pair("offset", [0.0, 0.0]),
                    t["rotation"].as_f64().unwrap_or(0.0),
                    pair("scale", [1.0, 1.0]),
                );
                let set = t["texCoord"]
                    .as_u64()
                    .map_or(self.tex_coord, |s| s as usize);
                (set, m, o)
            }
        }
    }

    /// Texel-space bounds of pixel (x, y): the transformed images of its corners (axis-aligned
    /// in every case here, rotations being multiples of 90°).
    fn texel_box(&self, x: u32, y: u32) -> ([f64; 2], [f64; 2]) {
        let (set, m, o) = self.lookup();
        let mut lo = DVec2::INFINITY;
        let mut hi = DVec2::NEG_INFINITY;
        for (dx, dy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
            let uv = self.uv_at(set, x as f64 + dx, y as f64 + dy);
            let q = apply_transform(&m, &o, uv) * DVec2::new(TW as f64, TH as f64);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        // Snap the exact multiples of 1/texel that rounding blurred (the layouts are exact).
        let snap = |v: f64| {
            let r = (v * 64.0).round() / 64.0;
            if (v - r).abs() < 1e-9 {
                r
            } else {
                v
            }
        };
        ([snap(lo.x), snap(hi.x)], [snap(lo.y), snap(hi.y)])
    }

    /// The pixel's expected emitted radiance: the mean over its box of the reconstructed,
    /// decoded texture (nearest: the texel's value, since every box here lies in one texel),
    /// times the emissive factor.
    fn expected(&self, texels: &[[u8; 3]], x: u32, y: u32) -> [f64; 3] {
        let (bx, by) = self.texel_box(x, y);
        let wx = axis_weights(bx[0], bx[1], self.linear);
        let wy = axis_weights(by[0], by[1], self.linear);
        if !self.linear {
            assert!(
                wx.len() == 1 && wy.len() == 1,
                "{}: pixel ({x}, {y}) straddles texels {bx:?} × {by:?}: the layout is wrong",
                self.name
            );
        }
        let mut out = [0.0; 3];
        for &(j, wj) in &wy {
            let jj = wrap_index(j, TH, self.wrap[1]);
            for &(i, wi) in &wx {
                let ii = wrap_index(i, TW, self.wrap[0]);
                let t = texels[(jj * TW + ii) as usize];
                for c in 0..3 {
                    out[c] += wi * wj * srgb_decode(t[c] as f64 / 255.0);
                }
            }
        }
        for c in 0..3 {
            out[c] *= EMISSIVE_FACTOR[c];
        }
        out
    }

    fn contains(&self, x: u32, y: u32) -> bool {
        (self.at.0..self.at.0 + self.size.0).contains(&x)
            && (self.at.1..self.at.1 + self.size.1).contains(&y)
    }
}

fn uv(u: f64, v: f64) -> DVec2 {
    DVec2::new(u, v)
}

/// The cases, laid out in rows; returns them and the film size. Every NEAREST case maps
/// texel edges onto pixel edges (k pixels per texel, k an integer): A–D two per texel, E–I as
/// noted. The LINEAR cases have 7 pixels per texel (J: pixel centres on texel centres; K: on
/// the half-way points between them) or 4 (L, M).
fn synthetic_cases() -> (Vec<Case>, (u32, u32)) {
    let nearest =
        |name, size, uv0: [DVec2; 2], uv1: Option<[DVec2; 2]>, wrap, tex_coord, transform| Case {
            name,
            at: (0, 0),
            size,
            uv: [uv0, uv1.unwrap_or(uv0)],
            wrap,
            linear: false,
            tex_coord,
            transform,
        };
    let linear = |name, size, uv0: [DVec2; 2], wrap| Case {
        name,
        at: (0, 0),
        size,
        uv: [uv0, uv0],
        wrap,
        linear: true,
        tex_coord: 0,
        transform: None,
    };
    let mut cases = vec![
        // u over 2 periods in 32 pixels, v over 2 in 16: 2 pixels per texel.
        nearest(
            "A REPEAT, uv in [-1, 1]",
            (32, 16),
            [uv(-1.0, -1.0), uv(1.0, 1.0)],
            None,
            [REPEAT, REPEAT],
            0,
            None,
        ),
        nearest(
            "B MIRRORED_REPEAT, uv in [-1, 1]",
            (32, 16),
            [uv(-1.0, -1.0), uv(1.0, 1.0)],
            None,
            [MIRRORED_REPEAT, MIRRORED_REPEAT],
            0,
            None,
        ),
        nearest(
            "C CLAMP_TO_EDGE, uv in [-0.5, 1.5]",
            (32, 16),
            [uv(-0.5, -0.5), uv(1.5, 1.5)],
            None,
            [CLAMP_TO_EDGE, CLAMP_TO_EDGE],
            0,
            None,
        ),
        nearest(
            "D CLAMP_TO_EDGE s, MIRRORED_REPEAT t",
            (32, 16),
            [uv(-0.5, -1.0), uv(1.5, 1.0)],
            None,
            [CLAMP_TO_EDGE, MIRRORED_REPEAT],
            0,
            None,
        ),
        // Offset of 2 texels each way.
        nearest(
            "E offset (0.25, -0.5)",
            (32, 16),
            [uv(0.0, 0.0), uv(2.0, 2.0)],
            None,
            [REPEAT, REPEAT],
            0,
            Some(json!({"offset": [0.25, -0.5]})),
        ),
        // u' = v, v' = −u: across, 8 rows in 32 pixels; down, 16 columns in 16 pixels.
        nearest(
            "F rotation π/2",
            (32, 16),
            [uv(0.0, 0.0), uv(2.0, 2.0)],
            None,
            [REPEAT, REPEAT],
            0,
            Some(json!({"rotation": std::f64::consts::FRAC_PI_2})),
        ),
        // u' = −v/2 + 1/2, v' = 2u + 1/4: across, 16 rows in 32 pixels; down, 8 columns in 16.
        // Scaling after rotating (S·R), or rotating the other way, reads other texels.
        nearest(
            "G offset, rotation -π/2, scale (2, 0.5)",
            (32, 16),
            [uv(0.0, 0.0), uv(2.0, 2.0)],
            None,
            [REPEAT, REPEAT],
            0,
            Some(
                json!({"offset": [0.5, 0.25], "rotation": -std::f64::consts::FRAC_PI_2, "scale": [2.0, 0.5]}),
            ),
        ),
        // TEXCOORD_1 through u' = 1 − u: 4 pixels per texel; TEXCOORD_0 would read other texels.
        nearest(
            "H texCoord override 0 → 1, scale (-1, 1), offset (1, 0)",
            (32, 16),
            [uv(0.0, 0.0), uv(2.0, 2.0)],
            Some([uv(0.0, 0.0), uv(1.0, 1.0)]),
            [REPEAT, REPEAT],
            0,
            Some(json!({"texCoord": 1, "scale": [-1.0, 1.0], "offset": [1.0, 0.0]})),
        ),
        nearest(
            "I texCoord 1",
            (32, 16),
            [uv(0.0, 0.0), uv(2.0, 2.0)],
            Some([uv(0.0, 0.0), uv(1.0, 1.0)]),
            [REPEAT, REPEAT],
            1,
            None,
        ),
        linear(
            "J LINEAR, pixel centres on texel centres",
            (56, 28),
            [uv(0.0, 0.0), uv(1.0, 1.0)],
            [REPEAT, REPEAT],
        ),
        linear(
            "K LINEAR, pixel centres half-way between texel centres",
            (56, 28),
            [
                uv(0.5 / 8.0, 0.5 / 4.0),
                uv(1.0 + 0.5 / 8.0, 1.0 + 0.5 / 4.0),
            ],
            [REPEAT, REPEAT],
        ),
        linear(
            "L LINEAR CLAMP_TO_EDGE, uv in [-0.25, 1.25]",
            (48, 24),
            [uv(-0.25, -0.25), uv(1.25, 1.25)],
            [CLAMP_TO_EDGE, CLAMP_TO_EDGE],
        ),
        linear(
            "M LINEAR MIRRORED_REPEAT, uv in [-0.5, 1]",
            (48, 24),
            [uv(-0.5, -0.5), uv(1.0, 1.0)],
            [MIRRORED_REPEAT, MIRRORED_REPEAT],
        ),
    ];
    // Rows of at most 140 pixels with 2-pixel gaps around every quad.
    let (mut x, mut y, mut row_h, mut width) = (2u32, 2u32, 0u32, 0u32);
    for c in &mut cases {
        if x + c.size.0 + 2 > 140 {
            x = 2;
            y += row_h + 2;
            row_h = 0;
        }
        c.at = (x, y);
        x += c.size.0 + 2;
        row_h = row_h.max(c.size.1);
        width = width.max(x);
    }
    (cases, (width, y + row_h + 2))
}

/// 8 × 4 random sRGB texels (a fixed linear congruential sequence).
fn synthetic_texels() -> Vec<[u8; 3]> {
    let mut state = 0x2545_f491_u32;
    (0..TW * TH)
        .map(|_| {
            [(); 3].map(|_| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (state >> 24) as u8
            })
        })
        .collect()
}

/// Writes the synthetic scene: one emissive quad per case, facing +Z, pixel (x, y) of the film
/// at world (x, −y)·PIXEL, seen by an orthographic camera that frames the film exactly.
fn write_synthetic(path: &Path, cases: &[Case], (w, h): (u32, u32), texels: &[[u8; 3]]) {
    let mut png = Vec::new();
    let raw: Vec<u8> = texels.iter().flatten().copied().collect();
    image::RgbImage::from_raw(TW as u32, TH as u32, raw)
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    use base64::Engine;
    let b64 = |bytes: &[u8]| base64::engine::general_purpose::STANDARD.encode(bytes);

    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut materials, mut textures, mut samplers) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let mut nodes = vec![json!({
        "camera": 0,
        "translation": [w as f64 * PIXEL / 2.0, -(h as f64) * PIXEL / 2.0, 10.0]
    })];
    let mut push = |bin: &mut Vec<u8>,
                    data: Vec<u8>,
                    count: usize,
                    kind: &str,
                    ctype: u32,
                    minmax: Option<(Vec<f64>, Vec<f64>)>| {
        let offset = bin.len();
        bin.extend_from_slice(&data);
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len()}));
        let mut a = json!({"bufferView": views.len() - 1, "componentType": ctype, "count": count, "type": kind});
        if let Some((min, max)) = minmax {
            a["min"] = json!(min);
            a["max"] = json!(max);
        }
        accessors.push(a);
        accessors.len() - 1
    };
    let f32s = |v: &[f64]| {
        v.iter()
            .flat_map(|x| (*x as f32).to_le_bytes())
            .collect::<Vec<u8>>()
    };
    for (k, c) in cases.iter().enumerate() {
        let (x0, y0) = (c.at.0 as f64 * PIXEL, -(c.at.1 as f64) * PIXEL);
        let (x1, y1) = (
            (c.at.0 + c.size.0) as f64 * PIXEL,
            -((c.at.1 + c.size.1) as f64) * PIXEL,
        );
        // Corners: top-left, bottom-left, bottom-right, top-right (counter-clockwise from +Z).
        let corners = [
            (x0, y0, 0.0, 0.0),
            (x0, y1, 0.0, 1.0),
            (x1, y1, 1.0, 1.0),
            (x1, y0, 1.0, 0.0),
        ];
        let pos: Vec<f64> = corners
            .iter()
            .flat_map(|&(x, y, _, _)| [x, y, 0.0])
            .collect();
        let set = |s: usize| -> Vec<f64> {
            let [a, b] = c.uv[s];
            corners
                .iter()
                .flat_map(|&(_, _, fx, fy)| [a.x + fx * (b.x - a.x), a.y + fy * (b.y - a.y)])
                .collect()
        };
        let p = push(
            &mut bin,
            f32s(&pos),
            4,
            "VEC3",
            5126,
            Some((vec![x0, y1, 0.0], vec![x1, y0, 0.0])),
        );
        let t0 = push(&mut bin, f32s(&set(0)), 4, "VEC2", 5126, None);
        let t1 = push(&mut bin, f32s(&set(1)), 4, "VEC2", 5126, None);
        let idx: Vec<u8> = [0u16, 1, 2, 0, 2, 3]
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let i = push(&mut bin, idx, 6, "SCALAR", 5123, None);
        meshes.push(json!({"primitives": [{
            "attributes": {"POSITION": p, "TEXCOORD_0": t0, "TEXCOORD_1": t1},
            "indices": i, "material": k}]}));
        let filter = if c.linear { LINEAR } else { NEAREST };
        samplers.push(json!({"magFilter": filter, "minFilter": filter, "wrapS": c.wrap[0], "wrapT": c.wrap[1]}));
        textures.push(json!({"source": 0, "sampler": k}));
        let mut info = json!({"index": k, "texCoord": c.tex_coord});
        if let Some(t) = &c.transform {
            info["extensions"] = json!({"KHR_texture_transform": t});
        }
        materials.push(json!({
            "name": c.name,
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0]},
            "emissiveFactor": EMISSIVE_FACTOR,
            "emissiveTexture": info
        }));
        nodes.push(json!({"mesh": k}));
    }
    let gltf = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "cameras": [{"type": "orthographic", "orthographic": {
            "xmag": w as f64 * PIXEL / 2.0, "ymag": h as f64 * PIXEL / 2.0,
            "znear": 0.01, "zfar": 100.0}}],
        "meshes": meshes,
        "materials": materials,
        "textures": textures,
        "samplers": samplers,
        "images": [{"uri": format!("data:image/png;base64,{}", b64(&png))}],
        "buffers": [{"byteLength": bin.len(), "uri": format!("data:application/octet-stream;base64,{}", b64(&bin))}],
        "bufferViews": views,
        "accessors": accessors,
    });
    std::fs::write(path, serde_json::to_vec_pretty(&gltf).unwrap()).unwrap();
}

/// Checks a film of the synthetic scene: every pixel of every case against its expected
/// value; NEAREST cases exactly (float tolerance: their samples all read one texel), LINEAR
/// cases within Student-t multiples of the pixel's standard error (its samples differ) at
/// family-wise level ALPHA over all pixels and channels; gaps black.
fn check_synthetic(film: &Film, cases: &[Case], texels: &[[u8; 3]], what: &str) {
    let comparisons: usize = cases
        .iter()
        .map(|c| (c.size.0 * c.size.1 * 3) as usize)
        .sum();
    let spp = film.pixels[0].count as f64;
    let t = student_t_quantile(ALPHA / comparisons as f64, spp - 1.0);
    let mut failures = Vec::new();
    let mut compared = 0;
    for y in 0..film.height {
        for x in 0..film.width {
            let p = (y * film.width + x) as usize;
            let got = film.mean_f64(p);
            let var = film.variance_of_mean_f64(p);
            let case = cases.iter().find(|c| c.contains(x, y));
            let expected = case.map_or([0.0; 3], |c| c.expected(texels, x, y));
            compared += 1;
            for c in 0..3 {
                let tol = FLOAT_TOL * (1.0 + expected[c]) + t * var[c].max(0.0).sqrt();
                if (got[c] - expected[c]).abs() > tol {
                    failures.push(format!(
                        "  {} pixel ({x}, {y}) channel {c}: got {:.5}, expected {:.5} (± {:.1e})",
                        case.map_or("gap", |c| c.name),
                        got[c],
                        expected[c],
                        tol
                    ));
                }
            }
        }
    }
    println!("{what}: {compared} pixels");
    assert!(
        failures.is_empty(),
        "{what}: {} channels differ from the specification, e.g.:\n{}",
        failures.len(),
        failures
            .iter()
            .take(16)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}

#[test]
fn synthetic_texture_lookups_are_exact_on_both_devices() {
    let (cases, size) = synthetic_cases();
    let texels = synthetic_texels();
    let path = temp("texture_spec", "synthetic.gltf");
    write_synthetic(&path, &cases, size, &texels);
    // Radiance of emitters seen directly (max depth 0) and the emission AOV, through the
    // file's own orthographic camera.
    for (aov, label) in [
        (AOV_RADIANCE, "radiance, max depth 0"),
        (AOV_EMISSION, "--aov emission"),
    ] {
        for (device, film) in renders(&path, None, size, 64, aov) {
            check_synthetic(&film, &cases, &texels, &format!("{device} {label}"));
        }
    }
}

/// The command line: `wavetrace render --device cpu --aov emission` (its layer equal to the
/// library's emission AOV) and `--max-depth 0`, written to EXR and read back.
#[test]
fn synthetic_texture_lookups_through_the_command_line() {
    let (cases, (w, h)) = synthetic_cases();
    let texels = synthetic_texels();
    let path = temp("texture_spec", "synthetic-cli.gltf");
    write_synthetic(&path, &cases, (w, h), &texels);
    // The emissive textures are the file's only emission, so without --env none the studio
    // would light it (`PreparedScene::has_own_lights`) and fill the gaps between the quads.
    for (k, extra) in [
        &["--aov", "emission"][..],
        &["--max-depth", "0", "--env", "none"][..],
    ]
    .iter()
    .enumerate()
    {
        let out = temp("texture_spec", &format!("cli-{k}.exr"));
        let (ws, hs) = (w.to_string(), h.to_string());
        let mut args = vec![
            "render",
            path.to_str().unwrap(),
            "--device",
            "cpu",
            "--spp",
            "16",
            "--width",
            &ws,
            "--height",
            &hs,
            "-o",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = wavetrace(&args);
        assert!(
            o.status.success(),
            "wavetrace {args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        // `--aov emission` is a layer beside the image, of the means only: it must hold the
        // library's emission AOV of the same samples (checked against the specification by
        // the test above), bit for bit.
        if k == 0 {
            let layer = wavetrace::image_io::read_exr_layer(&out, "emission").unwrap();
            let prepared = PreparedScene::new(&Scene::load(&path).unwrap());
            let settings = RenderSettings {
                width: w,
                height: h,
                spp: 16,
                aov: AOV_EMISSION,
                ..RenderSettings::default()
            };
            let film = render_cpu(&prepared, &settings).film;
            for (p, m) in layer.mean.iter().enumerate() {
                assert_eq!(
                    m.map(f32::to_bits),
                    film.mean(p).to_array().map(f32::to_bits),
                    "CLI --aov emission, pixel {p}"
                );
            }
            continue;
        }
        let film = wavetrace::image_io::read_film(&out).unwrap();
        check_synthetic(&film, &cases, &texels, &format!("CLI {extra:?}"));
    }
}

// ---------------------------------------------------------------------------------------------
// 2. The Khronos sample models.

/// Colour classes of the sample models' flat colours (linear): a channel is on above 0.25
/// (192 in sRGB is 0.527) and off below 0.05.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Hue {
    Red,
    Green,
    Blue,
    Yellow,
    Cyan,
    Other,
}

fn hue(c: [f64; 3]) -> Hue {
    let on = c.map(|v| v > 0.25);
    let off = c.map(|v| v < 0.05);
    match (on, off) {
        ([true, _, _], [false, true, true]) => Hue::Red,
        ([_, true, _], [true, false, true]) => Hue::Green,
        ([_, _, true], [true, true, false]) => Hue::Blue,
        ([true, true, _], [false, false, true]) => Hue::Yellow,
        ([_, true, true], [true, false, false]) => Hue::Cyan,
        _ => Hue::Other,
    }
}

/// Film-space bounding box (x0, y0, x1, y1) of the triangles for which `pick` holds.
fn film_rect(oracle: &Oracle, view: &View, pick: impl Fn(&Tri) -> bool) -> [f64; 4] {
    let mut r = [
        f64::INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NEG_INFINITY,
    ];
    for tri in oracle.tris.iter().filter(|t| pick(t)) {
        for &p in &tri.p {
            let q = view.project(p).unwrap();
            r = [r[0].min(q.x), r[1].min(q.y), r[2].max(q.x), r[3].max(q.y)];
        }
    }
    assert!(r[0].is_finite(), "no triangle picked");
    r
}

/// Pixels lying wholly inside `rect` shrunk by `inset` pixels.
fn inside(rect: [f64; 4], inset: f64) -> impl Fn(u32, u32) -> bool {
    move |x, y| {
        let (x, y) = (x as f64, y as f64);
        x >= rect[0] + inset
            && x + 1.0 <= rect[2] - inset
            && y >= rect[1] + inset
            && y + 1.0 <= rect[3] - inset
    }
}

/// The rows of TextureSettingsTest, by material: the "Test" square of each (left column,
/// world x < 1) must look like its "Sample pass" square: a green check, never one of the red
/// crosses the texture also holds, which only a wrong wrap mode (MIRRORED_REPEAT or
/// CLAMP_TO_EDGE on S or T), a back face shown despite doubleSided false, or one hidden despite
/// doubleSided true brings into view. Pixels outside the named rows' squares are not compared.
fn texture_settings_rows(rows: &[&str]) {
    texture_settings_rows_with(rows, 50);
}

/// `texture_settings_rows`, requiring `min_green` pixels pinned to the check's green per square.
fn texture_settings_rows_with(rows: &[&str], min_green: usize) {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("TextureSettingsTest.glb");
    let (_, oracle) = Oracle::open(&path);
    // The Test column (world x in [0.005, 0.905]), magnified: 150 pixels per unit, about one
    // pixel per texel.
    let view = View::ortho_rect([-0.02, 0.93], [-5.2, 3.02], 1.0, 150.0);
    let exp = oracle.expect(&view, Quantity::BaseColor);
    let squares: Vec<(&str, [f64; 4])> = rows
        .iter()
        .map(|&row| {
            let m = oracle.material(row);
            let rect = film_rect(&oracle, &view, |t| {
                t.material == m && t.p.iter().all(|p| p.x < 1.0)
            });
            (row, rect)
        })
        .collect();
    for (device, film) in renders(
        &path,
        Some(view.camera()),
        (view.w, view.h),
        2,
        AOV_BASE_COLOR,
    ) {
        for &(row, rect) in &squares {
            let what = format!("TextureSettingsTest {device} {row}");
            let keep = inside(rect, 1.0);
            let outcome = compare(&exp, &film, &keep);
            let pixels = || {
                (0..view.h)
                    .flat_map(|y| (0..view.w).map(move |x| (x, y)))
                    .filter(|&(x, y)| keep(x, y))
            };
            let green = pixels()
                .filter(|&(x, y)| {
                    exp.at(x, y)
                        .is_some_and(|e| e.tight() && hue(e.mid()) == Hue::Green)
                })
                .count();
            let red: Vec<(u32, u32)> = pixels()
                .filter(|&(x, y)| hue(mean(&film, x, y)) == Hue::Red)
                .collect();
            outcome.assert_passed(&what);
            println!("{what}: {green} pixels pinned to the check's green");
            assert!(
                green >= min_green,
                "{what}: only {green} pixels pinned to the check's green"
            );
            assert!(
                red.is_empty(),
                "{what}: {} pixels of the Test square show a red cross, e.g. {:?}",
                red.len(),
                &red[..red.len().min(5)]
            );
        }
    }
}

/// TextureSettingsTest: the wrap modes on S and T, and a double-sided material's back face.
#[test]
fn sample_texture_settings_test() {
    texture_settings_rows(&[
        "TextureMirrorMaterialT",
        "TextureMirrorMaterialS",
        "TextureRepeatMaterialT",
        "TextureRepeatMaterialS",
        "TextureClampMaterialT",
        "TextureClampMaterialS",
        "DoubleSidedMaterial",
    ]);
}

/// TextureSettingsTest's single-sided row: a back-facing quad with doubleSided false hides a
/// green check behind a red cross unless back faces are culled, as glTF 2.0 says they
/// are ("When this value is false, back-face culling is enabled").
/// The culled quad's own square holds no check, so no green pixels are required there; the
/// render must match the culling oracle and show no red.
#[test]
fn sample_texture_settings_single_sided_back_face_is_culled() {
    texture_settings_rows_with(&["SingleSidedMaterial"], 0);
}

/// The rendered arrow of an arrow panel of TextureTransformTest: its axis (principal axis of
/// the dark pixels, pointing to the head, the wider end) and its tip; returns the marker the
/// ray from the tip along the axis meets first.
fn arrow_target(doc: &Doc, view: &View, film: &Film, panel: &str) -> Result<String, String> {
    let (node, world) = doc.node_by_name(panel);
    let centre = world.transform_point3(DVec3::ZERO);
    let markers: Vec<(String, DVec3, f64)> = doc.json["nodes"][node]["children"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| {
            let name = doc.json["nodes"][usize_of(c)]["name"]
                .as_str()
                .unwrap()
                .to_owned();
            let (_, m) = doc.node_by_name(&name);
            let half = 0.5 * m.transform_vector3(DVec3::X).length();
            (name, m.transform_point3(DVec3::ZERO), half)
        })
        .collect();
    let pixel = 2.0 * view.half / view.h as f64;
    let mut dark = Vec::new();
    for y in 0..view.h {
        for x in 0..view.w {
            let p = view.world(x as f64 + 0.5, y as f64 + 0.5);
            let d = p - centre;
            let in_marker = markers
                .iter()
                .any(|(_, c, h)| (p.x - c.x).abs() < h + pixel && (p.y - c.y).abs() < h + pixel);
            if d.x.abs() < 0.5 - pixel
                && d.y.abs() < 0.5 - pixel
                && !in_marker
                && mean(film, x, y).iter().all(|&v| v < 0.02)
            {
                dark.push(DVec2::new(p.x, p.y));
            }
        }
    }
    if dark.len() < 50 {
        return Err(format!(
            "only {} dark (arrow) pixels in the panel",
            dark.len()
        ));
    }
    let m = dark.iter().fold(DVec2::ZERO, |a, &b| a + b) / dark.len() as f64;
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for p in &dark {
        let d = *p - m;
        sxx += d.x * d.x;
        sxy += d.x * d.y;
        syy += d.y * d.y;
    }
    let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
    let mut axis = DVec2::new(angle.cos(), angle.sin());
    let along: Vec<f64> = dark.iter().map(|p| (*p - m).dot(axis)).collect();
    let (lo, hi) = along
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &s| {
            (l.min(s), h.max(s))
        });
    let spread = |from: f64, to: f64| {
        let across: Vec<f64> = dark
            .iter()
            .zip(&along)
            .filter(|(_, &s)| s >= from && s <= to)
            .map(|(p, _)| (*p - m).perp_dot(axis))
            .collect();
        let mean = across.iter().sum::<f64>() / across.len().max(1) as f64;
        across.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / across.len().max(1) as f64
    };
    let quarter = 0.25 * (hi - lo);
    let tip_along = if spread(hi - quarter, hi) >= spread(lo, lo + quarter) {
        hi
    } else {
        axis = -axis;
        -lo
    };
    let tip = m + axis * tip_along;
    // First marker square met by the ray tip + s·axis, s ≥ 0 (slab test).
    let mut first: Option<(f64, &str)> = None;
    for (name, c, h) in &markers {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for k in 0..2 {
            let (o, d, lo, hi) = (tip[k], axis[k], c[k] - h, c[k] + h);
            if d.abs() < 1e-12 {
                if o < lo || o > hi {
                    t0 = f64::INFINITY;
                }
            } else {
                let (a, b) = ((lo - o) / d, (hi - o) / d);
                t0 = t0.max(a.min(b));
                t1 = t1.min(a.max(b));
            }
        }
        if t0 <= t1 && first.is_none_or(|(t, _)| t0 < t) {
            first = Some((t0, name));
        }
    }
    first
        .map(|(_, n)| n.to_owned())
        .ok_or_else(|| format!("the arrow (tip {tip:.3}, direction {axis:.3}) points at no marker"))
}

/// TextureTransformTest: every pixel against KHR_texture_transform; the offset panels show
/// the quadrant of their offset (green U, blue V, cyan UV), never the yellow "not applied"
/// one; the arrows of the rotation, scale and combined panels point at their green "Correct"
/// marker, not at the yellow (not applied) or red (rotated the wrong way) one.
#[test]
fn sample_texture_transform_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("TextureTransformTest/TextureTransformTest.gltf");
    let (doc, oracle) = Oracle::open(&path);
    let view = View::ortho_rect([-1.7, 1.7], [-1.1, 1.1], 1.0, 100.0);
    let exp = oracle.expect(&view, Quantity::BaseColor);
    for (device, film) in renders(
        &path,
        Some(view.camera()),
        (view.w, view.h),
        2,
        AOV_BASE_COLOR,
    ) {
        compare(&exp, &film, |_, _| true).assert_passed(&format!("TextureTransformTest {device}"));
        for (panel, expected) in [
            ("Offset U", Hue::Green),
            ("Offset V", Hue::Blue),
            ("Offset UV", Hue::Cyan),
        ] {
            let (_, world) = doc.node_by_name(panel);
            let c = world.transform_point3(DVec3::ZERO);
            let a = view.project(c + DVec3::new(-0.5, 0.5, 0.0)).unwrap();
            let b = view.project(c + DVec3::new(0.5, -0.5, 0.0)).unwrap();
            let keep = inside([a.x, a.y, b.x, b.y], 2.0);
            let (mut total, mut right, mut yellow) = (0, 0, 0);
            for y in 0..view.h {
                for x in 0..view.w {
                    if keep(x, y) {
                        total += 1;
                        match hue(mean(&film, x, y)) {
                            h if h == expected => right += 1,
                            Hue::Yellow => yellow += 1,
                            _ => {}
                        }
                    }
                }
            }
            println!("{device} {panel}: {right} of {total} pixels {expected:?}, {yellow} yellow");
            assert!(
                2 * right > total,
                "{device} {panel}: {right} of {total} pixels {expected:?}"
            );
            assert_eq!(yellow, 0, "{device} {panel}: the offset was not applied");
        }
        for panel in ["Rotation", "Scale", "All"] {
            let target = arrow_target(&doc, &view, &film, panel)
                .unwrap_or_else(|e| panic!("{device} {panel}: {e}"));
            println!("{device} {panel}: the arrow points at {target:?}");
            assert!(
                target.ends_with("Correct"),
                "{device} {panel}: the arrow points at {target:?}, not at the Correct marker"
            );
        }
    }
}

/// TextureCoordinateTest: texture coordinates put the image's top-left texel at (0, 0). The
/// quads face −Z (their NORMALs) in front of a grey back plane at z = 0.053, so the model is
/// seen from −Z; each quad then shows its own corner of the image — checkerboard, label and
/// cross — the right way round, which the oracle pins at the checkers' and crosses' texels.
#[test]
fn sample_texture_coordinate_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("TextureCoordinateTest.gltf");
    let (_, oracle) = Oracle::open(&path);
    let whole = View::ortho_rect([-1.25, 1.25], [-1.25, 1.25], -1.0, 100.0);
    let exp = oracle.expect(&whole, Quantity::BaseColor);
    for (device, film) in renders(
        &path,
        Some(whole.camera()),
        (whole.w, whole.h),
        2,
        AOV_BASE_COLOR,
    ) {
        compare(&exp, &film, |_, _| true).assert_passed(&format!("TextureCoordinateTest {device}"));
    }
    // Each quad's outer corner (its image corner: checkerboard and label), magnified so that a
    // pixel spans less than a texel.
    for (q, corner) in [
        ("TopLeftMaterial", [0.95, 0.95]),
        ("TopRightMaterial", [-0.95, 0.95]),
        ("BottomLeftMaterial", [0.95, -0.95]),
        ("BottomRightMaterial", [-0.95, -0.95]),
    ] {
        let view = View::ortho_rect(
            [corner[0] - 0.275, corner[0] + 0.275],
            [corner[1] - 0.275, corner[1] + 0.275],
            -1.0,
            250.0,
        );
        let exp = oracle.expect(&view, Quantity::BaseColor);
        for (device, film) in renders(
            &path,
            Some(view.camera()),
            (view.w, view.h),
            2,
            AOV_BASE_COLOR,
        ) {
            compare(&exp, &film, |_, _| true)
                .assert_passed(&format!("TextureCoordinateTest {device} {q}"));
            let m = oracle.material(q);
            let dark = exp
                .px
                .iter()
                .flatten()
                .filter(|e| {
                    e.tri.is_some_and(|t| oracle.tris[t].material == m)
                        && e.tight()
                        && e.iv.iter().all(|c| c[1] < 0.05)
                })
                .count();
            println!("{device} {q}: {dark} pixels pinned to black (checkers, label)");
            assert!(
                dark >= 200,
                "{device} {q}: only {dark} pixels pinned to black"
            );
        }
    }
}

/// The view of a perspective camera node of the file (glTF 2.0 "Cameras": it looks down its −Z
/// with +Y up), on a film of the camera's aspect ratio.
fn file_camera_view(doc: &Doc, w: u32, h: u32) -> View {
    let (node, world) = doc
        .world_nodes()
        .into_iter()
        .find(|(n, _)| doc.json["nodes"][*n].get("camera").is_some())
        .expect("a camera node");
    let camera = &doc.json["cameras"][usize_of(&doc.json["nodes"][node]["camera"])];
    let p = &camera["perspective"];
    let aspect = p["aspectRatio"].as_f64().unwrap();
    assert!(
        (aspect - w as f64 / h as f64).abs() < 1e-3,
        "film {w}×{h} for aspect {aspect}"
    );
    let forward = world.transform_vector3(DVec3::NEG_Z).normalize();
    let right = forward.cross(world.transform_vector3(DVec3::Y)).normalize();
    View {
        pos: world.transform_point3(DVec3::ZERO),
        forward,
        right,
        up: right.cross(forward),
        ortho: false,
        half: (0.5 * p["yfov"].as_f64().unwrap()).tan(),
        w,
        h,
    }
}

/// MultiUVTest, through the file's perspective camera: the base colour reads TEXCOORD_0 (a
/// pastel colour per face), the emissive texture TEXCOORD_1 (texCoord 1: the glTF logo). Read
/// through TEXCOORD_0, the emissive texture would show the white words "Multiple UVs not
/// supported"; no pixel may be white, and the logo's green must show.
#[test]
fn sample_multi_uv_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("MultiUVTest.glb");
    let (doc, oracle) = Oracle::open(&path);
    let view = file_camera_view(&doc, 256, 144);
    for (q, aov, name) in [
        (Quantity::BaseColor, AOV_BASE_COLOR, "base colour"),
        (Quantity::Emission, AOV_EMISSION, "emission"),
    ] {
        let exp = oracle.expect(&view, q);
        for (device, film) in renders(&path, None, (view.w, view.h), 2, aov) {
            let what = format!("MultiUVTest {device} {name}");
            let outcome = compare(&exp, &film, |_, _| true);
            outcome.assert_passed(&what);
            let on_cube = |x, y| exp.at(x, y).is_some_and(|e| e.tri.is_some());
            let pixels = (0..view.h).flat_map(|y| (0..view.w).map(move |x| (x, y)));
            if q == Quantity::BaseColor {
                assert!(
                    outcome.tight >= 1000,
                    "{what}: only {} pixels pinned",
                    outcome.tight
                );
            } else {
                let white = pixels
                    .clone()
                    .filter(|&(x, y)| mean(&film, x, y).iter().all(|&v| v > 0.5))
                    .count();
                // The logo's green, (135, 197, 64) in sRGB: (0.24, 0.56, 0.05) linear.
                let logo = |c: [f64; 3]| c[1] > 0.05 && c[1] > 1.5 * c[0] && c[1] > 2.0 * c[2];
                let green = pixels
                    .filter(|&(x, y)| on_cube(x, y) && logo(mean(&film, x, y)))
                    .count();
                println!("{what}: {white} white pixels, {green} green");
                assert_eq!(
                    white, 0,
                    "{what}: white pixels: the emissive texture read TEXCOORD_0"
                );
                assert!(green >= 20, "{what}: only {green} green (logo) pixels");
            }
        }
    }
}

/// VertexColorTest: base colour = factor × texture × COLOR_0. The upper row's quads carry
/// one-hot vertex colours (red, green, blue) over a texture of cyan, magenta, yellow and white
/// crosses: a channel the vertex colour zeroes must be 0 everywhere on the quad, and the quad
/// must show its colour's check, as the "Sample pass" quads below (white vertex colours over
/// coloured checks) do.
#[test]
fn sample_vertex_color_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("VertexColorTest.glb");
    let (_, oracle) = Oracle::open(&path);
    let whole = View::ortho_rect([-1.05, 1.05], [-1.05, 1.05], 1.0, 120.0);
    let exp = oracle.expect(&whole, Quantity::BaseColor);
    for (device, film) in renders(
        &path,
        Some(whole.camera()),
        (whole.w, whole.h),
        2,
        AOV_BASE_COLOR,
    ) {
        compare(&exp, &film, |_, _| true).assert_passed(&format!("VertexColorTest {device}"));
    }
    // The upper row, magnified (the crosses' strokes are a few texels wide).
    let view = View::ortho_rect([-0.85, 0.9], [0.05, 0.65], 1.0, 240.0);
    let exp = oracle.expect(&view, Quantity::BaseColor);
    for (device, film) in renders(
        &path,
        Some(view.camera()),
        (view.w, view.h),
        2,
        AOV_BASE_COLOR,
    ) {
        compare(&exp, &film, |_, _| true)
            .assert_passed(&format!("VertexColorTest {device}, upper row"));
        for (channel, colour) in [(0, Hue::Red), (1, Hue::Green), (2, Hue::Blue)] {
            let one_hot = |t: &Tri| {
                t.color
                    .iter()
                    .all(|c| (0..3).all(|k| c[k] == if k == channel { 1.0 } else { 0.0 }))
            };
            let keep = inside(film_rect(&oracle, &view, one_hot), 1.0);
            let (mut pinned, mut stray) = (0, Vec::new());
            for y in 0..view.h {
                for x in 0..view.w {
                    if !keep(x, y) {
                        continue;
                    }
                    let got = mean(&film, x, y);
                    if (0..3).any(|k| k != channel && got[k] > FLOAT_TOL) {
                        stray.push((x, y, got));
                    }
                    pinned += exp
                        .at(x, y)
                        .is_some_and(|e| e.tight() && hue(e.mid()) == colour)
                        as usize;
                }
            }
            println!(
                "VertexColorTest {device} {colour:?} quad: {pinned} pixels pinned to its check"
            );
            assert!(
                stray.is_empty(),
                "VertexColorTest {device} {colour:?} quad: a channel COLOR_0 zeroes is not 0, e.g. {:?}",
                &stray[..stray.len().min(4)]
            );
            assert!(
                pinned >= 50,
                "VertexColorTest {device} {colour:?} quad: only {pinned} pixels of its check"
            );
        }
    }
}

/// AlphaBlendModeTest, MASK and OPAQUE: where the footprint's alpha (factor × texture × COLOR_0)
/// lies wholly at or above alphaCutoff (0.25, 0.5 by default, 0.75) the panel is there, where
/// wholly below it is not and the "bed" behind it shows; OPAQUE ignores alpha.
#[test]
fn sample_alpha_mask_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("AlphaBlendModeTest.glb");
    let (_, oracle) = Oracle::open(&path);
    let view = View::ortho_rect([-3.65, 3.65], [0.15, 2.0], 1.0, 64.0);
    let exp = oracle.expect(&view, Quantity::BaseColor);
    for (device, film) in renders(
        &path,
        Some(view.camera()),
        (view.w, view.h),
        4,
        AOV_BASE_COLOR,
    ) {
        compare(&exp, &film, |_, _| true).assert_passed(&format!("AlphaBlendModeTest {device}"));
        for panel in [
            "MatCutoff25",
            "MatCutoffDefault",
            "MatCutoff75",
            "MatOpaque",
        ] {
            let m = oracle.material(panel);
            // The panel's own quad (the arrows and decals share MatOpaque).
            let quad = |t: &Tri| t.material == m && (t.p[0] - t.p[1]).length() > 1.0;
            let keep = inside(film_rect(&oracle, &view, quad), 1.0);
            let bed = oracle.material("MatBed");
            let (mut there, mut gone) = (0, 0);
            for y in 0..view.h {
                for x in 0..view.w {
                    if let (true, Some(e)) = (keep(x, y), exp.at(x, y)) {
                        match e.tri {
                            Some(t) if quad(&oracle.tris[t]) => there += 1,
                            Some(t) if oracle.tris[t].material == bed => gone += 1,
                            _ => {}
                        }
                    }
                }
            }
            println!(
                "AlphaBlendModeTest {device} {panel}: {there} pixels present, {gone} cut away"
            );
            assert!(
                there >= 200,
                "{device} {panel}: {there} pixels decided present"
            );
            if panel == "MatOpaque" {
                assert_eq!(gone, 0, "{device} {panel}: OPAQUE ignores alpha");
            } else {
                assert!(
                    gone >= 200,
                    "{device} {panel}: {gone} pixels decided cut away"
                );
            }
        }
    }
}

/// AlphaBlendModeTest, BLEND: each sample sees the panel with probability alpha (stochastic
/// transparency). With the "bed" behind the panels taken out of the scene, a sample that does
/// not see the panel sees nothing, so with the texture-coordinate AOV a pixel's mean U is
/// (present samples / n) × U on the panel. Over bands of alpha, the number of present samples
/// must be binomial: within z·σ of n·Σ alpha, z Bonferroni-corrected over bands and devices.
#[test]
fn sample_alpha_blend_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("AlphaBlendModeTest.glb");
    let (_, mut oracle) = Oracle::open(&path);
    let bed = oracle.material("MatBed");
    oracle.tris.retain(|t| t.material != bed);
    let m = oracle.material("MatBlend");
    // A strip down the middle of the panel (world x = −1.5), 256 pixels per unit (2 texels per
    // pixel), so that a pixel's alpha is known to a few 8-bit steps.
    let view = View::ortho_rect([-1.6, -1.4], [0.15, 2.0], 1.0, 256.0);
    let bins = oracle.bins(&view);
    // Per pixel: alpha range, U range over the footprint.
    let mut pixels = Vec::new();
    for y in 0..view.h {
        for x in 0..view.w {
            let lists = oracle.probe_hits(&view, &bins[(y * view.w + x) as usize], x, y);
            let Some(&(_, k, _)) = lists[0].first() else {
                continue;
            };
            let candidates = &bins[(y * view.w + x) as usize];
            if oracle.tris[k].material != m
                || lists.iter().any(|l| l.len() != 1 || l[0].1 != k)
                || candidates
                    .iter()
                    .any(|&c| c as usize != k && oracle.overlaps(&view, c as usize, x, y))
            {
                continue;
            }
            let tri = &oracle.tris[k];
            let b: Vec<[f64; 3]> = lists.iter().map(|l| l[0].2).collect();
            let Some(alpha) = oracle.alpha_range(&oracle.mats[m], tri, &b, view.lod_slack()) else {
                continue;
            };
            // Pixels across the frame's edges (alpha from 0 to 1) say little; leave them out.
            if alpha.1 - alpha.0 > 0.05 {
                continue;
            }
            let u = b
                .iter()
                .map(|&b| tri.uv_at(0, b).x)
                .fold((f64::INFINITY, 0.0f64), |(l, h), u| (l.min(u), h.max(u)));
            pixels.push((x, y, alpha, u));
        }
    }
    const BANDS: usize = 10;
    let films = renders_without(
        &path,
        &["MatBed"],
        Some(view.camera()),
        (view.w, view.h),
        32,
        AOV_UV,
    );
    let z = normal_quantile(ALPHA / (2.0 * (BANDS * films.len()) as f64));
    for (device, film) in &films {
        // Per band: present-sample count bounds from the film, expectation bounds, variance.
        let mut bands = [[0.0f64; 5]; BANDS];
        for &(x, y, (alo, ahi), (ulo, uhi)) in &pixels {
            let n = film.pixels[(y * view.w + x) as usize].count as f64;
            let v = mean(film, x, y)[0];
            let band = ((0.5 * (alo + ahi) * BANDS as f64) as usize).min(BANDS - 1);
            let worst = if alo <= 0.5 && ahi >= 0.5 {
                0.25
            } else {
                (alo * (1.0 - alo)).max(ahi * (1.0 - ahi))
            };
            let s = &mut bands[band];
            s[0] += n * v / uhi;
            s[1] += n * v / ulo;
            s[2] += n * alo;
            s[3] += n * ahi;
            s[4] += n * worst;
        }
        for (k, [klo, khi, elo, ehi, var]) in bands.iter().enumerate() {
            let sigma = var.sqrt();
            println!(
                "AlphaBlendModeTest {device} BLEND alpha band {k}: present samples in [{klo:.1}, {khi:.1}], expected [{elo:.1}, {ehi:.1}] ± {:.1}",
                z * sigma
            );
            assert!(
                *var > 0.0 || k == 0,
                "{device} BLEND alpha band {k} has no pixels"
            );
            assert!(
                *khi >= elo - z * sigma && *klo <= ehi + z * sigma,
                "{device} BLEND alpha band {k}: {klo:.1}..{khi:.1} present samples, expected {elo:.1}..{ehi:.1} ± {:.1}",
                z * sigma
            );
        }
    }
}

/// Bumps of NormalTangentMirrorTest's normal map: connected regions whose X or Y deviates by
/// more than 40/255 from the flat (128, 128), as (centre uv, radius in uv).
fn normal_map_bumps(t: &TexRef) -> Vec<(DVec2, f64)> {
    let img = &t.img;
    let steep = |i: i64, j: i64| {
        let p = img.at(i, j);
        (p[0] as i32 - 128).abs() > 40 || (p[1] as i32 - 128).abs() > 40
    };
    let mut seen = vec![false; (img.w * img.h) as usize];
    let mut out = Vec::new();
    for j0 in 0..img.h {
        for i0 in 0..img.w {
            if seen[(j0 * img.w + i0) as usize] || !steep(i0, j0) {
                continue;
            }
            let (mut lo, mut hi, mut count) = ((i0, j0), (i0, j0), 0);
            let mut stack = vec![(i0, j0)];
            seen[(j0 * img.w + i0) as usize] = true;
            while let Some((i, j)) = stack.pop() {
                count += 1;
                lo = (lo.0.min(i), lo.1.min(j));
                hi = (hi.0.max(i), hi.1.max(j));
                for (a, b) in [(i + 1, j), (i - 1, j), (i, j + 1), (i, j - 1)] {
                    if a >= 0
                        && b >= 0
                        && a < img.w
                        && b < img.h
                        && !seen[(b * img.w + a) as usize]
                        && steep(a, b)
                    {
                        seen[(b * img.w + a) as usize] = true;
                        stack.push((a, b));
                    }
                }
            }
            if count >= 2000 {
                let centre = DVec2::new(
                    0.5 * (lo.0 + hi.0 + 1) as f64 / img.w as f64,
                    0.5 * (lo.1 + hi.1 + 1) as f64 / img.h as f64,
                );
                let radius =
                    0.5 * ((hi.0 - lo.0 + 1) as f64).max((hi.1 - lo.1 + 1) as f64) / img.w as f64;
                out.push((centre, radius));
            }
        }
    }
    out
}

/// Whether the rendered normals (raw, in [−1, 1]) around world point `c` bulge outward like a dome
/// of radius `r` facing +Z: n·x > 0 on the right half and < 0 on the left, n·y > 0 on the
/// upper half and < 0 on the lower (means over the pixels of each half, the middle fifth of
/// the radius left out).
fn bulges_outward(view: &View, film: &Film, c: DVec3, r: f64) -> Result<(), String> {
    let mut sums = [(0.0, 0usize); 4]; // right, left, up, down
    for y in 0..view.h {
        for x in 0..view.w {
            let d = view.world(x as f64 + 0.5, y as f64 + 0.5) - c;
            if d.truncate().length() > 0.8 * r {
                continue;
            }
            let n = mean(film, x, y);
            for (k, (side, component)) in [(d.x, n[0]), (-d.x, n[0]), (d.y, n[1]), (-d.y, n[1])]
                .iter()
                .enumerate()
            {
                if *side > 0.1 * r {
                    sums[k].0 += component;
                    sums[k].1 += 1;
                }
            }
        }
    }
    let means = sums.map(|(s, n)| s / n.max(1) as f64);
    if sums.iter().any(|s| s.1 < 20) {
        return Err(format!("too few pixels: {sums:?}"));
    }
    if means[0] > 0.0 && means[1] < 0.0 && means[2] > 0.0 && means[3] < 0.0 {
        Ok(())
    } else {
        Err(format!(
            "mean normal x right {:.3}, left {:.3}; y up {:.3}, down {:.3}",
            means[0], means[1], means[2], means[3]
        ))
    }
}

/// NormalTangentMirrorTest: normal maps on UVs mirrored in U, in V and in both, with supplied
/// TANGENTs (w = ±1), next to bumps of real geometry. Every normal-mapped bump, wherever the
/// mesh's UVs place (and mirror) it, must bulge outward as the geometric ones do, which needs
/// the bitangent w·(N × T); and every pixel's normal lies where the oracle allows.
#[test]
fn sample_normal_tangent_mirror_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("NormalTangentMirrorTest.glb");
    let (_, oracle) = Oracle::open(&path);
    let view = View::ortho_rect([-1.45, 1.45], [-1.22, 1.07], 1.0, 100.0);
    let exp = oracle.expect(&view, Quantity::Normal);
    // Normal-mapped bumps: every place a texture bump lands on the mesh, front-facing.
    let normal_tex = oracle.mats[0].normal_tex.clone().expect("a normal map");
    let mut bumps: Vec<(DVec3, f64)> = Vec::new();
    for (uv, radius) in normal_map_bumps(&normal_tex) {
        for tri in &oracle.tris {
            let [a, b, c] = tri.uv[0];
            let det = (b - a).perp_dot(c - a);
            if det.abs() < 1e-12 {
                continue;
            }
            let (u, v) = (
                (uv - a).perp_dot(c - a) / det,
                (b - a).perp_dot(uv - a) / det,
            );
            if u < 0.0 || v < 0.0 || u + v > 1.0 || tri.geometric_normal().z < 0.9 {
                continue;
            }
            let p = tri.p[0] * (1.0 - u - v) + tri.p[1] * u + tri.p[2] * v;
            // World length of one unit of u and of v on this triangle.
            let du = ((tri.p[1] - tri.p[0]) * (c - a).y - (tri.p[2] - tri.p[0]) * (b - a).y) / det;
            let dv = ((tri.p[2] - tri.p[0]) * (b - a).x - (tri.p[1] - tri.p[0]) * (c - a).x) / det;
            let r = radius * 0.5 * (du.length() + dv.length());
            if bumps.iter().all(|(q, _)| (*q - p).length() > 1e-3) {
                bumps.push((p, r));
            }
        }
    }
    // Geometric bumps: clusters of vertices raised above the panel (z > 0.04).
    let mut domes: Vec<(DVec3, f64, usize)> = Vec::new();
    for p in oracle.tris.iter().flat_map(|t| t.p).filter(|p| p.z > 0.04) {
        match domes
            .iter_mut()
            .find(|(c, _, _)| (c.truncate() - p.truncate()).length() < 0.2)
        {
            Some(d) => {
                d.0 = (d.0 * d.2 as f64 + p) / (d.2 + 1) as f64;
                d.2 += 1;
            }
            None => domes.push((p, 0.0, 1)),
        }
    }
    for d in &mut domes {
        d.1 = oracle
            .tris
            .iter()
            .flat_map(|t| t.p)
            .filter(|p| p.z > 1e-3 && (p.truncate() - d.0.truncate()).length() < 0.25)
            .map(|p| (p.truncate() - d.0.truncate()).length())
            .fold(0.0, f64::max);
    }
    println!(
        "{} normal-mapped bumps, {} geometric",
        bumps.len(),
        domes.len()
    );
    assert!(
        bumps.len() >= 12,
        "found {} normal-mapped bumps",
        bumps.len()
    );
    assert!(domes.len() >= 3, "found {} geometric bumps", domes.len());
    for (device, film) in renders(&path, Some(view.camera()), (view.w, view.h), 4, AOV_NORMAL) {
        compare(&exp, &film, |_, _| true)
            .assert_passed(&format!("NormalTangentMirrorTest {device}"));
        for (c, r, _) in &domes {
            bulges_outward(&view, &film, *c, *r).unwrap_or_else(|e| {
                panic!("{device}: the geometric bump at {c:.3} (the reference): {e}")
            });
        }
        for (c, r) in &bumps {
            bulges_outward(&view, &film, *c, *r).unwrap_or_else(|e| {
                panic!("{device}: the normal-mapped bump at {c:.3} does not bulge outward: {e}")
            });
        }
    }
}

/// OrientationTest: node rotations (quaternions and matrices) place each arrow so that it
/// points at its target. Seen along each axis from both sides, every pixel's base colour must
/// be that of the surface the file's transforms put there; pixels pinned on every arrow (its
/// colour, or what lies around it) fix its direction to within a pixel.
#[test]
fn sample_orientation_test() {
    let Some(dir) = samples_dir() else { return };
    let path = dir.join("OrientationTest.gltf");
    let (_, oracle) = Oracle::open(&path);
    let views = [
        (DVec3::NEG_Z, DVec3::Y),
        (DVec3::Z, DVec3::Y),
        (DVec3::NEG_X, DVec3::Y),
        (DVec3::X, DVec3::Y),
        (DVec3::NEG_Y, DVec3::NEG_Z),
        (DVec3::Y, DVec3::Z),
    ];
    let arrows = ["MatX1", "MatX2", "MatY1", "MatY2", "MatZ1", "MatZ2"];
    let mut pinned: HashMap<&str, usize> = HashMap::new();
    for (forward, up) in views {
        let view = View::ortho(DVec3::ZERO, forward, up, 6.5, 96, 96);
        let exp = oracle.expect(&view, Quantity::BaseColor);
        for (device, film) in renders(
            &path,
            Some(view.camera()),
            (view.w, view.h),
            2,
            AOV_BASE_COLOR,
        ) {
            compare(&exp, &film, |_, _| true)
                .assert_passed(&format!("OrientationTest {device} looking along {forward}"));
        }
        for e in exp.px.iter().flatten().filter(|e| e.tight()) {
            if let Some(t) = e.tri {
                let name = oracle.mats[oracle.tris[t].material].name.as_str();
                if let Some(a) = arrows.iter().find(|a| **a == name) {
                    *pinned.entry(a).or_default() += 1;
                }
            }
        }
    }
    for a in arrows {
        let n = pinned.get(a).copied().unwrap_or(0);
        println!("OrientationTest {a}: {n} pixels pinned");
        assert!(n >= 30, "OrientationTest {a}: only {n} pixels pinned");
    }
}
