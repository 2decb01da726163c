use super::*;
use crate::sampling::rng_uniform4;
use crate::stats::chi_square_gof;
use glam::Vec4;

/// An emitter as the tests know it, beside its [`LightBounds`]: enough geometry to tell whether
/// it can light a point at all.
#[derive(Clone, Copy, Debug)]
enum Emitter {
    Triangle([Vec3; 3], bool),
    Point(Vec3),
    Spot(Vec3, Vec3, f32),
}

fn unit(u: Vec4) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// `count` lights in [−1, 1]³ (seeded): one- and two-sided triangles of edge up to 0.35, point
/// lights and spot lights of random axes and cones, powers log-uniform over four decades.
fn random_scene(count: u32, seed: u32) -> (Vec<Emitter>, Vec<LightBounds>) {
    let mut emitters = Vec::new();
    let mut bounds = Vec::new();
    for i in 0..count {
        let a = rng_uniform4(seed, i, 0, 0);
        let b = rng_uniform4(seed, i, 1, 0);
        let c = rng_uniform4(seed, i, 2, 0);
        let centre = a.truncate() * 2.0 - Vec3::ONE;
        let power = 10f32.powf(4.0 * a.w - 2.0);
        let kind = (c.w * 5.0) as u32;
        let (e, lb) = match kind {
            0..=2 => {
                let size = 0.02 + 0.33 * b.w;
                let p = [centre, centre + size * unit(b), centre + size * unit(c)];
                let two_sided = kind == 2;
                (
                    Emitter::Triangle(p, two_sided),
                    LightBounds::triangle(p[0], p[1], p[2], power, two_sided),
                )
            }
            3 => (Emitter::Point(centre), LightBounds::point(centre, power)),
            _ => {
                let inner = 0.1 + 1.1 * b.w;
                let outer = inner + 0.5 * c.z;
                let dir = unit(b);
                (
                    Emitter::Spot(centre, dir, outer),
                    LightBounds::spot(centre, dir, power, inner.cos(), outer.cos()),
                )
            }
        };
        emitters.push(e);
        bounds.push(lb);
    }
    (emitters, bounds)
}

/// A shading point in [−2, 2]³ with a random normal, or none (n = 0) for one case in four.
fn random_point(seed: u32, i: u32) -> (Vec3, Vec3) {
    let a = rng_uniform4(seed, i, 10, 0);
    let b = rng_uniform4(seed, i, 11, 0);
    let p = a.truncate() * 4.0 - Vec3::splat(2.0);
    let n = if i % 4 == 3 { Vec3::ZERO } else { unit(b) };
    (p, n)
}

/// Whether the emitter surely sends light to `p` across a surface of normal `n`, by a margin
/// that rounding cannot reverse: `p` on an emitting side of the triangle's plane (or inside the
/// spot's outer cone) by 1e-3, and some point of the emitter off `p`'s tangent plane by 1e-3 in
/// cosine. A node's importance is zero only where no direction in its bounds can reach `p`
/// (its box, cone and θe contain every light below it), so such a light must be reachable.
fn surely_lights(e: &Emitter, p: Vec3, n: Vec3) -> bool {
    let off_tangent_plane = |points: &[Vec3]| {
        n == Vec3::ZERO
            || points
                .iter()
                .any(|&v| n.dot(v - p).abs() > 1e-3 * (v - p).length())
    };
    match *e {
        Emitter::Triangle(v, two_sided) => {
            let normal = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
            let side = normal.dot(p - v[0]);
            let front = if two_sided { side.abs() } else { side };
            front > 1e-3 && off_tangent_plane(&v)
        }
        Emitter::Point(c) => p != c && off_tangent_plane(&[c]),
        Emitter::Spot(c, dir, outer) => {
            p != c
                && angle_between(dir, (p - c).normalize()) < outer - 1e-3
                && off_tangent_plane(&[c])
        }
    }
}

/// Checks the tree's structure: every node reachable once, each light in the tree in exactly
/// one leaf, reached by its trail.
fn check_structure(bvh: &LightBvh, lights: &[LightBounds]) {
    let in_tree = lights.iter().filter(|l| l.is_valid()).count();
    assert_eq!(bvh.nodes.len(), (2 * in_tree).saturating_sub(1));
    let mut seen = vec![false; lights.len()];
    for (i, node) in bvh.nodes.iter().enumerate() {
        if node.is_leaf() {
            let light = node.child_or_light as usize;
            assert!(!seen[light], "light {light} in two leaves");
            seen[light] = true;
            // Follow the trail from the root.
            let (mut index, mut trail) = (0usize, bvh.trails[light]);
            while !bvh.nodes[index].is_leaf() {
                index = if trail & 1 == 0 {
                    index + 1
                } else {
                    bvh.nodes[index].child_or_light as usize
                };
                trail >>= 1;
            }
            assert_eq!(index, i, "trail of light {light} leads to node {index}");
        } else {
            assert!((node.child_or_light as usize) > i + 1);
        }
    }
    for (i, l) in lights.iter().enumerate() {
        assert_eq!(seen[i], l.is_valid(), "light {i}");
        assert_eq!(bvh.trails[i] == NO_LIGHT_TRAIL, !l.is_valid(), "light {i}");
    }
}

/// The probability that [`light_bvh_sample`] at (p, n) stops at a node whose children both have
/// importance 0 (or at a lone root leaf of importance 0) and returns `None`, by walking the
/// whole tree in f64. The bounds of a node are looser than its children's (the union of their
/// cones and boxes), so a node may have a positive importance while both children have none: the
/// lights below it cannot reach p, and the sampler gives up there, as pbrt-v4's does.
fn dead_end_probability(nodes: &[GpuLightNode], p: Vec3, n: Vec3) -> f64 {
    fn walk(nodes: &[GpuLightNode], i: usize, p: Vec3, n: Vec3, prob: f64) -> f64 {
        let node = &nodes[i];
        if node.is_leaf() {
            return 0.0;
        }
        let second = node.child_or_light as usize;
        let c0 = light_bounds_importance(&nodes[i + 1], p, n) as f64;
        let c1 = light_bounds_importance(&nodes[second], p, n) as f64;
        if c0 + c1 == 0.0 {
            return prob;
        }
        let mut dead = 0.0;
        if c0 > 0.0 {
            dead += walk(nodes, i + 1, p, n, prob * c0 / (c0 + c1));
        }
        if c1 > 0.0 {
            dead += walk(nodes, second, p, n, prob * c1 / (c0 + c1));
        }
        dead
    }
    match nodes.first() {
        None => 1.0,
        Some(root) if root.is_leaf() && light_bounds_importance(root, p, n) > 0.0 => 0.0,
        Some(root) if root.is_leaf() => 1.0,
        Some(_) => walk(nodes, 0, p, n, 1.0),
    }
}

#[test]
fn pmfs_and_dead_ends_sum_to_one_and_every_lighting_emitter_is_reachable() {
    for (s, count) in [1u32, 2, 7, 300].into_iter().enumerate() {
        let (emitters, lights) = random_scene(count, 100 + s as u32);
        let bvh = LightBvh::build(&lights);
        check_structure(&bvh, &lights);
        let (mut lit_cases, mut dead_mass) = (0, 0.0);
        for i in 0..200 {
            let (p, n) = random_point(7 + s as u32, i);
            let pmfs: Vec<f32> = (0..count)
                .map(|l| light_bvh_pmf(&bvh.nodes, &bvh.trails, p, n, l))
                .collect();
            let sum: f64 = pmfs.iter().map(|&x| x as f64).sum();
            let dead = dead_end_probability(&bvh.nodes, p, n);
            dead_mass += dead;
            let lit: Vec<usize> = (0..count as usize)
                .filter(|&l| surely_lights(&emitters[l], p, n))
                .collect();
            assert!(
                (sum + dead - 1.0).abs() < 1e-5,
                "{count} lights, p {p}, n {n}: pmfs sum to {sum}, dead ends take {dead}"
            );
            if sum == 0.0 {
                assert!(
                    lit.is_empty(),
                    "{count} lights, p {p}, n {n}: nothing sampled, yet light {} lights p",
                    lit[0]
                );
                assert_eq!(light_bvh_sample(&bvh.nodes, p, n, 0.5), None);
            }
            for &l in &lit {
                assert!(
                    pmfs[l] > 0.0,
                    "{count} lights, p {p}, n {n}: light {l} ({:?}) lights p, pmf 0",
                    emitters[l]
                );
            }
            lit_cases += !lit.is_empty() as u32;
        }
        // The points must mostly see some light, or the test tests little.
        assert!(
            lit_cases > 150,
            "{count} lights: only {lit_cases} lit cases"
        );
        println!(
            "{count} lights: {lit_cases} of 200 points lit, mean dead-end probability {:.4}",
            dead_mass / 200.0
        );
    }
}

#[test]
fn sampled_pmf_equals_light_bvh_pmf_bit_for_bit() {
    let (_, lights) = random_scene(300, 3);
    let bvh = LightBvh::build(&lights);
    let mut sampled = 0;
    for i in 0..2000 {
        let (p, n) = random_point(5, i);
        for k in 0..8 {
            let u = rng_uniform4(6, i, k, 0).x;
            if let Some((light, pmf)) = light_bvh_sample(&bvh.nodes, p, n, u) {
                let again = light_bvh_pmf(&bvh.nodes, &bvh.trails, p, n, light);
                assert_eq!(
                    pmf.to_bits(),
                    again.to_bits(),
                    "p {p}, n {n}, u {u}: sample says light {light} with pmf {pmf}, pmf says {again}"
                );
                assert!(pmf > 0.0);
                sampled += 1;
            }
        }
    }
    assert!(sampled > 10_000, "only {sampled} samples");
    // Ends of the unit interval.
    let (p, n) = (Vec3::new(0.1, 2.5, -0.3), Vec3::ZERO);
    for u in [0.0, ONE_MINUS_EPSILON, 1.0] {
        let (light, pmf) = light_bvh_sample(&bvh.nodes, p, n, u).unwrap();
        assert_eq!(
            pmf.to_bits(),
            light_bvh_pmf(&bvh.nodes, &bvh.trails, p, n, light).to_bits()
        );
    }
}

#[test]
fn sampled_lights_follow_the_pmf() {
    const SAMPLES: u32 = 200_000;
    const CASES: u32 = 4;
    let (_, lights) = random_scene(300, 11);
    let bvh = LightBvh::build(&lights);
    let alpha = 1e-3 / CASES as f64;
    for case in 0..CASES {
        let (p, n) = random_point(13, case);
        // One cell per light and a last one for `None` (dead ends).
        let mut expected: Vec<f64> = (0..lights.len() as u32)
            .map(|l| light_bvh_pmf(&bvh.nodes, &bvh.trails, p, n, l) as f64 * SAMPLES as f64)
            .collect();
        expected.push(dead_end_probability(&bvh.nodes, p, n) * SAMPLES as f64);
        let mut observed = vec![0.0; lights.len() + 1];
        for k in 0..SAMPLES {
            let u = rng_uniform4(17, case, k, 0).x;
            match light_bvh_sample(&bvh.nodes, p, n, u) {
                Some((light, _)) => observed[light as usize] += 1.0,
                None => observed[lights.len()] += 1.0,
            }
        }
        let (chi2, dof, p_value) = chi_square_gof(&observed, &expected);
        println!("case {case}: p {p}, n {n}: chi2 {chi2:.1}, dof {dof}, p-value {p_value:.3}");
        assert!(dof > 50.0, "case {case}: only {dof} degrees of freedom");
        assert!(
            p_value > alpha,
            "case {case} (p {p}, n {n}): chi2 {chi2} with {dof} dof, p-value {p_value} < {alpha}"
        );
    }
}

#[test]
fn importance_is_zero_behind_one_sided_emitters_and_positive_for_point_lights() {
    // Triangles in 0 ≤ z ≤ 0.3 all facing +z: nothing reaches a point below z = 0.
    let triangles: Vec<LightBounds> = (0..20)
        .map(|i| {
            let o = Vec3::new(i as f32 * 0.1, (i % 3) as f32 * 0.2, (i % 4) as f32 * 0.1);
            LightBounds::triangle(
                o,
                o + Vec3::X * 0.1,
                o + Vec3::Y * 0.1,
                1.0 + i as f32,
                false,
            )
        })
        .collect();
    let bvh = LightBvh::build(&triangles);
    for i in 0..500 {
        let a = rng_uniform4(21, i, 0, 0);
        let b = rng_uniform4(21, i, 1, 0);
        // Below the bounding sphere of every node (the root's reaches down to z = −0.89).
        let p = Vec3::new(8.0 * a.x - 4.0, 8.0 * a.y - 4.0, -0.9 - 5.0 * a.z);
        for n in [Vec3::ZERO, unit(b)] {
            for t in &triangles {
                assert_eq!(importance(t, p, n), 0.0, "p {p}, n {n}, {t:?}");
            }
            for (k, node) in bvh.nodes.iter().enumerate() {
                assert_eq!(light_bounds_importance(node, p, n), 0.0, "node {k}, p {p}");
            }
            assert_eq!(light_bvh_sample(&bvh.nodes, p, n, a.w), None);
            for l in 0..triangles.len() as u32 {
                assert_eq!(light_bvh_pmf(&bvh.nodes, &bvh.trails, p, n, l), 0.0);
            }
        }
        // Two-sided, the same triangles light the point.
        let mut t = triangles[i as usize % triangles.len()];
        t.two_sided = true;
        assert!(importance(&t, p, Vec3::ZERO) > 0.0);
    }

    // A point light: positive and finite from everywhere, its own position included.
    let light = Vec3::new(0.3, -0.7, 1.1);
    let bounds = LightBounds::point(light, 5.0);
    let mut points = vec![light, light + Vec3::splat(1e-6), Vec3::splat(1e4)];
    points
        .extend((0..1000).map(|i| rng_uniform4(22, i, 0, 0).truncate() * 20.0 - Vec3::splat(10.0)));
    for (i, &p) in points.iter().enumerate() {
        let n = unit(rng_uniform4(22, i as u32, 1, 0));
        for n in [Vec3::ZERO, n] {
            let x = importance(&bounds, p, n);
            assert!(x > 0.0 && x.is_finite(), "p {p}, n {n}: importance {x}");
        }
    }
    // A single light: the root leaf is sampled with probability 1.
    let bvh = LightBvh::build(&[bounds]);
    assert_eq!(
        light_bvh_sample(&bvh.nodes, Vec3::ZERO, Vec3::Y, 0.3),
        Some((0, 1.0))
    );
}

#[test]
fn spot_importance_is_zero_outside_the_outer_cone() {
    let bounds = LightBounds::spot(Vec3::ZERO, Vec3::Z, 1.0, 0.5f32.cos(), 0.7f32.cos());
    for i in 0..2000 {
        let d = unit(rng_uniform4(23, i, 0, 0));
        let angle = d.z.clamp(-1.0, 1.0).acos();
        let x = importance(&bounds, d * 2.0, Vec3::ZERO);
        if angle < 0.7 - 1e-3 {
            assert!(x > 0.0, "angle {angle}: importance {x}");
        } else if angle > 0.7 + 1e-3 {
            assert_eq!(x, 0.0, "angle {angle}");
        }
    }
}

#[test]
fn depth_stays_within_31_levels() {
    let count = 100_000u32;
    let row: Vec<LightBounds> = (0..count)
        .map(|i| LightBounds::point(Vec3::new(i as f32, 0.0, 0.0), 1.0))
        .collect();
    let one_point: Vec<LightBounds> = (0..count)
        .map(|i| LightBounds::point(Vec3::new(1.0, 2.0, 3.0), 1.0 + (i % 7) as f32))
        .collect();
    // Points crowding towards the origin in halving steps, the rest at the origin: each binned
    // split can peel off only the few points in the upper buckets.
    let crowded: Vec<LightBounds> = (0..count)
        .map(|i| {
            let x = if i < 140 { 0.5f32.powi(i as i32) } else { 0.0 };
            LightBounds::point(Vec3::new(x, x, 0.5 * x), 1.0)
        })
        .collect();
    // One-sided triangles all in one place and all facing one way: zero-area clusters.
    let stacked: Vec<LightBounds> = (0..count)
        .map(|_| LightBounds::triangle(Vec3::ZERO, Vec3::X, Vec3::Y, 1.0, false))
        .collect();
    for (name, lights) in [
        ("row", &row),
        ("one point", &one_point),
        ("crowded", &crowded),
        ("stacked", &stacked),
    ] {
        let bvh = LightBvh::build(lights);
        let depth = bvh.depth();
        println!("{name}: {} nodes, depth {depth}", bvh.nodes.len());
        assert!(depth <= MAX_LIGHT_BVH_DEPTH, "{name}: depth {depth}");
        check_structure(&bvh, lights);
        for &t in &bvh.trails {
            assert_eq!(t >> MAX_LIGHT_BVH_DEPTH, 0);
        }
    }
}

#[test]
fn empty_and_powerless_inputs() {
    let empty = LightBvh::build(&[]);
    assert!(empty.nodes.is_empty() && empty.trails.is_empty());
    assert_eq!(
        light_bvh_sample(&empty.nodes, Vec3::ZERO, Vec3::Z, 0.5),
        None
    );
    assert_eq!(
        light_bvh_pmf(&empty.nodes, &empty.trails, Vec3::ZERO, Vec3::Z, 0),
        0.0
    );

    let mut lights = vec![
        LightBounds::point(Vec3::ZERO, 0.0),
        LightBounds::point(Vec3::X, 2.0),
        LightBounds::point(Vec3::Y, f32::NAN),
        LightBounds::point(Vec3::splat(f32::INFINITY), 1.0),
        LightBounds::triangle(Vec3::ZERO, Vec3::X, Vec3::X * 2.0, 1.0, false),
    ];
    lights.push(LightBounds::point(Vec3::Z, -1.0));
    let bvh = LightBvh::build(&lights);
    check_structure(&bvh, &lights);
    assert_eq!(
        bvh.nodes.len(),
        3,
        "the point at x and the degenerate triangle"
    );
    let p = Vec3::new(0.5, 3.0, 0.0);
    let total: f32 = (0..lights.len() as u32)
        .map(|l| light_bvh_pmf(&bvh.nodes, &bvh.trails, p, Vec3::ZERO, l))
        .sum();
    assert!((total - 1.0).abs() < 1e-6);
    assert_eq!(
        light_bvh_pmf(&bvh.nodes, &bvh.trails, p, Vec3::ZERO, 0),
        0.0
    );
    assert_eq!(
        light_bvh_pmf(&bvh.nodes, &bvh.trails, p, Vec3::ZERO, 99),
        0.0
    );

    let none = LightBvh::build(&[LightBounds::point(Vec3::ZERO, 0.0)]);
    assert!(none.nodes.is_empty());
    assert_eq!(none.trails, vec![NO_LIGHT_TRAIL]);
}

#[test]
fn cone_union_holds_both_cones() {
    for i in 0..6000 {
        let a = unit(rng_uniform4(31, i, 0, 0));
        let t = rng_uniform4(31, i, 2, 0);
        // Random axes, then axes one rounding apart, then opposite axes.
        let b = match i % 3 {
            0 => unit(rng_uniform4(31, i, 1, 0)),
            1 => (a + Vec3::splat(1e-7)).normalize(),
            _ => -a,
        };
        // Half-angles as their f32 cosines hold them (cos loses angles below ~3e-4).
        let (ta, tb) = ((t.x * PI).cos().acos(), (t.y * PI).cos().acos());
        let (w, cos) = cone_union(a, ta.cos(), b, tb.cos());
        let theta = cos.clamp(-1.0, 1.0).acos();
        assert!((w.length() - 1.0).abs() < 1e-5);
        let whole_sphere = cos == -1.0;
        for (axis, spread) in [(a, ta), (b, tb)] {
            assert!(
                whole_sphere || angle_between(w, axis) + spread <= theta + 1e-4,
                "union ({w}, {theta}) of ({a}, {ta}) and ({b}, {tb})"
            );
        }
        // No wider than needed: the whole sphere only when the spread reaches π.
        let needed = (ta + angle_between(a, b) + tb) / 2.0;
        assert!(
            theta <= needed.max(ta).max(tb) + 1e-4,
            "union ({w}, {theta}) of ({a}, {ta}) and ({b}, {tb}), {needed} would do"
        );
    }
}

/// Build statistics for the record (not a timed test): `cargo test --release --lib
/// light_bvh_build_statistics -- --ignored --nocapture`. Also, on scenes/many-lights.gltf, how
/// often floor points pick one of the emitters that face up (away from every surface) and the
/// mean dead-end probability, against choosing by power alone.
#[test]
#[ignore]
fn light_bvh_build_statistics() {
    for count in [10_000u32, 100_000] {
        let (_, lights) = random_scene(count, 41);
        let start = std::time::Instant::now();
        let bvh = LightBvh::build(&lights);
        let elapsed = start.elapsed();
        println!(
            "{count} random lights: built in {:.1} ms, {} nodes, depth {}",
            elapsed.as_secs_f64() * 1e3,
            bvh.nodes.len(),
            bvh.depth()
        );
    }

    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/many-lights.gltf");
    let scene = crate::scene::Scene::load(&path).unwrap();
    let (mut lights, mut facing_up) = (Vec::new(), Vec::new());
    for t in &scene.triangles {
        let m = &scene.materials[t.material as usize];
        if m.emission == Vec3::ZERO {
            continue;
        }
        let normal = (t.p[1] - t.p[0]).cross(t.p[2] - t.p[0]);
        let area = 0.5 * normal.length();
        let power = crate::lights::emitted_power(m.emission, area, m.double_sided);
        lights.push(LightBounds::triangle(
            t.p[0],
            t.p[1],
            t.p[2],
            power,
            m.double_sided,
        ));
        facing_up.push(normal.y > 0.0 && !m.double_sided);
    }
    let start = std::time::Instant::now();
    let bvh = LightBvh::build(&lights);
    println!(
        "many-lights.gltf: {} emitters, built in {:.1} ms, {} nodes, depth {}",
        lights.len(),
        start.elapsed().as_secs_f64() * 1e3,
        bvh.nodes.len(),
        bvh.depth()
    );
    let total: f64 = lights.iter().map(|l| l.phi as f64).sum();
    let up_by_power: f64 = lights
        .iter()
        .zip(&facing_up)
        .filter(|(_, &up)| up)
        .map(|(l, _)| l.phi as f64)
        .sum::<f64>()
        / total;
    let (mut up_by_bvh, mut dead) = (0.0, 0.0);
    let points = 200;
    for i in 0..points {
        let a = rng_uniform4(43, i, 0, 0);
        let p = Vec3::new(16.0 * a.x - 8.0, 0.0, 10.0 * a.y - 7.0);
        for (l, _) in facing_up.iter().enumerate().filter(|(_, &up)| up) {
            up_by_bvh += light_bvh_pmf(&bvh.nodes, &bvh.trails, p, Vec3::Y, l as u32) as f64;
        }
        dead += dead_end_probability(&bvh.nodes, p, Vec3::Y);
    }
    println!(
        "floor points pick an up-facing emitter with probability {:.5} (by power: {up_by_power:.3}); \
         mean dead-end probability {:.5}",
        up_by_bvh / points as f64,
        dead / points as f64
    );
}

/// Every node's stored constants are its own bounds' (the importance reads them instead of
/// computing them): the bounding sphere's radius, half the box's diagonal, and sin θo, bit for
/// bit, on random trees and on the single-leaf tree.
#[test]
fn node_constants_are_their_bounds() {
    for (count, seed) in [(1, 0), (2, 1), (40, 2), (300, 3)] {
        let (_, lights) = random_scene(count, seed);
        for (k, node) in LightBvh::build(&lights).nodes.iter().enumerate() {
            let diagonal = Vec3::from(node.bounds_max) - Vec3::from(node.bounds_min);
            let sin_theta_o = (1.0 - node.cos_theta_o * node.cos_theta_o).max(0.0).sqrt();
            assert_eq!(
                node.radius.to_bits(),
                (diagonal.length() * 0.5).to_bits(),
                "node {k} of {count}: radius"
            );
            assert_eq!(
                node.sin_theta_o.to_bits(),
                sin_theta_o.to_bits(),
                "node {k} of {count}: sin θo"
            );
        }
    }
}

/// The premise of `LightBvh::power_alike`: lights of one box and cone (a quad's two triangles,
/// and a third coplanar one with the same box) get their power share as their pmf through the
/// tree at every point, so a render samples them by power instead; moving one light's box
/// makes the tree tell them apart.
#[test]
fn lights_of_one_box_and_cone_get_their_power_share() {
    let (a, b, c, d) = (
        Vec3::new(-0.3, 0.9, -0.2),
        Vec3::new(0.3, 0.9, -0.2),
        Vec3::new(0.3, 0.9, 0.2),
        Vec3::new(-0.3, 0.9, 0.2),
    );
    // Downward-facing, as a ceiling light: (p1 − p0) × (p2 − p0) points along −y.
    let quad = [
        LightBounds::triangle(a, b, c, 1.0, false),
        LightBounds::triangle(a, c, d, 3.0, false),
        LightBounds::triangle(b, c, d, 0.5, false),
    ];
    assert!(quad.iter().all(|l| l.w == Vec3::NEG_Y), "{quad:?}");
    let bvh = LightBvh::build(&quad);
    assert!(bvh.power_alike);
    let total: f32 = quad.iter().map(|l| l.phi).sum();
    let mut lit = 0;
    for i in 0..2000 {
        let (p, n) = random_point(5, i);
        for (k, light) in quad.iter().enumerate() {
            let pmf = light_bvh_pmf(&bvh.nodes, &bvh.trails, p, n, k as u32);
            if pmf > 0.0 {
                lit += 1;
                let share = light.phi / total;
                // Rounding only: the walk multiplies per-level ratios of sums of products.
                assert!(
                    (pmf - share).abs() <= 4.0 * f32::EPSILON * share,
                    "{p} {n}: light {k}: {pmf} against {share}"
                );
            }
        }
    }
    assert!(lit > 1000, "too few points lit: {lit}");

    let mut moved = quad;
    moved[2].bounds_min += Vec3::new(0.0, 0.0, 0.1);
    assert!(!LightBvh::build(&moved).power_alike);
    let mut turned = quad;
    turned[1].two_sided = true;
    assert!(!LightBvh::build(&turned).power_alike);
}

/// The tree as one thread builds it, written out: each node pushed before its subtrees, the
/// second child's index where the first's subtree ends, each leaf's trail set on the way down.
fn sequential_build(lights: &[LightBounds]) -> (Vec<GpuLightNode>, Vec<u32>) {
    fn node(
        nodes: &mut Vec<GpuLightNode>,
        trails: &mut [u32],
        lights: &mut [BuildLight],
        depth: u32,
        trail: u32,
    ) -> LightBounds {
        let index = nodes.len();
        if let [light] = lights {
            nodes.push(GpuLightNode::leaf(&light.cluster.bounds, light.index));
            trails[light.index as usize] = trail;
            return light.cluster.bounds;
        }
        nodes.push(GpuLightNode::default());
        let mid = split(lights, depth);
        let (first, second) = lights.split_at_mut(mid);
        let a = node(nodes, trails, first, depth + 1, trail);
        let second_index = nodes.len() as u32;
        let b = node(nodes, trails, second, depth + 1, trail | (1 << depth));
        let bounds = union(&a, &b);
        nodes[index] = GpuLightNode::interior(&bounds, second_index);
        bounds
    }
    let mut build = build_lights(lights);
    let (mut nodes, mut trails) = (Vec::new(), vec![NO_LIGHT_TRAIL; lights.len()]);
    if !build.is_empty() {
        node(&mut nodes, &mut trails, &mut build, 0, 0);
    }
    (nodes, trails)
}

/// Built with its large subtrees on separate threads, on pools of 1, 2 and 5 threads, the tree
/// is the one-thread tree bit for bit: the same nodes in the same places, the same trails.
#[test]
fn parallel_build_equals_sequential_build() {
    for (count, seed) in [(1, 3), (2, 4), (2047, 5), (2048, 6), (9000, 7)] {
        let (_, mut lights) = random_scene(count, seed);
        // Some lights powerless: left out of the tree, with no trail.
        for l in lights.iter_mut().step_by(17) {
            l.phi = 0.0;
        }
        let (want_nodes, want_trails) = sequential_build(&lights);
        for threads in [1, 2, 5] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let bvh = pool.install(|| LightBvh::build(&lights));
            assert_eq!(
                bytemuck::cast_slice::<_, u8>(&bvh.nodes),
                bytemuck::cast_slice::<_, u8>(&want_nodes),
                "{count} lights, {threads} threads: nodes differ"
            );
            assert_eq!(bvh.trails, want_trails, "{count} lights, {threads} threads");
        }
    }
}
