//! The two-level structure: bottom-level BVHs (one over the baked world-space triangles, one
//! per mesh that several nodes instance) and a top-level BVH over their instances, each a
//! `GpuInstance` with its object ↔ world transforms. Twin of `shaders/inc/tlas.glsl`.
//!
//! All BVH nodes share one array (bottom levels first, each with absolute node and triangle
//! indices, the top level last, its leaves indexing the instances in top-level order). Rays
//! enter an instance through its world → object transform without normalising the direction,
//! so t is the same in both spaces. A scene with one identity instance (no instancing) skips
//! the top level: its traversal is exactly the one-level traversal.

use crate::bvh::prefetch_range;
use crate::bvh::{any_triangle, closest_triangle, Hierarchy, Hit, Ray};
use crate::layout::{BvhNode, GpuInstance, GpuTriangle, INSTANCE_IDENTITY, INSTANCE_MIRRORED};
use glam::{Mat4, UVec4, Vec3, Vec4};
use rayon::prelude::*;

/// An affine point through the rows of a 3×4 transform.
pub fn transform_point(rows: &[[f32; 4]; 3], p: Vec3) -> Vec3 {
    let r = |k: usize| Vec4::from(rows[k]);
    Vec3::new(
        r(0).truncate().dot(p) + rows[0][3],
        r(1).truncate().dot(p) + rows[1][3],
        r(2).truncate().dot(p) + rows[2][3],
    )
}

/// A direction through the linear part of a 3×4 transform.
pub fn transform_vector(rows: &[[f32; 4]; 3], v: Vec3) -> Vec3 {
    let r = |k: usize| Vec4::from(rows[k]).truncate();
    Vec3::new(r(0).dot(v), r(1).dot(v), r(2).dot(v))
}

/// A normal through the inverse transpose: the transpose of the world → object rows.
pub fn transform_normal(world_to_object: &[[f32; 4]; 3], n: Vec3) -> Vec3 {
    let r = |k: usize| Vec4::from(world_to_object[k]).truncate();
    r(0) * n.x + r(1) * n.y + r(2) * n.z
}

/// The alpha key of a ray inside instance `k` (the same triangle in two instances decides
/// apart).
pub fn instance_key(key: UVec4, k: u32) -> UVec4 {
    UVec4::new(key.x, key.y, key.z, key.w ^ k.wrapping_mul(0x85eb_ca6b))
}

/// The instance placing the bottom level rooted at `blas_root` by `transform` (object → world).
pub fn gpu_instance(transform: &Mat4, blas_root: u32) -> GpuInstance {
    let rows = |m: &Mat4| {
        let t = m.transpose();
        [
            t.x_axis.to_array(),
            t.y_axis.to_array(),
            t.z_axis.to_array(),
        ]
    };
    let identity = *transform == Mat4::IDENTITY;
    let mut flags = if identity { INSTANCE_IDENTITY } else { 0 };
    if glam::Mat3::from_mat4(*transform).determinant() < 0.0 {
        flags |= INSTANCE_MIRRORED;
    }
    GpuInstance {
        object_to_world: rows(transform),
        world_to_object: rows(&transform.inverse()),
        blas_root,
        flags,
        wide_root: crate::layout::NO_WIDE_ROOT,
        placement: 0,
    }
}

/// World-space bounds of a bottom level's root box under an instance: the box of its eight
/// transformed corners.
pub fn instance_bounds(root: &BvhNode, instance: &GpuInstance) -> (Vec3, Vec3) {
    let (lo, hi) = (Vec3::from(root.bounds_min), Vec3::from(root.bounds_max));
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for k in 0..8 {
        let c = Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        );
        let w = transform_point(&instance.object_to_world, c);
        min = min.min(w);
        max = max.max(w);
    }
    (min, max)
}

/// Appends the tree `blas` (its nodes with triangle indices offset by `first_triangle`) to
/// `nodes`; returns the index of its root. The first tree of an array with no offset is moved
/// in as it is; others are copied on every core (a 1M-triangle tree's 35 MiB are fresh memory,
/// faulted in by the writer).
pub fn append_blas(nodes: &mut Vec<BvhNode>, blas: Vec<BvhNode>, first_triangle: u32) -> u32 {
    let base = nodes.len() as u32;
    if base == 0 && first_triangle == 0 {
        *nodes = blas;
        return 0;
    }
    nodes.par_extend(blas.into_par_iter().map(|mut n| {
        n.offset += if n.is_leaf() { first_triangle } else { base };
        n
    }));
    base
}

/// One identity instance (a scene without instancing): the top level is skipped.
fn single_identity_instance(instances: &[GpuInstance]) -> bool {
    instances.len() == 1 && instances[0].flags & INSTANCE_IDENTITY != 0
}

fn object_ray(instance: &GpuInstance, ray: &Ray) -> Ray {
    if instance.flags & INSTANCE_IDENTITY != 0 {
        *ray
    } else {
        Ray {
            origin: transform_point(&instance.world_to_object, ray.origin),
            dir: transform_vector(&instance.world_to_object, ray.dir),
        }
    }
}

/// Closest hit with t in (t_min, t_max) over every instance, with the instance's index;
/// `accept(triangle, u, v, instance, object-space direction)` is the any-hit test. `tree` is the
/// binary node array (the GPU's walk) or its wide collapse (the CPU integrators').
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn scene_intersect_closest<H: Hierarchy + ?Sized>(
    tree: &H,
    tlas_root: u32,
    instances: &[GpuInstance],
    triangles: &[GpuTriangle],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    accept: impl Fn(u32, f32, f32, u32, Vec3) -> bool,
) -> Option<(Hit, u32)> {
    if instances.is_empty() {
        return None;
    }
    if single_identity_instance(instances) {
        let root = instances[0].blas_root;
        return closest_triangle(tree, root, triangles, ray, t_min, t_max, |i, u, v| {
            accept(i, u, v, 0, ray.dir)
        })
        .0
        .map(|h| (h, 0));
    }
    let mut closest: Option<(Hit, u32)> = None;
    let prefetch = |first, count| prefetch_range(instances, first, count);
    let leaf = |first, count, t_far| {
        let mut found = None;
        for k in first..first + count {
            let inst = &instances[k as usize];
            let r = object_ray(inst, ray);
            let t_max = found.unwrap_or(t_far);
            if let (Some(hit), ..) = closest_triangle(
                tree,
                inst.blas_root,
                triangles,
                &r,
                t_min,
                t_max,
                |i, u, v| accept(i, u, v, k, r.dir),
            ) {
                found = Some(hit.t);
                closest = Some((hit, k));
            }
        }
        found
    };
    tree.traverse_closest(tlas_root, ray, t_min, t_max, leaf, prefetch);
    closest
}

/// True if anything of any instance is hit with t in (t_min, t_max).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn scene_intersect_any<H: Hierarchy + ?Sized>(
    tree: &H,
    tlas_root: u32,
    instances: &[GpuInstance],
    triangles: &[GpuTriangle],
    ray: &Ray,
    t_min: f32,
    t_max: f32,
    accept: impl Fn(u32, f32, f32, u32, Vec3) -> bool,
) -> bool {
    if instances.is_empty() {
        return false;
    }
    if single_identity_instance(instances) {
        let root = instances[0].blas_root;
        return any_triangle(tree, root, triangles, ray, t_min, t_max, |i, u, v| {
            accept(i, u, v, 0, ray.dir)
        });
    }
    let leaf = |first, count| {
        (first..first + count).any(|k| {
            let inst = &instances[k as usize];
            let r = object_ray(inst, ray);
            any_triangle(
                tree,
                inst.blas_root,
                triangles,
                &r,
                t_min,
                t_max,
                |i, u, v| accept(i, u, v, k, r.dir),
            )
        })
    };
    let prefetch = |first, count| prefetch_range(instances, first, count);
    tree.traverse_any(tlas_root, ray, t_min, t_max, leaf, prefetch)
}
