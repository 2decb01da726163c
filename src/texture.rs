//! Texture sampling: the twin of `shaders/inc/texture.glsl` (same names, same maths).
//!
//! Textures are mip chains of RGBA8 texels in one buffer (`GpuTexture` says where), sampled by
//! hand rather than by the GPU's samplers, so that the CPU reference reads exactly the texels
//! the GPU reads and one storage binding holds any number of textures. glTF's sampler settings
//! are honoured as Vulkan defines them: wrap modes REPEAT, MIRRORED_REPEAT and CLAMP_TO_EDGE on
//! integer texel coordinates, nearest or bilinear filtering, mip levels chosen nearest or
//! linearly (Vulkan spec, "Texel Filtering" and "Wrapping Operation"). sRGB colour textures
//! are decoded texel by texel before filtering, as sRGB image formats are.
//!
//! The level of detail comes from ray cones (Akenine-Möller et al. 2021, "Improved Shader and
//! Texture Level of Detail Using Ray Cones", JCGT 10(1); Ray Tracing Gems ch. 20, eq. 34):
//! λ = log2(W / |n·d|) + ½·log2(t_a / p_a), with W the cone's width at the hit, t_a the
//! triangle's texel-space area and p_a its world-space area. `surface` computes the part that
//! does not depend on the texture (`lod_base`); [`texture_lod`] adds ½·log2(w·h·|det M|) for
//! the texture's size and its KHR_texture_transform M.

use crate::layout::{
    GpuTexture, GpuTextureRef, FILTER_LINEAR, MIN_LINEAR, MIN_LINEAR_MIPMAP_LINEAR,
    MIN_LINEAR_MIPMAP_NEAREST, MIN_NEAREST, MIN_NEAREST_MIPMAP_NEAREST, WRAP_CLAMP_TO_EDGE,
    WRAP_MIRRORED_REPEAT,
};
use glam::{Vec2, Vec4};

/// The texture data of a prepared scene, as the GPU's bindings hold it.
#[derive(Clone, Copy)]
pub struct TextureData<'a> {
    pub textures: &'a [GpuTexture],
    pub refs: &'a [GpuTextureRef],
    pub texels: &'a [u32],
}

/// The sRGB transfer function's inverse (IEC 61966-2-1), per channel.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB transfer function (IEC 61966-2-1), per channel.
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.0031308 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// [`srgb_to_linear`] of each 8-bit value k / 255: the same floats as calling it, without three
/// `powf` per texel (they were 13 % of a CPU render of DamagedHelmet, and most of its mip chains'
/// build).
static SRGB_TO_LINEAR_8BIT: std::sync::LazyLock<[f32; 256]> =
    std::sync::LazyLock::new(|| std::array::from_fn(|k| srgb_to_linear(k as f32 / 255.0)));

/// An RGBA8 texel (R in the low byte, GLSL's unpackUnorm4x8) as floats in [0, 1], its RGB
/// decoded from sRGB if `srgb`.
pub fn unpack_texel(word: u32, srgb: bool) -> Vec4 {
    let byte = |k: u32| ((word >> (8 * k)) & 0xff) as usize;
    let c = |k: u32| byte(k) as f32 / 255.0;
    if srgb {
        let decode = &*SRGB_TO_LINEAR_8BIT;
        Vec4::new(decode[byte(0)], decode[byte(1)], decode[byte(2)], c(3))
    } else {
        Vec4::new(c(0), c(1), c(2), c(3))
    }
}

/// A texture coordinate reduced to the range its wrap mode repeats over ([0, 1] for REPEAT,
/// [0, 2] for MIRRORED_REPEAT, [−1, 2] for CLAMP_TO_EDGE), so that texel indices stay small;
/// a non-finite coordinate reads as 0.
pub fn reduce_coordinate(u: f32, mode: u32) -> f32 {
    if !u.is_finite() {
        return 0.0;
    }
    match mode {
        WRAP_CLAMP_TO_EDGE => u.clamp(-1.0, 2.0),
        WRAP_MIRRORED_REPEAT => u - 2.0 * (0.5 * u).floor(),
        _ => u - u.floor(),
    }
}

/// Texel index `i` (in [−n, 3n) after [`reduce_coordinate`]) wrapped into [0, n) (Vulkan spec,
/// "Wrapping Operation").
pub fn wrap_texel(i: i32, n: i32, mode: u32) -> i32 {
    // The remainders (i + n) mod n and (i + 2n) mod 2n by conditional subtractions, exact for
    // i in [-n, 3n): a division is tens of cycles here and a `div` per lane on lavapipe.
    let less = |r: i32, m: i32| if r >= m { r - m } else { r };
    match mode {
        WRAP_CLAMP_TO_EDGE => i.clamp(0, n - 1),
        WRAP_MIRRORED_REPEAT => {
            let j = less(less(i + 2 * n, 2 * n), 2 * n);
            if j >= n {
                2 * n - 1 - j
            } else {
                j
            }
        }
        _ => less(less(less(i + n, n), n), n),
    }
}

/// Width, height and first texel of mip level `level`.
pub fn texture_level(t: &GpuTexture, level: u32) -> (u32, u32, u32) {
    let (mut w, mut h, mut offset) = (t.width, t.height, t.texel_offset);
    for _ in 0..level {
        offset += w * h;
        w = (w / 2).max(1);
        h = (h / 2).max(1);
    }
    (w, h, offset)
}

fn fetch(data: &TextureData, t: &GpuTexture, offset: u32, w: u32, x: i32, y: i32) -> Vec4 {
    let word = data.texels[(offset + y as u32 * w + x as u32) as usize];
    unpack_texel(word, t.srgb != 0)
}

/// One mip level, nearest or bilinear.
pub fn texture_sample_level(
    data: &TextureData,
    t: &GpuTexture,
    level: u32,
    uv: Vec2,
    linear: bool,
) -> Vec4 {
    let (w, h, offset) = texture_level(t, level);
    let (wi, hi) = (w as i32, h as i32);
    let x = reduce_coordinate(uv.x, t.wrap_s) * w as f32;
    let y = reduce_coordinate(uv.y, t.wrap_t) * h as f32;
    if !linear {
        let i = wrap_texel(x.floor() as i32, wi, t.wrap_s);
        let j = wrap_texel(y.floor() as i32, hi, t.wrap_t);
        return fetch(data, t, offset, w, i, j);
    }
    let (x, y) = (x - 0.5, y - 0.5);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let i0 = wrap_texel(x0 as i32, wi, t.wrap_s);
    let i1 = wrap_texel(x0 as i32 + 1, wi, t.wrap_s);
    let j0 = wrap_texel(y0 as i32, hi, t.wrap_t);
    let j1 = wrap_texel(y0 as i32 + 1, hi, t.wrap_t);
    let top = fetch(data, t, offset, w, i0, j0).lerp(fetch(data, t, offset, w, i1, j0), fx);
    let bottom = fetch(data, t, offset, w, i0, j1).lerp(fetch(data, t, offset, w, i1, j1), fx);
    top.lerp(bottom, fy)
}

/// λ of a texture: `lod_base` (from the surface and the cone) + ½·log2(w·h·|det M|).
pub fn texture_lod(t: &GpuTexture, r: &GpuTextureRef, lod_base: f32) -> f32 {
    let det = (r.transform[0] * r.transform[3] - r.transform[1] * r.transform[2]).abs();
    lod_base + 0.5 * (t.width as f32 * t.height as f32 * det).max(1e-30).log2()
}

/// The texture at `uv` with level of detail `lod`: the magnification filter where lod ≤ 0
/// (or is NaN), else the minification filter and its mip mode.
pub fn texture_sample_lod(data: &TextureData, t: &GpuTexture, uv: Vec2, lod: f32) -> Vec4 {
    let mag = t.filters & 15;
    let min = (t.filters >> 4) & 15;
    if lod.is_nan() || lod <= 0.0 {
        return texture_sample_level(data, t, 0, uv, mag == FILTER_LINEAR);
    }
    if min == MIN_NEAREST || min == MIN_LINEAR {
        return texture_sample_level(data, t, 0, uv, min == MIN_LINEAR);
    }
    let linear = min == MIN_LINEAR_MIPMAP_NEAREST || min == MIN_LINEAR_MIPMAP_LINEAR;
    let top = (t.levels - 1) as f32;
    if min == MIN_NEAREST_MIPMAP_NEAREST || min == MIN_LINEAR_MIPMAP_NEAREST {
        let level = (lod + 0.5).floor().min(top);
        return texture_sample_level(data, t, level as u32, uv, linear);
    }
    let l0 = lod.floor().min(top);
    let l1 = (l0 + 1.0).min(top);
    let f = (lod - l0).clamp(0.0, 1.0);
    let a = texture_sample_level(data, t, l0 as u32, uv, linear);
    let b = texture_sample_level(data, t, l1 as u32, uv, linear);
    a.lerp(b, f)
}

/// The texture coordinate a reference reads: its set, through its KHR_texture_transform.
pub fn texture_ref_uv(r: &GpuTextureRef, uv: [Vec2; 2]) -> Vec2 {
    let st = if r.texcoord == 1 { uv[1] } else { uv[0] };
    Vec2::new(
        r.transform[0] * st.x + r.transform[1] * st.y + r.offset[0],
        r.transform[2] * st.x + r.transform[3] * st.y + r.offset[1],
    )
}

/// A material's texture `index` (a `GpuTextureRef`) at the texture coordinates `uv` of both
/// sets, with `lod_base` for each set (see the module's documentation).
pub fn sample_texture_ref(
    data: &TextureData,
    index: u32,
    uv: [Vec2; 2],
    lod_base: [f32; 2],
) -> Vec4 {
    let r = &data.refs[index as usize];
    let t = &data.textures[r.texture as usize];
    let base = if r.texcoord == 1 {
        lod_base[1]
    } else {
        lod_base[0]
    };
    texture_sample_lod(data, t, texture_ref_uv(r, uv), texture_lod(t, r, base))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::{FILTER_NEAREST, WRAP_REPEAT};

    fn pack(r: u8, g: u8, b: u8, a: u8) -> u32 {
        u32::from_le_bytes([r, g, b, a])
    }

    #[test]
    fn srgb_round_trips() {
        for k in 0..=255 {
            let c = k as f32 / 255.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5, "{k}");
        }
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn wrap_modes_follow_vulkan() {
        let n = 4;
        let repeat: Vec<i32> = (-4..8).map(|i| wrap_texel(i, n, WRAP_REPEAT)).collect();
        assert_eq!(repeat, [0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3]);
        let mirror: Vec<i32> = (-4..8)
            .map(|i| wrap_texel(i, n, WRAP_MIRRORED_REPEAT))
            .collect();
        assert_eq!(mirror, [3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0]);
        let clamp: Vec<i32> = (-4..8)
            .map(|i| wrap_texel(i, n, WRAP_CLAMP_TO_EDGE))
            .collect();
        assert_eq!(clamp, [0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3]);
        // The conditional subtractions are the remainders over the whole domain, [-n, 3n).
        for n in 1..=40 {
            for i in -n..3 * n {
                assert_eq!(wrap_texel(i, n, WRAP_REPEAT), (i + n) % n, "{i} {n}");
                let j = (i + 2 * n) % (2 * n);
                let mirrored = if j >= n { 2 * n - 1 - j } else { j };
                assert_eq!(wrap_texel(i, n, WRAP_MIRRORED_REPEAT), mirrored, "{i} {n}");
            }
        }
        for u in [-3.7f32, -1.0, -1e-9, 0.0, 0.3, 1.0, 2.5, 1e7, f32::NAN] {
            for mode in [WRAP_REPEAT, WRAP_MIRRORED_REPEAT, WRAP_CLAMP_TO_EDGE] {
                let r = reduce_coordinate(u, mode);
                assert!((-1.0..=2.0).contains(&r), "{u} {mode} → {r}");
            }
        }
    }

    /// A 2×2 texture, nearest and bilinear, every wrap mode at texel centres and edges.
    #[test]
    fn texel_centres_read_exact_values() {
        let texels = vec![
            pack(255, 0, 0, 255),
            pack(0, 255, 0, 255),
            pack(0, 0, 255, 255),
            pack(255, 255, 255, 0),
        ];
        let mut t = GpuTexture {
            width: 2,
            height: 2,
            levels: 1,
            filters: FILTER_NEAREST | (MIN_NEAREST << 4),
            ..Default::default()
        };
        let data = TextureData {
            textures: &[],
            refs: &[],
            texels: &texels,
        };
        for linear in [false, true] {
            for (uv, k) in [
                ((0.25, 0.25), 0),
                ((0.75, 0.25), 1),
                ((0.25, 0.75), 2),
                ((0.75, 0.75), 3),
            ] {
                let got = texture_sample_level(&data, &t, 0, Vec2::new(uv.0, uv.1), linear);
                assert_eq!(
                    got,
                    unpack_texel(texels[k], false),
                    "{uv:?} linear {linear}"
                );
                // One period further along s and t: the same texel under REPEAT.
                let got =
                    texture_sample_level(&data, &t, 0, Vec2::new(uv.0 + 3.0, uv.1 - 2.0), linear);
                assert_eq!(got, unpack_texel(texels[k], false));
            }
        }
        // Bilinear half-way between the two top texels.
        let mid = texture_sample_level(&data, &t, 0, Vec2::new(0.5, 0.25), true);
        assert!((mid - Vec4::new(0.5, 0.5, 0.0, 1.0)).abs().max_element() < 1e-6);
        // REPEAT at u = 0 blends with the far column; CLAMP_TO_EDGE does not.
        let edge = texture_sample_level(&data, &t, 0, Vec2::new(0.0, 0.25), true);
        assert!((edge - Vec4::new(0.5, 0.5, 0.0, 1.0)).abs().max_element() < 1e-6);
        t.wrap_s = WRAP_CLAMP_TO_EDGE;
        let edge = texture_sample_level(&data, &t, 0, Vec2::new(0.0, 0.25), true);
        assert_eq!(edge, unpack_texel(texels[0], false));
        // MIRRORED_REPEAT: (1.25, ·) reads the mirror image of (0.75, ·).
        t.wrap_s = WRAP_MIRRORED_REPEAT;
        let m = texture_sample_level(&data, &t, 0, Vec2::new(1.25, 0.25), false);
        assert_eq!(m, unpack_texel(texels[1], false));
    }

    #[test]
    fn mip_levels_follow_one_another() {
        let t = GpuTexture {
            texel_offset: 7,
            width: 5,
            height: 3,
            levels: 3,
            ..Default::default()
        };
        assert_eq!(texture_level(&t, 0), (5, 3, 7));
        assert_eq!(texture_level(&t, 1), (2, 1, 22));
        assert_eq!(texture_level(&t, 2), (1, 1, 24));
    }
}
