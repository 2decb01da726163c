use super::binary::{bvh_slab, bvh_slab_min_max, SlabRay};
use super::*;
use crate::layout::{BvhNode, GpuTriangle};
use glam::{BVec3, Vec3};

/// PCG32 (O'Neill 2014): deterministic test data without a crate.
struct Pcg(u64);

impl Pcg {
    const MUL: u64 = 6364136223846793005;
    const INC: u64 = 1442695040888963407;
    fn new(seed: u64) -> Pcg {
        Pcg(seed.wrapping_mul(Self::MUL).wrapping_add(Self::INC))
    }
    fn next_u32(&mut self) -> u32 {
        let old = self.0;
        self.0 = old.wrapping_mul(Self::MUL).wrapping_add(Self::INC);
        ((((old >> 18) ^ old) >> 27) as u32).rotate_right((old >> 59) as u32)
    }
    fn below(&mut self, n: u32) -> u32 {
        self.next_u32() % n
    }
    fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * ((self.next_u32() >> 8) as f32 / 16777216.0)
    }
    fn vec3(&mut self, lo: f32, hi: f32) -> Vec3 {
        Vec3::new(self.range(lo, hi), self.range(lo, hi), self.range(lo, hi))
    }
}

#[derive(Clone, Copy)]
enum Kind {
    Uniform,
    Clustered,
    Thin,
    SameCentroid,
    Duplicated,
    Flat,
}
const ALL_KINDS: &[Kind] = &[
    Kind::Uniform,
    Kind::Clustered,
    Kind::Thin,
    Kind::SameCentroid,
    Kind::Duplicated,
    Kind::Flat,
];
/// The plane z = FLAT_Z holds every `Kind::Flat` triangle.
const FLAT_Z: f32 = 0.25;

fn soup(rng: &mut Pcg, n: usize, kinds: &[Kind]) -> Vec<[Vec3; 3]> {
    let clusters: Vec<Vec3> = (0..4).map(|_| rng.vec3(-1.0, 1.0)).collect();
    let mut tris: Vec<[Vec3; 3]> = Vec::with_capacity(n);
    for i in 0..n {
        let tri = match kinds[i % kinds.len()] {
            Kind::Uniform => {
                let c = rng.vec3(-1.0, 1.0);
                [
                    c + rng.vec3(-0.1, 0.1),
                    c + rng.vec3(-0.1, 0.1),
                    c + rng.vec3(-0.1, 0.1),
                ]
            }
            Kind::Clustered => {
                let c = clusters[rng.below(4) as usize] + rng.vec3(-0.02, 0.02);
                [
                    c + rng.vec3(-0.01, 0.01),
                    c + rng.vec3(-0.01, 0.01),
                    c + rng.vec3(-0.01, 0.01),
                ]
            }
            Kind::Thin => {
                let (a, b) = (rng.vec3(-1.0, 1.0), rng.vec3(-1.0, 1.0));
                [a, b, a + rng.vec3(-0.005, 0.005)]
            }
            // Bounds symmetric about 0: every centroid is exactly the origin.
            Kind::SameCentroid => {
                let s = rng.vec3(0.01, 0.5);
                [
                    -s,
                    s,
                    Vec3::new(
                        rng.range(-s.x, s.x),
                        rng.range(-s.y, s.y),
                        rng.range(-s.z, s.z),
                    ),
                ]
            }
            Kind::Duplicated if !tris.is_empty() => {
                let [a, b, c] = tris[rng.below(tris.len() as u32) as usize];
                if rng.below(2) == 0 {
                    [a, b, c]
                } else {
                    [b, c, a]
                }
            }
            Kind::Duplicated => [Vec3::ZERO, Vec3::X, Vec3::Y],
            Kind::Flat => {
                let c = rng.vec3(-1.0, 1.0).with_z(FLAT_Z);
                let mut corner = || c + rng.vec3(-0.2, 0.2).with_z(0.0);
                [corner(), corner(), corner()]
            }
        };
        tris.push(tri);
    }
    tris
}

/// Origins inside and outside the bounds; some direction components exactly 0, some rays in
/// the flat plane or on a box face (a vertex coordinate) along it.
fn random_ray(rng: &mut Pcg, tris: &[[Vec3; 3]], lo: Vec3, hi: Vec3) -> Ray {
    let size = hi - lo;
    let mut origin = if rng.below(2) == 0 {
        lo + size * rng.vec3(0.0, 1.0)
    } else {
        lo - size + 3.0 * size * rng.vec3(0.0, 1.0)
    };
    // Aim at a point of a random triangle half the time, anywhere in the bounds otherwise.
    let target = if rng.below(2) == 0 {
        let [a, b, c] = tris[rng.below(tris.len() as u32) as usize];
        let (u, v) = (rng.range(0.0, 1.0), rng.range(0.0, 1.0));
        let (u, v) = if u + v > 1.0 {
            (1.0 - u, 1.0 - v)
        } else {
            (u, v)
        };
        a + u * (b - a) + v * (c - a)
    } else {
        lo + size * rng.vec3(0.0, 1.0)
    };
    let mut dir = (target - origin) * rng.range(0.1, 10.0);
    match rng.below(10) {
        0 | 1 => dir[rng.below(3) as usize] = 0.0,
        2 => {
            let keep = rng.below(3) as usize;
            dir = Vec3::select(
                BVec3::new(keep == 0, keep == 1, keep == 2),
                dir,
                -Vec3::ZERO,
            );
        }
        3 => {
            origin.z = FLAT_Z;
            dir.z = 0.0;
        }
        4 => {
            let axis = rng.below(3) as usize;
            origin[axis] = tris[rng.below(tris.len() as u32) as usize][rng.below(3) as usize][axis];
            dir[axis] = 0.0;
        }
        _ => {}
    }
    if dir == Vec3::ZERO {
        dir = Vec3::Y;
    }
    Ray { origin, dir }
}

fn brute_closest(tris: &[GpuTriangle], ray: &Ray, t_min: f32, t_max: f32) -> Option<Hit> {
    let mut closest = None;
    let mut t_far = t_max;
    for (i, tri) in tris.iter().enumerate() {
        if let Some((t, u, v)) = intersect_triangle(tri, ray, t_min, t_far) {
            t_far = t;
            closest = Some(Hit {
                t,
                triangle: i as u32,
                u,
                v,
            });
        }
    }
    closest
}

fn brute_any(tris: &[GpuTriangle], ray: &Ray, t_min: f32, t_max: f32) -> bool {
    tris.iter()
        .any(|tri| intersect_triangle(tri, ray, t_min, t_max).is_some())
}

/// Structure: depth-first numbering, every triangle in exactly one leaf, exact and nested
/// bounds, stats that agree with the nodes.
fn validate(bvh: &Bvh, tris: &[[Vec3; 3]]) {
    if tris.is_empty() {
        assert_eq!(bvh.nodes.len(), 1);
        assert!(bvh.is_empty() && bvh.order.is_empty());
        return;
    }
    assert!(!bvh.is_empty());
    let mut sorted = bvh.order.clone();
    sorted.sort_unstable();
    assert!(
        sorted.iter().enumerate().all(|(i, &o)| i as u32 == o),
        "order is a permutation"
    );

    let mut covered = vec![0u32; tris.len()];
    let (mut visited, mut leaves, mut max_depth, mut max_leaf) = (0, 0, 0, 0);
    let mut stack = vec![(0u32, 0usize, None::<BvhNode>)];
    while let Some((index, depth, parent)) = stack.pop() {
        // Pre-order with the left child first must visit 0, 1, 2, …
        assert_eq!(index as usize, visited, "depth-first flattening");
        visited += 1;
        let node = bvh.nodes[index as usize];
        let (bmin, bmax) = (Vec3::from(node.bounds_min), Vec3::from(node.bounds_max));
        if let Some(p) = parent {
            assert!(bmin.cmpge(p.bounds_min.into()).all() && bmax.cmple(p.bounds_max.into()).all());
        }
        if node.is_leaf() {
            leaves += 1;
            max_depth = max_depth.max(depth);
            max_leaf = max_leaf.max(node.count as usize);
            let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for i in node.first_triangle()..node.first_triangle() + node.count {
                covered[i as usize] += 1;
                for p in tris[bvh.order[i as usize] as usize] {
                    (lo, hi) = (lo.min(p), hi.max(p));
                }
            }
            assert_eq!(
                (lo, hi),
                (bmin, bmax),
                "leaf bounds are the exact union of its triangles"
            );
        } else {
            assert!(node.right_child() > index + 1);
            stack.push((node.right_child(), depth + 1, Some(node)));
            stack.push((index + 1, depth + 1, Some(node)));
        }
    }
    assert_eq!(visited, bvh.nodes.len(), "every node reachable once");
    assert!(
        covered.iter().all(|&c| c == 1),
        "every triangle in exactly one leaf"
    );
    let s = &bvh.stats;
    assert_eq!(
        (s.nodes, s.leaves, s.max_depth, s.max_leaf_size),
        (visited, leaves, max_depth, max_leaf)
    );
    assert_eq!(s.nodes, 2 * s.leaves - 1);
    assert!(s.max_depth <= MAX_DEPTH);
    assert!(s.max_leaf_size <= MAX_LEAF_SIZE);
    assert_eq!(s.sah_cost, sah_cost(&bvh.nodes));
}

/// Builds, validates, and compares both traversals with brute force on `rays` random rays.
/// Returns the BVH and how many closest-hit queries hit.
fn check(tris: &[[Vec3; 3]], rays: usize, seed: u64) -> (Bvh, usize) {
    let bvh = Bvh::build(tris);
    validate(&bvh, tris);
    let wide = WideBvh::collapse(&bvh.nodes, &[0]);
    validate_wide(&bvh, &wide);
    let quant = wide.quantized();
    let gpu = gpu_triangles(tris, &[], &bvh.order);
    let (mut lo, mut hi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    for p in tris.iter().flatten() {
        (lo, hi) = (lo.min(*p), hi.max(*p));
    }
    // Padded, so that a flat soup still gets rays from off its plane.
    let pad = Vec3::splat(0.1 * (hi - lo).max_element());
    let (lo, hi) = (lo - pad, hi + pad);
    let mut rng = Pcg::new(seed);
    let mut hits = 0;
    for _ in 0..rays {
        let ray = random_ray(&mut rng, tris, lo, hi);
        let t_min = [0.0, 1e-4, -1.0][rng.below(3) as usize];
        let t_max = [f32::INFINITY, f32::MAX, rng.range(0.0, 2.0)][rng.below(3) as usize];
        let got = bvh.intersect_closest(&gpu, &ray, t_min, t_max);
        let want = brute_closest(&gpu, &ray, t_min, t_max);
        // The wide walk finds the binary walk's hit: the same t and, unless another triangle
        // lies at exactly that distance, the same triangle and (u, v).
        let (wide_hit, ..) = closest_triangle(&wide, 0, &gpu, &ray, t_min, t_max, |_, _, _| true);
        match (wide_hit, got) {
            (Some(w), Some(g)) if w.triangle != g.triangle => assert_eq!(w.t, g.t),
            _ => assert_eq!(wide_hit, got, "wide: {ray:?} ({t_min}, {t_max})"),
        }
        // So does the walk of its quantised boxes, which contain the binary tree's.
        let (quant_hit, ..) = closest_triangle(&quant, 0, &gpu, &ray, t_min, t_max, |_, _, _| true);
        match (quant_hit, got) {
            (Some(q), Some(g)) if q.triangle != g.triangle => assert_eq!(q.t, g.t),
            _ => assert_eq!(quant_hit, got, "quantised: {ray:?} ({t_min}, {t_max})"),
        }
        match (got, want) {
            (None, None) => {}
            (Some(g), Some(w)) => {
                hits += 1;
                assert_eq!(g.t.to_bits(), w.t.to_bits(), "{ray:?}: {g:?} vs {w:?}");
                if g.triangle == w.triangle {
                    assert_eq!(g, w);
                }
            }
            _ => panic!("{ray:?} ({t_min}, {t_max}): bvh {got:?}, brute force {want:?}"),
        }
        // Shadow-ray range ending just before or after the closest hit, or anywhere.
        let t_max = match want {
            Some(w) if rng.below(2) == 0 => w.t * rng.range(0.9, 1.1),
            _ => rng.range(0.0, 3.0),
        };
        assert_eq!(
            bvh.intersect_any(&gpu, &ray, t_min, t_max),
            brute_any(&gpu, &ray, t_min, t_max),
            "{ray:?} ({t_min}, {t_max})"
        );
        assert_eq!(
            any_triangle(&wide, 0, &gpu, &ray, t_min, t_max, |_, _, _| true),
            brute_any(&gpu, &ray, t_min, t_max),
            "wide: {ray:?} ({t_min}, {t_max})"
        );
        assert_eq!(
            any_triangle(&quant, 0, &gpu, &ray, t_min, t_max, |_, _, _| true),
            brute_any(&gpu, &ray, t_min, t_max),
            "quantised: {ray:?} ({t_min}, {t_max})"
        );
    }
    (bvh, hits)
}

/// The wide collapse holds every leaf of the binary tree once with its box, and its other boxes
/// are boxes of the binary tree's interior nodes (those it did not open).
fn validate_wide(bvh: &Bvh, wide: &WideBvh) {
    let key = |(lo, hi, leaf): ([f32; 3], [f32; 3], Option<(u32, u32)>)| {
        (lo.map(f32::to_bits), hi.map(f32::to_bits), leaf)
    };
    let binary: Vec<_> = bvh
        .nodes
        .iter()
        .map(|n| {
            let leaf = n.is_leaf().then(|| (n.first_triangle(), n.count));
            key((n.bounds_min, n.bounds_max, leaf))
        })
        .collect();
    let slots: Vec<_> = wide.boxes(0).into_iter().map(key).collect();
    let leaves = |boxes: &[_]| {
        let mut l: Vec<_> = boxes
            .iter()
            .filter(|b: &&(_, _, Option<_>)| b.2.is_some())
            .copied()
            .collect();
        l.sort_unstable();
        l
    };
    assert_eq!(
        leaves(&slots),
        leaves(&binary),
        "the same leaves and leaf boxes"
    );
    let interior: std::collections::HashSet<_> = binary.iter().filter(|b| b.2.is_none()).collect();
    assert!(
        slots
            .iter()
            .filter(|b| b.2.is_none())
            .all(|b| interior.contains(b)),
        "every interior slot's box is a binary node's"
    );
    assert!(wide.nodes.len() <= (bvh.nodes.len() - bvh.stats.leaves).max(1));
    // The wide nodes are the plan's: their boxes' half areas sum to its cost. The two sums add
    // the same f32 areas in different orders; each of their n − 1 additions rounds by at most
    // 2⁻²⁴ of the running sum (n < 2¹⁶ here), hence the bound.
    if !bvh.nodes[0].is_leaf() && !bvh.is_empty() {
        let areas: Vec<f64> = wide.nodes.iter().map(wide_node_half_area).collect();
        let sum: f64 = areas.iter().sum();
        let plan = wide::Plan::cost_of(&bvh.nodes) as f64;
        let bound = areas.len() as f64 * 2f64.powi(-24) * sum;
        assert!((plan - sum).abs() <= bound, "plan {plan}, wide nodes {sum}");
    }
}

/// The half area of the box around a wide node's slots (the binary node it collapses).
fn wide_node_half_area(w: &wide::WideNode) -> f64 {
    let (bounds, _, _, valid) = w.parts();
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for s in (0..wide::WIDTH).filter(|s| valid & (1 << s) != 0) {
        for a in 0..3 {
            lo[a] = lo[a].min(bounds[0][a][s]);
            hi[a] = hi[a].max(bounds[1][a][s]);
        }
    }
    let d = [0, 1, 2].map(|a| (hi[a] - lo[a]) as f64);
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

/// Binary node `i`'s half area, as the collapse's plan takes it.
fn node_half_area(n: &BvhNode) -> f64 {
    super::build::node_half_area(n) as f64
}

/// The least sum of wide-node half areas of the collapse of the subtree at interior node `i`,
/// by enumerating, for each wide node, every set of at most four binary nodes reachable by
/// opening interior nodes below it — not the plan's slot-budget recursion.
fn brute_collapse(
    nodes: &[BvhNode],
    i: u32,
    memo: &mut std::collections::HashMap<u32, f64>,
) -> f64 {
    if let Some(&c) = memo.get(&i) {
        return c;
    }
    let children = |j: u32| [j + 1, nodes[j as usize].right_child()];
    let mut seen = std::collections::HashSet::new();
    let mut todo = vec![children(i).to_vec()];
    let mut best = f64::INFINITY;
    while let Some(set) = todo.pop() {
        if !seen.insert(set.clone()) {
            continue;
        }
        let below: f64 = set
            .iter()
            .filter(|&&j| !nodes[j as usize].is_leaf())
            .map(|&j| brute_collapse(nodes, j, memo))
            .sum();
        best = best.min(below);
        if set.len() < wide::WIDTH {
            for (k, &j) in set.iter().enumerate() {
                if !nodes[j as usize].is_leaf() {
                    let mut next = set.clone();
                    next.splice(k..=k, children(j));
                    todo.push(next);
                }
            }
        }
    }
    let c = node_half_area(&nodes[i as usize]) + best;
    memo.insert(i, c);
    c
}

/// The same sum for the greedy collapse that opens the largest interior node first.
fn greedy_collapse(nodes: &[BvhNode], i: u32) -> f64 {
    let children = |j: u32| [j + 1, nodes[j as usize].right_child()];
    let mut open = children(i).to_vec();
    while open.len() < wide::WIDTH {
        let largest = (0..open.len())
            .filter(|&k| !nodes[open[k] as usize].is_leaf())
            .max_by(|&a, &b| {
                node_half_area(&nodes[open[a] as usize])
                    .total_cmp(&node_half_area(&nodes[open[b] as usize]))
            });
        let Some(k) = largest else { break };
        let j = open[k];
        open.splice(k..=k, children(j));
    }
    node_half_area(&nodes[i as usize])
        + open
            .iter()
            .filter(|&&j| !nodes[j as usize].is_leaf())
            .map(|&j| greedy_collapse(nodes, j))
            .sum::<f64>()
}

/// The collapse's plan is the least sum of wide-node areas there is (the SAH cost of the wide
/// walk, whose leaves are fixed), found by enumerating every collapse of small random trees,
/// and never more than the greedy collapse's (largest node opened first), which it beats on
/// some. The plan sums f32 areas: at most 2⁻²⁴ of the sum per addition, fewer than 2⁸ here.
#[test]
fn collapse_is_the_least_sum_of_wide_node_areas() {
    let mut rng = Pcg::new(11);
    let (mut trees, mut better) = (0, 0);
    for n in 3..60usize {
        let kinds: &[Kind] = if n % 2 == 0 {
            ALL_KINDS
        } else {
            &[Kind::Uniform]
        };
        let tris = soup(&mut rng, n, kinds);
        let bvh = Bvh::build(&tris);
        if bvh.nodes[0].is_leaf() {
            continue;
        }
        let plan = wide::Plan::cost_of(&bvh.nodes) as f64;
        let brute = brute_collapse(&bvh.nodes, 0, &mut Default::default());
        let greedy = greedy_collapse(&bvh.nodes, 0);
        let bound = bvh.nodes.len() as f64 * 2f64.powi(-24) * brute;
        assert!(
            (plan - brute).abs() <= bound,
            "{n} triangles: plan {plan}, least {brute}"
        );
        assert!(
            brute <= greedy * (1.0 + 1e-12),
            "{n} triangles: least {brute}, greedy {greedy}"
        );
        trees += 1;
        better += usize::from(brute < greedy * (1.0 - 1e-6));
    }
    assert!(
        trees > 40 && better > 5,
        "{trees} trees, {better} better than greedy"
    );
}

#[test]
fn matches_brute_force_on_random_soups() {
    let mut rng = Pcg::new(1);
    for (n, kinds) in [
        (1, ALL_KINDS),
        (2, ALL_KINDS),
        (7, ALL_KINDS),
        (100, ALL_KINDS),
        (5000, ALL_KINDS),
        (5000, &[Kind::Uniform][..]),
        (300, &[Kind::Clustered][..]),
        (300, &[Kind::Thin][..]),
        (300, &[Kind::SameCentroid][..]),
        (300, &[Kind::Duplicated][..]),
        (300, &[Kind::Flat][..]),
    ] {
        let tris = soup(&mut rng, n, kinds);
        let (bvh, hits) = check(&tris, 4000, n as u64);
        assert!(
            hits > 500,
            "{n} triangles: only {hits} hits, the test is too weak"
        );
        if n == 5000 {
            println!("{n} triangles, {} kinds: {:?}", kinds.len(), bvh.stats);
        }
    }
}

#[test]
fn empty_input_misses() {
    let bvh = Bvh::build(&[]);
    // Its wide collapse has no root: both walks miss.
    let wide = WideBvh::collapse(&bvh.nodes, &[0]);
    assert!(wide.nodes.is_empty());
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::X,
    };
    assert!(
        closest_triangle(&wide, 0, &[], &ray, 0.0, f32::MAX, |_, _, _| true)
            .0
            .is_none()
    );
    assert!(!any_triangle(
        &wide,
        0,
        &[],
        &ray,
        0.0,
        f32::MAX,
        |_, _, _| true
    ));
    validate(&bvh, &[]);
    let ray = Ray {
        origin: Vec3::ZERO,
        dir: Vec3::X,
    };
    assert_eq!(bvh.intersect_closest(&[], &ray, 0.0, f32::MAX), None);
    assert!(!bvh.intersect_any(&[], &ray, 0.0, f32::MAX));
}

#[test]
fn identical_triangles_make_bounded_leaves() {
    let tris = vec![[Vec3::ZERO, Vec3::X, Vec3::Y]; 10_000];
    let (bvh, hits) = check(&tris, 200, 3);
    assert!(hits > 0);
    assert!(bvh.stats.max_depth <= 12, "{:?}", bvh.stats);
}

#[test]
fn depth_stays_bounded_on_geometric_spacing() {
    // Sizes and gaps growing geometrically: the SAH peels a few triangles per level.
    let tris: Vec<[Vec3; 3]> = (0..2000)
        .map(|k| {
            let x = 1.02f32.powi(k);
            [
                Vec3::new(x, 0.0, 0.0),
                Vec3::new(x * 1.01, 0.0, 0.0),
                Vec3::new(x, x * 0.01, 0.01),
            ]
        })
        .collect();
    let (bvh, _) = check(&tris, 2000, 4);
    assert!(bvh.stats.max_depth <= MAX_DEPTH, "{:?}", bvh.stats);
}

#[test]
fn builds_a_million_triangles() {
    let tris = soup(
        &mut Pcg::new(5),
        1_000_000,
        &[Kind::Uniform, Kind::Thin, Kind::Clustered],
    );
    let (bvh, _) = check(&tris, 20, 6);
    println!("1M triangles: {:?}", bvh.stats);
}

/// The sign-selected slab test `bvh_slab` takes for rays with no still axis gives the answer of
/// `bvh_slab_min_max` (the form `bvh.glsl` runs) for every box and ray: boxes and origins on a
/// coarse grid, so origins on box faces, flat boxes and equal entry distances occur often, and
/// directions with tiny, huge and negative components.
#[test]
fn sign_selected_slab_equals_min_max_slab() {
    let mut rng = Pcg::new(17);
    let grid = |rng: &mut Pcg| (rng.below(9) as f32 - 4.0) * 0.5;
    let component = |rng: &mut Pcg| {
        let magnitude = match rng.below(4) {
            0 => f32::MIN_POSITIVE * rng.range(1.0, 4.0),
            1 => 1e30 * rng.range(0.5, 2.0),
            _ => rng.range(0.01, 4.0),
        };
        if rng.below(2) == 0 {
            magnitude
        } else {
            -magnitude
        }
    };
    let mut hits = 0;
    for _ in 0..200_000 {
        let (a, b) = (
            Vec3::new(grid(&mut rng), grid(&mut rng), grid(&mut rng)),
            Vec3::new(grid(&mut rng), grid(&mut rng), grid(&mut rng)),
        );
        let node = BvhNode {
            bounds_min: a.min(b).into(),
            offset: 0,
            bounds_max: a.max(b).into(),
            count: 1,
        };
        let ray = Ray {
            origin: Vec3::new(grid(&mut rng), grid(&mut rng), grid(&mut rng)),
            dir: Vec3::new(
                component(&mut rng),
                component(&mut rng),
                component(&mut rng),
            ),
        };
        let slab = SlabRay::new(&ray);
        assert!(slab.moving);
        let (t_min, t_max) = (rng.range(0.0, 0.5), rng.range(0.5, 8.0));
        // Signed zeros compare equal wherever the traversal uses an entry distance.
        let fast = bvh_slab(&node, &slab, t_min, t_max).map(|t| (t + 0.0).to_bits());
        let exact = bvh_slab_min_max(&node, &slab, t_min, t_max).map(|t| (t + 0.0).to_bits());
        assert_eq!(fast, exact, "{node:?} {ray:?} ({t_min}, {t_max})");
        hits += fast.is_some() as u32;
    }
    // Both outcomes occur often enough for the comparison to mean something.
    assert!((2_000..198_000).contains(&hits), "{hits} hits");
}

/// The wide slab test is the binary one lane by lane: the same entry distance (bits) and the
/// same answer for each of four boxes, on rays with and without still axes.
#[test]
fn slab4_equals_bvh_slab_per_lane() {
    let mut rng = Pcg::new(23);
    let grid = |rng: &mut Pcg| (rng.below(9) as f32 - 4.0) * 0.5;
    let mut hits = 0;
    for _ in 0..50_000 {
        let nodes: Vec<BvhNode> = (0..4)
            .map(|_| {
                let a = Vec3::new(grid(&mut rng), grid(&mut rng), grid(&mut rng));
                let b = Vec3::new(grid(&mut rng), grid(&mut rng), grid(&mut rng));
                BvhNode {
                    bounds_min: a.min(b).into(),
                    offset: 0,
                    bounds_max: a.max(b).into(),
                    count: 1,
                }
            })
            .collect();
        // Root 0 with two interior children of two leaves each: one wide node of four slots.
        let mut tree = vec![nodes[0]; 7];
        tree[0].count = 0;
        tree[0].offset = 4;
        tree[1].count = 0;
        tree[1].offset = 3;
        tree[4].count = 0;
        tree[4].offset = 6;
        for (slot, &at) in [2usize, 3, 5, 6].iter().enumerate() {
            tree[at] = nodes[slot];
        }
        let wide = WideBvh::collapse(&tree, &[0]);
        assert_eq!(wide.nodes.len(), 1);
        let mut dir = Vec3::new(
            rng.range(-2.0, 2.0),
            rng.range(-2.0, 2.0),
            rng.range(-2.0, 2.0),
        );
        if rng.below(4) == 0 {
            dir[rng.below(3) as usize] = 0.0;
        }
        let ray = Ray {
            origin: Vec3::new(grid(&mut rng), grid(&mut rng), grid(&mut rng)),
            dir,
        };
        let (t_min, t_max) = (rng.range(0.0, 0.5), rng.range(0.5, 8.0));
        let (t_enter, mask) = wide::slab4(&wide.nodes[0], &wide::WideRay::new(&ray), t_min, t_max);
        let slab = SlabRay::new(&ray);
        for (slot, node) in nodes.iter().enumerate() {
            let want = bvh_slab(node, &slab, t_min, t_max).map(|t| (t + 0.0).to_bits());
            let got = (mask & (1 << slot) != 0).then(|| (t_enter[slot] + 0.0).to_bits());
            assert_eq!(
                got, want,
                "slot {slot}: {node:?} {ray:?} ({t_min}, {t_max})"
            );
            hits += want.is_some() as u32;
        }
    }
    assert!((10_000..190_000).contains(&hits), "{hits} hits");
}

/// `WideRay::new`'s one vector division and compare give `SlabRay::new`'s terms bit for bit:
/// the origin, the inverse direction (0 on still axes) and which axes are still, for
/// directions with zero, negative-zero, subnormal, tiny, huge, infinite and NaN components.
#[test]
fn wide_ray_equals_slab_ray() {
    let specials = [
        0.0,
        -0.0,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        f32::MIN_POSITIVE / 2.0,
        -f32::MIN_POSITIVE / 3.0,
        1e-30,
        -3e-38,
        1e30,
        -f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        1.0,
        -0.3,
    ];
    let mut rng = Pcg::new(7);
    let bits = |v: f32| if v.is_nan() { u32::MAX } else { v.to_bits() };
    for i in 0..20_000 {
        let mut pick = |k: u32| {
            if (i + k) % 3 == 0 {
                specials[rng.below(specials.len() as u32) as usize]
            } else {
                rng.range(-2.0, 2.0)
            }
        };
        let dir = Vec3::new(pick(0), pick(1), pick(2));
        let ray = Ray {
            origin: Vec3::new(
                rng.range(-9.0, 9.0),
                rng.range(-9.0, 9.0),
                rng.range(-9.0, 9.0),
            ),
            dir,
        };
        let slab = SlabRay::new(&ray);
        let (origin, inv_dir, still) = wide::WideRay::new(&ray).terms();
        for a in 0..3 {
            assert_eq!(
                origin[a].to_bits(),
                slab.origin[a].to_bits(),
                "{ray:?} axis {a}"
            );
            assert_eq!(bits(inv_dir[a]), bits(slab.inv_dir[a]), "{ray:?} axis {a}");
            assert_eq!(still[a], slab.still.test(a), "{ray:?} axis {a}");
        }
    }
}

/// A forest as the scene's node array holds one (the top level and the bottom levels one after
/// another, `tlas::append_blas`), and its roots.
fn forest(trees: &[&[BvhNode]]) -> (Vec<BvhNode>, Vec<u32>) {
    let mut nodes = Vec::new();
    let roots = trees
        .iter()
        .map(|tree| crate::tlas::append_blas(&mut nodes, tree.to_vec(), 0))
        .collect();
    (nodes, roots)
}

/// The plan solved tree by tree, large subtrees split between threads, is the one pass over
/// the whole array on one thread that it replaced: the same choices, wide node counts and root
/// costs, bit for bit, on trees large enough to be split (and small ones, leaves and the empty
/// tree, in a forest).
#[test]
fn parallel_plan_equals_one_pass() {
    let mut rng = Pcg::new(23);
    let big = Bvh::build(&soup(&mut rng, 40_000, ALL_KINDS));
    let uniform = Bvh::build(&soup(&mut rng, 20_000, &[Kind::Uniform]));
    let small = Bvh::build(&soup(&mut rng, 300, ALL_KINDS));
    let leaf = Bvh::build(&soup(&mut rng, 1, ALL_KINDS));
    let empty = Bvh::build(&[]);
    assert!(
        big.nodes.len() > 8 * wide::PARALLEL_NODES,
        "{}",
        big.nodes.len()
    );
    let (trees, _) = forest(&[
        &small.nodes,
        &big.nodes,
        &leaf.nodes,
        &empty.nodes,
        &uniform.nodes,
    ]);
    for nodes in [&big.nodes, &uniform.nodes, &small.nodes, &trees] {
        let (roots, choice, wide_nodes) = wide::Plan::solve(nodes);
        let (one_roots, one_choice, one_wide_nodes) = wide::Plan::solve_one_pass(nodes);
        let bits = |r: &[[(f32, u32); wide::WIDTH]]| -> Vec<_> {
            r.iter().flatten().map(|&(a, n)| (a.to_bits(), n)).collect()
        };
        assert_eq!(bits(&roots), bits(&one_roots), "root costs");
        assert!(choice == one_choice, "choices");
        assert!(wide_nodes == one_wide_nodes, "wide node counts");
    }
}

/// The collapse lays its wide nodes out depth first, each followed by its slots' subtrees in
/// slot order (the layout the recursion on one thread wrote), whichever thread wrote them, and
/// a forest's roots are its trees' collapses one after another.
#[test]
fn parallel_collapse_lays_out_nodes_depth_first() {
    let mut rng = Pcg::new(29);
    let big = Bvh::build(&soup(&mut rng, 120_000, ALL_KINDS));
    let small = Bvh::build(&soup(&mut rng, 300, ALL_KINDS));
    let leaf = Bvh::build(&soup(&mut rng, 1, ALL_KINDS));
    let empty = Bvh::build(&[]);
    let (nodes, roots) = forest(&[&small.nodes, &big.nodes, &empty.nodes, &leaf.nodes]);
    let wide = WideBvh::collapse(&nodes, &roots);
    assert!(
        wide.nodes.len() > 4 * wide::PARALLEL_NODES,
        "{}",
        wide.nodes.len()
    );
    // Pre-order from each root in turn numbers the nodes 0, 1, 2, … with no gap.
    let mut next = 0;
    for &root in &roots {
        let Some(w) = wide.root(root) else {
            assert_eq!(root, roots[2], "only the empty tree has no wide root");
            continue;
        };
        let mut todo = vec![w];
        while let Some(w) = todo.pop() {
            assert_eq!(w, next, "depth-first order");
            next += 1;
            let (_, child, _, valid) = wide.nodes[w as usize].parts();
            let interior =
                (0..wide::WIDTH).filter(|&s| valid & (1 << s) != 0 && child[s] & wide::LEAF == 0);
            todo.extend(interior.map(|s| child[s]).rev());
        }
    }
    assert_eq!(next as usize, wide.nodes.len(), "every node reached once");
    // Each tree's collapse is the one it makes alone (its node indices shifted).
    let alone = WideBvh::collapse(&big.nodes, &[0]);
    let start = wide.root(roots[1]).unwrap() as usize;
    for (a, b) in alone.nodes.iter().zip(&wide.nodes[start..]) {
        let (ba, ca, na, va) = a.parts();
        let (bb, cb, nb, vb) = b.parts();
        assert!(
            ba == bb && na == nb && va == vb,
            "the same boxes and leaves"
        );
        for s in (0..wide::WIDTH).filter(|&s| va & (1 << s) != 0) {
            let shifted = if ca[s] & wide::LEAF != 0 {
                ca[s]
            } else {
                ca[s] + start as u32
            };
            assert_eq!(shifted, cb[s], "slot {s}");
        }
    }
    validate_wide(&big, &alone);
}
