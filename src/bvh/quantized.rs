//! The 4-wide BVH with its boxes quantised to a byte per plane (after Ylitie, Karras & Laine
//! 2017, "Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs", §3.1): one
//! 64-byte node — four 16-byte texels — holds what [`WideNode`] holds in 128 and the binary
//! tree in 32 per child.
//!
//! Per axis a node stores an origin (the minimum of its slots' boxes, an `f32`) and a scale
//! that is a power of two (its biased exponent, a byte); slot s's planes are
//! `origin + q · scale` for bytes q. A power-of-two scale makes `q · scale` exact (q < 2^8), so
//! the plane is one rounding of one addition whether or not a compiler fuses the multiply and
//! the add — the GPU's GLSL and this file compute the same floats. The build rounds each
//! minimum down and each maximum up and checks them in that float arithmetic, so every
//! dequantised box contains the binary tree's box: a ray tests the same leaves it would have
//! tested there, and a few more, and finds the same closest hit.

use super::wide::{Entry, WideBvh, WideNode, WideSlots, WIDTH};
use crate::layout::BvhNode;
use glam::Vec4;
use rayon::prelude::*;

/// A wide node with quantised boxes: 64 bytes, four 16-byte texels. The GPU reads it as two
/// consecutive [`BvhNode`] records (`QuantNode` in `layout.glsl`, `quant_node_at` in
/// `scene_arrays.glsl`), so it shares their array, images and bindings ([`gpu_nodes`]).
#[repr(C, align(64))]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct QuantNode {
    /// The planes' origin per axis.
    origin: [f32; 3],
    /// Per axis the scale's biased exponent (an `f32`'s exponent field, 1..=254); the fourth
    /// byte has bit s set where slot s is in use.
    exponents_valid: [u8; 4],
    /// A wide node's index, or a leaf's first triangle with the leaf bit set (`wide.rs`).
    child: [u32; WIDTH],
    /// `q[0][axis][s]`, `q[1][axis][s]`: slot s's minimum and maximum on the axis.
    q: [[[u8; WIDTH]; 3]; 2],
    /// A leaf slot's triangle count.
    count: [u8; WIDTH],
    _pad: u32,
}

const _: () = assert!(std::mem::size_of::<QuantNode>() == 64);

/// The scale 2^(e − 127) of biased exponent e.
#[inline(always)]
fn scale(e: u8) -> f32 {
    f32::from_bits((e as u32) << 23)
}

/// The plane of byte `q` over `origin` at `scale`, as the walk dequantises it.
#[inline(always)]
fn plane(origin: f32, q: u8, scale: f32) -> f32 {
    origin + q as f32 * scale
}

impl QuantNode {
    /// `node`'s slots quantised: each dequantised box contains the slot's box.
    pub fn quantize(node: &WideNode) -> QuantNode {
        let (bounds, child, count, valid) = node.parts();
        let used = |s: usize| valid & (1 << s) != 0;
        let mut out = QuantNode {
            origin: [0.0; 3],
            exponents_valid: [0, 0, 0, valid as u8],
            child,
            q: [[[0; WIDTH]; 3]; 2],
            count,
            _pad: 0,
        };
        for axis in 0..3 {
            let (lo, hi) = (bounds[0][axis].to_array(), bounds[1][axis].to_array());
            let slots = (0..WIDTH).filter(|&s| used(s));
            let origin = slots.clone().map(|s| lo[s]).fold(f32::INFINITY, f32::min);
            let top = slots.map(|s| hi[s]).fold(f32::NEG_INFINITY, f32::max);
            if !origin.is_finite() || !top.is_finite() {
                // No slot in use (or a box the loader would not have let through): slots that
                // are not in use are never tested.
                out.exponents_valid[axis] = 127;
                continue;
            }
            // The least exponent whose 255 steps reach the top, starting from the one of
            // (top − origin) / 255, rounded down.
            let steps = ((top - origin) / 255.0).max(f32::MIN_POSITIVE);
            let mut e = ((steps.to_bits() >> 23) as u8).max(1);
            while e < 254 && plane(origin, 255, scale(e)) < top {
                e += 1;
            }
            let s_e = scale(e);
            out.origin[axis] = origin;
            out.exponents_valid[axis] = e;
            for s in (0..WIDTH).filter(|&s| used(s)) {
                // Down and up from the estimate until the plane is outside the box; both ends
                // exist: byte 0 is the origin, byte 255 reaches the top.
                let mut q_lo = ((lo[s] - origin) / s_e).floor().clamp(0.0, 255.0) as u8;
                while q_lo > 0 && plane(origin, q_lo, s_e) > lo[s] {
                    q_lo -= 1;
                }
                let mut q_hi = ((hi[s] - origin) / s_e).ceil().clamp(0.0, 255.0) as u8;
                while q_hi < 255 && plane(origin, q_hi, s_e) < hi[s] {
                    q_hi += 1;
                }
                out.q[0][axis][s] = q_lo;
                out.q[1][axis][s] = q_hi;
            }
        }
        out
    }
}

impl WideSlots for QuantNode {
    /// The slots' planes, dequantised four at a time per axis.
    #[inline(always)]
    fn bounds(&self) -> [[Vec4; 3]; 2] {
        [0, 1].map(|side| {
            [0, 1, 2].map(|axis| {
                let q = self.q[side][axis].map(|b| b as f32);
                Vec4::splat(self.origin[axis])
                    + Vec4::from(q) * Vec4::splat(scale(self.exponents_valid[axis]))
            })
        })
    }

    #[inline(always)]
    fn valid(&self) -> u32 {
        self.exponents_valid[3] as u32
    }

    #[inline(always)]
    fn entry(&self, s: usize) -> Entry {
        Entry::new(self.child[s], self.count[s] as u32)
    }
}

impl WideBvh<WideNode> {
    /// The same tree with quantised boxes ([`QuantNode`]).
    pub fn quantized(&self) -> WideBvh<QuantNode> {
        self.map(QuantNode::quantize)
    }
}

/// The most slots the GPU's walks (`qbvh.glsl`) keep deferred: their per-lane array
/// (`QBVH_STACK_SIZE`) and the two the any-hit walk holds in registers (the closest-hit walk
/// holds three). A level whose
/// [`WideBvh::deferred_bound`] exceeds it is walked in its binary nodes on the GPU.
pub const GPU_DEFERRED_MAX: u32 = crate::layout::QBVH_STACK_MAX + GPU_DEFERRED_REGISTERS;

/// The deferred slots the any-hit walk keeps in registers (`qbvh.glsl`; the closest-hit walk
/// keeps three): a level whose bound is b needs b less these in the array.
pub const GPU_DEFERRED_REGISTERS: u32 = 2;

impl WideBvh<QuantNode> {
    /// The most slots a walk from wide node `w` can have deferred at once: over every path from
    /// it to a leaf, the sum over the path's nodes of their slots in use less one (a walk defers
    /// every entered slot but the one it visits, and keeps only those of the path it is on).
    pub fn deferred_bound(&self, w: u32) -> u32 {
        let node = &self.nodes[w as usize];
        let below = node
            .interior_slots()
            .map(|s| self.deferred_bound(node.child[s]))
            .max()
            .unwrap_or(0);
        node.valid().count_ones().saturating_sub(1) + below
    }
}

/// The node array the GPU reads: the binary nodes (padded to an even count, `base`), then each
/// quantised node as two [`BvhNode`] records, its interior children renumbered to where they
/// are in this array ([`gpu_node_index`]). Returns the array and `base`.
pub fn gpu_nodes(binary: &[BvhNode], quant: &WideBvh<QuantNode>) -> (Vec<BvhNode>, u32) {
    let base = binary.len().next_multiple_of(2);
    let mut nodes = Vec::with_capacity(base + 2 * quant.nodes.len());
    // Copied on every core: a million-triangle scene's 48 MiB are fresh memory, faulted in by
    // the thread that writes them.
    nodes.par_extend(binary.par_iter().copied());
    nodes.resize(base, BvhNode::default());
    let base = base as u32;
    // Record k is half k % 2 of quantised node k / 2 (each node renumbered for both halves:
    // an indexed iterator, which rayon writes in place).
    nodes.par_extend((0..2 * quant.nodes.len()).into_par_iter().map(|k| {
        let node = &quant.nodes[k / 2];
        let mut gpu = *node;
        for s in node.interior_slots() {
            gpu.child[s] = gpu_node_index(base, node.child[s]);
        }
        bytemuck::cast::<QuantNode, [BvhNode; 2]>(gpu)[k % 2]
    }));
    (nodes, base)
}

/// The GPU's node index of wide node `w` in an array whose quantised nodes start at `base`.
pub fn gpu_node_index(base: u32, w: u32) -> u32 {
    base + 2 * w
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::Bvh;
    use glam::Vec3;

    /// The GPU's bound is its walks' largest array (the specialisation constant's default, which
    /// kernels made with every feature keep) and the any-hit walk's two registers (`qbvh.glsl`).
    #[test]
    fn gpu_deferred_max_is_the_shaders_array_and_two_registers() {
        let glsl = include_str!("../../shaders/inc/qbvh.glsl");
        let size: u32 = glsl
            .lines()
            .find_map(|l| l.strip_prefix("layout(constant_id = 7) const uint QBVH_STACK_SIZE = "))
            .and_then(|v| v.trim().trim_end_matches("u;").parse().ok())
            .expect("QBVH_STACK_SIZE in qbvh.glsl");
        assert_eq!(size, crate::layout::QBVH_STACK_MAX);
        assert_eq!(size + 2, GPU_DEFERRED_MAX);
    }

    /// Small triangles at x = 1.5^k: the SAH peels the farthest off at every level, a binary
    /// vine as deep as the triangles are many (up to the depth limit).
    fn vine(n: usize) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|k| {
                let p = Vec3::new(1.5f32.powi(k as i32), 0.0, 0.0);
                [p, p + Vec3::Y * 0.1, p + Vec3::Z * 0.1]
            })
            .collect()
    }

    /// `deferred_bound` is the largest sum, over the paths from the root to a leaf, of each
    /// node's slots in use less one: checked against every path enumerated one by one, on
    /// balanced trees and on vines (which exceed what the GPU keeps, and so are walked there in
    /// their binary nodes).
    #[test]
    fn deferred_bound_is_the_largest_sum_over_paths() {
        let mut rng = 12345u32;
        let mut next = move || {
            rng = rng.wrapping_mul(1664525).wrapping_add(1013904223);
            (rng >> 8) as f32 / 16_777_216.0
        };
        let mut soups: Vec<Vec<[Vec3; 3]>> = (0..6)
            .map(|s| {
                (0..50 + 400 * s)
                    .map(|_| {
                        let p = Vec3::new(next(), next(), next()) * 10.0;
                        [
                            p,
                            p + Vec3::new(next(), 0.0, 0.1),
                            p + Vec3::new(0.0, next(), 0.1),
                        ]
                    })
                    .collect()
            })
            .collect();
        soups.push(vine(20));
        soups.push(vine(200));
        let mut over = 0;
        for tris in &soups {
            let bvh = Bvh::build(tris);
            let quant = WideBvh::collapse(&bvh.nodes, &[0]).quantized();
            let root = quant.root(0).unwrap();
            let mut largest = 0;
            let mut paths = vec![(root, 0u32)];
            while let Some((w, sum)) = paths.pop() {
                let node = &quant.nodes[w as usize];
                let sum = sum + node.valid().count_ones() - 1;
                largest = largest.max(sum);
                for s in node.interior_slots() {
                    paths.push((node.child[s], sum));
                }
            }
            assert_eq!(quant.deferred_bound(root), largest);
            over += usize::from(largest > GPU_DEFERRED_MAX);
        }
        assert_eq!(over, 1, "only the long vine needs the binary walk");
    }

    /// Every dequantised box contains its slot's box, and no plane lies further out than a
    /// step and a rounding beyond it: the planes are tight where they can be.
    #[test]
    fn dequantised_boxes_contain_the_slots_and_stay_close() {
        let mut checked = 0;
        for seed in 0..3000u32 {
            let u = |k: u32| crate::sampling::rng_uniform4(5, seed, k, 0);
            // Boxes from tiny to huge, near the origin and far from it, some flat.
            let magnitude = [1e-30, 1e-3, 1.0, 1e3, 1e30][seed as usize % 5];
            let offset = [0.0, 1.0, -1e6, 7.5e3][seed as usize / 5 % 4];
            let node = WideNode::test_node((seed % 4 + 1) as usize, |s| {
                let (a, b) = (u(2 * s as u32), u(2 * s as u32 + 1));
                let lo = (a.truncate() - 0.5) * magnitude + offset;
                let size = b.truncate() * magnitude * if seed % 7 == 0 { 0.0 } else { 1.0 };
                (lo.to_array(), (lo + size).to_array())
            });
            let quant = QuantNode::quantize(&node);
            let (bounds, _, _, valid) = node.parts();
            let deq = quant.bounds();
            assert_eq!(quant.valid(), valid);
            for s in (0..WIDTH).filter(|&s| valid & (1 << s) != 0) {
                for axis in 0..3 {
                    let (lo, hi) = (bounds[0][axis][s], bounds[1][axis][s]);
                    let (qlo, qhi) = (deq[0][axis][s], deq[1][axis][s]);
                    assert!(
                        qlo <= lo && hi <= qhi,
                        "seed {seed} slot {s} axis {axis}: [{qlo}, {qhi}] ⊉ [{lo}, {hi}]"
                    );
                    let step = scale(quant.exponents_valid[axis]);
                    let slack = 2.0 * step + 4.0 * f32::EPSILON * lo.abs().max(hi.abs());
                    assert!(lo - qlo <= slack && qhi - hi <= slack, "seed {seed} slot {s} axis {axis}: [{qlo}, {qhi}] for [{lo}, {hi}], step {step}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 20_000, "{checked}");
    }
}
