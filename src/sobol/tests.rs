use super::*;
use crate::stats::{chi_square_gof, sidak};

/// Keys of a few pixels' pairs, and the all-zero key (no scrambling at all).
fn some_keys() -> Vec<UVec4> {
    let mut keys = vec![UVec4::ZERO];
    keys.extend((0..12).map(|i| sobol_keys(i * 7 + 1, i * 1013, i % 5)));
    keys
}

/// Whether `points` (32-bit binary fractions) put exactly one point in every elementary interval
/// of area 1/len: for every split 2^a × 2^(k−a) of the square, len = 2^k. The message names the
/// first split that fails.
fn is_net(points: &[UVec2]) -> Result<(), String> {
    let k = points.len().trailing_zeros();
    assert_eq!(points.len(), 1 << k, "a net has 2^k points");
    for a in 0..=k {
        let b = k - a;
        let mut seen = vec![false; points.len()];
        for p in points {
            let col = (p.x as u64 >> (32 - a)) as usize;
            let row = (p.y as u64 >> (32 - b)) as usize;
            let cell = (row << a) | col;
            if seen[cell] {
                return Err(format!(
                    "two of {} points in one interval of the {}×{} split",
                    points.len(),
                    1 << a,
                    1 << b
                ));
            }
            seen[cell] = true;
        }
    }
    Ok(())
}

#[test]
fn sobol2_starts_like_the_sobol_sequence() {
    // Sobol's first eight points in index order (dimension 2: direction numbers 1/2, 3/4, 5/8).
    let expected = [
        (0.0, 0.0),
        (0.5, 0.5),
        (0.25, 0.75),
        (0.75, 0.25),
        (0.125, 0.625),
        (0.625, 0.125),
        (0.375, 0.375),
        (0.875, 0.875),
    ];
    for (i, &(x, y)) in expected.iter().enumerate() {
        let p = sobol2(i as u32);
        let got = (p.x as f64 / 2f64.powi(32), p.y as f64 / 2f64.powi(32));
        assert_eq!(got, (x, y), "Sobol point {i}");
    }
}

#[test]
fn sobol2_equals_the_direction_number_loop() {
    // The superset-XOR form against the definition: XOR of v_k over the set bits k of the index.
    let reference = |index: u32| {
        let (mut y, mut v, mut i) = (0u32, 1u32 << 31, index);
        while i != 0 {
            if i & 1 != 0 {
                y ^= v;
            }
            i >>= 1;
            v ^= v >> 1;
        }
        y
    };
    let mut indices: Vec<u32> = (0..65_536).collect();
    indices.extend((0..65_536u32).map(|i| crate::sampling::pcg4d(glam::UVec4::new(i, 1, 2, 3)).x));
    indices.extend([u32::MAX, 1 << 31, 0xdead_beef]);
    for i in indices {
        assert_eq!(sobol2(i).y, reference(i), "index {i:#x}");
    }
}

/// The shortened form gives the bits of Burley's Listing 4 as written: scramble the index, take
/// both Sobol coordinates, scramble each.
#[test]
fn shuffled_scrambled_sobol2_is_the_written_out_composition() {
    for keys in some_keys() {
        for i in 0..4096u32 {
            let index = i.wrapping_mul(0x9e37_79b9) ^ i;
            let p = sobol2(nested_uniform_scramble(index, keys.x));
            let written_out = UVec2::new(
                nested_uniform_scramble(p.x, keys.y),
                nested_uniform_scramble(p.y, keys.z),
            );
            assert_eq!(
                shuffled_scrambled_sobol2(index, keys),
                written_out,
                "{index} {keys}"
            );
        }
    }
}

#[test]
fn shuffled_index_is_a_bijection_on_every_power_of_two() {
    // Bit j of the shuffled index depends only on bits 0..=j, so the first 2^k indices map one to
    // one onto the residues mod 2^k (and so does every aligned block of 2^k).
    for keys in some_keys() {
        for k in [0u32, 1, 2, 5, 8, 12, 16] {
            let n = 1usize << k;
            for block in [0u32, 1, 77] {
                let mut seen = vec![false; n];
                for i in 0..n as u32 {
                    let s = nested_uniform_scramble((block << k) | i, keys.x);
                    let residue = (s as u64 & (n as u64 - 1)) as usize;
                    assert!(
                        !seen[residue],
                        "key {:#x}, k = {k}, block {block}: index {i} repeats residue {residue}",
                        keys.x
                    );
                    seen[residue] = true;
                }
            }
        }
    }
    // A shuffle that is not the identity.
    let key = sobol_keys(1, 2, 3).x;
    assert!((0..16).any(|i| nested_uniform_scramble(i, key) != i));
}

#[test]
fn scrambling_is_nested() {
    // Owen's nesting: flipping a bit of the binary fraction never changes the more significant
    // bits of its scramble, and does change the scramble.
    for keys in some_keys() {
        for x in (0..1000u32).map(|i| i.wrapping_mul(0x9e37_79b9)) {
            let s = nested_uniform_scramble(x, keys.y);
            for j in 0..32 {
                let t = nested_uniform_scramble(x ^ (1 << j), keys.y);
                let above = !((2u64 << j) - 1) as u32;
                assert_eq!(
                    s & above,
                    t & above,
                    "x = {x:#x}, bit {j}: upper bits moved"
                );
                assert_ne!(s, t, "x = {x:#x}, bit {j}: not a bijection");
            }
        }
    }
}

#[test]
fn scrambled_pairs_are_nets() {
    // The first 2^k points of every pair, and the next 2^k, are (0,k,2)-nets, before and after
    // shuffling and scrambling.
    for keys in some_keys() {
        for k in 0..=10u32 {
            for block in [0u32, 1] {
                let points: Vec<UVec2> = (0..1u32 << k)
                    .map(|i| shuffled_scrambled_sobol2((block << k) + i, keys))
                    .collect();
                is_net(&points).unwrap_or_else(|e| panic!("keys {keys}, block {block}: {e}"));
            }
        }
    }
    // The float pair keeps the top 24 bits: the same cells.
    let points: Vec<Vec2> = (0..256).map(|i| sobol_pair(3, 4, i, 5)).collect();
    for a in 0..=8 {
        let mut seen = [false; 256];
        for u in &points {
            assert!((0.0..1.0).contains(&u.x) && (0.0..1.0).contains(&u.y));
            let cell =
                ((u.y * (1 << (8 - a)) as f32) as usize) << a | (u.x * (1 << a) as f32) as usize;
            assert!(!seen[cell], "sobol_pair: split {a}");
            seen[cell] = true;
        }
    }
}

#[test]
fn pairs_are_uniform_over_pixels_and_independent_of_each_other() {
    // Over many pixels (≈ 1e6 points in all), each (sample, dimension) is uniform on the square
    // (χ² on a 16×16 grid), and two pairs of the same path are independent (χ² of the joint
    // distribution of their first coordinates). Šidák over the five tests, α = 0.01.
    let k = 16;
    let pixels = 200_000u32;
    let configs = [(0u32, 0u32), (1, 5), (5, 8), (200, 1), (77, 4)];
    let alpha = sidak(0.01, configs.len());
    for (t, &(sample, dimension)) in configs.iter().enumerate() {
        let mut observed = vec![0f64; k * k];
        for pixel in 0..pixels {
            let u = sobol_pair(9, pixel, sample, dimension);
            let (col, row) = if t + 1 < configs.len() {
                (u.x, u.y)
            } else {
                (u.x, sobol_pair(9, pixel, sample, dimension + 4).x)
            };
            observed[(row * k as f32) as usize * k + (col * k as f32) as usize] += 1.0;
        }
        let expected = vec![pixels as f64 / (k * k) as f64; k * k];
        let (chi2, _, p) = chi_square_gof(&observed, &expected);
        assert!(
            p > alpha,
            "sample {sample}, dimension {dimension}: χ² = {chi2:.1}, p = {p:.2e}"
        );
    }
}
