//! The binned SAH build (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies") and its depth-first flattening; see the parent module's docs.

use super::{Bvh, BvhStats, INTERSECTION_COST, MAX_DEPTH, MAX_LEAF_SIZE, SAH_BINS, TRAVERSAL_COST};
use crate::layout::BvhNode;
use glam::Vec3;
use std::time::Instant;

/// An axis-aligned box; empty when min > max.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    min: Vec3,
    max: Vec3,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    fn grow(&mut self, min: Vec3, max: Vec3) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    /// Half the surface area (0 for an empty box): the SAH only uses ratios.
    fn half_area(&self) -> f32 {
        let d = self.max - self.min;
        if d.x < 0.0 || d.y < 0.0 || d.z < 0.0 {
            return 0.0;
        }
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// A triangle during the build: its bounds and input index.
#[derive(Clone, Copy, Debug)]
struct PrimRef {
    min: Vec3,
    max: Vec3,
    id: u32,
}

impl PrimRef {
    fn centroid(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
}

/// A range of `refs` still to become a subtree, with the bounds of its primitives and of their
/// centroids; `patch` is the node whose `offset` must point to it (it is a right child), or
/// `u32::MAX`.
struct Task {
    start: usize,
    end: usize,
    depth: usize,
    patch: u32,
    bounds: Aabb,
    centroids: Aabb,
}

/// Where a range splits: the first `mid` primitives (after reordering) go left; the bounds of
/// each side's primitives and centroids, as (left, right).
struct Split {
    mid: usize,
    bounds: (Aabb, Aabb),
    centroids: (Aabb, Aabb),
}

fn ceil_log2(n: usize) -> usize {
    (usize::BITS - n.saturating_sub(1).leading_zeros()) as usize
}

/// Bin of a centroid coordinate; the same float expression when binning and partitioning.
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(SAH_BINS - 1)
}

/// Reorders `refs` so that those with `pred` come first; returns how many there are. Hoare's
/// scheme from both ends: each misplaced pair costs one swap, so about half the swaps of a
/// single forward scan.
fn partition(refs: &mut [PrimRef], pred: impl Fn(&PrimRef) -> bool) -> usize {
    let (mut i, mut j) = (0, refs.len());
    loop {
        while i < j && pred(&refs[i]) {
            i += 1;
        }
        while i < j && !pred(&refs[j - 1]) {
            j -= 1;
        }
        if i >= j {
            return i;
        }
        refs.swap(i, j - 1);
        i += 1;
        j -= 1;
    }
}

/// Where to split `refs` (0 < mid < len, after reordering them), or `None` for a leaf. An SAH
/// split takes both sides' bounds from its bins (the same unions of the same boxes, so the same
/// bounds as a pass over each side, without the pass); a median split passes over them.
fn choose_split(
    refs: &mut [PrimRef],
    bounds: &Aabb,
    centroids: &Aabb,
    depth: usize,
) -> Option<Split> {
    let measured = |refs: &[PrimRef], mid: usize| {
        let (lb, lc) = range_bounds(&refs[..mid]);
        let (rb, rc) = range_bounds(&refs[mid..]);
        Split {
            mid,
            bounds: (lb, rb),
            centroids: (lc, rc),
        }
    };
    let n = refs.len();
    if n <= 1 {
        return None;
    }
    let extent = centroids.max - centroids.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    // Identical centroids: the SAH cannot separate them; halve large sets in any order.
    if extent[axis].is_nan() || extent[axis] <= 0.0 {
        return (n > MAX_LEAF_SIZE).then(|| measured(refs, n / 2));
    }
    // Near the depth limit: object median, which halves the set and so bounds the depth.
    if depth + ceil_log2(n) >= MAX_DEPTH {
        if n <= MAX_LEAF_SIZE {
            return None;
        }
        refs.select_nth_unstable_by(n / 2, |a, b| {
            a.centroid()[axis].total_cmp(&b.centroid()[axis])
        });
        return Some(measured(refs, n / 2));
    }

    // Binned SAH: bounds and counts per bin, then sweep the 15 planes between bins.
    let lo = centroids.min[axis];
    let scale = SAH_BINS as f32 / extent[axis];
    // Per bin: primitive bounds, count and centroid bounds.
    let mut bins = [(Aabb::EMPTY, 0usize); SAH_BINS];
    let mut bin_centroids = [Aabb::EMPTY; SAH_BINS];
    for r in refs.iter() {
        let c = r.centroid();
        let k = bin_of(c[axis], lo, scale);
        bins[k].0.grow(r.min, r.max);
        bins[k].1 += 1;
        bin_centroids[k].grow(c, c);
    }
    let mut right_cost = [0.0f32; SAH_BINS];
    let (mut acc, mut count) = (Aabb::EMPTY, 0);
    for plane in (1..SAH_BINS).rev() {
        acc.grow(bins[plane].0.min, bins[plane].0.max);
        count += bins[plane].1;
        right_cost[plane] = acc.half_area() * count as f32;
    }
    let (mut acc, mut count) = (Aabb::EMPTY, 0);
    let mut best: Option<(usize, f32)> = None;
    for plane in 1..SAH_BINS {
        acc.grow(bins[plane - 1].0.min, bins[plane - 1].0.max);
        count += bins[plane - 1].1;
        if count == 0 || count == n {
            continue;
        }
        let cost = acc.half_area() * count as f32 + right_cost[plane];
        if best.is_none_or(|(_, c)| cost < c) {
            best = Some((plane, cost));
        }
    }
    let (plane, cost) = best?;
    // Split when C_T·A + C_I·(A_L·N_L + A_R·N_R) < C_I·N·A (areas unnormalised).
    let area = bounds.half_area();
    let pays =
        TRAVERSAL_COST * area + INTERSECTION_COST * cost < INTERSECTION_COST * n as f32 * area;
    if !pays && n <= MAX_LEAF_SIZE {
        return None;
    }
    let mid = partition(refs, |r| bin_of(r.centroid()[axis], lo, scale) < plane);
    debug_assert!(mid > 0 && mid < n);
    let union = |range: std::ops::Range<usize>| {
        let (mut b, mut c) = (Aabb::EMPTY, Aabb::EMPTY);
        for k in range {
            b.grow(bins[k].0.min, bins[k].0.max);
            c.grow(bin_centroids[k].min, bin_centroids[k].max);
        }
        (b, c)
    };
    let ((lb, lc), (rb, rc)) = (union(0..plane), union(plane..SAH_BINS));
    Some(Split {
        mid,
        bounds: (lb, rb),
        centroids: (lc, rc),
    })
}

/// Subtrees with at least this many primitives build their two children on separate threads.
const PARALLEL_MIN: usize = 16384;

/// A subtree built in parallel, as pieces in depth-first order, assembled once at the end
/// (`Subtree::assemble`) rather than copied into each parent.
struct Subtree {
    pieces: Vec<Piece>,
    len: usize,
    stats: BvhStats,
}

enum Piece {
    /// A sequentially built subtree: interior offsets relative to its first node.
    Range(Vec<BvhNode>),
    /// An interior node whose right child is `right` nodes after it.
    Interior(BvhNode, usize),
}

impl Subtree {
    /// The flattened nodes, offsets absolute.
    fn assemble(self) -> Vec<BvhNode> {
        let mut nodes = Vec::with_capacity(self.len);
        for piece in self.pieces {
            let base = nodes.len() as u32;
            match piece {
                Piece::Range(range) => nodes.extend(range.into_iter().map(|mut n| {
                    if !n.is_leaf() {
                        n.offset += base;
                    }
                    n
                })),
                Piece::Interior(mut n, right) => {
                    n.offset = base + right as u32;
                    nodes.push(n);
                }
            }
        }
        nodes
    }
}

/// Builds the subtree over `refs` (which start at `start` in the whole array) at `depth`, with
/// the bounds of its primitives and centroids: large ranges split here and build both halves
/// in parallel (rayon::join), small ones with [`build_range`]. The order is the same
/// depth-first, left-first order as a sequential build, so the tree does not depend on threads.
fn build_parallel(
    refs: &mut [PrimRef],
    start: usize,
    depth: usize,
    bounds: Aabb,
    centroids: Aabb,
) -> Subtree {
    let sequential = |refs: &mut [PrimRef]| {
        let (nodes, stats) = build_range(refs, start, depth, bounds, centroids);
        Subtree {
            len: nodes.len(),
            pieces: vec![Piece::Range(nodes)],
            stats,
        }
    };
    if refs.len() < PARALLEL_MIN {
        return sequential(refs);
    }
    let Some(split) = choose_split(refs, &bounds, &centroids, depth) else {
        return sequential(refs);
    };
    let mid = split.mid;
    let (left, right) = refs.split_at_mut(mid);
    let (l, r) = rayon::join(
        || build_parallel(left, start, depth + 1, split.bounds.0, split.centroids.0),
        || {
            build_parallel(
                right,
                start + mid,
                depth + 1,
                split.bounds.1,
                split.centroids.1,
            )
        },
    );
    let node = BvhNode {
        bounds_min: bounds.min.into(),
        offset: 0,
        bounds_max: bounds.max.into(),
        count: 0,
    };
    let mut pieces = Vec::with_capacity(1 + l.pieces.len() + r.pieces.len());
    pieces.push(Piece::Interior(node, 1 + l.len));
    pieces.extend(l.pieces);
    pieces.extend(r.pieces);
    Subtree {
        pieces,
        len: 1 + l.len + r.len,
        stats: BvhStats {
            leaves: l.stats.leaves + r.stats.leaves,
            max_depth: l.stats.max_depth.max(r.stats.max_depth),
            max_leaf_size: l.stats.max_leaf_size.max(r.stats.max_leaf_size),
            ..BvhStats::default()
        },
    }
}

/// Bounds of the primitives and of their centroids.
fn range_bounds(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let (mut bounds, mut centroids) = (Aabb::EMPTY, Aabb::EMPTY);
    for r in refs {
        bounds.grow(r.min, r.max);
        centroids.grow(r.centroid(), r.centroid());
    }
    (bounds, centroids)
}

/// The sequential build of the subtree over `refs` (which start at `start` in the whole array)
/// at `depth`, with a work stack: node indices relative to the result, leaf offsets absolute.
fn build_range(
    refs: &mut [PrimRef],
    start: usize,
    depth: usize,
    bounds: Aabb,
    centroids: Aabb,
) -> (Vec<BvhNode>, BvhStats) {
    let mut nodes: Vec<BvhNode> = Vec::with_capacity(2 * refs.len().max(1));
    let mut stats = BvhStats::default();
    let mut stack = vec![Task {
        start: 0,
        end: refs.len(),
        depth,
        patch: u32::MAX,
        bounds,
        centroids,
    }];
    while let Some(task) = stack.pop() {
        let index = nodes.len() as u32;
        if task.patch != u32::MAX {
            nodes[task.patch as usize].offset = index;
        }
        let range = &mut refs[task.start..task.end];
        let (bounds, centroids) = (task.bounds, task.centroids);
        let mut node = BvhNode {
            bounds_min: bounds.min.into(),
            offset: 0,
            bounds_max: bounds.max.into(),
            count: 0,
        };
        match choose_split(range, &bounds, &centroids, task.depth) {
            Some(split) => {
                let mid = task.start + split.mid;
                // Right pushed first: the left subtree is built (and numbered) first.
                stack.push(Task {
                    start: mid,
                    end: task.end,
                    depth: task.depth + 1,
                    patch: index,
                    bounds: split.bounds.1,
                    centroids: split.centroids.1,
                });
                stack.push(Task {
                    start: task.start,
                    end: mid,
                    depth: task.depth + 1,
                    patch: u32::MAX,
                    bounds: split.bounds.0,
                    centroids: split.centroids.0,
                });
            }
            None => {
                node.offset = (start + task.start) as u32;
                node.count = range.len() as u32;
                stats.leaves += 1;
                stats.max_depth = stats.max_depth.max(task.depth);
                stats.max_leaf_size = stats.max_leaf_size.max(range.len());
            }
        }
        nodes.push(node);
    }
    (nodes, stats)
}

impl Bvh {
    /// Binned SAH build (see the module docs). Works for 0 triangles (traversal then misses) and
    /// for millions (work stack, bounded depth).
    pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
        Bvh::build_boxes(
            &triangles
                .iter()
                .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
                .collect::<Vec<_>>(),
        )
    }

    /// The same build over axis-aligned boxes (min, max): the top level over instances.
    pub fn build_boxes(boxes: &[(Vec3, Vec3)]) -> Bvh {
        let start_time = Instant::now();
        let mut refs: Vec<PrimRef> = boxes
            .iter()
            .enumerate()
            .map(|(i, &(min, max))| PrimRef {
                min,
                max,
                id: i as u32,
            })
            .collect();
        let (nodes, mut stats) = if refs.is_empty() {
            let empty = BvhNode {
                bounds_min: [f32::MAX; 3],
                offset: 0,
                bounds_max: [-f32::MAX; 3],
                count: 0,
            };
            (vec![empty], BvhStats::default())
        } else {
            let (bounds, centroids) = range_bounds(&refs);
            let tree = build_parallel(&mut refs, 0, 0, bounds, centroids);
            let stats = tree.stats.clone();
            (tree.assemble(), stats)
        };

        stats.nodes = nodes.len();
        stats.sah_cost = sah_cost(&nodes);
        stats.build_time = start_time.elapsed();
        Bvh {
            nodes,
            order: refs.iter().map(|r| r.id).collect(),
            stats,
        }
    }
}

/// SAH cost of a flattened BVH: Σ interior area·C_T + Σ leaf area·count·C_I, over the root's area
/// (C_T = C_I = 1). 0 for an empty or zero-area BVH.
pub fn sah_cost(nodes: &[BvhNode]) -> f32 {
    let area = |n: &BvhNode| {
        Aabb {
            min: n.bounds_min.into(),
            max: n.bounds_max.into(),
        }
        .half_area()
    };
    let Some(root_area) = nodes.first().map(area).filter(|&a| a > 0.0) else {
        return 0.0;
    };
    let total: f64 = nodes
        .iter()
        .map(|n| {
            let cost = if n.is_leaf() {
                INTERSECTION_COST * n.count as f32
            } else {
                TRAVERSAL_COST
            };
            (area(n) * cost) as f64
        })
        .sum();
    (total / root_area as f64) as f32
}

#[cfg(test)]
mod parallel_tests {
    use super::*;

    /// The parallel build makes the same tree, node for node and in the same order, as the
    /// sequential one: the threads only change who builds a subtree.
    #[test]
    fn parallel_build_equals_sequential_build() {
        let n = 3 * PARALLEL_MIN + 123;
        let make = || -> Vec<PrimRef> {
            (0..n as u32)
                .map(|i| {
                    let u = crate::sampling::rng_uniform4(3, i, 0, 0);
                    let c = Vec3::new(u.x, u.y * u.y, u.z) * 100.0;
                    let h = Vec3::splat(0.01 + u.w);
                    PrimRef {
                        min: c - h,
                        max: c + h,
                        id: i,
                    }
                })
                .collect()
        };
        let (mut a, mut b) = (make(), make());
        let (bounds, centroids) = range_bounds(&a);
        let tree = build_parallel(&mut a, 0, 0, bounds, centroids);
        let sa = tree.stats.clone();
        let pa = tree.assemble();
        let (pb, sb) = build_range(&mut b, 0, 0, bounds, centroids);
        assert!(pa.len() > 2 * n / MAX_LEAF_SIZE);
        assert_eq!(pa, pb);
        assert_eq!(
            a.iter().map(|r| r.id).collect::<Vec<_>>(),
            b.iter().map(|r| r.id).collect::<Vec<_>>()
        );
        assert_eq!(
            (sa.leaves, sa.max_depth, sa.max_leaf_size),
            (sb.leaves, sb.max_depth, sb.max_leaf_size)
        );
    }
}
