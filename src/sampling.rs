//! Random numbers and warps: each sampler beside its pdf (with the measure named) and, where it
//! exists, its inverse. The GLSL twins in `shaders/inc/rng.glsl` and `shaders/inc/sampling.glsl`
//! carry the same names and the same arithmetic.

use glam::{UVec4, Vec2, Vec3, Vec4};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI};

/// PCG-based 4-D hash (Jarzynski & Olano, "Hash Functions for GPU Rendering", JCGT 2020, §3).
pub fn pcg4d(v: UVec4) -> UVec4 {
    // u32 arithmetic wraps, as GLSL's does (`inc/rng.glsl`).
    let mut v = v
        .wrapping_mul(UVec4::splat(1664525))
        .wrapping_add(UVec4::splat(1013904223));
    v.x = v.x.wrapping_add(v.y.wrapping_mul(v.w));
    v.y = v.y.wrapping_add(v.z.wrapping_mul(v.x));
    v.z = v.z.wrapping_add(v.x.wrapping_mul(v.y));
    v.w = v.w.wrapping_add(v.y.wrapping_mul(v.z));
    v ^= v >> 16;
    v.x = v.x.wrapping_add(v.y.wrapping_mul(v.w));
    v.y = v.y.wrapping_add(v.z.wrapping_mul(v.x));
    v.z = v.z.wrapping_add(v.x.wrapping_mul(v.y));
    v.w = v.w.wrapping_add(v.y.wrapping_mul(v.z));
    v
}

/// The top 24 bits of `x` as a float in [0, 1).
pub fn uint_to_unit_float(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Four uniform numbers in [0, 1): a pure function of (seed, pixel, sample, dimension block), so
/// the same path draws the same numbers on every device and in every split of the samples.
/// Two rounds of pcg4d: with one round, keys that differ in one component only (consecutive
/// pixels, sample 0) leave structure that a χ² test of GGX visible-normal sampling over 10⁶ keys
/// detects (p ≈ 10⁻⁴, `bsdf::tests::ggx_visible_normals_match_their_pdf`); two rounds pass it.
pub fn rng_uniform4(seed: u32, pixel: u32, sample: u32, block: u32) -> Vec4 {
    let h = pcg4d(pcg4d(UVec4::new(pixel, sample, block, seed)));
    Vec4::new(
        uint_to_unit_float(h.x),
        uint_to_unit_float(h.y),
        uint_to_unit_float(h.z),
        uint_to_unit_float(h.w),
    )
}

/// A pseudo-random permutation of [0, n) keyed by `key`: `i` ↦ its image. Kensler's
/// construction ("Correlated Multi-Jittered Sampling", Pixar TM 13-01, 2013, §3): a hash made of
/// steps that are each bijective on the low k bits (xor with a constant, multiply by an odd
/// constant, xorshift of the masked value), k the bits of n − 1, cycle-walked until the value
/// falls below n, then rotated by the key.
pub fn permute(i: u32, n: u32, key: u32) -> u32 {
    let mut w = n.wrapping_sub(1);
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    let mut i = i;
    loop {
        i ^= key;
        i = i.wrapping_mul(0x9e37_79b1);
        i ^= (i & w) >> 3;
        i ^= key >> 11;
        i = i.wrapping_mul(0x85eb_ca6b | 1);
        i ^= (i & w) >> 7;
        i = i.wrapping_mul(1 | (key >> 25));
        i = i.wrapping_mul(0xc2b2_ae35 | 1);
        i ^= (i & w) >> 2;
        i &= w;
        i ^= i >> 5;
        if i < n {
            break;
        }
    }
    (i.wrapping_add(key)) % n
}

/// The largest f32 below 1.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Stratified (N-rooks, Latin hypercube) version of a pair of uniform numbers: sample `sample`
/// of `spp` falls in column stratum π₁(sample) and row stratum π₂(sample), with π₁, π₂
/// permutations keyed by (seed, pixel, dimension), jittered inside its cell by `jitter`. Each
/// sample stays uniform on [0, 1)², so estimates stay unbiased, while the `spp` samples of a
/// pixel cover every row and every column once (lecture, "Stratified sampling": N rooks).
pub fn stratify2(
    seed: u32,
    pixel: u32,
    sample: u32,
    spp: u32,
    dimension: u32,
    jitter: Vec2,
) -> Vec2 {
    // Samples past the strata (sample ≥ spp) have none: `permute` is defined on [0, spp) only
    // (outside it its cycle walk need not end). They keep the independent pair.
    if sample >= spp {
        return jitter;
    }
    let keys = pcg4d(UVec4::new(pixel, dimension, seed, 0x5354_5241));
    let sx = permute(sample, spp, keys.x) as f32;
    let sy = permute(sample, spp, keys.y) as f32;
    let inv = 1.0 / spp as f32;
    Vec2::new(
        ((sx + jitter.x) * inv).min(ONE_MINUS_EPSILON),
        ((sy + jitter.y) * inv).min(ONE_MINUS_EPSILON),
    )
}

/// Cosine-weighted direction on the hemisphere around +Z (Malley's method: uniform disk by
/// inverting its CDF, r = √u₀, φ = 2πu₁, then projected up).
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    let z = (1.0 - u.x).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Pdf of [`sample_cosine_hemisphere`] with respect to solid angle: cos θ / π.
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * FRAC_1_PI
}

/// The `u` that [`sample_cosine_hemisphere`] maps to direction `w` (z > 0).
pub fn invert_cosine_hemisphere_sample(w: Vec3) -> Vec2 {
    let mut phi = w.y.atan2(w.x) / (2.0 * PI);
    if phi < 0.0 {
        phi += 1.0;
    }
    Vec2::new(w.x * w.x + w.y * w.y, phi)
}

/// Uniform point on a triangle as barycentric weights (b1, b2) of p1 and p2, by inverting the CDF
/// of the first barycentric (Shirley & Chiu 1997; pbrt-v3 §13.6.5): √u₀ along the height.
pub fn sample_uniform_triangle(u: Vec2) -> Vec2 {
    let su = u.x.sqrt();
    Vec2::new(u.y * su, (1.0 - u.y) * su)
}

/// Pdf of [`sample_uniform_triangle`] with respect to area: 1 / area.
pub fn uniform_triangle_pdf(area: f32) -> f32 {
    1.0 / area
}

/// The `u` that [`sample_uniform_triangle`] maps to barycentrics (b1, b2).
pub fn invert_uniform_triangle_sample(b: Vec2) -> Vec2 {
    let su = b.x + b.y;
    let v = if su > 0.0 { b.x / su } else { 0.0 };
    Vec2::new(su * su, v)
}

/// Uniform point on the unit disk by Shirley and Chiu's concentric mapping ("A Low Distortion
/// Map Between Disk and Square", JGT 1997; pbrt-v3 §13.6.2): the square [−1, 1]² is mapped ring
/// by ring onto the disk, so that strata of `u` stay compact on the disk. Used for the thin lens.
pub fn sample_concentric_disk(u: Vec2) -> Vec2 {
    let a = 2.0 * u - Vec2::ONE;
    if a.x == 0.0 && a.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, phi) = if a.x.abs() > a.y.abs() {
        (a.x, FRAC_PI_4 * (a.y / a.x))
    } else {
        (a.y, FRAC_PI_2 - FRAC_PI_4 * (a.x / a.y))
    };
    r * Vec2::new(phi.cos(), phi.sin())
}

/// Pdf of [`sample_concentric_disk`] with respect to area on the unit disk: 1 / π.
pub fn uniform_disk_pdf() -> f32 {
    FRAC_1_PI
}

/// Orthonormal basis (t, b) around unit `n` (Duff et al., "Building an Orthonormal Basis,
/// Revisited", JCGT 2017, Listing 3).
pub fn build_frame(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

/// Moves a surface point off its surface along the geometric normal `n` (pointing to the side
/// the new ray leaves to) by a few ulps, so the ray cannot re-hit the surface (Wächter & Binder,
/// "A Fast and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, ch. 6).
///
/// On x86-64 the three coordinates go through SSE2 at once, the same bits as the scalar form
/// ([`offset_ray_origin_scalar`]; test `offset_ray_origin_is_its_scalar_form`): `as i32`'s
/// saturation (NaN to 0, beyond the range to its ends) is spelt out, where the scalar
/// conversions and their checks cost about 100 instructions a call.
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { offset_ray_origin_sse2(p, n) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        offset_ray_origin_scalar(p, n)
    }
}

const OFFSET_ORIGIN: f32 = 1.0 / 32.0;
const OFFSET_FLOAT_SCALE: f32 = 1.0 / 65536.0;
const OFFSET_INT_SCALE: f32 = 256.0;

/// [`offset_ray_origin`] one coordinate at a time, as the GLSL twin writes it.
pub fn offset_ray_origin_scalar(p: Vec3, n: Vec3) -> Vec3 {
    let offset = |p: f32, n: f32| -> f32 {
        let of_i = (OFFSET_INT_SCALE * n) as i32;
        let p_i =
            f32::from_bits(
                (p.to_bits() as i32).wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32,
            );
        if p.abs() < OFFSET_ORIGIN {
            p + OFFSET_FLOAT_SCALE * n
        } else {
            p_i
        }
    };
    Vec3::new(offset(p.x, n.x), offset(p.y, n.y), offset(p.z, n.z))
}

#[cfg(target_arch = "x86_64")]
#[inline]
unsafe fn offset_ray_origin_sse2(p: Vec3, n: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    let pv = _mm_set_ps(0.0, p.z, p.y, p.x);
    let nv = _mm_set_ps(0.0, n.z, n.y, n.x);
    let scaled = _mm_mul_ps(nv, _mm_set1_ps(OFFSET_INT_SCALE));
    // `as i32`: truncation; NaN gives 0 and values from 2^31 up give i32::MAX, where the
    // conversion instruction gives i32::MIN for both (below −2^31 it gives i32::MIN too).
    let truncated = _mm_cvttps_epi32(scaled);
    let ordered = _mm_castps_si128(_mm_cmpord_ps(scaled, scaled));
    let high = _mm_castps_si128(_mm_cmpge_ps(scaled, _mm_set1_ps(2_147_483_648.0)));
    let of_i = _mm_or_si128(
        _mm_andnot_si128(high, _mm_and_si128(truncated, ordered)),
        _mm_and_si128(high, _mm_set1_epi32(i32::MAX)),
    );
    // −of_i where p < 0 (wrapping, as `-of_i` of i32::MIN is in a release build):
    // (of_i ^ m) − m with m all ones.
    let negative = _mm_castps_si128(_mm_cmplt_ps(pv, _mm_setzero_ps()));
    let signed = _mm_sub_epi32(_mm_xor_si128(of_i, negative), negative);
    let p_i = _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(pv), signed));
    let p_f = _mm_add_ps(pv, _mm_mul_ps(_mm_set1_ps(OFFSET_FLOAT_SCALE), nv));
    let magnitude = _mm_and_ps(pv, _mm_castsi128_ps(_mm_set1_epi32(i32::MAX)));
    let near = _mm_cmplt_ps(magnitude, _mm_set1_ps(OFFSET_ORIGIN));
    let out = _mm_or_ps(_mm_and_ps(near, p_f), _mm_andnot_ps(near, p_i));
    let mut lanes = [0.0f32; 4];
    _mm_storeu_ps(lanes.as_mut_ptr(), out);
    Vec3::new(lanes[0], lanes[1], lanes[2])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::LightEntry;
    use crate::lights::sample_light;
    use crate::stats::{chi_square_gof, sidak};

    /// 1e6 keyed numbers from one pixel's sample stream.
    fn uniforms(n: u32) -> impl Iterator<Item = Vec4> {
        (0..n).map(|i| rng_uniform4(7, i % 4096, i / 4096, 3))
    }

    #[test]
    fn rng_is_uniform_and_keyed() {
        // χ² on 64 bins per component, Šidák over the 4 components, α = 0.01.
        let bins = 64;
        let mut counts = vec![vec![0f64; bins]; 4];
        let n = 1_000_000;
        for u in uniforms(n) {
            for c in 0..4 {
                assert!((0.0..1.0).contains(&u[c]));
                counts[c][(u[c] * bins as f32) as usize] += 1.0;
            }
        }
        let expected = vec![n as f64 / bins as f64; bins];
        for c in counts {
            let (_, _, p) = chi_square_gof(&c, &expected);
            assert!(p > sidak(0.01, 4), "component not uniform: p = {p}");
        }
        assert_eq!(rng_uniform4(1, 2, 3, 4), rng_uniform4(1, 2, 3, 4));
        assert_ne!(rng_uniform4(1, 2, 3, 4), rng_uniform4(2, 2, 3, 4));
    }

    #[test]
    fn cosine_hemisphere_matches_its_pdf() {
        // χ² over a (cos θ, φ) grid: each cell's expected mass is the integral of cos θ/π over it,
        // which in cos²θ is uniform: cell mass = Δ(cos²θ) · Δφ / 2π.
        let (nt, np) = (16usize, 16usize);
        let mut observed = vec![0f64; nt * np];
        let n = 1_000_000u32;
        for u in uniforms(n) {
            let w = sample_cosine_hemisphere(Vec2::new(u.x, u.y));
            assert!((w.length() - 1.0).abs() < 1e-5 && w.z >= 0.0);
            let c2 = (w.z * w.z).clamp(0.0, 0.999_999);
            let mut phi = w.y.atan2(w.x) / (2.0 * PI);
            if phi < 0.0 {
                phi += 1.0;
            }
            let i = (c2 * nt as f32) as usize;
            let j = ((phi * np as f32) as usize).min(np - 1);
            observed[i * np + j] += 1.0;
        }
        let expected = vec![n as f64 / (nt * np) as f64; nt * np];
        let (_, _, p) = chi_square_gof(&observed, &expected);
        assert!(
            p > 0.01,
            "cosine hemisphere sampling does not match cos θ/π: p = {p}"
        );
    }

    #[test]
    fn cosine_hemisphere_inverse_round_trips() {
        for u in uniforms(10_000) {
            let uv = Vec2::new(u.x, u.y);
            let back = invert_cosine_hemisphere_sample(sample_cosine_hemisphere(uv));
            assert!((back.x - uv.x).abs() < 1e-4, "{uv} -> {back}");
            let dphi = (back.y - uv.y).abs();
            assert!(dphi.min(1.0 - dphi) < 1e-4, "{uv} -> {back}");
        }
    }

    #[test]
    fn concentric_disk_is_uniform() {
        // Uniform on the disk ⇔ the map from the unit square is area-preserving up to the
        // constant π: |det J| = π everywhere (Shirley & Chiu 1997). Checked by central
        // differences at points of a grid away from the wedge seams |a| = |b|, where the map is
        // only continuous; the tolerance covers the O(h²) truncation and f32 rounding / h.
        let h = 1e-3f32;
        let mut worst = 0f32;
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new((i as f32 + 0.37) / 64.0, (j as f32 + 0.61) / 64.0);
                let (a, b) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
                if (a.abs() - b.abs()).abs() < 4.0 * h
                    || u.min_element() < 2.0 * h
                    || u.max_element() > 1.0 - 2.0 * h
                {
                    continue;
                }
                let f = sample_concentric_disk;
                let dx = (f(u + Vec2::new(h, 0.0)) - f(u - Vec2::new(h, 0.0))) / (2.0 * h);
                let dy = (f(u + Vec2::new(0.0, h)) - f(u - Vec2::new(0.0, h))) / (2.0 * h);
                let det = (dx.x * dy.y - dx.y * dy.x).abs();
                worst = worst.max((det - PI).abs() / PI);
                let d = f(u);
                assert!(
                    d.length_squared() <= 1.0 + 1e-6,
                    "{d} lies outside the unit disk"
                );
            }
        }
        assert!(worst < 1e-2, "|det J| departs from π by {worst} (relative)");
        // The mapping's landmarks: the square's centre, edge midpoints and corners.
        assert_eq!(sample_concentric_disk(Vec2::splat(0.5)), Vec2::ZERO);
        for (u, d) in [
            (Vec2::new(1.0, 0.5), Vec2::X),
            (Vec2::new(0.5, 1.0), Vec2::Y),
            (Vec2::new(0.0, 0.5), Vec2::NEG_X),
            (Vec2::ONE, Vec2::splat(std::f32::consts::FRAC_1_SQRT_2)),
        ] {
            assert!((sample_concentric_disk(u) - d).length() < 1e-6, "{u}");
        }
        assert_eq!(uniform_disk_pdf(), FRAC_1_PI);
    }

    #[test]
    fn uniform_triangle_is_uniform_and_inverts() {
        // χ² on a k×k grid over (b1, b2): cells inside the simplex have area 1/k², cells on the
        // diagonal 1/(2k²), of the simplex's 1/2.
        let k = 8usize;
        let n = 1_000_000u32;
        let mut observed = vec![0f64; k * k];
        for u in uniforms(n) {
            let b = sample_uniform_triangle(Vec2::new(u.x, u.y));
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
            let i = ((b.x * k as f32) as usize).min(k - 1);
            let j = ((b.y * k as f32) as usize).min(k - 1);
            observed[i * k + j] += 1.0;
        }
        let (mut obs, mut exp) = (Vec::new(), Vec::new());
        for i in 0..k {
            for j in 0..k {
                let area = match (i + j).cmp(&(k - 1)) {
                    std::cmp::Ordering::Less => 1.0,
                    std::cmp::Ordering::Equal => 0.5,
                    std::cmp::Ordering::Greater => 0.0,
                } / (k * k) as f64;
                if area == 0.0 {
                    assert!(observed[i * k + j] < 20.0, "mass outside the simplex");
                    continue;
                }
                obs.push(observed[i * k + j]);
                exp.push(n as f64 * area * 2.0);
            }
        }
        let (_, _, p) = chi_square_gof(&obs, &exp);
        assert!(p > 0.01, "triangle sampling not uniform: p = {p}");
        for u in uniforms(10_000) {
            let uv = Vec2::new(u.x, u.y);
            let back = invert_uniform_triangle_sample(sample_uniform_triangle(uv));
            assert!((back - uv).abs().max_element() < 1e-3, "{uv} -> {back}");
        }
    }

    #[test]
    fn light_selection_follows_the_cdf() {
        let pmfs = [0.1f32, 0.0, 0.6, 0.3];
        let mut cdf = 0.0;
        let lights: Vec<LightEntry> = pmfs
            .iter()
            .enumerate()
            .map(|(i, &pmf)| {
                cdf += pmf;
                LightEntry {
                    cdf: if i == 3 { 1.0 } else { cdf },
                    triangle: i as u32,
                    pmf,
                    pad: 0,
                }
            })
            .collect();
        let mut observed = [0f64; 4];
        let n = 200_000;
        for u in uniforms(n) {
            observed[sample_light(&lights, u.x)] += 1.0;
        }
        assert_eq!(observed[1], 0.0, "a zero-probability light was chosen");
        let kept = [0usize, 2, 3];
        let obs: Vec<f64> = kept.iter().map(|&i| observed[i]).collect();
        let exp: Vec<f64> = kept.iter().map(|&i| pmfs[i] as f64 * n as f64).collect();
        let (_, _, p) = chi_square_gof(&obs, &exp);
        assert!(p > 0.01, "light selection does not follow the pmf: p = {p}");
    }

    #[test]
    fn permute_is_a_bijection() {
        for n in [1u32, 2, 3, 7, 16, 17, 100, 1000, 4096] {
            for key in [0u32, 1, 0xdead_beef, 12345] {
                let mut seen = vec![false; n as usize];
                for i in 0..n {
                    let j = permute(i, n, key);
                    assert!(
                        j < n && !seen[j as usize],
                        "n = {n}, key = {key}: {i} -> {j} repeats"
                    );
                    seen[j as usize] = true;
                }
            }
        }
    }

    #[test]
    fn stratified_pairs_are_latin_hypercubes_and_uniform() {
        // Each pixel's spp samples take every row and every column stratum once.
        let spp = 64;
        for pixel in 0..50 {
            let (mut rows, mut cols) = (vec![0; spp as usize], vec![0; spp as usize]);
            for s in 0..spp {
                let j = rng_uniform4(9, pixel, s, 0);
                let u = stratify2(9, pixel, s, spp, 3, Vec2::new(j.x, j.y));
                assert!((0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y));
                cols[(u.x * spp as f32) as usize] += 1;
                rows[(u.y * spp as f32) as usize] += 1;
            }
            assert!(
                rows.iter().chain(&cols).all(|&c| c == 1),
                "pixel {pixel}: {rows:?} {cols:?}"
            );
        }
        // Over many pixels each sample index is uniform on the square: χ² on an 8×8 grid of
        // sample 5 of 16, α = 0.01.
        let k = 8;
        let mut observed = vec![0f64; k * k];
        let n = 200_000u32;
        for pixel in 0..n {
            let j = rng_uniform4(9, pixel, 5, 0);
            let u = stratify2(9, pixel, 5, 16, 3, Vec2::new(j.x, j.y));
            observed[(u.y * k as f32) as usize * k + (u.x * k as f32) as usize] += 1.0;
        }
        let (_, _, p) = chi_square_gof(&observed, &vec![n as f64 / (k * k) as f64; k * k]);
        assert!(
            p > 0.01,
            "stratified sample 5 is not uniform over pixels: p = {p}"
        );
    }

    /// A sample index past the strata returns (it used to cycle-walk forever in `permute`)
    /// with the independent pair.
    #[test]
    fn samples_past_the_strata_keep_their_pair() {
        let j = Vec2::new(0.25, 0.75);
        assert_eq!(stratify2(9, 3, 16, 16, 3, j), j);
        assert_eq!(stratify2(9, 3, 1000, 4, 3, j), j);
        assert_ne!(stratify2(9, 3, 15, 16, 3, j), j);
    }

    #[test]
    fn frame_is_orthonormal() {
        for u in uniforms(1000) {
            let n = Vec3::new(u.x - 0.5, u.y - 0.5, u.z - 0.5).normalize();
            let (t, b) = build_frame(n);
            assert!(t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5 && t.dot(b).abs() < 1e-5);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
        }
    }

    /// The SSE2 form gives the scalar form's bits: random points and normals at every scale,
    /// and the edges — ±0, the 1/32 boundary, NaN and infinite coordinates, normals beyond the
    /// conversion's range.
    #[test]
    fn offset_ray_origin_is_its_scalar_form() {
        let special = [
            0.0,
            -0.0,
            1.0 / 32.0,
            -1.0 / 32.0,
            f32::from_bits((1.0f32 / 32.0).to_bits() - 1),
            1.0,
            -1.0,
            1e-30,
            -3e38,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            8.4e6,
            -8.4e6,
            2.0e7,
            -2.0e7,
        ];
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut checked = 0;
        for (k, u) in uniforms(20_000).enumerate() {
            let scale = 10f32.powi((k % 13) as i32 - 6);
            let p = (Vec3::new(u.x, u.y, u.z) - Vec3::splat(0.5)) * scale;
            let n = (Vec3::new(u.w, u.x * u.y, u.z - u.w) - Vec3::splat(0.3)).normalize();
            let (p, n) = match k % 5 {
                0 => (Vec3::new(special[k / 5 % special.len()], p.y, p.z), n),
                1 => (p, Vec3::new(n.x, special[k / 5 % special.len()], n.z)),
                _ => (p, n),
            };
            assert_eq!(
                bits(offset_ray_origin(p, n)),
                bits(offset_ray_origin_scalar(p, n)),
                "p = {p}, n = {n}"
            );
            checked += 1;
        }
        assert_eq!(checked, 20_000);
    }

    #[test]
    fn offset_moves_to_the_normal_side() {
        for u in uniforms(1000) {
            let p = Vec3::new(u.x - 0.5, u.y * 100.0, -u.z * 1e-3);
            let n = Vec3::new(u.w - 0.5, 0.3, -0.7).normalize();
            let q = offset_ray_origin(p, n);
            assert!((q - p).dot(n) > 0.0, "{p} moved to {q}");
            assert!((q - p).length() < 1e-3);
        }
    }
}

/// Uniform direction in the cone of half-angle θmax around +Z (cos θ uniform on
/// [cos θmax, 1]; pbrt-v3 §13.6.4); `cos_max` = −1 gives the whole sphere.
pub fn sample_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - u.x * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Pdf of [`sample_uniform_cone`] with respect to solid angle: 1 / (2π (1 − cos θmax)).
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}
