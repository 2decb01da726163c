//! The binary BVH as the GPU walks it (nodes in depth-first order, an interior node's left child
//! next, its `offset` the right child) and its walks, closest hit and any hit: the CPU twin of
//! `shaders/inc/bvh.glsl`, same maths and names. Rays, hits and the slab and triangle tests that
//! every walk of `bvh/` shares live here too.

use crate::layout::{BvhNode, GpuTriangle};
use arrayvec::ArrayVec;
use glam::{BVec3, Vec3};
use rayon::prelude::*;
use std::time::Duration;

/// SAH bins on the longest centroid axis.
pub const SAH_BINS: usize = 16;

/// Largest leaf the SAH may choose to keep; larger sets are always split.
pub const MAX_LEAF_SIZE: usize = 8;

/// Deepest leaf (root = depth 0); also the size of the traversal stack (`BVH_STACK_SIZE`).
pub const MAX_DEPTH: usize = 64;

/// SAH cost of visiting a node, relative to intersecting one triangle.
pub const TRAVERSAL_COST: f32 = 1.0;

pub const INTERSECTION_COST: f32 = 1.0;

/// Relative slack of the slab test (`BVH_SLAB_SLACK`): a box counts as hit if its entry distance
/// is within this fraction of its exit distance. Keeps culling conservative against rounding in
/// the slab test and in Möller–Trumbore's t (cf. Ize 2013, "Robust BVH Ray Traversal").
pub const SLAB_SLACK: f32 = 1.0 / 4096.0;

/// A ray `origin + t·dir`; `dir` need not be normalised (t is in units of `dir`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
}

/// A ray/triangle hit: `triangle` indexes the BVH-ordered triangles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub triangle: u32,
    /// Barycentric weight of p1.
    pub u: f32,
    /// Barycentric weight of p2.
    pub v: f32,
}

#[derive(Clone, Debug, Default)]
pub struct BvhStats {
    pub nodes: usize,
    pub leaves: usize,
    /// Depth of the deepest leaf (root = 0).
    pub max_depth: usize,
    pub max_leaf_size: usize,
    /// See [`sah_cost`].
    pub sah_cost: f32,
    pub build_time: Duration,
    /// The parts of `build_time`: the primitive references made (every primitive's bounds,
    /// written to fresh memory: on a large scene mostly the page faults of that memory), the
    /// tree built over them (bounds, splits, partitions and the primitive order) and its
    /// pieces assembled into the node array.
    pub refs_time: Duration,
    pub tree_time: Duration,
    pub assemble_time: Duration,
}

#[derive(Clone, Debug)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// Triangle order: leaf ranges index into the input triangles reordered by this
    /// (BVH triangle `i` is input triangle `order[i]`).
    pub order: Vec<u32>,
    pub stats: BvhStats,
}

impl Bvh {
    /// True for the BVH of no triangles (a single node with inverted bounds).
    pub fn is_empty(&self) -> bool {
        self.nodes
            .first()
            .is_none_or(|root| root.bounds_min[0] > root.bounds_max[0])
    }

    /// Closest hit with t in (t_min, t_max); `triangles` are in BVH order (`order` applied).
    pub fn intersect_closest(
        &self,
        triangles: &[GpuTriangle],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> Option<Hit> {
        if self.is_empty() {
            return None;
        }
        let accept = |_, _, _| true;
        closest_triangle(
            self.nodes.as_slice(),
            0,
            triangles,
            ray,
            t_min,
            t_max,
            accept,
        )
        .0
    }

    /// What a closest-hit query from the root costs: (boxes slab-tested, triangles
    /// intersected), the traversal cost per ray that `wavetrace bench --bvh` reports.
    pub fn closest_hit_cost(
        &self,
        triangles: &[GpuTriangle],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> (u32, u32) {
        if self.is_empty() {
            return (0, 0);
        }
        let accept = |_, _, _| true;
        let (_, boxes, tested) = closest_triangle(
            self.nodes.as_slice(),
            0,
            triangles,
            ray,
            t_min,
            t_max,
            accept,
        );
        (boxes, tested)
    }

    /// True if anything is hit with t in (t_min, t_max) (shadow rays; exits at the first hit).
    pub fn intersect_any(
        &self,
        triangles: &[GpuTriangle],
        ray: &Ray,
        t_min: f32,
        t_max: f32,
    ) -> bool {
        if self.is_empty() {
            return false;
        }
        let accept = |_, _, _| true;
        any_triangle(
            self.nodes.as_slice(),
            0,
            triangles,
            ray,
            t_min,
            t_max,
            accept,
        )
    }
}

/// A tree of boxes over primitive ranges that a ray walks, its roots named by their node index
/// in the binary layout: the binary tree itself (`[BvhNode]`, twin of `bvh.glsl`, which the GPU
/// walks over instances) or its 4-wide collapse ([`WideBvh`], which the CPU integrators walk;
/// with quantised boxes, [`QuantNode`], the GPU's bottom levels: `qbvh.glsl`). Leaves are
/// (first, count) ranges of triangles, or of instances in the top level (`tlas.rs`).
pub trait Hierarchy {
    /// Front-to-back walk for the closest hit: `leaf(first, count, t_far)` tests a leaf's
    /// primitives against hits closer than `t_far` and returns the closest it found; subtrees
    /// the ray enters beyond the closest hit so far are skipped. Returns the boxes tested.
    /// `prefetch_leaf(first, count)` may be called for a leaf the walk will visit, to ask for
    /// its primitives' memory early ([`prefetch_range`]).
    fn traverse_closest(
        &self,
        root: u32,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        leaf: impl FnMut(u32, u32, f32) -> Option<f32>,
        prefetch_leaf: impl Fn(u32, u32),
    ) -> u32;

    /// Walk until `leaf(first, count)` reports a hit (shadow rays).
    fn traverse_any(
        &self,
        root: u32,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        leaf: impl FnMut(u32, u32) -> bool,
        prefetch_leaf: impl Fn(u32, u32),
    ) -> bool;
}

/// The binary walk, twin of `bvh.glsl` (`bvh_step`, `bvh_cursor`), for both levels
/// (`tlas.rs`). Closest hit: an interior node's nearer child is visited first, the farther
/// deferred with its entry distance. Any hit: the left child first.
impl Hierarchy for [BvhNode] {
    fn traverse_closest(
        &self,
        root: u32,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut leaf: impl FnMut(u32, u32, f32) -> Option<f32>,
        _: impl Fn(u32, u32),
    ) -> u32 {
        let (nodes, ray) = (self, &SlabRay::new(ray));
        let mut t_far = t_max;
        // Deferred nodes with their entry distances; no deeper than the tree (MAX_DEPTH), and left
        // uninitialised (zeroing 768 bytes per ray was 1.5 % of a CPU render).
        let mut stack = ArrayVec::<(Cursor, f32), MAX_DEPTH>::new();
        let node = &nodes[root as usize];
        let mut boxes = 1;
        if bvh_slab(node, ray, t_min, t_far).is_none() {
            return boxes;
        }
        let mut at = cursor(root, node);
        loop {
            let [a, b] = at;
            if b & CURSOR_LEAF != 0 {
                if let Some(t) = leaf(a, b & !CURSOR_LEAF, t_far) {
                    t_far = t;
                }
            } else {
                // Descend into the nearer child; keep the farther for later when both are entered.
                boxes += 2;
                let (entered, near, far, far_enter) = step(nodes, at, ray, t_min, t_far, true);
                if entered > 0 {
                    if entered == 2 {
                        stack.push((far, far_enter));
                    }
                    at = near;
                    continue;
                }
            }
            match pop_entered(&mut stack, t_far) {
                Some(deferred) => at = deferred,
                None => return boxes,
            }
        }
    }

    fn traverse_any(
        &self,
        root: u32,
        ray: &Ray,
        t_min: f32,
        t_max: f32,
        mut leaf: impl FnMut(u32, u32) -> bool,
        _: impl Fn(u32, u32),
    ) -> bool {
        let (nodes, ray) = (self, &SlabRay::new(ray));
        // As in the closest-hit walk: no deeper than the tree, uninitialised.
        let mut stack = ArrayVec::<Cursor, MAX_DEPTH>::new();
        let node = &nodes[root as usize];
        if bvh_slab(node, ray, t_min, t_max).is_none() {
            return false;
        }
        let mut at = cursor(root, node);
        loop {
            let [a, b] = at;
            if b & CURSOR_LEAF != 0 {
                if leaf(a, b & !CURSOR_LEAF) {
                    return true;
                }
            } else {
                let (entered, near, far, _) = step(nodes, at, ray, t_min, t_max, false);
                if entered > 0 {
                    if entered == 2 {
                        stack.push(far);
                    }
                    at = near;
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

/// The closest hit (t in (t_min, t_max), `accept`ed) among the triangles of the tree rooted at
/// `root`, with the boxes and triangles its walk tested.
#[inline]
pub fn closest_triangle<H: Hierarchy + ?Sized>(
    tree: &H,
    root: u32,
    triangles: &[GpuTriangle],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    accept: impl Fn(u32, f32, f32) -> bool,
) -> (Option<Hit>, u32, u32) {
    let mut closest: Option<Hit> = None;
    let mut tested = 0;
    let leaf = |first, count, t_far| {
        tested += count;
        let mut found = None;
        for i in first..first + count {
            if let Some((t, u, v)) =
                intersect_triangle(&triangles[i as usize], ray, t_min, found.unwrap_or(t_far))
                    .filter(|&(_, u, v)| accept(i, u, v))
            {
                found = Some(t);
                closest = Some(Hit {
                    t,
                    triangle: i,
                    u,
                    v,
                });
            }
        }
        found
    };
    let prefetch = |first, count| prefetch_range(triangles, first, count);
    let boxes = tree.traverse_closest(root, ray, t_min, t_max, leaf, prefetch);
    (closest, boxes, tested)
}

/// True if an `accept`ed triangle of the tree rooted at `root` is hit with t in (t_min, t_max).
#[inline]
pub fn any_triangle<H: Hierarchy + ?Sized>(
    tree: &H,
    root: u32,
    triangles: &[GpuTriangle],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    accept: impl Fn(u32, f32, f32) -> bool,
) -> bool {
    let leaf = |first, count| {
        (first..first + count).any(|i| {
            intersect_triangle(&triangles[i as usize], ray, t_min, t_max)
                .is_some_and(|(_, u, v)| accept(i, u, v))
        })
    };
    let prefetch = |first, count| prefetch_range(triangles, first, count);
    tree.traverse_any(root, ray, t_min, t_max, leaf, prefetch)
}

/// A node to visit, as the traversal needs it once its box has been tested (`bvh.glsl`,
/// `bvh_cursor`): an interior node's children [left, right] or a leaf's primitives [first,
/// count | CURSOR_LEAF]. A deferred node is kept as its cursor, made from the record read with
/// its sibling, so visiting it later reads nothing.
type Cursor = [u32; 2];

const CURSOR_LEAF: u32 = 1 << 31;

#[inline(always)]
fn cursor(index: u32, node: &BvhNode) -> Cursor {
    // Selects rather than a branch on the node's kind, which the CPU cannot predict.
    let leaf = node.is_leaf();
    [
        if leaf {
            node.first_triangle()
        } else {
            index + 1
        },
        if leaf {
            node.count | CURSOR_LEAF
        } else {
            node.right_child()
        },
    ]
}

/// One step down from the interior node `[left, right]` names (`bvh.glsl`, `bvh_step`): how
/// many of its children the ray enters before `t_far` (0, 1 or 2), the one to visit next
/// (`near`) and, when both, the one to defer (`far`, entered at `far_enter`). By distance, the
/// nearer child first (closest hit); else the left child first (any hit). Written with selects,
/// as the GLSL is: which children a ray enters is what the CPU's branch predictor guesses worst.
#[inline(always)]
fn step(
    nodes: &[BvhNode],
    [li, ri]: Cursor,
    ray: &SlabRay,
    t_min: f32,
    t_far: f32,
    by_distance: bool,
) -> (u32, Cursor, Cursor, f32) {
    let (left, right) = (&nodes[li as usize], &nodes[ri as usize]);
    let (l, r) = (
        bvh_slab(left, ray, t_min, t_far),
        bvh_slab(right, ray, t_min, t_far),
    );
    let (hit_left, dl) = (l.is_some(), l.unwrap_or(0.0));
    let (hit_right, dr) = (r.is_some(), r.unwrap_or(0.0));
    let (cl, cr) = (cursor(li, left), cursor(ri, right));
    let left_first = hit_left && (!hit_right || !by_distance || dl <= dr);
    let (near, far, far_enter) = if left_first {
        (cl, cr, dr)
    } else {
        (cr, cl, dl)
    };
    (hit_left as u32 + hit_right as u32, near, far, far_enter)
}

/// Pops the next deferred subtree the ray enters before the closest hit so far, `t_far` (its
/// entry distance was found when it was pushed; `t_far` can only have shrunk since), dropping
/// those it does not; `None` when the stack is empty. Both walks' closest-hit stacks.
#[inline(always)]
pub(crate) fn pop_entered<E, const N: usize>(
    stack: &mut ArrayVec<(E, f32), N>,
    t_far: f32,
) -> Option<E> {
    while let Some((deferred, t_enter)) = stack.pop() {
        if t_enter - t_enter.abs() * SLAB_SLACK <= t_far {
            return Some(deferred);
        }
    }
    None
}

/// A ray prepared for slab tests: inverse direction, with axes it does not move along
/// (zero or subnormal components, `still`) handled exactly instead of through ∞ and 0·∞ = NaN.
pub(crate) struct SlabRay {
    pub(super) origin: Vec3,
    pub(super) inv_dir: Vec3,
    pub(super) still: BVec3,
    /// No axis is still: [`bvh_slab`] takes its sign-selected form.
    pub(super) moving: bool,
    /// Per axis, 1 where the direction is negative (the ray enters through the max plane).
    pub(super) negative: [usize; 3],
}

impl SlabRay {
    pub(crate) fn new(ray: &Ray) -> SlabRay {
        let still = ray.dir.abs().cmplt(Vec3::splat(f32::MIN_POSITIVE));
        let inv_dir = Vec3::select(still, Vec3::ZERO, ray.dir.recip());
        let negative = ray.dir.cmplt(Vec3::ZERO);
        SlabRay {
            origin: ray.origin,
            inv_dir,
            still,
            moving: !still.any(),
            negative: [0, 1, 2].map(|a| negative.test(a) as usize),
        }
    }
}

/// Slab test (Kay & Kajiya 1986): the distance at which the ray enters `node`'s box, if the box
/// overlaps (t_min, t_max), with [`SLAB_SLACK`] of tolerance. No NaN arises: `inv_dir` is finite.
///
/// A ray with no still axis (nearly every ray) takes the sign-selected form (Williams et al.
/// 2005, "An Efficient and Robust Ray–Box Intersection Algorithm"): on an axis the ray moves
/// along positively, (min − o)·inv ≤ (max − o)·inv because rounding is monotone, so the entry
/// plane is known from the sign and the min/max of `bvh.glsl`'s form select the same values —
/// the same answer bit for bit (test `sign_selected_slab_equals_min_max_slab`) in fewer
/// operations on the CPU.
#[inline(always)]
pub(crate) fn bvh_slab(node: &BvhNode, ray: &SlabRay, t_min: f32, t_max: f32) -> Option<f32> {
    if !ray.moving {
        return bvh_slab_min_max(node, ray, t_min, t_max);
    }
    let planes = [&node.bounds_min, &node.bounds_max];
    let (o, inv, n) = (ray.origin, ray.inv_dir, ray.negative);
    let near = |a: usize| (planes[n[a]][a] - o[a]) * inv[a];
    let far = |a: usize| (planes[1 - n[a]][a] - o[a]) * inv[a];
    // No NaN arises, so plain compare-and-select (one instruction each; f32::max and min add
    // NaN handling).
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let t_enter = max(max(max(near(0), near(1)), near(2)), t_min);
    let t_exit = min(min(min(far(0), far(1)), far(2)), t_max);
    (t_enter - t_enter.abs() * SLAB_SLACK <= t_exit).then_some(t_enter)
}

/// [`bvh_slab`] as `bvh.glsl` writes it, for rays with a still axis: near and far planes by
/// min/max, still axes admitting every t or none.
pub(crate) fn bvh_slab_min_max(
    node: &BvhNode,
    ray: &SlabRay,
    t_min: f32,
    t_max: f32,
) -> Option<f32> {
    let (bmin, bmax) = (Vec3::from(node.bounds_min), Vec3::from(node.bounds_max));
    let t0 = (bmin - ray.origin) * ray.inv_dir;
    let t1 = (bmax - ray.origin) * ray.inv_dir;
    // A still axis admits every t if the origin lies within the slab, none otherwise.
    let outside = (bmin - ray.origin).max(ray.origin - bmax);
    let still_near = Vec3::select(
        outside.cmpgt(Vec3::ZERO),
        Vec3::splat(f32::MAX),
        Vec3::splat(-f32::MAX),
    );
    let near = Vec3::select(ray.still, still_near, t0.min(t1));
    let far = Vec3::select(ray.still, -still_near, t0.max(t1));
    let t_enter = near.max_element().max(t_min);
    let t_exit = far.min_element().min(t_max);
    (t_enter - t_enter.abs() * SLAB_SLACK <= t_exit).then_some(t_enter)
}

/// Möller–Trumbore ray/triangle test (Möller & Trumbore 1997), double-sided: (t, u, v) for a hit
/// with t in (t_min, t_max), u and v the barycentric weights of p1 and p2. Every acceptance test
/// is written so that NaN rejects.
#[inline]
pub fn intersect_triangle(
    tri: &GpuTriangle,
    ray: &Ray,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let (e1, e2) = (Vec3::from(tri.e1), Vec3::from(tri.e2));
    let pvec = ray.dir.cross(e2);
    let det = e1.dot(pvec);
    if det == 0.0 {
        return None;
    }
    let inv_det = 1.0 / det;
    let tvec = ray.origin - Vec3::from(tri.p0);
    let u = tvec.dot(pvec) * inv_det;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let qvec = tvec.cross(e1);
    let v = ray.dir.dot(qvec) * inv_det;
    if !(v >= 0.0 && u + v <= 1.0) {
        return None;
    }
    let t = e2.dot(qvec) * inv_det;
    (t > t_min && t < t_max).then_some((t, u, v))
}

/// The triangles as the intersector wants them, in BVH order: BVH triangle `i` is input triangle
/// `order[i]` with material `materials[order[i]]` (0 when `materials` is empty); `light_pmf` = 0.
pub fn gpu_triangles(
    triangles: &[[Vec3; 3]],
    materials: &[u32],
    order: &[u32],
) -> Vec<GpuTriangle> {
    assert!(
        materials.is_empty() || materials.len() == triangles.len(),
        "one material per triangle"
    );
    gpu_triangles_with(order, |i| {
        (triangles[i], materials.get(i).copied().unwrap_or(0))
    })
}

/// [`gpu_triangles`] of the triangles whose corners and material `triangle(i)` gives.
pub fn gpu_triangles_with(
    order: &[u32],
    triangle: impl Fn(usize) -> ([Vec3; 3], u32) + Sync,
) -> Vec<GpuTriangle> {
    // In BVH order, on every core (a collect keeps the order).
    order
        .par_iter()
        .map(|&i| {
            let ([p0, p1, p2], material) = triangle(i as usize);
            let (e1, e2) = (p1 - p0, p2 - p0);
            GpuTriangle {
                p0: p0.into(),
                material,
                e1: e1.into(),
                light_pmf: 0.0,
                e2: e2.into(),
                area: 0.5 * e1.cross(e2).length(),
            }
        })
        .collect()
}

/// Asks the memory system for the bytes of `items[first..first + count]` (at most 8 cache
/// lines) before they are read: on large scenes most of a walk's time is the wait for a node or
/// a leaf's triangles that are not in cache (`perf`: 40 % of the wide walk on the first load
/// of a node, 70 % of the triangle test on its first load, 1M-triangle scenes).
#[inline(always)]
pub fn prefetch_range<T>(items: &[T], first: u32, count: u32) {
    #[cfg(target_arch = "x86_64")]
    if let Some(range) = items.get(first as usize..(first + count) as usize) {
        let bytes = std::mem::size_of_val(range).min(8 * 64);
        let start = range.as_ptr().cast::<i8>();
        for offset in (0..bytes).step_by(64) {
            // SAFETY: a prefetch has no effect on memory; the address lies in `range`.
            unsafe {
                use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
                _mm_prefetch::<_MM_HINT_T0>(start.add(offset));
            }
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (items, first, count);
}
