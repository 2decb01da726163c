//! Bounding volume hierarchy: binned SAH build, depth-first flattening into [`BvhNode`]s, and the
//! CPU twin of `shaders/inc/bvh.glsl` (closest-hit and any-hit traversal, same maths and names).
//! The CPU integrators walk the same tree collapsed to four children per node ([`wide`]); both
//! walks are a [`Hierarchy`], and they find the same hits.
//!
//! Build: binned surface area heuristic on the longest centroid axis (Wald 2007, "On fast
//! Construction of SAH-based Bounding Volume Hierarchies"), a full SAH sweep for ranges of 32 or
//! fewer primitives, recursion no deeper than [`MAX_DEPTH`], and depth-first flattening as it goes:
//! an interior node's left child is the next node, its `offset` is the right child. Node bounds
//! are exact f32 unions of the triangles' vertices.
//!
//! Depth is bounded by [`MAX_DEPTH`] (= the traversal stack): a subtree that could otherwise grow
//! deeper is split at the object median, which halves it per level. Traversal therefore never
//! overflows its 64-entry stack, whatever the input.
//!
//! An empty scene yields one node with inverted bounds (min = `f32::MAX`, max = `-f32::MAX`,
//! count 0), so the GPU buffer is never empty; both traversals check for it and report a miss.

mod binary;
mod build;
pub mod quantized;
pub mod wide;

pub use binary::{
    any_triangle, closest_triangle, gpu_triangles, gpu_triangles_with, intersect_triangle,
    prefetch_range, Bvh, BvhStats, Hierarchy, Hit, Ray, INTERSECTION_COST, MAX_DEPTH,
    MAX_LEAF_SIZE, SAH_BINS, SLAB_SLACK, TRAVERSAL_COST,
};
pub use build::sah_cost;
pub use quantized::QuantNode;
pub use wide::{WideBvh, WideNode};

#[cfg(test)]
mod tests;
