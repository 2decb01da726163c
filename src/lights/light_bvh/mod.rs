//! Light BVH for many-light sampling: a binary tree over the bounded emitters (triangles, point
//! and spot lights) whose every node carries the bounds of its lights' positions, emission
//! directions and power, so a shading point can descend from the root choosing each child with
//! probability proportional to an importance estimate (Conty Estevez & Kulla 2018, "Importance
//! Sampling of Many Lights with Adaptive Tree Splitting", §4–5; the form of pbrt-v4's
//! `BVHLightSampler`, Pharr, Jakob & Humphreys, "Physically Based Rendering", 4th ed., §12.6.3).
//! Directional and environment lights have no bounds and are not in the tree: the caller samples
//! them separately and mixes the two choices.
//!
//! The GLSL twin is `shaders/inc/light_bvh.glsl` (same names, same arithmetic in the same order;
//! tests/twins/light_bvh_twins.rs compares them).
//!
//! Build: top down, each light in its own leaf, split by the surface area orientation heuristic
//! (SAOH, Conty Estevez & Kulla §4.2) over 12 buckets per axis, nodes flattened depth first
//! (first child = next node). A subtree that could grow deeper than [`MAX_LIGHT_BVH_DEPTH`] is
//! split at the centroid median instead, so every light's path from the root fits in the 31 low
//! bits of its trail and bit 31 is free for [`NO_LIGHT_TRAIL`].

use crate::sampling::{build_frame, ONE_MINUS_EPSILON};
use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use std::f32::consts::PI;

#[cfg(test)]
mod tests;

/// [`GpuLightNode::flags`]: the node is a leaf holding one light.
pub const LIGHT_NODE_LEAF: u32 = 1;
/// [`GpuLightNode::flags`]: the node's emission is bounded by |cos| to its axis (two-sided
/// emitters below it).
pub const LIGHT_NODE_TWO_SIDED: u32 = 2;
/// Deepest leaf (root = depth 0): a light's trail uses bits 0..=30.
pub const MAX_LIGHT_BVH_DEPTH: u32 = 31;
/// The trail of a light that is not in the tree (power not positive and finite, or bounds not
/// finite): it is never sampled and its pmf is 0.
pub const NO_LIGHT_TRAIL: u32 = u32::MAX;
/// Lower bound of the squared distance in the importance: a point light evaluated at its own
/// position would otherwise give an infinite importance (and NaN probabilities).
pub const LIGHT_BVH_MIN_DISTANCE_SQUARED: f32 = 1e-20;
/// Buckets per axis of the SAOH split search (pbrt-v4 `BVHLightSampler::buildBVH`).
pub const SAOH_BUCKETS: usize = 12;

/// Bounds of one emitter or of a cluster of them (Conty Estevez & Kulla §4.1; pbrt-v4
/// `LightBounds`): positions within the box, total emitted power `phi`, and emission directions
/// within θe of the cone of half-angle θo around the unit axis `w` (normals within θo of `w`,
/// emission within θe of a normal).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub bounds_min: Vec3,
    pub bounds_max: Vec3,
    /// Emitted power (> 0 for a light in the tree).
    pub phi: f32,
    /// Unit axis of the normal cone.
    pub w: Vec3,
    pub cos_theta_o: f32,
    pub cos_theta_e: f32,
    /// Emits on both sides of its normals: the angle to the axis is measured with |cos|.
    pub two_sided: bool,
}

impl LightBounds {
    /// An emitting triangle: its box, the unit geometric normal (p1 − p0) × (p2 − p0) as the
    /// axis with θo = 0, and θe = π/2 (a diffuse emitter emits into the hemisphere of its
    /// normal). A degenerate triangle (no normal) gets the whole sphere of axes (θo = π).
    pub fn triangle(p0: Vec3, p1: Vec3, p2: Vec3, power: f32, two_sided: bool) -> LightBounds {
        let normal = (p1 - p0).cross(p2 - p0).normalize_or_zero();
        let (w, cos_theta_o) = if normal == Vec3::ZERO {
            (Vec3::Z, -1.0)
        } else {
            (normal, 1.0)
        };
        LightBounds {
            bounds_min: p0.min(p1).min(p2),
            bounds_max: p0.max(p1).max(p2),
            phi: power,
            w,
            cos_theta_o,
            cos_theta_e: 0.0,
            two_sided,
        }
    }

    /// A point light: a point box, every direction (θo = π, θe = π/2, as pbrt-v4
    /// `PointLight::Bounds`).
    pub fn point(p: Vec3, power: f32) -> LightBounds {
        LightBounds {
            bounds_min: p,
            bounds_max: p,
            phi: power,
            w: Vec3::Z,
            cos_theta_o: -1.0,
            cos_theta_e: 0.0,
            two_sided: false,
        }
    }

    /// A spot light at `p` shining along `dir`, full intensity inside the cone of cosine
    /// `cos_inner` and none outside `cos_outer`: θo = the inner angle, θe = outer − inner
    /// (pbrt-v4 `SpotLight::Bounds`, including its 0.999 when distinct cones round to θe = 0).
    pub fn spot(p: Vec3, dir: Vec3, power: f32, cos_inner: f32, cos_outer: f32) -> LightBounds {
        let cos_inner = cos_inner.clamp(-1.0, 1.0);
        let cos_outer = cos_outer.clamp(-1.0, 1.0);
        let theta_e = (cos_outer.acos() - cos_inner.acos()).max(0.0);
        let mut cos_theta_e = theta_e.cos();
        if cos_theta_e == 1.0 && cos_outer != cos_inner {
            cos_theta_e = 0.999;
        }
        LightBounds {
            bounds_min: p,
            bounds_max: p,
            phi: power,
            w: dir.normalize_or(Vec3::Z),
            cos_theta_o: cos_inner,
            cos_theta_e,
            two_sided: false,
        }
    }

    /// The same box and cone of directions (everything but the power): the two bounds'
    /// importance at any point differs only by the ratio of their powers.
    pub fn same_reach(&self, other: &LightBounds) -> bool {
        LightBounds {
            phi: other.phi,
            ..*self
        } == *other
    }

    pub fn centroid(&self) -> Vec3 {
        (self.bounds_min + self.bounds_max) * 0.5
    }

    /// Whether the light can go into the tree: positive finite power, finite bounds and axis.
    fn is_valid(&self) -> bool {
        self.phi > 0.0
            && self.phi.is_finite()
            && self.bounds_min.is_finite()
            && self.bounds_max.is_finite()
            && self.w.is_finite()
            && self.cos_theta_o.is_finite()
            && self.cos_theta_e.is_finite()
    }
}

/// Importance of `bounds` at the point `p` with normal `n` (`n` = 0: a point in a medium, no
/// cosine term). See [`light_bounds_importance`].
pub fn importance(bounds: &LightBounds, p: Vec3, n: Vec3) -> f32 {
    light_bounds_importance(&GpuLightNode::leaf(bounds, 0), p, n)
}

/// One node of the flattened light BVH as the GPU reads it (std430, 64 bytes; twin of
/// `struct GpuLightNode` in `shaders/inc/light_bvh.glsl`). Depth first, root at 0: an interior
/// node's first child is the next node and `child_or_light` is its second child; a leaf's
/// `child_or_light` is the light's index in the input of [`LightBvh::build`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuLightNode {
    pub bounds_min: [f32; 3],
    pub phi: f32,
    pub bounds_max: [f32; 3],
    pub cos_theta_o: f32,
    pub w: [f32; 3],
    pub cos_theta_e: f32,
    pub child_or_light: u32,
    /// [`LIGHT_NODE_LEAF`] | [`LIGHT_NODE_TWO_SIDED`].
    pub flags: u32,
    /// Half the length of the box's diagonal: the radius of its bounding sphere (a constant of
    /// the node, computed once instead of at every importance).
    pub radius: f32,
    /// sin θo = √max(0, 1 − cos²θo), likewise.
    pub sin_theta_o: f32,
}

impl GpuLightNode {
    fn new(b: &LightBounds, child_or_light: u32, leaf: bool) -> GpuLightNode {
        GpuLightNode {
            bounds_min: b.bounds_min.to_array(),
            phi: b.phi,
            bounds_max: b.bounds_max.to_array(),
            cos_theta_o: b.cos_theta_o,
            w: b.w.to_array(),
            cos_theta_e: b.cos_theta_e,
            child_or_light,
            flags: if leaf { LIGHT_NODE_LEAF } else { 0 }
                | if b.two_sided { LIGHT_NODE_TWO_SIDED } else { 0 },
            radius: (b.bounds_max - b.bounds_min).length() * 0.5,
            sin_theta_o: safe_sqrt(1.0 - b.cos_theta_o * b.cos_theta_o),
        }
    }

    /// A leaf holding light `light`.
    pub fn leaf(b: &LightBounds, light: u32) -> GpuLightNode {
        GpuLightNode::new(b, light, true)
    }

    /// An interior node whose second child is node `second_child`.
    pub fn interior(b: &LightBounds, second_child: u32) -> GpuLightNode {
        GpuLightNode::new(b, second_child, false)
    }

    pub fn is_leaf(&self) -> bool {
        self.flags & LIGHT_NODE_LEAF != 0
    }

    pub fn two_sided(&self) -> bool {
        self.flags & LIGHT_NODE_TWO_SIDED != 0
    }
}

/// The parts of the importance (pbrt-v4 `LightBounds::Importance`) besides its value, for tests
/// that must know how close a point is to the function's discontinuities.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportanceTerms {
    pub importance: f32,
    /// Squared distance from `p` to the box centre, before clamping.
    pub distance_squared: f32,
    /// Squared radius of the box's bounding sphere: inside it every direction counts (θb = π),
    /// a step in the importance at its surface.
    pub radius_squared: f32,
    /// cos θ', the cosine of the smallest angle between a direction the node may emit to and
    /// the direction to `p`; the importance is 0 where cos θ' ≤ cos θe (a step).
    pub cos_theta_p: f32,
    /// cos θ'i, the receiver's cosine bound (1 when `n` = 0).
    pub cos_theta_pi: f32,
}

/// cos(max(0, θa − θb)) from the sines and cosines of θa, θb ∈ [0, π] (pbrt-v4 `cosSubClamped`).
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        return 1.0;
    }
    cos_a * cos_b + sin_a * sin_b
}

/// sin(max(0, θa − θb)) (pbrt-v4 `sinSubClamped`).
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        return 0.0;
    }
    sin_a * cos_b - cos_a * sin_b
}

fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// The importance of a node at `p` (normal `n`, or 0 for none) and its parts: Conty Estevez &
/// Kulla eq. 3 in pbrt-v4's `LightBounds::Importance` form. phi · cos θ' / d², where
///
/// - d² is the squared distance from `p` to the box centre, clamped below by half the box
///   diagonal's length (pbrt-v4's clamp, which keeps points inside a cluster from dominating;
///   it compares a squared length with a length, so it is not invariant under scaling the
///   scene) and by [`LIGHT_BVH_MIN_DISTANCE_SQUARED`];
/// - θ' = max(0, θw − θo − θb): θw is the angle between the axis `w` and the direction from the
///   box centre to `p` (|cos| for two-sided nodes), θb the half-angle of the cone from `p` around
///   the box's bounding sphere (π inside it); 0 importance where θ' ≥ θe;
///
/// times, when `n` ≠ 0, cos(max(0, θi − θb)) with θi the angle between `n` and the direction to
/// the centre, measured with |cos| because transmissive surfaces receive from both sides.
pub fn light_bounds_importance_terms(node: &GpuLightNode, p: Vec3, n: Vec3) -> ImportanceTerms {
    let bmin = Vec3::from(node.bounds_min);
    let bmax = Vec3::from(node.bounds_max);
    let pc = (bmin + bmax) * 0.5;
    let radius = node.radius;
    let radius_squared = radius * radius;
    let to_p = p - pc;
    let distance_squared = to_p.dot(to_p);
    let d2 = distance_squared
        .max(radius)
        .max(LIGHT_BVH_MIN_DISTANCE_SQUARED);

    // Direction from the centre to p (any unit vector at the centre itself, where p is inside
    // the bounding sphere and the direction does not matter).
    let wi = if distance_squared > 0.0 {
        to_p * (1.0 / distance_squared.sqrt())
    } else {
        Vec3::from(node.w)
    };
    let mut cos_theta_w = Vec3::from(node.w).dot(wi);
    if node.two_sided() {
        cos_theta_w = cos_theta_w.abs();
    }
    let sin_theta_w = safe_sqrt(1.0 - cos_theta_w * cos_theta_w);

    // The cone of directions from p that the bounding sphere subtends (pbrt-v4
    // `BoundSubtendedDirections`): everything when p is inside.
    let cos_theta_b = if distance_squared <= radius_squared {
        -1.0
    } else {
        safe_sqrt(1.0 - radius_squared / distance_squared)
    };
    let sin_theta_b = safe_sqrt(1.0 - cos_theta_b * cos_theta_b);

    let cos_theta_o = node.cos_theta_o;
    let sin_theta_o = node.sin_theta_o;
    let cos_theta_x = cos_sub_clamped(sin_theta_w, cos_theta_w, sin_theta_o, cos_theta_o);
    let sin_theta_x = sin_sub_clamped(sin_theta_w, cos_theta_w, sin_theta_o, cos_theta_o);
    let cos_theta_p = cos_sub_clamped(sin_theta_x, cos_theta_x, sin_theta_b, cos_theta_b);
    let mut terms = ImportanceTerms {
        importance: 0.0,
        distance_squared,
        radius_squared,
        cos_theta_p,
        cos_theta_pi: 1.0,
    };
    if cos_theta_p <= node.cos_theta_e {
        return terms;
    }
    let mut importance = node.phi * cos_theta_p / d2;
    if n != Vec3::ZERO {
        let cos_theta_i = wi.dot(n).abs();
        let sin_theta_i = safe_sqrt(1.0 - cos_theta_i * cos_theta_i);
        terms.cos_theta_pi = cos_sub_clamped(sin_theta_i, cos_theta_i, sin_theta_b, cos_theta_b);
        importance *= terms.cos_theta_pi;
    }
    terms.importance = importance.max(0.0);
    terms
}

/// The importance of a node at `p` with normal `n` (see [`light_bounds_importance_terms`]).
pub fn light_bounds_importance(node: &GpuLightNode, p: Vec3, n: Vec3) -> f32 {
    light_bounds_importance_terms(node, p, n).importance
}

/// The flattened tree and each light's path to its leaf.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightBvh {
    /// Depth first, root at 0; empty when no light has positive power.
    pub nodes: Vec<GpuLightNode>,
    /// `trails[light]`: bit d = 1 where the path from the root to the light's leaf takes the
    /// second child at depth d; [`NO_LIGHT_TRAIL`] for a light that is not in the tree.
    pub trails: Vec<u32>,
    /// Every light in the tree has the same box and cone of directions (a quad light's two
    /// triangles share their box): the importance is linear in the power and its other factor
    /// depends only on those, so at every point each light's pmf through the tree is its share
    /// of the power — the walk cannot tell the lights apart, and sampling by power is the same
    /// estimator without it (up to rounding; exactly for two lights of equal power). False for
    /// an empty tree.
    pub power_alike: bool,
}

/// Memory one light takes while its tree is built and kept: its bounds (`build_light_bvh`'s
/// input), its build record, two nodes (a tree of n lights has 2n − 1) and its trail.
pub const BYTES_PER_LIGHT: usize = std::mem::size_of::<LightBounds>()
    + std::mem::size_of::<BuildLight>()
    + 2 * std::mem::size_of::<GpuLightNode>()
    + 4;

/// A light while the tree is built.
#[derive(Clone, Copy)]
struct BuildLight {
    /// The light's bounds as a cluster of one, its cones' angles taken once for the whole build.
    cluster: Cluster,
    centroid: Vec3,
    index: u32,
}

/// θ ∈ [0, π] between unit vectors, without acos's loss of precision near 0 and π (pbrt-v4
/// `AngleBetween`).
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    if a.dot(b) < 0.0 {
        PI - 2.0 * ((a + b).length() * 0.5).min(1.0).asin()
    } else {
        2.0 * ((b - a).length() * 0.5).min(1.0).asin()
    }
}

/// The smallest cone holding two cones (axis, cos of half-angle), as pbrt-v4's
/// `Union(DirectionCone, DirectionCone)`: one if it holds the other, else the cone spanning both
/// with its axis rotated from `a`'s towards `b`'s in their plane; the whole sphere (axis +Z,
/// cos = −1) when the spread reaches π.
fn cone_union(a_w: Vec3, a_cos: f32, b_w: Vec3, b_cos: f32) -> (Vec3, f32) {
    if a_w == b_w {
        return (a_w, a_cos.min(b_cos));
    }
    let (w, cos, _) = cone_union_with(a_w, a_cos, theta_of(a_cos), b_w, b_cos, theta_of(b_cos));
    (w, cos)
}

/// A cone's half-angle from its cosine, as [`cone_union`] takes it.
fn theta_of(cos: f32) -> f32 {
    cos.clamp(-1.0, 1.0).acos()
}

/// [`cone_union`] of cones whose half-angles ([`theta_of`] their cosines) are known, and the
/// half-angle of the union ([`theta_of`] its cosine): the binning of [`split`] unites every
/// light with a bucket three times per level, and most unions return one of the two cones, whose
/// angle it then need not take again. The same floats as `cone_union` (one function, the angles
/// passed in are the values it would compute).
fn cone_union_with(
    a_w: Vec3,
    a_cos: f32,
    theta_a: f32,
    b_w: Vec3,
    b_cos: f32,
    theta_b: f32,
) -> (Vec3, f32, f32) {
    if a_w == b_w {
        let (cos, theta) = min_with_angle(a_cos, theta_a, b_cos, theta_b);
        return (a_w, cos, theta);
    }
    let theta_d = angle_between(a_w, b_w);
    if (theta_d + theta_b).min(PI) <= theta_a {
        return (a_w, a_cos, theta_a);
    }
    if (theta_d + theta_a).min(PI) <= theta_b {
        return (b_w, b_cos, theta_b);
    }
    let theta_o = (theta_a + theta_d + theta_b) * 0.5;
    if theta_o >= PI {
        return (Vec3::Z, -1.0, theta_of(-1.0));
    }
    let theta_r = theta_o - theta_a;
    // Rotate a's axis by θr towards b's in their plane: along the unit v ⟂ a in that plane
    // (Gram–Schmidt, twice for accuracy when a and b are nearly (anti)parallel). Where v
    // vanishes, any v ⟂ a serves: the cone's error is then below |v| (pbrt-v4 returns the whole
    // sphere there, which for two normals one rounding apart loses all orientation).
    let mut v = b_w - a_w * a_w.dot(b_w);
    v -= a_w * a_w.dot(v);
    let v = if v.length_squared() > 1e-14 {
        v.normalize()
    } else {
        build_frame(a_w).0
    };
    let (sin_r, cos_r) = theta_r.sin_cos();
    let w = (a_w * cos_r + v * sin_r).normalize();
    let cos = theta_o.cos();
    (w, cos, theta_of(cos))
}

/// The lesser of two cosines (`f32::min`, which returns one of its operands) and that operand's
/// angle.
fn min_with_angle(a_cos: f32, theta_a: f32, b_cos: f32, theta_b: f32) -> (f32, f32) {
    let cos = a_cos.min(b_cos);
    (
        cos,
        if cos.to_bits() == a_cos.to_bits() {
            theta_a
        } else {
            theta_b
        },
    )
}

/// Bounds of two clusters together (pbrt-v4 `Union(LightBounds, LightBounds)`).
fn union(a: &LightBounds, b: &LightBounds) -> LightBounds {
    let (w, cos_theta_o) = cone_union(a.w, a.cos_theta_o, b.w, b.cos_theta_o);
    union_with_cone(a, b, w, cos_theta_o)
}

/// [`union`] of `a` and `b` given the cone of directions holding both (axis `w`, `cos_theta_o`).
fn union_with_cone(a: &LightBounds, b: &LightBounds, w: Vec3, cos_theta_o: f32) -> LightBounds {
    LightBounds {
        bounds_min: a.bounds_min.min(b.bounds_min),
        bounds_max: a.bounds_max.max(b.bounds_max),
        phi: a.phi + b.phi,
        w,
        cos_theta_o,
        cos_theta_e: a.cos_theta_e.min(b.cos_theta_e),
        two_sided: a.two_sided || b.two_sided,
    }
}

/// A cluster of [`split`]'s binning (a bucket, or the buckets below or above a boundary): the
/// union of its lights and the half-angles of its cones, θo and θe ([`theta_of`] its
/// `cos_theta_o` and `cos_theta_e`), which [`saoh_cost`] and every union take: carried with the
/// cluster instead of taken again from the cosines (the same values; `acos` was most of the
/// build's time).
#[derive(Clone, Copy)]
struct Cluster {
    bounds: LightBounds,
    theta_o: f32,
    theta_e: f32,
}

impl Cluster {
    fn of(bounds: &LightBounds) -> Cluster {
        Cluster {
            bounds: *bounds,
            theta_o: theta_of(bounds.cos_theta_o),
            theta_e: theta_of(bounds.cos_theta_e),
        }
    }

    /// [`union`] of two clusters, with the angles of its cones.
    fn union(&self, other: &Cluster) -> Cluster {
        let (a, b) = (&self.bounds, &other.bounds);
        let (w, cos_theta_o, theta_o) = cone_union_with(
            a.w,
            a.cos_theta_o,
            self.theta_o,
            b.w,
            b.cos_theta_o,
            other.theta_o,
        );
        let bounds = union_with_cone(a, b, w, cos_theta_o);
        let (_, theta_e) =
            min_with_angle(a.cos_theta_e, self.theta_e, b.cos_theta_e, other.theta_e);
        Cluster {
            bounds,
            theta_o,
            theta_e,
        }
    }
}

/// `a` and `b` united; either may be empty.
fn cluster_union(a: Option<Cluster>, b: Option<Cluster>) -> Option<Cluster> {
    match (a, b) {
        (None, b) => b,
        (a, None) => a,
        (Some(a), Some(b)) => Some(a.union(&b)),
    }
}

/// The SAOH cost of a cluster in a split of a node along `dim` (Conty Estevez & Kulla eq. 1–2;
/// pbrt-v4 `EvaluateCost`): phi · M_Ω · surface area · Kr, with M_Ω the orientation measure of
/// the cone (θo, θe) and Kr = the node's longest extent over its extent along `dim`, which
/// penalises thin slices.
fn saoh_cost(cluster: &Cluster, node_diagonal: Vec3, dim: usize) -> f32 {
    let (b, theta_o, theta_e) = (&cluster.bounds, cluster.theta_o, cluster.theta_e);
    let theta_w = (theta_o + theta_e).min(PI);
    let sin_theta_o = safe_sqrt(1.0 - b.cos_theta_o * b.cos_theta_o);
    let m_omega = 2.0 * PI * (1.0 - b.cos_theta_o)
        + PI / 2.0
            * (2.0 * theta_w * sin_theta_o
                - (theta_o - 2.0 * theta_w).cos()
                - 2.0 * theta_o * sin_theta_o
                + b.cos_theta_o);
    let kr = node_diagonal.max_element() / node_diagonal[dim];
    let d = b.bounds_max - b.bounds_min;
    let area = 2.0 * (d.x * d.y + d.y * d.z + d.z * d.x);
    b.phi * m_omega * kr * area
}

/// The bucket of a centroid coordinate in [lo, hi] (hi > lo).
fn bucket(c: f32, lo: f32, hi: f32) -> usize {
    let b = (SAOH_BUCKETS as f32 * ((c - lo) / (hi - lo))) as usize;
    b.min(SAOH_BUCKETS - 1)
}

impl LightBvh {
    /// Builds the tree over `lights` (leaf light indices are indices into `lights`). Lights
    /// whose power is not positive and finite, or whose bounds are not finite, are left out
    /// (trail [`NO_LIGHT_TRAIL`]). At most 2³¹ lights.
    pub fn build(lights: &[LightBounds]) -> LightBvh {
        assert!(
            lights.len() as u64 <= 1 << MAX_LIGHT_BVH_DEPTH,
            "a light BVH holds at most 2^31 lights"
        );
        let mut build = build_lights(lights);
        let power_alike = !build.is_empty()
            && build
                .windows(2)
                .all(|w| w[0].cluster.bounds.same_reach(&w[1].cluster.bounds));
        // Every light has a leaf of its own, so a subtree of n lights is exactly 2n − 1 nodes:
        // each child's place is known before its sibling is built, and the two children of a
        // large node are built on separate threads into their own parts of the array.
        let mut nodes = vec![GpuLightNode::default(); (2 * build.len()).saturating_sub(1)];
        if !build.is_empty() {
            build_subtree(&mut nodes, 0, &mut build, 0);
        }
        let trails = leaf_trails(&nodes, lights.len());
        LightBvh {
            nodes,
            trails,
            power_alike,
        }
    }

    /// Depth of the deepest leaf (root = 0); 0 for an empty tree.
    pub fn depth(&self) -> u32 {
        let mut deepest = 0;
        let mut stack = Vec::new();
        if !self.nodes.is_empty() {
            stack.push((0usize, 0u32));
        }
        while let Some((i, d)) = stack.pop() {
            let node = &self.nodes[i];
            if node.is_leaf() {
                deepest = deepest.max(d);
            } else {
                stack.push((i + 1, d + 1));
                stack.push((node.child_or_light as usize, d + 1));
            }
        }
        deepest
    }
}

/// The lights that go into the tree (positive, finite power and bounds), as the build takes
/// them, with their indices in `lights`.
fn build_lights(lights: &[LightBounds]) -> Vec<BuildLight> {
    lights
        .iter()
        .enumerate()
        .filter(|(_, b)| b.is_valid())
        .map(|(i, b)| BuildLight {
            cluster: Cluster::of(b),
            centroid: b.centroid(),
            index: i as u32,
        })
        .collect()
}

/// Subtrees of at least this many lights build their two children in parallel (smaller ones
/// cost less than handing them to another thread).
const PARALLEL_MIN_LIGHTS: usize = 2048;

/// Builds the subtree of `lights` (at `depth`) into `nodes` (exactly its 2n − 1 nodes, the
/// first at absolute index `base`) and returns its bounds. The same splits and unions, in the
/// same order, whichever thread builds a subtree: the tree does not depend on the thread count
/// (test `parallel_build_equals_sequential_build`).
fn build_subtree(
    nodes: &mut [GpuLightNode],
    base: u32,
    lights: &mut [BuildLight],
    depth: u32,
) -> LightBounds {
    debug_assert_eq!(nodes.len(), 2 * lights.len() - 1);
    if let [light] = lights {
        nodes[0] = GpuLightNode::leaf(&light.cluster.bounds, light.index);
        return light.cluster.bounds;
    }
    let n = lights.len();
    let mid = split(lights, depth);
    let (first, second) = lights.split_at_mut(mid);
    let (node, rest) = nodes.split_first_mut().expect("a subtree has a node");
    let (first_nodes, second_nodes) = rest.split_at_mut(2 * mid - 1);
    let second_base = base + 2 * mid as u32;
    let mut build_first = move || build_subtree(first_nodes, base + 1, first, depth + 1);
    let mut build_second = move || build_subtree(second_nodes, second_base, second, depth + 1);
    let (a, b) = if n >= PARALLEL_MIN_LIGHTS {
        rayon::join(build_first, build_second)
    } else {
        (build_first(), build_second())
    };
    let bounds = union(&a, &b);
    *node = GpuLightNode::interior(&bounds, second_base);
    bounds
}

/// Per light (of `count`), the trail to its leaf in `nodes` (bit d set where the path takes the
/// second child at depth d), [`NO_LIGHT_TRAIL`] for lights without one.
fn leaf_trails(nodes: &[GpuLightNode], count: usize) -> Vec<u32> {
    let mut trails = vec![NO_LIGHT_TRAIL; count];
    let mut stack = Vec::new();
    if !nodes.is_empty() {
        stack.push((0usize, 0u32, 0u32));
    }
    while let Some((i, depth, trail)) = stack.pop() {
        let node = &nodes[i];
        if node.is_leaf() {
            trails[node.child_or_light as usize] = trail;
        } else {
            stack.push((
                node.child_or_light as usize,
                depth + 1,
                trail | (1 << depth),
            ));
            stack.push((i + 1, depth + 1, trail));
        }
    }
    trails
}

/// Reorders `lights` (two or more) into two nonempty groups for the children of a node at
/// `depth` and returns the size of the first: the cheapest SAOH split over the bucket
/// boundaries of the three axes, or the centroid median when there is no valid split or when
/// the larger side could not reach its leaves within [`MAX_LIGHT_BVH_DEPTH`].
fn split(lights: &mut [BuildLight], depth: u32) -> usize {
    let count = lights.len();
    // A child at depth + 1 with at most 2^(30 − depth) lights has its leaves at depth ≤ 31
    // through median splits.
    let cap = 1u64 << (MAX_LIGHT_BVH_DEPTH - 1 - depth).min(63);
    let mut bounds_min = Vec3::splat(f32::INFINITY);
    let mut bounds_max = Vec3::splat(f32::NEG_INFINITY);
    let mut centroid_min = Vec3::splat(f32::INFINITY);
    let mut centroid_max = Vec3::splat(f32::NEG_INFINITY);
    for l in lights.iter() {
        bounds_min = bounds_min.min(l.cluster.bounds.bounds_min);
        bounds_max = bounds_max.max(l.cluster.bounds.bounds_max);
        centroid_min = centroid_min.min(l.centroid);
        centroid_max = centroid_max.max(l.centroid);
    }
    let diagonal = bounds_max - bounds_min;

    let mut buckets = [[None::<Cluster>; SAOH_BUCKETS]; 3];
    let mut counts = [[0usize; SAOH_BUCKETS]; 3];
    let axes: Vec<usize> = (0..3)
        .filter(|&d| centroid_max[d] > centroid_min[d])
        .collect();
    for l in lights.iter() {
        for &d in &axes {
            let b = bucket(l.centroid[d], centroid_min[d], centroid_max[d]);
            buckets[d][b] = cluster_union(buckets[d][b], Some(l.cluster));
            counts[d][b] += 1;
        }
    }
    // (cost, |difference of the two counts|, axis, bucket): the cheapest split, the most balanced
    // among equally cheap ones (a row of point lights costs 0 everywhere: zero-area boxes).
    let mut best: Option<(f32, usize, usize, usize)> = None;
    for &d in &axes {
        // Clusters below and above each of the 11 bucket boundaries, by prefix and suffix.
        let mut below = [None::<Cluster>; SAOH_BUCKETS];
        let mut acc = None;
        for i in 0..SAOH_BUCKETS {
            acc = cluster_union(acc, buckets[d][i]);
            below[i] = acc;
        }
        let mut above = [None::<Cluster>; SAOH_BUCKETS];
        acc = None;
        for i in (0..SAOH_BUCKETS).rev() {
            acc = cluster_union(acc, buckets[d][i]);
            above[i] = acc;
        }
        let mut count_below = 0;
        for i in 0..SAOH_BUCKETS - 1 {
            count_below += counts[d][i];
            let count_above = count - count_below;
            if count_below == 0
                || count_above == 0
                || count_below as u64 > cap
                || count_above as u64 > cap
            {
                continue;
            }
            let (Some(lo), Some(hi)) = (below[i], above[i + 1]) else {
                continue;
            };
            let cost = saoh_cost(&lo, diagonal, d) + saoh_cost(&hi, diagonal, d);
            let imbalance = count_below.abs_diff(count_above);
            if cost.is_finite()
                && best.is_none_or(|(c, m, _, _)| cost < c || (cost == c && imbalance < m))
            {
                best = Some((cost, imbalance, d, i));
            }
        }
    }
    if let Some((_, _, d, split_bucket)) = best {
        let (lo, hi) = (centroid_min[d], centroid_max[d]);
        let mut mid = 0;
        for i in 0..count {
            if bucket(lights[i].centroid[d], lo, hi) <= split_bucket {
                lights.swap(i, mid);
                mid += 1;
            }
        }
        debug_assert!(mid > 0 && mid < count);
        return mid;
    }
    // Median along the widest centroid axis (or in input order when all centroids coincide).
    let mid = count / 2;
    let extent = centroid_max - centroid_min;
    if extent.max_element() > 0.0 {
        let d = extent.max_position();
        lights.select_nth_unstable_by(mid, |a, b| a.centroid[d].total_cmp(&b.centroid[d]));
    }
    mid
}

/// How [`light_bvh_walk`] picks a child at each node.
#[derive(Clone, Copy)]
enum Choice {
    /// The child `u` falls in, by the children's probabilities, `u` remapped to [0, 1) after.
    Sample(f32),
    /// The child the trail's next bit names (bit d = 1: second child at depth d).
    Trail(u32),
}

/// One descent from the root for the point `p` with normal `n` (0 for none): at each interior
/// node a child is taken as `choice` says, and the probabilities of the children taken —
/// importance over the sum of the two — are multiplied (pbrt-v4 `BVHLightSampler::Sample` and
/// `PMF` share it). Returns (light index, product), or `None` when no light can reach `p` (both
/// children of a node, or a lone root leaf, of importance 0) or the tree is empty.
fn light_bvh_walk(nodes: &[GpuLightNode], p: Vec3, n: Vec3, choice: Choice) -> Option<(u32, f32)> {
    if nodes.is_empty() {
        return None;
    }
    let (mut u, mut trail) = match choice {
        Choice::Sample(u) => (u.clamp(0.0, ONE_MINUS_EPSILON), 0),
        Choice::Trail(trail) => (0.0, trail),
    };
    let by_trail = matches!(choice, Choice::Trail(_));
    let mut index = 0usize;
    let mut pmf = 1.0f32;
    // The node at `index`: below the root, the child taken at its parent's level (the GLSL twin
    // so fetches each node of the path once).
    let mut node = &nodes[0];
    for _ in 0..=MAX_LIGHT_BVH_DEPTH {
        if node.is_leaf() {
            if index == 0 && light_bounds_importance(node, p, n) <= 0.0 {
                return None;
            }
            return Some((node.child_or_light, pmf));
        }
        let second = node.child_or_light as usize;
        let (child0, child1) = (&nodes[index + 1], &nodes[second]);
        let c0 = light_bounds_importance(child0, p, n);
        let c1 = light_bounds_importance(child1, p, n);
        let sum = c0 + c1;
        if sum.is_nan() || sum <= 0.0 {
            return None;
        }
        let p0 = c0 / sum;
        let first = if by_trail { trail & 1 == 0 } else { u < p0 };
        if first {
            pmf *= p0;
            u = (u / p0).min(ONE_MINUS_EPSILON);
            index += 1;
            node = child0;
        } else {
            let p1 = c1 / sum;
            pmf *= p1;
            u = ((u - p0) / p1).min(ONE_MINUS_EPSILON);
            index = second;
            node = child1;
        }
        trail >>= 1;
    }
    None
}

/// Chooses a light for the point `p` with normal `n` (0 for none) by descending from the root,
/// taking each child with probability proportional to its importance and remapping `u` to
/// [0, 1) after each choice (pbrt-v4 `BVHLightSampler::Sample`). Returns (light index, pmf), the
/// pmf being the product of the choices' probabilities, or `None` when no light can reach `p`
/// (both children of a node, or a lone root leaf, of importance 0) or the tree is empty.
pub fn light_bvh_sample(nodes: &[GpuLightNode], p: Vec3, n: Vec3, u: f32) -> Option<(u32, f32)> {
    light_bvh_walk(nodes, p, n, Choice::Sample(u))
}

/// The probability that [`light_bvh_sample`] at (`p`, `n`) returns `light`: the same walk along
/// the light's trail (pbrt-v4 `BVHLightSampler::PMF`), bit for bit. 0 for a light not in the
/// tree or out of range.
pub fn light_bvh_pmf(nodes: &[GpuLightNode], trails: &[u32], p: Vec3, n: Vec3, light: u32) -> f32 {
    match trails.get(light as usize) {
        Some(&trail) if trail != NO_LIGHT_TRAIL => {
            light_bvh_walk(nodes, p, n, Choice::Trail(trail)).map_or(0.0, |(_, pmf)| pmf)
        }
        _ => 0.0,
    }
}
