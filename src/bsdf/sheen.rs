//! KHR_materials_sheen's microfiber lobe: the "Charlie" distribution and visibility of Conty
//! Estevez & Kulla 2017 ("Production Friendly Microfacet Sheen BRDF"), exactly as the
//! extension's implementation notes write them, and the directional albedo E(cos θ, roughness)
//! its albedo scaling needs, as a 32 × 32 table ([`SHEEN_ALBEDO`], `sheen_table.rs`, generated
//! by quadrature: `sheen_albedo_quadrature`) looked up bilinearly; the shaders read the same
//! table from `FrameParams::sheen_albedo`. Twin of `shaders/inc/sheen.glsl`, same names; local
//! shading frame, +Z the normal.
//!
//! The lobe is not energy-conserving everywhere: at grazing views and low sheen roughness the
//! fitted Λ does not grow fast enough and E exceeds 1 (E(cos 0.03, roughness ≤ 0.07) ≈ 1.5; the
//! table's largest value, 2.7, is its grazing node): the spec's own model, kept as written. The
//! albedo scaling 1 − max(sheenColor)·E of the layers below is clamped at 0 there.
//!
//! Sheen roughness is clamped below at [`SHEEN_MIN_ROUGHNESS`]: at roughness 0 (the
//! extension's default) the distribution (2 + 1/α)·sin^(1/α)θ_h / 2π degenerates, and below
//! α ≈ 0.005 its f32 evaluation and a tabulated albedo stop being meaningful.

use super::sheen_table::SHEEN_ALBEDO;
use std::f32::consts::PI;

/// The smallest sheen roughness evaluated (α = 0.0049); smaller values are raised to it.
pub const SHEEN_MIN_ROUGHNESS: f32 = 0.07;
/// Nodes per axis of [`SHEEN_ALBEDO`]: cos θ = i / 31, roughness = j / 31 (raised to the
/// minimum), entry `[j * 32 + i]`.
pub const SHEEN_TABLE_SIZE: usize = 32;

/// α_g = max(sheenRoughness, [`SHEEN_MIN_ROUGHNESS`])².
pub fn sheen_alpha(roughness: f32) -> f32 {
    let r = roughness.max(SHEEN_MIN_ROUGHNESS);
    r * r
}

/// The Charlie distribution D_s(h) = (2 + 1/α)·sin^(1/α)θ_h / 2π (KHR_materials_sheen, "Sheen
/// distribution") for `cos_h` = n·h.
pub fn charlie_d(cos_h: f32, alpha: f32) -> f32 {
    let inv_r = 1.0 / alpha;
    let sin2h = (1.0 - cos_h * cos_h).max(0.0);
    (2.0 + inv_r) * sin2h.powf(inv_r * 0.5) / (2.0 * PI)
}

/// The fitted exponent l(x, α) of the Charlie shadowing (KHR_materials_sheen, "Sheen
/// visibility"; Conty Estevez & Kulla 2017, table 1).
pub fn sheen_l(x: f32, alpha: f32) -> f32 {
    let t = (1.0 - alpha) * (1.0 - alpha);
    let mix = |a: f32, b: f32| a + (b - a) * t;
    let a = mix(21.5473, 25.3245);
    let b = mix(3.82987, 3.32435);
    let c = mix(0.19823, 0.16801);
    let d = mix(-1.97760, -1.27393);
    let e = mix(-4.32054, -4.85967);
    a / (1.0 + b * x.powf(c)) + d * x + e
}

/// Λ of the Charlie shadowing for a direction with cosine `cos` to the normal.
pub fn sheen_lambda(cos: f32, alpha: f32) -> f32 {
    let c = cos.abs();
    if c < 0.5 {
        sheen_l(c, alpha).exp()
    } else {
        (2.0 * sheen_l(0.5, alpha) - sheen_l(1.0 - c, alpha)).exp()
    }
}

/// The sheen visibility ν_s = G_s / (4 |n·l| |n·v|) with G_s = 1 / (1 + Λ(v) + Λ(l)).
pub fn sheen_visibility(cos_o: f32, cos_i: f32, alpha: f32) -> f32 {
    let denom = (1.0 + sheen_lambda(cos_o, alpha) + sheen_lambda(cos_i, alpha))
        * (4.0 * cos_o.abs() * cos_i.abs());
    if denom > 0.0 {
        1.0 / denom
    } else {
        0.0
    }
}

/// The directional albedo E(cos θ) of the white sheen lobe D_s·ν_s, bilinear in
/// [`SHEEN_ALBEDO`] over (|cos θ|, roughness).
pub fn sheen_albedo(cos: f32, roughness: f32) -> f32 {
    let last = (SHEEN_TABLE_SIZE - 1) as f32;
    let x = cos.abs().clamp(0.0, 1.0) * last;
    let y = roughness.clamp(0.0, 1.0) * last;
    let (i, j) = (
        (x as usize).min(SHEEN_TABLE_SIZE - 2),
        (y as usize).min(SHEEN_TABLE_SIZE - 2),
    );
    let (fx, fy) = (x - i as f32, y - j as f32);
    let at = |i: usize, j: usize| SHEEN_ALBEDO[j * SHEEN_TABLE_SIZE + i];
    let bottom = at(i, j) + (at(i + 1, j) - at(i, j)) * fx;
    let top = at(i, j + 1) + (at(i + 1, j + 1) - at(i, j + 1)) * fx;
    bottom + (top - bottom) * fy
}

/// E(μ, roughness) = ∫ D_s ν_s |n·l| dω_l by the midpoint rule over half vectors (dω_l =
/// 4 (v·h) dω_h, which resolves the distribution's peak at grazing h): 512 steps of cos θ_h,
/// 64 of φ_h over the half circle (the integrand is symmetric about v's plane). μ is raised to
/// 10⁻⁴ (the node at grazing).
pub fn sheen_albedo_quadrature(mu: f64, roughness: f64) -> f64 {
    let mu = mu.max(1e-4);
    let alpha = sheen_alpha(roughness as f32);
    let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
    let (nc, np) = (512, 64);
    let mut sum = 0.0;
    for a in 0..nc {
        let ch = (a as f64 + 0.5) / nc as f64;
        let sh = (1.0 - ch * ch).sqrt();
        let d = charlie_d(ch as f32, alpha) as f64;
        for b in 0..np {
            let phi = (b as f64 + 0.5) / np as f64 * std::f64::consts::PI;
            let h = [sh * phi.cos(), sh * phi.sin(), ch];
            let oh = wo[0] * h[0] + wo[2] * h[2];
            let wi_z = 2.0 * oh * h[2] - wo[2];
            if oh <= 0.0 || wi_z <= 0.0 {
                continue;
            }
            let v = sheen_visibility(mu as f32, wi_z as f32, alpha) as f64;
            sum += d * v * wi_z * 4.0 * oh;
        }
    }
    // dω_h = d(cos θ_h) dφ, φ over [0, π) counted twice.
    2.0 * sum * (1.0 / nc as f64) * (std::f64::consts::PI / np as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Writes `sheen_table.rs` from the quadrature:
    /// `cargo test --release --lib write_sheen_tables -- --ignored`.
    #[test]
    #[ignore]
    fn write_sheen_tables() {
        let n = SHEEN_TABLE_SIZE;
        let values: Vec<f32> = (0..n * n)
            .map(|k| {
                let (i, j) = (k % n, k / n);
                sheen_albedo_quadrature(i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64) as f32
            })
            .collect();
        let rows = |indent: &str| -> String {
            values
                .chunks(8)
                .map(|c| {
                    let row: Vec<String> = c.iter().map(|v| format!("{v:.7e}")).collect();
                    format!("{indent}{},", row.join(", "))
                })
                .collect::<Vec<_>>()
                .join("\n")
        };
        let root = env!("CARGO_MANIFEST_DIR");
        let rust = format!(
            "//! Generated by `sheen::tests::write_sheen_tables` (do not edit): the directional albedo\n\
             //! E(cos θ = i/31, roughness = j/31) of KHR_materials_sheen's Charlie lobe at\n\
             //! `[j * 32 + i]` (`sheen::sheen_albedo_quadrature`); the shaders read it from\n\
             //! `FrameParams::sheen_albedo`.\n\n\
             #[rustfmt::skip]\npub const SHEEN_ALBEDO: [f32; {}] = [\n{}\n];\n",
            n * n,
            rows("    ")
        );
        std::fs::write(format!("{root}/src/bsdf/sheen_table.rs"), rust).unwrap();
    }

    #[test]
    fn the_albedo_table_is_the_quadrature() {
        let n = SHEEN_TABLE_SIZE;
        let mut worst: f64 = 0.0;
        for j in 0..n {
            for i in 0..n {
                let q =
                    sheen_albedo_quadrature(i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
                let t = SHEEN_ALBEDO[j * n + i] as f64;
                worst = worst.max((q - t).abs());
                assert!(
                    (q - t).abs() <= 1e-6 * q.max(1e-3),
                    "E({i}, {j}): table {t} vs quadrature {q}"
                );
            }
        }
        println!("largest table − quadrature difference: {worst:.2e}");
    }

    #[test]
    fn the_quadrature_converges() {
        // The midpoint rule against Monte Carlo with uniform hemisphere directions (a different
        // estimator of the same integral): within 4 standard errors.
        use crate::sampling::{rng_uniform4, sample_uniform_cone, uniform_cone_pdf};
        use glam::{Vec2, Vec3};
        for (mu, r) in [(0.9f32, 0.3f32), (0.4, 1.0), (0.15, 0.07), (0.7, 0.6)] {
            let alpha = sheen_alpha(r);
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let n = 400_000;
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for k in 0..n {
                let u = rng_uniform4(3, k, 0, 0);
                let wi = sample_uniform_cone(Vec2::new(u.x, u.y), 0.0);
                let h = (wo + wi).normalize();
                let f = charlie_d(h.z, alpha) * sheen_visibility(wo.z, wi.z, alpha);
                let x = (f * wi.z / uniform_cone_pdf(0.0)) as f64;
                s += x;
                s2 += x * x;
            }
            let mean = s / n as f64;
            let se = ((s2 / n as f64 - mean * mean) / n as f64).sqrt();
            let q = sheen_albedo_quadrature(mu as f64, r as f64);
            assert!(
                (q - mean).abs() < 4.0 * se + 1e-4,
                "μ {mu}, r {r}: {q} vs {mean} ± {se}"
            );
        }
    }
}
