//! The emitter table: every emitting triangle with its probability of being chosen by next
//! event estimation, proportional to its emitted power (luminance-weighted).

use crate::layout::{
    GpuMaterial, GpuPunctualLight, GpuTriangle, LightEntry, LIGHT_DIRECTIONAL,
    LIGHT_ENTRY_PUNCTUAL, LIGHT_SPOT, MATERIAL_DOUBLE_SIDED,
};
use glam::Vec3;
use rayon::prelude::*;

/// Photometric luminance of linear Rec. 709 RGB (ITU-R BT.709 weights).
pub fn luminance(rgb: Vec3) -> f32 {
    0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z
}

/// Power emitted by a Lambertian emitter of constant radiance: Φ = L·A·π per emitting side
/// (the cosine-weighted hemisphere integrates to π).
pub fn emitted_power(emission: Vec3, area: f32, double_sided: bool) -> f32 {
    let sides = if double_sided { 2.0 } else { 1.0 };
    luminance(emission) * area * std::f32::consts::PI * sides
}

/// Fills `light_pmf` of every triangle (0 for those that do not emit) and returns the emitter
/// table: one entry per triangle of positive power, in triangle order, with `pmf` = power /
/// total and `cdf` the running sum of pmfs, the last entry exactly 1. No emitters → empty.
///
/// `triangles[i].area` must already hold 0.5·|e1 × e2|; `material` indexes `materials`
/// (an index out of range counts as non-emitting).
pub fn build_light_table(
    triangles: &mut [GpuTriangle],
    materials: &[GpuMaterial],
) -> Vec<LightEntry> {
    build_light_table_with(triangles, materials, &[], &[], 0.0).0
}

/// Power of a punctual light for emitter selection: 4π·I for a point light, 2π(1 − cos θ_outer)·I
/// for a spot (its cone's solid angle; the smooth falloff only lowers it), π·R²·E for a
/// directional light seen by a scene of bounding radius R. Luminance-weighted.
pub fn punctual_power(light: &GpuPunctualLight, scene_radius: f32) -> f32 {
    use std::f32::consts::PI;
    let i = luminance(Vec3::from(light.intensity));
    match light.kind {
        LIGHT_SPOT => {
            let cos_outer = -light.spot_offset / light.spot_scale;
            2.0 * PI * (1.0 - cos_outer).clamp(0.0, 2.0) * i
        }
        LIGHT_DIRECTIONAL => PI * scene_radius * scene_radius * i,
        _ => 4.0 * PI * i,
    }
}

/// [`build_light_table`] with a power scale per triangle (`scales[i]`, 1 where `scales` is
/// shorter: an emissive texture's mean over the triangle against its mean over the image) and
/// `punctual` lights after the triangles, directional ones last: their entries carry
/// `LIGHT_ENTRY_PUNCTUAL | index`, chosen in proportion to [`punctual_power`]. Also returns the table's total power.
pub fn build_light_table_with(
    triangles: &mut [GpuTriangle],
    materials: &[GpuMaterial],
    scales: &[f32],
    punctual: &[GpuPunctualLight],
    scene_radius: f32,
) -> (Vec<LightEntry>, f64) {
    // Per triangle on every core; the sums and the CDF below stay in triangle order (the same
    // floats as one pass), over the emitting triangles alone.
    let power: Vec<f64> = triangles
        .par_iter()
        .enumerate()
        .map(|(i, tri)| {
            let scale = scales.get(i).copied().unwrap_or(1.0);
            let Some(m) = materials.get(tri.material_index() as usize) else {
                return 0.0;
            };
            let p = emitted_power(
                Vec3::from(m.emission),
                tri.area,
                m.flags & MATERIAL_DOUBLE_SIDED != 0,
            );
            let p = p * scale;
            if p.is_finite() && p > 0.0 {
                p as f64
            } else {
                0.0
            }
        })
        .collect();
    let punctual_power: Vec<f64> = punctual
        .iter()
        .map(|l| {
            let p = punctual_power(l, scene_radius);
            if p.is_finite() && p > 0.0 {
                p as f64
            } else {
                0.0
            }
        })
        .collect();
    let total: f64 = power.iter().chain(&punctual_power).sum();

    triangles
        .par_iter_mut()
        .zip(&power)
        .for_each(|(tri, &p)| tri.light_pmf = if p > 0.0 { (p / total) as f32 } else { 0.0 });
    let emitting: Vec<u32> = (0..power.len() as u32)
        .into_par_iter()
        .filter(|&i| power[i as usize] > 0.0)
        .collect();
    let mut table = Vec::with_capacity(emitting.len());
    let mut running = 0.0f64;
    for i in emitting {
        let p = power[i as usize];
        running += p;
        table.push(LightEntry {
            cdf: (running / total) as f32,
            triangle: i,
            pmf: (p / total) as f32,
            pad: 0,
        });
    }
    // Bounded lights first, directional lights (at infinity, outside the light BVH) last.
    let order = (0..punctual.len())
        .filter(|&i| punctual[i].kind != LIGHT_DIRECTIONAL)
        .chain((0..punctual.len()).filter(|&i| punctual[i].kind == LIGHT_DIRECTIONAL));
    for i in order {
        let p = punctual_power[i];
        if p <= 0.0 {
            continue;
        }
        running += p;
        table.push(LightEntry {
            cdf: (running / total) as f32,
            triangle: LIGHT_ENTRY_PUNCTUAL | i as u32,
            pmf: (p / total) as f32,
            pad: 0,
        });
    }
    if let Some(last) = table.last_mut() {
        last.cdf = 1.0;
    }
    (table, total)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle(material: u32, area: f32) -> GpuTriangle {
        GpuTriangle {
            material,
            area,
            light_pmf: -1.0,
            ..Default::default()
        }
    }

    fn material(emission: [f32; 3], flags: u32) -> GpuMaterial {
        GpuMaterial {
            base_color: [0.5; 3],
            flags,
            emission,
            ..Default::default()
        }
    }

    #[test]
    fn table_is_proportional_to_power() {
        let materials = [
            material([0.0; 3], 0),
            material([1.0; 3], 0),
            material([1.0; 3], MATERIAL_DOUBLE_SIDED),
            material([0.0, 2.0, 0.0], 0),
        ];
        // Powers (in units of π): 0, 1, 3, 2 (double-sided, area 1), 0, 0.7152·2·0.5.
        let mut tris = [
            triangle(0, 1.0),
            triangle(1, 1.0),
            triangle(1, 3.0),
            triangle(2, 1.0),
            triangle(1, 0.0),
            triangle(3, 0.5),
        ];
        let table = build_light_table(&mut tris, &materials);
        let powers = [1.0, 3.0, 2.0, 0.7152];
        let total: f32 = powers.iter().sum();
        assert_eq!(
            table.iter().map(|e| e.triangle).collect::<Vec<_>>(),
            [1, 2, 3, 5]
        );
        let mut cdf = 0.0;
        for (entry, p) in table.iter().zip(powers) {
            assert!((entry.pmf - p / total).abs() < 1e-6, "{entry:?}");
            assert_eq!(tris[entry.triangle as usize].light_pmf, entry.pmf);
            cdf += p / total;
            assert!((entry.cdf - cdf).abs() < 1e-6);
        }
        assert_eq!(table.last().unwrap().cdf, 1.0);
        assert_eq!(tris[0].light_pmf, 0.0);
        assert_eq!(tris[4].light_pmf, 0.0);
    }

    #[test]
    fn no_emitters_gives_an_empty_table() {
        let mut tris = [triangle(0, 1.0), triangle(7, 1.0)];
        let table = build_light_table(&mut tris, &[material([0.0; 3], 0)]);
        assert!(table.is_empty());
        assert!(tris.iter().all(|t| t.light_pmf == 0.0));
    }

    #[test]
    fn power_of_a_unit_emitter() {
        let p = emitted_power(Vec3::ONE, 2.0, true);
        assert!((p - 4.0 * std::f32::consts::PI).abs() < 1e-5);
        assert!((luminance(Vec3::ONE) - 1.0).abs() < 1e-6);
    }
}

/// Picks an emitter by inverting the discrete CDF of the light table (binary search for the first
/// entry whose `cdf` exceeds `u`). Returns the table index; its probability is `pmf`.
pub fn sample_light(lights: &[LightEntry], u: f32) -> usize {
    let (mut lo, mut hi) = (0usize, lights.len() - 1);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if lights[mid].cdf > u {
            hi = mid;
        } else {
            lo = mid + 1;
        }
    }
    lo
}
