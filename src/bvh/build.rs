//! (Over 900 lines: the binned build, its parallel split and the flattening are one algorithm, read top to bottom.)
//! The binned SAH build (Wald 2007, "On fast Construction of SAH-based Bounding Volume
//! Hierarchies") and its depth-first flattening; see the parent module's docs.
//!
//! Boxes and primitive references are four-wide (`Vec4`, one SSE register each: growing a box
//! is one `min` and one `max`), and centroids are kept doubled (`lower + upper`, no `× 0.5`):
//! binning on doubled centroids with a halved scale puts every primitive in the same bin as
//! binning on centroids, since scaling by two is exact in floating point.

use super::binary::{
    Bvh, BvhStats, INTERSECTION_COST, MAX_DEPTH, MAX_LEAF_SIZE, SAH_BINS, TRAVERSAL_COST,
};
use crate::layout::BvhNode;
use arrayvec::ArrayVec;
use glam::{Vec3, Vec4};
use rayon::prelude::*;
use std::time::Instant;

/// Coordinate `axis` (0, 1 or 2) of `v`, read through memory: indexing a `Vec4` by a runtime
/// axis compiles to a bounds check and a jump table, about a sixth of the partition loop's
/// instructions (callgrind); in time the two measured the same.
#[inline(always)]
fn lane(v: Vec4, axis: usize) -> f32 {
    v.to_array()[axis & 3]
}

/// An axis-aligned box in x, y, z (w is not read); empty when min > max.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Aabb {
    min: Vec4,
    max: Vec4,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        min: Vec4::INFINITY,
        max: Vec4::NEG_INFINITY,
    };

    #[inline(always)]
    fn grow(&mut self, min: Vec4, max: Vec4) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    #[inline(always)]
    fn grow_point(&mut self, p: Vec4) {
        self.grow(p, p);
    }

    /// Half the surface area (0 for an empty box): the SAH only uses ratios. A grown box's
    /// extents are all ≥ 0 or, when empty, all −∞, so clamping them at 0 is the emptiness test;
    /// the sum is xy + yz + zx in that order, one product per lane.
    #[inline(always)]
    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec4::ZERO);
        let p = d * Vec4::new(d.y, d.z, d.x, 0.0);
        p.x + p.y + p.z
    }

    fn lower(&self) -> [f32; 3] {
        self.min.truncate().into()
    }

    fn upper(&self) -> [f32; 3] {
        self.max.truncate().into()
    }
}

/// A primitive during the build: its bounds, with its input index in `lower.w`. The same size
/// and alignment as a `BvhNode`: the finished tree is written over the references.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct PrimRef {
    lower: Vec4,
    upper: Vec4,
}

/// The index is stored as the bits of `lower.w` XOR this, so that every index below 2^30 is a
/// normal float (≥ 2): the doubled centroid adds the w lanes, and a denormal operand can cost a
/// microcode assist. The bits come back unchanged whatever they are (nothing writes `lower.w`).
const ID_BITS: u32 = 0x4000_0000;

impl PrimRef {
    fn new(min: Vec3, max: Vec3, id: u32) -> PrimRef {
        PrimRef {
            lower: min.extend(f32::from_bits(id ^ ID_BITS)),
            upper: max.extend(2.0),
        }
    }

    fn id(&self) -> u32 {
        self.lower.w.to_bits() ^ ID_BITS
    }

    /// Twice the centroid (x, y, z; w is not read).
    #[inline(always)]
    fn centroid2(&self) -> Vec4 {
        self.lower + self.upper
    }
}

/// Where a range splits: the first `mid` primitives (after reordering) go left; the bounds of
/// each side's primitives and doubled centroids, and each side's bins where the partition
/// binned them, as (left, right).
struct Split {
    mid: usize,
    bounds: (Aabb, Aabb),
    centroids: (Aabb, Aabb),
    bins: (Option<Box<Bins>>, Option<Box<Bins>>),
}

fn ceil_log2(n: usize) -> usize {
    (usize::BITS - n.saturating_sub(1).leading_zeros()) as usize
}

/// How a range's primitives fall into the SAH bins: by doubled centroid on `axis`, bin k
/// covering [lo + k/scale, lo + (k+1)/scale).
#[derive(Clone, Copy, Debug)]
struct Binning {
    axis: usize,
    lo: f32,
    scale: f32,
}

impl Binning {
    /// Bin of a doubled centroid by its coordinate on the axis; the same float expression when
    /// binning and partitioning. `max` then `min` also send NaN to bin 0, as `as usize` would.
    #[inline(always)]
    fn bin_of(&self, c: Vec4) -> usize {
        let x = ((lane(c, self.axis) - self.lo) * self.scale)
            .max(0.0)
            .min((SAH_BINS - 1) as f32);
        // SAFETY: x is in [0, SAH_BINS - 1], so it truncates to a u32 (one instruction instead
        // of `as`'s saturating conversion, measured in the partition loop). The mask changes
        // nothing and lets the compiler drop the bins' bounds checks.
        (unsafe { x.to_int_unchecked::<u32>() }) as usize & (SAH_BINS - 1)
    }
}

/// Per bin: the bounds of its primitives and of their doubled centroids, and their count.
#[derive(Clone, Debug, PartialEq)]
struct Bins {
    bounds: [Aabb; SAH_BINS],
    centroids: [Aabb; SAH_BINS],
    counts: [u32; SAH_BINS],
}

impl Bins {
    const EMPTY: Bins = Bins {
        bounds: [Aabb::EMPTY; SAH_BINS],
        centroids: [Aabb::EMPTY; SAH_BINS],
        counts: [0; SAH_BINS],
    };

    #[inline(always)]
    fn add(&mut self, k: usize, r: &PrimRef, c: Vec4) {
        self.bounds[k].grow(r.lower, r.upper);
        self.centroids[k].grow_point(c);
        self.counts[k] += 1;
    }

    fn of(refs: &[PrimRef], binning: &Binning) -> Bins {
        let mut sets = [Bins::EMPTY, Bins::EMPTY, Bins::EMPTY, Bins::EMPTY];
        let groups = refs.chunks_exact(4);
        for (bins, r) in sets.iter_mut().zip(groups.remainder()) {
            let c = r.centroid2();
            bins.add(binning.bin_of(c), r, c);
        }
        for group in groups {
            for (bins, r) in sets.iter_mut().zip(group) {
                let c = r.centroid2();
                bins.add(binning.bin_of(c), r, c);
            }
        }
        let [mut bins, b, c, d] = sets;
        bins.merge(&b);
        bins.merge(&c);
        bins.merge(&d);
        bins
    }

    /// [`Bins::of`] over chunks on every thread, merged: the same bins.
    fn of_parallel(refs: &[PrimRef], binning: &Binning) -> Bins {
        refs.par_chunks(PARALLEL_CHUNK)
            .map(|chunk| Bins::of(chunk, binning))
            .reduce(
                || Bins::EMPTY,
                |mut a, b| {
                    a.merge(&b);
                    a
                },
            )
    }

    /// Adds `other`'s primitives: the same bins as if they had been added one by one (min, max
    /// and sums do not depend on the order). Large ranges are binned into four sets in turn,
    /// then merged: neighbours in the array are usually neighbours in space and fall into the
    /// same bin, and with one set each waits for the previous one's store to that bin
    /// (measured on a 100k-triangle terrain, one thread: `Bins::of` 4.0 → 2.5 ns per
    /// primitive, the partition with both sides binned 4.2 → 3.3).
    fn merge(&mut self, other: &Bins) {
        for k in 0..SAH_BINS {
            self.bounds[k].grow(other.bounds[k].min, other.bounds[k].max);
            self.centroids[k].grow(other.centroids[k].min, other.centroids[k].max);
            self.counts[k] += other.counts[k];
        }
    }

    /// Bounds of the primitives and of the centroids in bins `range`.
    fn union(&self, range: std::ops::Range<usize>) -> (Aabb, Aabb) {
        let (mut b, mut c) = (Aabb::EMPTY, Aabb::EMPTY);
        for k in range {
            b.grow(self.bounds[k].min, self.bounds[k].max);
            c.grow(self.centroids[k].min, self.centroids[k].max);
        }
        (b, c)
    }
}

/// The longest axis of `centroids`' box and its extent.
fn longest_axis(centroids: &Aabb) -> (usize, f32) {
    let extent = centroids.max - centroids.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    (axis, extent[axis])
}

/// The binning of a range of `n` primitives at `depth` whose doubled centroids span
/// `centroids`, if [`choose_split`] takes the binned SAH path for it: the complement of its
/// earlier cases, so that a parent can bin its children's primitives while partitioning.
fn binned_path(n: usize, depth: usize, centroids: &Aabb) -> Option<Binning> {
    let (axis, extent) = longest_axis(centroids);
    let usable = n > SWEEP_MAX && extent > 0.0 && depth + ceil_log2(n) < MAX_DEPTH;
    usable.then(|| Binning {
        axis,
        lo: centroids.min[axis],
        scale: SAH_BINS as f32 / extent,
    })
}

/// Reorders `refs` so that those whose bin under `split` is below `plane` come first; returns
/// how many there are, and each side's primitives binned by its own `Binning` (where given).
/// Hoare's scheme from both ends: each misplaced pair costs one swap, so about half the swaps
/// of a single forward scan, and each primitive is looked at once, when its side is known.
fn partition_binned<const SETS: usize>(
    refs: &mut [PrimRef],
    split: &Binning,
    plane: usize,
    left: Option<Binning>,
    right: Option<Binning>,
) -> (usize, Option<Box<Bins>>, Option<Box<Bins>>) {
    // Each side's primitives binned into SETS sets by their position's low bits (each added
    // primitive moves the position by one, so consecutive ones go to different sets; see
    // `Bins::merge`).
    let (mut lsets, mut rsets) = ([Bins::EMPTY; SETS], [Bins::EMPTY; SETS]);
    let add =
        |sets: &mut [Bins; SETS], binning: &Option<Binning>, at: usize, r: &PrimRef, c: Vec4| {
            if let Some(binning) = binning {
                sets[at % SETS].add(binning.bin_of(c), r, c);
            }
        };
    let (mut i, mut j) = (0, refs.len());
    let mid = loop {
        let mut ci = Vec4::ZERO;
        while i < j {
            ci = refs[i].centroid2();
            if split.bin_of(ci) >= plane {
                break;
            }
            add(&mut lsets, &left, i, &refs[i], ci);
            i += 1;
        }
        let mut cj = Vec4::ZERO;
        while i < j {
            cj = refs[j - 1].centroid2();
            if split.bin_of(cj) < plane {
                break;
            }
            add(&mut rsets, &right, j, &refs[j - 1], cj);
            j -= 1;
        }
        if i >= j {
            break i;
        }
        // refs[i] belongs right, refs[j - 1] left.
        refs.swap(i, j - 1);
        add(&mut lsets, &left, i, &refs[i], cj);
        add(&mut rsets, &right, j, &refs[j - 1], ci);
        i += 1;
        j -= 1;
    };
    let merged = |sets: [Bins; SETS], binning: Option<Binning>| {
        binning.map(|_| {
            let mut sets = sets.into_iter();
            let mut bins = Box::new(sets.next().unwrap_or(Bins::EMPTY));
            sets.for_each(|other| bins.merge(&other));
            bins
        })
    };
    (mid, merged(lsets, left), merged(rsets, right))
}

/// Where to split `refs` (0 < mid < len, after reordering them), or `None` for a leaf. `bins`
/// are the primitives binned by [`binned_path`], where the parent's partition binned them. An
/// SAH split takes both sides' bounds from its bins (the same unions of the same boxes, so the
/// same bounds as a pass over each side, without the pass) and bins each side's primitives
/// for its own split as it partitions; a median or sweep split passes over them.
fn choose_split(
    refs: &mut [PrimRef],
    bounds: &Aabb,
    centroids: &Aabb,
    depth: usize,
    bins: Option<Box<Bins>>,
) -> Option<Split> {
    let n = refs.len();
    if n <= 1 {
        return None;
    }
    let (axis, extent) = longest_axis(centroids);
    // Identical centroids: the SAH cannot separate them; halve large sets in any order.
    if extent.is_nan() || extent <= 0.0 {
        return (n > MAX_LEAF_SIZE).then(|| measured_split(refs, n / 2));
    }
    // Near the depth limit: object median, which halves the set and so bounds the depth.
    if depth + ceil_log2(n) >= MAX_DEPTH {
        if n <= MAX_LEAF_SIZE {
            return None;
        }
        refs.select_nth_unstable_by(n / 2, |a, b| {
            lane(a.centroid2(), axis).total_cmp(&lane(b.centroid2(), axis))
        });
        return Some(measured_split(refs, n / 2));
    }
    // What is left of binned_path's conditions: at most SWEEP_MAX primitives.
    let Some(binning) = binned_path(n, depth, centroids) else {
        return sweep_split(refs, bounds, axis);
    };

    // Binned SAH: bounds and counts per bin, then sweep the 15 planes between bins.
    let bins = bins.unwrap_or_else(|| Box::new(Bins::of(refs, &binning)));
    let mut right_cost = [0.0f32; SAH_BINS];
    let (mut acc, mut count) = (Aabb::EMPTY, 0);
    for plane in (1..SAH_BINS).rev() {
        acc.grow(bins.bounds[plane].min, bins.bounds[plane].max);
        count += bins.counts[plane] as usize;
        right_cost[plane] = acc.half_area() * count as f32;
    }
    let (mut acc, mut count) = (Aabb::EMPTY, 0);
    let mut best: Option<(usize, f32, usize)> = None;
    for plane in 1..SAH_BINS {
        acc.grow(bins.bounds[plane - 1].min, bins.bounds[plane - 1].max);
        count += bins.counts[plane - 1] as usize;
        if count == 0 || count == n {
            continue;
        }
        let cost = acc.half_area() * count as f32 + right_cost[plane];
        if best.is_none_or(|(_, c, _)| cost < c) {
            best = Some((plane, cost, count));
        }
    }
    let (plane, cost, left_count) = best?;
    // Split when C_T·A + C_I·(A_L·N_L + A_R·N_R) < C_I·N·A (areas unnormalised).
    let area = bounds.half_area();
    let pays =
        TRAVERSAL_COST * area + INTERSECTION_COST * cost < INTERSECTION_COST * n as f32 * area;
    if !pays && n <= MAX_LEAF_SIZE {
        return None;
    }
    let ((lb, lc), (rb, rc)) = (bins.union(0..plane), bins.union(plane..SAH_BINS));
    let partition = if n >= SETS_MIN {
        partition_binned::<4>
    } else {
        partition_binned::<1>
    };
    let (mid, lbins, rbins) = partition(
        refs,
        &binning,
        plane,
        binned_path(left_count, depth + 1, &lc),
        binned_path(n - left_count, depth + 1, &rc),
    );
    debug_assert_eq!(mid, left_count);
    Some(Split {
        mid,
        bounds: (lb, rb),
        centroids: (lc, rc),
        bins: (lbins, rbins),
    })
}

/// Ranges this large bin into four sets of bins while partitioning (see `Bins::merge`); smaller
/// ones use one, where clearing and merging 4 × 1 KiB of bins would be a large part of the work.
const SETS_MIN: usize = 1024;

/// The split at `mid` of `refs` as they are ordered, with both sides' bounds measured.
fn measured_split(refs: &[PrimRef], mid: usize) -> Split {
    let (lb, lc) = range_bounds(&refs[..mid]);
    let (rb, rc) = range_bounds(&refs[mid..]);
    Split {
        mid,
        bounds: (lb, rb),
        centroids: (lc, rc),
        bins: (None, None),
    }
}

/// Ranges this small are split by a full SAH sweep instead of binning: setting up and sweeping
/// the bins costs more than sorting a few primitives, and the sweep tries every split between
/// neighbours along the axis, a superset of the planes the bins offer.
const SWEEP_MAX: usize = 32;

/// Full sweep (MacDonald & Booth 1990) over `refs` sorted by centroid on `axis`: the split
/// between neighbours of least SAH cost, or `None` for a leaf by the same rule as the bins.
fn sweep_split(refs: &mut [PrimRef], bounds: &Aabb, axis: usize) -> Option<Split> {
    let n = refs.len();
    debug_assert!((2..=SWEEP_MAX).contains(&n));
    // The coordinates' bits in total order; a range already in that order (a child of a split
    // on the same axis) stays as it is, as the sort below would leave it.
    let mut coords = [0u32; SWEEP_MAX];
    for (key, r) in coords.iter_mut().zip(refs.iter()) {
        let bits = lane(r.centroid2(), axis).to_bits();
        *key = bits ^ if bits >> 31 == 1 { u32::MAX } else { 1 << 31 };
    }
    let coords = &coords[..n];
    if coords.windows(2).any(|w| w[0] > w[1]) {
        // Sort 8-byte keys (the coordinate, then the position, so equal coordinates keep
        // their order) rather than the 32-byte references, then gather.
        let mut keys = [0u64; SWEEP_MAX];
        for (key, (i, &c)) in keys.iter_mut().zip(coords.iter().enumerate()) {
            *key = (c as u64) << 32 | i as u64;
        }
        let keys = &mut keys[..n];
        keys.sort_unstable();
        // Filled in place (collecting into an ArrayVec returns it by value: a 1 KiB copy).
        let mut sorted = ArrayVec::<PrimRef, SWEEP_MAX>::new();
        sorted.extend(keys.iter().map(|&key| refs[key as u32 as usize]));
        refs.copy_from_slice(&sorted);
    }
    // right_cost[i]: area·count of refs[i..].
    let mut right_cost = [0.0f32; SWEEP_MAX];
    let mut acc = Aabb::EMPTY;
    for i in (1..n).rev() {
        acc.grow(refs[i].lower, refs[i].upper);
        right_cost[i] = acc.half_area() * (n - i) as f32;
    }
    let mut acc = Aabb::EMPTY;
    let (mut mid, mut cost) = (0, f32::INFINITY);
    for i in 1..n {
        acc.grow(refs[i - 1].lower, refs[i - 1].upper);
        let c = acc.half_area() * i as f32 + right_cost[i];
        if c < cost {
            (mid, cost) = (i, c);
        }
    }
    let area = bounds.half_area();
    let pays =
        TRAVERSAL_COST * area + INTERSECTION_COST * cost < INTERSECTION_COST * n as f32 * area;
    if !pays && n <= MAX_LEAF_SIZE {
        return None;
    }
    // Only a NaN cost leaves `mid` at 0; split in the middle then.
    Some(measured_split(refs, if mid == 0 { n / 2 } else { mid }))
}

/// Subtrees with at least this many primitives build their two children on separate threads.
const PARALLEL_MIN: usize = 16384;

/// Passes over the whole range (the root's bounds and bins) run in chunks of this many
/// primitives on every thread.
const PARALLEL_CHUNK: usize = 8192;

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
    /// The flattened nodes, offsets absolute: each piece copied into its place in parallel,
    /// into `nodes` (the primitive references' memory, already mapped: on this machine a
    /// fresh page costs ~2 µs to fault in, 15–20 ms for the 32 MiB of a 1M-triangle tree).
    fn assemble(self, mut nodes: Vec<BvhNode>) -> Vec<BvhNode> {
        nodes.resize(self.len, BvhNode::default());
        nodes.shrink_to_fit();
        let mut rest = nodes.as_mut_slice();
        let mut jobs = Vec::with_capacity(self.pieces.len());
        let mut base = 0u32;
        for piece in self.pieces {
            let len = match &piece {
                Piece::Range(range) => range.len(),
                Piece::Interior(..) => 1,
            };
            let (out, tail) = rest.split_at_mut(len);
            rest = tail;
            jobs.push((base, piece, out));
            base += len as u32;
        }
        jobs.into_par_iter()
            .for_each(|(base, piece, out)| match piece {
                Piece::Range(range) => {
                    for (to, mut n) in out.iter_mut().zip(range) {
                        if !n.is_leaf() {
                            n.offset += base;
                        }
                        *to = n;
                    }
                }
                Piece::Interior(mut n, right) => {
                    n.offset = base + right as u32;
                    out[0] = n;
                }
            });
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
    bins: Option<Box<Bins>>,
) -> Subtree {
    let sequential = |refs: &mut [PrimRef], bins| {
        let (nodes, stats) = build_range(refs, start, depth, bounds, centroids, bins);
        Subtree {
            len: nodes.len(),
            pieces: vec![Piece::Range(nodes)],
            stats,
        }
    };
    if refs.len() < PARALLEL_MIN {
        return sequential(refs, bins);
    }
    // Bins no partition filled (the root's): binned on every thread.
    let bins = bins.or_else(|| {
        binned_path(refs.len(), depth, &centroids)
            .map(|binning| Box::new(Bins::of_parallel(refs, &binning)))
    });
    let Some(split) = choose_split(refs, &bounds, &centroids, depth, bins) else {
        return sequential(refs, None);
    };
    let mid = split.mid;
    let (left, right) = refs.split_at_mut(mid);
    let (lbins, rbins) = split.bins;
    let (l, r) = rayon::join(
        || {
            build_parallel(
                left,
                start,
                depth + 1,
                split.bounds.0,
                split.centroids.0,
                lbins,
            )
        },
        || {
            build_parallel(
                right,
                start + mid,
                depth + 1,
                split.bounds.1,
                split.centroids.1,
                rbins,
            )
        },
    );
    let node = BvhNode {
        bounds_min: bounds.lower(),
        offset: 0,
        bounds_max: bounds.upper(),
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

/// [`range_bounds`] over chunks on every thread, merged (min and max: the same bounds).
fn range_bounds_parallel(refs: &[PrimRef]) -> (Aabb, Aabb) {
    refs.par_chunks(PARALLEL_CHUNK).map(range_bounds).reduce(
        || (Aabb::EMPTY, Aabb::EMPTY),
        |(mut b, mut c), (b2, c2)| {
            b.grow(b2.min, b2.max);
            c.grow(c2.min, c2.max);
            (b, c)
        },
    )
}

/// Bounds of the primitives and of their centroids.
fn range_bounds(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let (mut bounds, mut centroids) = (Aabb::EMPTY, Aabb::EMPTY);
    for r in refs {
        bounds.grow(r.lower, r.upper);
        centroids.grow_point(r.centroid2());
    }
    (bounds, centroids)
}

/// The sequential build of the subtree over `refs` (which start at `start` in the whole array)
/// at `depth`: node indices relative to the result, leaf offsets absolute.
fn build_range(
    refs: &mut [PrimRef],
    start: usize,
    depth: usize,
    bounds: Aabb,
    centroids: Aabb,
    bins: Option<Box<Bins>>,
) -> (Vec<BvhNode>, BvhStats) {
    let mut flat = Flattened {
        nodes: Vec::with_capacity(2 * refs.len().max(1)),
        stats: BvhStats::default(),
    };
    flat.subtree(refs, start, depth, bounds, centroids, bins);
    (flat.nodes, flat.stats)
}

/// A sequentially built subtree's nodes, in depth-first, left-first order, and its statistics.
struct Flattened {
    nodes: Vec<BvhNode>,
    stats: BvhStats,
}

impl Flattened {
    /// Appends the subtree over `refs` (starting at `at` in the whole array) at `depth`. The
    /// recursion is no deeper than [`MAX_DEPTH`] (`choose_split` halves ranges near it).
    fn subtree(
        &mut self,
        refs: &mut [PrimRef],
        at: usize,
        depth: usize,
        bounds: Aabb,
        centroids: Aabb,
        bins: Option<Box<Bins>>,
    ) {
        let index = self.nodes.len();
        self.nodes.push(BvhNode {
            bounds_min: bounds.lower(),
            offset: at as u32,
            bounds_max: bounds.upper(),
            count: refs.len() as u32,
        });
        match choose_split(refs, &bounds, &centroids, depth, bins) {
            Some(split) => {
                let (left, right) = refs.split_at_mut(split.mid);
                let ((lb, rb), (lc, rc), (lbins, rbins)) =
                    (split.bounds, split.centroids, split.bins);
                self.nodes[index].count = 0;
                self.subtree(left, at, depth + 1, lb, lc, lbins);
                self.nodes[index].offset = self.nodes.len() as u32;
                self.subtree(right, at + split.mid, depth + 1, rb, rc, rbins);
            }
            None => {
                self.stats.leaves += 1;
                self.stats.max_depth = self.stats.max_depth.max(depth);
                self.stats.max_leaf_size = self.stats.max_leaf_size.max(refs.len());
            }
        }
    }
}

/// An empty vector for `n` primitive references with room for the nodes of their tree, which
/// are written over them: a tree of n primitives has at most 2n − 1 nodes, and the scenes
/// measured have 0.9–1.2 n (leaves of 1.7–2.2 primitives); past n·5/4 the nodes reallocate.
fn with_node_room(n: usize) -> Vec<PrimRef> {
    Vec::with_capacity(n + n / 4 + 1)
}

impl Bvh {
    /// Binned SAH build (see the module docs). Works for 0 triangles (traversal then misses) and
    /// for millions (recursion no deeper than [`MAX_DEPTH`]).
    pub fn build(triangles: &[[Vec3; 3]]) -> Bvh {
        Bvh::build_with(triangles.len(), |i| triangles[i])
    }

    /// [`Bvh::build`] over `count` triangles whose corners `corners(i)` gives: the same tree,
    /// without a copy of the corners where they live in larger records (a scene's triangles).
    pub fn build_with(count: usize, corners: impl Fn(usize) -> [Vec3; 3] + Sync) -> Bvh {
        let start_time = Instant::now();
        let mut refs = with_node_room(count);
        refs.par_extend((0..count).into_par_iter().map(|i| {
            let t = corners(i);
            PrimRef::new(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]), i as u32)
        }));
        Bvh::build_refs(refs, start_time)
    }

    /// The same build over axis-aligned boxes (min, max): the top level over instances.
    pub fn build_boxes(boxes: &[(Vec3, Vec3)]) -> Bvh {
        let start_time = Instant::now();
        let mut refs = with_node_room(boxes.len());
        refs.par_extend(
            boxes
                .par_iter()
                .enumerate()
                .map(|(i, &(min, max))| PrimRef::new(min, max, i as u32)),
        );
        Bvh::build_refs(refs, start_time)
    }

    fn build_refs(mut refs: Vec<PrimRef>, start_time: Instant) -> Bvh {
        let refs_time = start_time.elapsed();
        let mut assemble_time = std::time::Duration::ZERO;
        let mut order = Vec::new();
        let (nodes, mut stats) = if refs.is_empty() {
            let empty = BvhNode {
                bounds_min: [f32::MAX; 3],
                offset: 0,
                bounds_max: [-f32::MAX; 3],
                count: 0,
            };
            (vec![empty], BvhStats::default())
        } else {
            let (bounds, centroids) = range_bounds_parallel(&refs);
            let tree = build_parallel(&mut refs, 0, 0, bounds, centroids, None);
            let stats = tree.stats.clone();
            order = refs.par_iter().map(PrimRef::id).collect();
            let assembling = Instant::now();
            let nodes = tree.assemble(bytemuck::cast_vec(refs));
            assemble_time = assembling.elapsed();
            (nodes, stats)
        };
        // The build ends here; the SAH cost is a statistic of its result.
        stats.build_time = start_time.elapsed();
        stats.refs_time = refs_time;
        stats.assemble_time = assemble_time;
        stats.tree_time = stats.build_time.saturating_sub(refs_time + assemble_time);
        stats.nodes = nodes.len();
        stats.sah_cost = sah_cost(&nodes);
        Bvh {
            nodes,
            order,
            stats,
        }
    }
}

/// Half the surface area of a node's box (0 for an inverted one), as the build's SAH takes it:
/// xy + yz + zx in that order.
pub(crate) fn node_half_area(n: &BvhNode) -> f32 {
    Aabb {
        min: Vec3::from(n.bounds_min).extend(0.0),
        max: Vec3::from(n.bounds_max).extend(0.0),
    }
    .half_area()
}

/// SAH cost of a flattened BVH: Σ interior area·C_T + Σ leaf area·count·C_I, over the root's area
/// (C_T = C_I = 1). 0 for an empty or zero-area BVH.
pub fn sah_cost(nodes: &[BvhNode]) -> f32 {
    let area = node_half_area;
    let Some(root_area) = nodes.first().map(area).filter(|&a| a > 0.0) else {
        return 0.0;
    };
    // Summed per chunk on every thread, then the chunks' sums in order: the same total
    // whatever the threads.
    let sums: Vec<f64> = nodes
        .par_chunks(PARALLEL_CHUNK)
        .map(|chunk| {
            chunk
                .iter()
                .map(|n| {
                    let cost = if n.is_leaf() {
                        INTERSECTION_COST * n.count as f32
                    } else {
                        TRAVERSAL_COST
                    };
                    (area(n) * cost) as f64
                })
                .sum::<f64>()
        })
        .collect();
    (sums.iter().sum::<f64>() / root_area as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Boxes of random size around random points, denser towards y = 0.
    fn random_refs(n: usize, seed: u32) -> Vec<PrimRef> {
        (0..n as u32)
            .map(|i| {
                let u = crate::sampling::rng_uniform4(seed, i, 0, 0);
                let c = Vec3::new(u.x, u.y * u.y, u.z) * 100.0;
                let h = Vec3::splat(0.01 + u.w);
                PrimRef::new(c - h, c + h, i)
            })
            .collect()
    }

    #[test]
    fn primitive_indices_survive_the_w_lane() {
        for id in [
            0,
            1,
            0x3f_ffff,
            0x3fff_ffff,
            0x4000_0000,
            0x7f80_0001,
            u32::MAX,
        ] {
            let r = PrimRef::new(Vec3::ZERO, Vec3::ONE, id);
            assert_eq!(r.id(), id);
            assert_eq!(r.centroid2().truncate(), Vec3::ONE);
        }
    }

    /// The bins a partition fills for each side are the bins that side would fill itself:
    /// the same primitives, binned by the same expression, so the tree does not depend on who
    /// binned them.
    #[test]
    fn partition_bins_equal_each_sides_own_bins() {
        let mut checked = 0;
        for (n, seed) in [(100, 1), (1000, 2), (5000, 3), (40, 4)] {
            let mut refs = random_refs(n, seed);
            let (bounds, centroids) = range_bounds(&refs);
            let split = choose_split(&mut refs, &bounds, &centroids, 0, None).expect("a split");
            let (left, right) = refs.split_at(split.mid);
            for (side, bins, b, c) in [
                (left, &split.bins.0, split.bounds.0, split.centroids.0),
                (right, &split.bins.1, split.bounds.1, split.centroids.1),
            ] {
                assert_eq!((b, c), range_bounds(side));
                match binned_path(side.len(), 1, &c) {
                    Some(binning) => {
                        assert_eq!(bins.as_deref(), Some(&Bins::of(side, &binning)));
                        checked += 1;
                    }
                    None => assert!(bins.is_none()),
                }
            }
        }
        assert!(checked >= 4, "{checked}");
    }

    /// Binning in four interleaved sets (and in chunks on every thread) gives the bins one set
    /// filled in order gives: the sets only reorder exact min, max and integer sums.
    #[test]
    fn bins_in_sets_equal_bins_in_one_set() {
        for (n, seed) in [
            (0, 1),
            (1, 2),
            (3, 3),
            (4, 4),
            (5, 5),
            (999, 6),
            (40_000, 7),
        ] {
            let refs = random_refs(n, seed);
            let (_, centroids) = range_bounds(&refs);
            let (axis, extent) = longest_axis(&centroids);
            let binning = Binning {
                axis,
                lo: centroids.min[axis],
                scale: SAH_BINS as f32 / extent.max(1e-3),
            };
            let mut one = Bins::EMPTY;
            for r in &refs {
                let c = r.centroid2();
                one.add(binning.bin_of(c), r, c);
            }
            assert_eq!(Bins::of(&refs, &binning), one, "n {n}");
            assert_eq!(Bins::of_parallel(&refs, &binning), one, "n {n}");
            assert_eq!(one.counts.iter().sum::<u32>() as usize, n);
        }
    }

    /// The half area as one vector product equals xy + yz + zx written out, and is 0 for the
    /// empty box.
    #[test]
    fn half_area_is_the_written_out_sum() {
        assert_eq!(Aabb::EMPTY.half_area(), 0.0);
        for r in random_refs(10_000, 9) {
            let b = Aabb {
                min: r.lower,
                max: r.upper,
            };
            let d = (b.max - b.min).truncate();
            assert_eq!(b.half_area(), d.x * d.y + d.y * d.z + d.z * d.x);
        }
    }

    /// SAH cost (unnormalised, as `choose_split` weighs it) of splitting `refs` at `mid`.
    fn split_cost(refs: &[PrimRef], mid: usize) -> f32 {
        let (l, _) = range_bounds(&refs[..mid]);
        let (r, _) = range_bounds(&refs[mid..]);
        l.half_area() * mid as f32 + r.half_area() * (refs.len() - mid) as f32
    }

    /// The sweep tries every split between neighbours along the axis, so none of the 15
    /// planes between 16 bins on that axis does better.
    #[test]
    fn sweep_is_at_least_as_good_as_every_bin_plane() {
        for seed in 0..200 {
            let n = 2 + seed as usize % (SWEEP_MAX - 1);
            let mut refs = random_refs(n, 100 + seed);
            let (bounds, centroids) = range_bounds(&refs);
            let (axis, extent) = longest_axis(&centroids);
            let Some(split) = sweep_split(&mut refs, &bounds, axis) else {
                assert!(n <= MAX_LEAF_SIZE);
                continue;
            };
            let swept = split_cost(&refs, split.mid);
            let binning = Binning {
                axis,
                lo: centroids.min[axis],
                scale: SAH_BINS as f32 / extent,
            };
            for plane in 1..SAH_BINS {
                let mut trial = refs.clone();
                let mid = partition_binned::<1>(&mut trial, &binning, plane, None, None).0;
                if mid > 0 && mid < n {
                    let binned = split_cost(&trial, mid);
                    assert!(swept <= binned, "n {n}, plane {plane}: {swept} > {binned}");
                }
            }
        }
    }

    /// The parallel build makes the same tree, node for node and in the same order, as the
    /// sequential one: the threads only change who builds a subtree.
    #[test]
    fn parallel_build_equals_sequential_build() {
        let n = 3 * PARALLEL_MIN + 123;
        let (mut a, mut b) = (random_refs(n, 3), random_refs(n, 3));
        let (bounds, centroids) = range_bounds(&a);
        let tree = build_parallel(&mut a, 0, 0, bounds, centroids, None);
        let sa = tree.stats.clone();
        let pa = tree.assemble(Vec::new());
        let (pb, sb) = build_range(&mut b, 0, 0, bounds, centroids, None);
        assert!(pa.len() > 2 * n / MAX_LEAF_SIZE);
        assert_eq!(pa, pb);
        assert_eq!(
            a.iter().map(PrimRef::id).collect::<Vec<_>>(),
            b.iter().map(PrimRef::id).collect::<Vec<_>>()
        );
        assert_eq!(
            (sa.leaves, sa.max_depth, sa.max_leaf_size),
            (sb.leaves, sb.max_depth, sb.max_leaf_size)
        );
    }
}
