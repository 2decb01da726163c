//! The CPU integrators' form of the BVH: the binary tree (`bvh.glsl`) collapsed into nodes of up
//! to four children whose boxes one ray tests together, four lanes of one SIMD register per
//! plane. Its nodes with quantised boxes (`quantized.rs`) are the GPU's bottom levels.
//!
//! The collapse keeps every leaf of the binary tree and the box of every node it does not open:
//! a wide node's children are the binary nodes found by opening, from a binary interior node,
//! interior nodes below it until at most four are open, as [`Plan`] chooses: the opening that
//! makes the sum of the wide nodes' surface areas least (the SAH cost of the walk, whose leaves
//! are fixed). So the leaves, the triangle order and each kept box's slab test are the binary
//! tree's — [`slab4`] gives [`super::bvh_slab`]'s answer lane by lane — and a ray finds the
//! same closest hit; only the order in which subtrees are visited differs (nearest entry first,
//! as in the binary traversal), which can change which of two hits at exactly the same distance
//! is kept. Tests `bvh::tests::matches_brute_force_on_random_soups` and
//! `instancing::wide_and_binary_walks_find_the_same_hits`.
//!
//! Roots are named by their binary node index ([`Hierarchy`]): the bottom levels and the top
//! level of `tlas.rs` share one node array, and each root the collapse was given has its own
//! wide root.

use super::binary::{pop_entered, prefetch_range, Hierarchy, Ray, SLAB_SLACK};
use crate::layout::BvhNode;
use arrayvec::ArrayVec;
use glam::Vec4;
use std::mem::MaybeUninit;

/// Children per wide node.
pub const WIDTH: usize = 4;

/// A child reference that names a leaf: `first triangle | LEAF`, its count beside it.
pub(super) const LEAF: u32 = 1 << 31;

// A leaf's count is kept in a byte: the build makes no leaf larger than this.
const _: () = assert!(super::binary::MAX_LEAF_SIZE <= u8::MAX as usize);

/// Up to [`WIDTH`] children: their boxes per axis as four lanes (`bounds[0]` the minima,
/// `bounds[1]` the maxima), each a wide node's index or a leaf's first triangle with
/// [`LEAF`] set and its triangle count. Slots whose `valid` bit is clear are unused. Two
/// cache lines.
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug)]
pub struct WideNode {
    bounds: [[Vec4; 3]; 2],
    child: [u32; WIDTH],
    count: [u8; WIDTH],
    /// Bit s set where slot s is in use (the slots in use come first).
    valid: u32,
}

/// What the wide walk reads of a node: its slots' boxes per axis as four lanes (`[0]` the
/// minima, `[1]` the maxima), which slots are in use, and what each names. [`WideNode`] keeps
/// the binary tree's boxes; [`super::quantized::QuantNode`] keeps them in a byte per plane.
pub trait WideSlots: Copy + Send + Sync {
    fn bounds(&self) -> [[Vec4; 3]; 2];
    fn valid(&self) -> u32;
    fn entry(&self, s: usize) -> Entry;

    /// How many slots are in use: they come first, so `valid` is a run of low bits and its
    /// length is its highest set bit's place (a bit scan; `count_ones` without the POPCNT of a
    /// portable x86-64 build is a dozen instructions per node visited).
    #[inline(always)]
    fn slots(&self) -> u32 {
        u32::BITS - self.valid().leading_zeros()
    }

    /// The slots in use that name a wide node (not a leaf).
    fn interior_slots(&self) -> impl Iterator<Item = usize> + '_ {
        (0..WIDTH).filter(move |&s| self.valid() & (1 << s) != 0 && self.entry(s).child & LEAF == 0)
    }
}

impl WideSlots for WideNode {
    #[inline(always)]
    fn bounds(&self) -> [[Vec4; 3]; 2] {
        self.bounds
    }

    #[inline(always)]
    fn valid(&self) -> u32 {
        self.valid
    }

    #[inline(always)]
    fn entry(&self, s: usize) -> Entry {
        WideNode::entry(self, s)
    }
}

impl WideNode {
    const EMPTY: WideNode = WideNode {
        bounds: [[Vec4::splat(f32::MAX); 3], [Vec4::splat(-f32::MAX); 3]],
        child: [0; WIDTH],
        count: [0; WIDTH],
        valid: 0,
    };

    /// Slot s as the traversal keeps it.
    #[inline(always)]
    fn entry(&self, s: usize) -> Entry {
        Entry {
            child: self.child[s],
            count: self.count[s] as u32,
        }
    }

    /// The slots' boxes, what they name and which are in use (for the quantised form).
    pub(super) fn parts(&self) -> (&[[Vec4; 3]; 2], [u32; WIDTH], [u8; WIDTH], u32) {
        (&self.bounds, self.child, self.count, self.valid)
    }
}

#[cfg(test)]
impl WideNode {
    /// A node of `slots` one-triangle leaves with the boxes `bounds(s)` gives (for tests).
    pub(crate) fn test_node(
        slots: usize,
        bounds: impl Fn(usize) -> ([f32; 3], [f32; 3]),
    ) -> WideNode {
        let mut node = WideNode::EMPTY;
        for s in 0..slots {
            let (lo, hi) = bounds(s);
            for a in 0..3 {
                node.bounds[0][a][s] = lo[a];
                node.bounds[1][a][s] = hi[a];
            }
            node.child[s] = s as u32 | LEAF;
            node.count[s] = 1;
            node.valid |= 1 << s;
        }
        node
    }
}

/// Slot s's box (min, max) of `bounds` as [`WideSlots::bounds`] gives them.
#[cfg(test)]
fn slot_bounds(bounds: &[[Vec4; 3]; 2], s: usize) -> ([f32; 3], [f32; 3]) {
    let [lo, hi] = bounds;
    (
        [lo[0][s], lo[1][s], lo[2][s]],
        [hi[0][s], hi[1][s], hi[2][s]],
    )
}

/// A wide node's slot: its box (min, max) and, for a leaf, its (first triangle, count).
#[cfg(test)]
pub(crate) type SlotBox = ([f32; 3], [f32; 3], Option<(u32, u32)>);

/// A subtree to visit: a wide node, or a leaf's triangles.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    child: u32,
    count: u32,
}

impl Entry {
    pub(super) fn new(child: u32, count: u32) -> Entry {
        Entry { child, count }
    }
}

/// Trees whose wide nodes take at least this many bytes are walked with prefetches. Below it
/// the nodes and the triangles they name stay in cache between rays (this machine's L2 is 1 MiB
/// a core), where a prefetch is only instructions: 2.6 % of a Cornell box sample's (callgrind,
/// 9 581 → 9 332 without them).
const PREFETCH_MIN_BYTES: usize = 256 << 10;

/// Entries deferred on the traversal stack: at most three per wide node on the path from the
/// root, and no path is longer than the binary tree's (`MAX_DEPTH`).
const STACK: usize = (WIDTH - 1) * super::binary::MAX_DEPTH;

/// The binary tree collapsed to [`WideNode`]s (or their quantised form), and the wide root of
/// each binary root it was given.
#[derive(Clone, Debug, Default)]
pub struct WideBvh<N = WideNode> {
    pub nodes: Vec<N>,
    /// (binary root, wide root), sorted by binary root.
    roots: Vec<(u32, u32)>,
    /// Whether the walks prefetch the children a ray enters: only where the tree is too large
    /// to stay in cache ([`PREFETCH_MIN_BYTES`]).
    prefetches: bool,
}

impl<N> WideBvh<N> {
    /// The same tree with every node mapped by `f` (node indices and roots unchanged).
    pub(super) fn map<M>(&self, f: impl Fn(&N) -> M + Sync + Send) -> WideBvh<M>
    where
        N: Sync,
        M: Send,
    {
        use rayon::prelude::*;
        WideBvh {
            nodes: self.nodes.par_iter().map(f).collect(),
            roots: self.roots.clone(),
            prefetches: self.prefetches,
        }
    }
}

impl WideBvh<WideNode> {
    /// The wide form of the trees rooted at `roots` in `nodes` (the depth-first binary layout of
    /// `bvh.rs`: an interior node's left child follows it, `offset` is its right child).
    ///
    /// The wide nodes come out depth first, each followed by its slots' subtrees in slot order.
    /// Since [`Plan`] knows how many wide nodes each subtree becomes, every subtree's range of
    /// the output is known before it is collapsed, and large subtrees are collapsed on separate
    /// threads into their ranges: the same nodes in the same places as one recursion would
    /// write (test `bvh::tests::parallel_collapse_lays_out_nodes_depth_first`).
    pub fn collapse(nodes: &[BvhNode], roots: &[u32]) -> WideBvh {
        // Each root once (instances share bottom levels), in order: `root` searches them.
        let mut distinct = roots.to_vec();
        distinct.sort_unstable();
        distinct.dedup();
        let plan = Plan::of(nodes);
        // Wide nodes per root: none for the tree of no triangles (one node with inverted
        // bounds, `Bvh::is_empty`: its walks miss), one holding a tree that is one leaf.
        let sizes: Vec<usize> = distinct
            .iter()
            .map(|&root| match nodes.get(root as usize) {
                None => 0,
                Some(n) if n.is_leaf() => 1,
                Some(n) if n.bounds_min[0] > n.bounds_max[0] => 0,
                Some(_) => plan.wide_nodes[root as usize] as usize,
            })
            .collect();
        // Written in place by the threads that collapse each part: fresh memory's pages are
        // faulted in by the thread that first writes them (a 1M-triangle tree's wide nodes are
        // 27 MiB, about 13 ms of faults on one thread on this project's VM), and nothing clears
        // them first (an allocation zeroed at this alignment is one thread's memset).
        let total = sizes.iter().sum();
        let mut out: Vec<WideNode> = Vec::with_capacity(total);
        let mut wide_roots = Vec::with_capacity(distinct.len());
        let (mut rest, mut base) = (&mut out.spare_capacity_mut()[..total], 0);
        for (&root, &size) in distinct.iter().zip(&sizes) {
            if size == 0 {
                continue;
            }
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut(size);
            if nodes[root as usize].is_leaf() {
                let mut node = WideNode::EMPTY;
                fill_slot(&mut node, 0, &nodes[root as usize]);
                mine[0].write(node);
            } else {
                collapse_interior(nodes, &plan, root, base, mine);
            }
            wide_roots.push((root, base));
            (rest, base) = (tail, base + size as u32);
        }
        // SAFETY: the roots' ranges partition the first `total` elements, and
        // `collapse_interior` writes the first element of its range and partitions the rest
        // between its subtrees' ranges (it asserts that they fill it), so every element is
        // written.
        unsafe { out.set_len(total) };
        let prefetches = out.len() * std::mem::size_of::<WideNode>() >= PREFETCH_MIN_BYTES;
        WideBvh {
            nodes: out,
            roots: wide_roots,
            prefetches,
        }
    }
}

/// Writes the wide subtree of binary interior node `at` into `out` (its
/// `plan.wide_nodes[at]` nodes, the first at index `base`): its own wide node, then each
/// interior slot's subtree in slot order. Every element of `out` is written (see `collapse`).
fn collapse_interior(
    nodes: &[BvhNode],
    plan: &Plan,
    at: u32,
    base: u32,
    out: &mut [MaybeUninit<WideNode>],
) {
    let mut open = ArrayVec::<u32, WIDTH>::new();
    let (k1, k2) = plan.children_slots(at);
    plan.open(nodes, at + 1, k1, &mut open);
    plan.open(nodes, nodes[at as usize].right_child(), k2, &mut open);
    let parallel = out.len() >= PARALLEL_NODES;
    let (first, mut rest) = out.split_first_mut().expect("a wide node's room");
    let mut node = WideNode::EMPTY;
    let mut subtrees = ArrayVec::<(u32, u32, &mut [MaybeUninit<WideNode>]), WIDTH>::new();
    let mut next = base + 1;
    for (s, &i) in open.iter().enumerate() {
        let n = &nodes[i as usize];
        fill_slot(&mut node, s, n);
        if !n.is_leaf() {
            let size = plan.wide_nodes[i as usize];
            let (mine, tail) = std::mem::take(&mut rest).split_at_mut(size as usize);
            node.child[s] = next;
            subtrees.push((i, next, mine));
            (rest, next) = (tail, next + size);
        }
    }
    // The slots in use come first (`WideSlots::slots`).
    debug_assert_eq!(node.valid & (node.valid + 1), 0);
    // What makes `collapse`'s `set_len` sound: the subtrees' ranges fill the rest.
    assert!(rest.is_empty(), "the plan's count of wide nodes");
    first.write(node);
    if parallel {
        rayon::scope(|scope| {
            for (i, base, out) in subtrees {
                scope.spawn(move |_| collapse_interior(nodes, plan, i, base, out));
            }
        });
    } else {
        for (i, base, out) in subtrees {
            collapse_interior(nodes, plan, i, base, out);
        }
    }
}

/// Slot s of `node` for binary node `n`: its box, and its leaf (an interior node's wide node
/// is set by the caller).
fn fill_slot(node: &mut WideNode, s: usize, n: &BvhNode) {
    for a in 0..3 {
        node.bounds[0][a][s] = n.bounds_min[a];
        node.bounds[1][a][s] = n.bounds_max[a];
    }
    if n.is_leaf() {
        node.child[s] = n.first_triangle() | LEAF;
        node.count[s] = n.count as u8;
    }
    node.valid |= 1 << s;
}

/// Subtrees of at least this many nodes (binary nodes in [`Plan::solve`], wide nodes in the
/// collapse) have their parts done on separate threads.
pub(super) const PARALLEL_NODES: usize = 1 << 12;

/// One past the last node of the subtree rooted at `i` in the depth-first layout: the end of
/// its rightmost path. A node without children (the tree of no triangles' one node) or with a
/// right child that is not after its left one ends with itself.
fn subtree_end(nodes: &[BvhNode], mut i: usize) -> usize {
    loop {
        let n = &nodes[i];
        let right = n.right_child() as usize;
        if n.is_leaf() || right <= i + 1 || right >= nodes.len() {
            return i + 1;
        }
        i = right;
    }
}

/// A subtree's least cost per number of slots (area, wide nodes), as [`Plan::solve`] keeps it.
type Cost = [(f32, u32); WIDTH];

/// Which binary nodes the collapse opens: the least expected cost of a walk in the SAH's model
/// (Ylitie et al. 2017, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide
/// BVHs", §3.1's dynamic program, for four slots). Every binary leaf is kept, so the leaves'
/// part of the cost is fixed, and a ray's walk tests a wide node's slots together: a tree's
/// cost is the sum of its wide nodes' surface areas (each the box of the binary node it
/// collapses). In [`Plan::solve`], `cost[i][k − 1]` is the least such sum over the wide nodes
/// in binary node i's subtree when the subtree fills at most k slots of its parent's wide
/// node: 0 for a leaf; for k = 1 an interior node is a wide node of its own, its area plus the
/// best split of four slots between its children; for k ≥ 2 the better of k − 1 slots and each
/// split of k between the children. Opening the largest child first (pbrt's and Embree's greedy
/// collapse, this project's until December 2026) left the Cornell box's walks 19 % more wide
/// nodes by this measure, and DamagedHelmet's 3 %.
pub(super) struct Plan {
    /// Per node and k: for k ≥ 2 the left child's share of the k slots, 0 where k − 1 slots
    /// cost less; for k = 1 the two children's shares of their wide node's four slots (left in
    /// the high nibble).
    choice: Vec<[u8; WIDTH]>,
    /// Per interior node: how many wide nodes its subtree becomes when it is a wide node of its
    /// own (the count in its cost for one slot), which places each subtree in the collapse's
    /// output before it is collapsed.
    wide_nodes: Vec<u32>,
}

impl Plan {
    fn of(nodes: &[BvhNode]) -> Plan {
        let (_, choice, wide_nodes) = Plan::solve(nodes);
        Plan { choice, wide_nodes }
    }

    /// The program's choices and wide node counts per node, and the cost of every tree's root
    /// (last root first). Costs compare by area, then by the number of wide nodes: of two
    /// collapses the model cannot tell apart (boxes of no area), the one with fewer nodes.
    ///
    /// Each tree of the array (the top level's and each bottom level's, one after another) is
    /// solved by [`solve_subtree`], which splits large subtrees between threads; a node's
    /// choice depends only on its subtree, so the choices are those of one pass over the whole
    /// array ([`solve_run`]; test `bvh::tests::parallel_plan_equals_one_pass`).
    #[allow(clippy::type_complexity)]
    pub(super) fn solve(nodes: &[BvhNode]) -> (Vec<Cost>, Vec<[u8; WIDTH]>, Vec<u32>) {
        let mut choice = vec![[0u8; WIDTH]; nodes.len()];
        let mut wide_nodes = vec![0u32; nodes.len()];
        let mut roots = Vec::new();
        let (mut c, mut w, mut start) = (&mut choice[..], &mut wide_nodes[..], 0);
        while start < nodes.len() {
            let end = subtree_end(nodes, start);
            let (c0, c1) = std::mem::take(&mut c).split_at_mut(end - start);
            let (w0, w1) = std::mem::take(&mut w).split_at_mut(end - start);
            roots.push(solve_subtree(nodes, start, c0, w0));
            (c, w, start) = (c1, w1, end);
        }
        roots.reverse();
        (roots, choice, wide_nodes)
    }

    /// [`Plan::solve`] as one pass over the whole array on one thread (for tests).
    #[cfg(test)]
    #[allow(clippy::type_complexity)]
    pub(super) fn solve_one_pass(nodes: &[BvhNode]) -> (Vec<Cost>, Vec<[u8; WIDTH]>, Vec<u32>) {
        let mut choice = vec![[0u8; WIDTH]; nodes.len()];
        let mut wide_nodes = vec![0u32; nodes.len()];
        let roots = solve_run(nodes, 0, &mut choice, &mut wide_nodes);
        (roots, choice, wide_nodes)
    }

    /// The slots of interior node `i`'s wide node that go to its left and right children.
    fn children_slots(&self, i: u32) -> (usize, usize) {
        let c = self.choice[i as usize][0];
        ((c >> 4) as usize, (c & 15) as usize)
    }

    /// Appends the binary nodes that subtree `i` takes as its at most `k` slots, left to right.
    fn open(&self, nodes: &[BvhNode], i: u32, k: usize, slots: &mut ArrayVec<u32, WIDTH>) {
        let n = &nodes[i as usize];
        if k == 1 || n.is_leaf() {
            slots.push(i);
            return;
        }
        match self.choice[i as usize][k - 1] as usize {
            0 => self.open(nodes, i, k - 1, slots),
            k1 => {
                self.open(nodes, i + 1, k1, slots);
                self.open(nodes, n.right_child(), k - k1, slots);
            }
        }
    }

    /// The least sum of the wide nodes' surface areas (half areas) of the one tree in `nodes`
    /// (root 0, an interior node), its own wide node included: what [`WideBvh::collapse`]
    /// builds.
    #[cfg(test)]
    pub(super) fn cost_of(nodes: &[BvhNode]) -> f32 {
        let (roots, _, _) = Plan::solve(nodes);
        assert_eq!(roots.len(), 1, "one tree");
        roots[0][0].0
    }
}

/// The cost of the subtree rooted at `start` (its nodes `choice.len()` long from there), its
/// nodes' choices and wide node counts written into `choice` and `wide_nodes` (indexed from
/// `start`). A large subtree's two children are solved on separate threads.
fn solve_subtree(
    nodes: &[BvhNode],
    start: usize,
    choice: &mut [[u8; WIDTH]],
    wide_nodes: &mut [u32],
) -> Cost {
    let len = choice.len();
    let n = &nodes[start];
    let right = n.right_child() as usize;
    if len < PARALLEL_NODES || n.is_leaf() || right <= start + 1 || right >= start + len {
        let roots = solve_run(nodes, start, choice, wide_nodes);
        debug_assert_eq!(roots.len(), 1, "one subtree");
        return roots.first().copied().unwrap_or_default();
    }
    let (own_choice, choice) = choice.split_at_mut(1);
    let (own_wide, wide_nodes) = wide_nodes.split_at_mut(1);
    let (lc, rc) = choice.split_at_mut(right - start - 1);
    let (lw, rw) = wide_nodes.split_at_mut(right - start - 1);
    let (l, r) = rayon::join(
        || solve_subtree(nodes, start + 1, lc, lw),
        || solve_subtree(nodes, right, rc, rw),
    );
    let (cost, c) = node_cost(n, &l, &r);
    (own_choice[0], own_wide[0]) = (c, cost[0].1);
    cost
}

/// The program over the nodes `choice.len()` long from `start`, visited last to first.
/// Children follow their parents in the depth-first layout (left child next, then its
/// subtree, then the right child's), so visiting the nodes last to first finishes a node's
/// right subtree, then its left subtree, then the node: the costs of the subtrees no parent
/// has taken yet form a stack, a node's two children on top (left above right), and what is
/// left on it at the end are the costs of the trees in the range (last first). A stack as
/// deep as the tree instead of a cost per node (32 MiB of fresh memory for a 1M-triangle
/// tree, whose page faults and far reads of right children's costs were most of this
/// pass's time: terrain-1M 34-36 -> 15-24 ms).
fn solve_run(
    nodes: &[BvhNode],
    start: usize,
    choice: &mut [[u8; WIDTH]],
    wide_nodes: &mut [u32],
) -> Vec<Cost> {
    let mut pending: Vec<Cost> = Vec::with_capacity(2 * super::binary::MAX_DEPTH + 2);
    for k in (0..choice.len()).rev() {
        let i = start + k;
        let n = &nodes[i];
        // Leaves, and an empty tree's one node (no children: its right child is itself),
        // cost nothing.
        if n.is_leaf() || n.right_child() as usize <= i + 1 || pending.len() < 2 {
            pending.push([(0.0, 0); WIDTH]);
            continue;
        }
        let l = pending.pop().unwrap_or_default();
        let r = pending.pop().unwrap_or_default();
        let (cost, c) = node_cost(n, &l, &r);
        (choice[k], wide_nodes[k]) = (c, cost[0].1);
        pending.push(cost);
    }
    pending
}

/// Interior node `n`'s cost per number of slots and its choices, from its children's costs.
fn node_cost(n: &BvhNode, l: &Cost, r: &Cost) -> (Cost, [u8; WIDTH]) {
    let less = |a: (f32, u32), b: (f32, u32)| a.0 < b.0 || (a.0 == b.0 && a.1 < b.1);
    let add = |a: (f32, u32), b: (f32, u32)| (a.0 + b.0, a.1 + b.1);
    let mut cost = [(0.0f32, 0u32); WIDTH];
    let mut choice = [0u8; WIDTH];
    // A wide node: its four slots split between the children (each child's cost is of at most
    // so many slots, so splits of all four are enough). Ties keep the first.
    let mut best = (add(l[0], r[2]), 1 << 4 | 3);
    for k1 in 2..WIDTH {
        let c = add(l[k1 - 1], r[WIDTH - k1 - 1]);
        if less(c, best.0) {
            best = (c, (k1 << 4 | (WIDTH - k1)) as u8);
        }
    }
    cost[0] = add((super::build::node_half_area(n), 1), best.0);
    choice[0] = best.1;
    for k in 2..=WIDTH {
        let mut best = (add(l[0], r[k - 2]), 1u8);
        for k1 in 2..k {
            let c = add(l[k1 - 1], r[k - k1 - 1]);
            if less(c, best.0) {
                best = (c, k1 as u8);
            }
        }
        if less(cost[k - 2], best.0) {
            best = (cost[k - 2], 0);
        }
        cost[k - 1] = best.0;
        choice[k - 1] = best.1;
    }
    (cost, choice)
}

impl<N: WideSlots> WideBvh<N> {
    /// Prefetches what the slots in `mask` of `node` name: wide nodes here, leaves through
    /// `prefetch_leaf` (which knows their primitives), so that the misses of the children a
    /// ray enters overlap.
    #[inline(always)]
    fn prefetch(&self, node: &N, mut mask: u32, prefetch_leaf: &impl Fn(u32, u32)) {
        while mask != 0 {
            let e = node.entry(mask.trailing_zeros() as usize);
            if e.child & LEAF != 0 {
                prefetch_leaf(e.child & !LEAF, e.count);
            } else {
                prefetch_range(&self.nodes, e.child, 1);
            }
            mask &= mask - 1;
        }
    }

    /// The wide root of binary root `root` (one the collapse was given).
    #[inline]
    pub fn root(&self, root: u32) -> Option<u32> {
        match self.roots.as_slice() {
            // A scene without instancing has two roots (the top level's and the one bottom
            // level's): a scan, where the search's loop cost every ray ~20 instructions.
            roots if roots.len() <= 4 => roots.iter().find(|(r, _)| *r == root).map(|(_, w)| *w),
            roots => roots
                .binary_search_by_key(&root, |&(r, _)| r)
                .ok()
                .map(|k| roots[k].1),
        }
    }

    /// Every slot of the wide tree of binary root `root` (for tests).
    #[cfg(test)]
    pub(crate) fn boxes(&self, root: u32) -> Vec<SlotBox> {
        let mut out = Vec::new();
        let mut todo: Vec<u32> = self.root(root).into_iter().collect();
        while let Some(w) = todo.pop() {
            let node = &self.nodes[w as usize];
            for s in (0..WIDTH).filter(|&s| node.valid() & (1 << s) != 0) {
                let (lo, hi) = slot_bounds(&node.bounds(), s);
                let e = node.entry(s);
                if e.child & LEAF != 0 {
                    out.push((lo, hi, Some((e.child & !LEAF, e.count))));
                } else {
                    out.push((lo, hi, None));
                    todo.push(e.child);
                }
            }
        }
        out
    }
}

/// A ray prepared for [`slab4`]: [`super::SlabRay`]'s terms, each splatted across four lanes. Made
/// with one vector division and compare for the three axes (the same IEEE quotients as
/// [`super::SlabRay::new`]'s: test `wide_ray_equals_slab_ray`); per axis in scalar code it took about
/// 60 instructions of every ray's walk.
pub(super) struct WideRay {
    origin: [Vec4; 3],
    inv_dir: [Vec4; 3],
    /// Bit a set: axis a is still ([`super::SlabRay`]'s `still`).
    still: u32,
    moving: bool,
}

impl WideRay {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> WideRay {
        // The fourth lane is 1, so its quotient is finite and never still.
        let d = ray.dir.extend(1.0);
        let still = d.abs().cmplt(Vec4::splat(f32::MIN_POSITIVE));
        let inv = Vec4::select(still, Vec4::ZERO, d.recip());
        let still = still.bitmask();
        WideRay {
            origin: [ray.origin.x, ray.origin.y, ray.origin.z].map(Vec4::splat),
            inv_dir: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            still,
            moving: still == 0,
        }
    }

    /// The ray's terms as [`super::SlabRay`] holds them (for tests).
    #[cfg(test)]
    pub(super) fn terms(&self) -> ([f32; 3], [f32; 3], [bool; 3]) {
        (
            [0, 1, 2].map(|a| self.origin[a].x),
            [0, 1, 2].map(|a| self.inv_dir[a].x),
            [0, 1, 2].map(|a| self.still & (1 << a) != 0),
        )
    }
}

/// The slab test of a wide node's four boxes at once: per lane, the entry distance and whether
/// the box overlaps (t_min, t_max) — lane by lane [`super::bvh_slab`]'s answer, in the min/max
/// form of `super::bvh_slab_min_max` and `bvh.glsl` (the same floats as its sign-selected form:
/// test `slab4_equals_bvh_slab_per_lane`). Selecting each axis's entry plane by the sign of
/// the ray's direction made the compiler branch on those signs at every node: 40 % of a
/// Cornell box render's mispredicted branches in cachegrind's branch model (which this
/// machine's predictor beats: samples/s measured the same within the spread). The min/max form
/// has no branch on them and runs 1 % fewer instructions per sample.
#[inline(always)]
pub(super) fn slab4(node: &impl WideSlots, ray: &WideRay, t_min: f32, t_max: f32) -> (Vec4, u32) {
    let bounds = node.bounds();
    let (o, inv) = (&ray.origin, &ray.inv_dir);
    // Per axis, the entry and exit distances of the four slabs.
    let slabs = |a: usize| {
        let (t0, t1) = (
            (bounds[0][a] - o[a]) * inv[a],
            (bounds[1][a] - o[a]) * inv[a],
        );
        (t0.min(t1), t0.max(t1))
    };
    let ((nx, fx), (ny, fy), (nz, fz)) = if ray.moving {
        (slabs(0), slabs(1), slabs(2))
    } else {
        // A still axis admits every t if the origin lies within the slab, none otherwise.
        let axis = |a: usize| {
            if ray.still & (1 << a) != 0 {
                let (lo, hi) = (bounds[0][a] - o[a], bounds[1][a] - o[a]);
                let outside = lo.max(-hi).cmpgt(Vec4::ZERO);
                let near = Vec4::select(outside, Vec4::splat(f32::MAX), Vec4::splat(-f32::MAX));
                (near, -near)
            } else {
                slabs(a)
            }
        };
        (axis(0), axis(1), axis(2))
    };
    let (near, far) = (nx.max(ny).max(nz), fx.min(fy).min(fz));
    let t_enter = near.max(Vec4::splat(t_min));
    let t_exit = far.min(Vec4::splat(t_max));
    let hit = (t_enter - t_enter.abs() * SLAB_SLACK).cmple(t_exit);
    (t_enter, hit.bitmask() & node.valid())
}

/// Slots set in `mask`, nearest entry first (ties: lower slot first).
#[inline(always)]
fn by_distance(mut mask: u32, t: &[f32; 4]) -> ArrayVec<usize, WIDTH> {
    let mut order = ArrayVec::<usize, WIDTH>::new();
    while mask != 0 {
        let s = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        // Insertion: few entries, mostly in order already.
        let mut k = order.len();
        order.push(s);
        while k > 0 && t[order[k - 1]] > t[s] {
            order[k] = order[k - 1];
            k -= 1;
        }
        order[k] = s;
    }
    order
}

impl<N: WideSlots> Hierarchy for WideBvh<N> {
    /// Front to back: of a node's children the ray enters, the nearest is visited next and the
    /// others deferred with their entry distances, nearest on top. Inlined, as `traverse_any`,
    /// into each caller, whose leaf test and any-hit closure it then takes in place (Cornell box
    /// 8 470 -> 8 409 CPU instructions per sample sampling as Mitsuba does).
    #[inline(always)]
    fn traverse_closest(
        &self,
        root: u32,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut leaf: impl FnMut(u32, u32, f32) -> Option<f32>,
        prefetch_leaf: impl Fn(u32, u32),
    ) -> u32 {
        let Some(root) = self.root(root) else {
            return 0;
        };
        let ray = WideRay::new(ray);
        let mut t_far = t_max;
        let mut boxes = 0;
        let mut stack = ArrayVec::<(Entry, f32), STACK>::new();
        let mut at = Entry {
            child: root,
            count: 0,
        };
        loop {
            if at.child & LEAF != 0 {
                if let Some(t) = leaf(at.child & !LEAF, at.count, t_far) {
                    t_far = t;
                }
            } else {
                let node = &self.nodes[at.child as usize];
                boxes += node.slots();
                let (t_enter, mask) = slab4(node, &ray, t_min, t_far);
                if mask != 0 {
                    if mask & (mask - 1) == 0 {
                        at = node.entry(mask.trailing_zeros() as usize);
                        continue;
                    }
                    if self.prefetches {
                        self.prefetch(node, mask, &prefetch_leaf);
                    }
                    let t = t_enter.to_array();
                    let rest = mask & (mask - 1);
                    if rest & (rest - 1) == 0 {
                        // Two children (most multi-child steps): by_distance's order without
                        // its general sort — the nearer first, the lower slot on a tie.
                        let (a, b) = (
                            mask.trailing_zeros() as usize,
                            rest.trailing_zeros() as usize,
                        );
                        let (near, far) = if t[a] > t[b] { (b, a) } else { (a, b) };
                        stack.push((node.entry(far), t[far]));
                        at = node.entry(near);
                        continue;
                    }
                    let order = by_distance(mask, &t);
                    for &s in order[1..].iter().rev() {
                        stack.push((node.entry(s), t[s]));
                    }
                    at = node.entry(order[0]);
                    continue;
                }
            }
            match pop_entered(&mut stack, t_far) {
                Some(deferred) => at = deferred,
                None => return boxes,
            }
        }
    }

    #[inline(always)]
    fn traverse_any(
        &self,
        root: u32,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut leaf: impl FnMut(u32, u32) -> bool,
        prefetch_leaf: impl Fn(u32, u32),
    ) -> bool {
        let Some(root) = self.root(root) else {
            return false;
        };
        let ray = WideRay::new(ray);
        let mut stack = ArrayVec::<Entry, STACK>::new();
        let mut at = Entry {
            child: root,
            count: 0,
        };
        loop {
            if at.child & LEAF != 0 {
                if leaf(at.child & !LEAF, at.count) {
                    return true;
                }
            } else {
                let node = &self.nodes[at.child as usize];
                let (_, mut mask) = slab4(node, &ray, t_min, t_max);
                if self.prefetches && mask & mask.wrapping_sub(1) != 0 {
                    self.prefetch(node, mask, &prefetch_leaf);
                }
                if mask != 0 {
                    // The lowest slot next, the others deferred.
                    let s = mask.trailing_zeros() as usize;
                    mask &= mask - 1;
                    while mask != 0 {
                        stack.push(node.entry(mask.trailing_zeros() as usize));
                        mask &= mask - 1;
                    }
                    at = node.entry(s);
                    continue;
                }
            }
            let Some(deferred) = stack.pop() else {
                return false;
            };
            at = deferred;
        }
    }
}
