//! Animations (glTF 2.0 §3.11 "Animations", Appendix C "Interpolation"): every sampler's
//! keyframes read and checked once, then any moment posed from them — node translations,
//! rotations, scales and morph weights at time t, from STEP, LINEAR (spherical for rotations)
//! and CUBICSPLINE (cubic Hermite) samplers. Before its first keyframe a channel holds its first
//! value, after its last its last (the specification leaves this to the renderer; the Khronos
//! sample viewer and Blender's importer hold the ends too).
//!
//! The pose is what the loader's node walk reads instead of the nodes' own transforms and
//! weights (`nodes.rs`); the static pose (no animation plays) is the nodes' own values exactly.

use super::accessors::read_attribute;
use super::json::{json_path, label};
use super::limits::Budget;
use anyhow::{anyhow, bail, Context, Result};
use glam::{Mat4, Quat, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::{Interpolation, Property};
use gltf::Document;

/// Which of the file's animations play.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Animations {
    /// None: the file's static pose (what the specification shows when no animation plays).
    #[default]
    Static,
    /// Every animation of the file at once (as the Khronos sample viewer plays them).
    All,
    /// One animation, by index or by name (`--animation N|NAME`).
    One(String),
}

/// A moment of a file's animations: which play, and the time in seconds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Moment {
    pub animations: Animations,
    pub time: f32,
}

impl Moment {
    /// The file's static pose.
    pub fn rest() -> Moment {
        Moment::default()
    }
}

/// One of the file's animations, for listing: its index, name and length in seconds (its last
/// keyframe).
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationInfo {
    pub index: usize,
    pub name: Option<String>,
    pub start: f32,
    pub end: f32,
}

impl AnimationInfo {
    /// "animations[1] ("Walk"), 0 to 2.5 s".
    pub fn describe(&self) -> String {
        format!(
            "{}, {} to {} s",
            label("animations", self.index, self.name.as_deref()),
            self.start,
            self.end
        )
    }
}

/// What a channel moves.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Path {
    Translation,
    Rotation,
    Scale,
    Weights,
}

/// A channel with its sampler's keyframes: `values` holds `width` elements a keyframe (the
/// morph target count for weights, else 1), three times that for CUBICSPLINE (in-tangents,
/// values, out-tangents, glTF 2.0 Appendix C).
#[derive(Clone, Debug)]
struct Channel {
    node: usize,
    path: Path,
    interpolation: Interpolation,
    times: Vec<f32>,
    values: Vec<[f32; 4]>,
    width: usize,
}

/// One animation's channels.
#[derive(Clone, Debug)]
pub(super) struct Clip {
    info: AnimationInfo,
    channels: Vec<Channel>,
}

/// Every node's local transform and morph weights at one moment.
#[derive(Clone, Debug)]
pub(super) struct Pose {
    pub(super) locals: Vec<Mat4>,
    /// The node's morph weights (its own `weights` at the static pose), None where it has none.
    pub(super) weights: Vec<Option<Vec<f32>>>,
}

impl Pose {
    /// The static pose: each node's own matrix (or TRS) and weights, exactly as the file holds
    /// them.
    pub(super) fn rest(document: &Document) -> Pose {
        Pose {
            locals: document
                .nodes()
                .map(|n| Mat4::from_cols_array_2d(&n.transform().matrix()))
                .collect(),
            weights: document
                .nodes()
                .map(|n| n.weights().map(<[f32]>::to_vec))
                .collect(),
        }
    }
}

/// Reads and checks every animation of `document`.
pub(super) fn read_clips(
    document: &Document,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<Vec<Clip>> {
    check_channels(document)?;
    document
        .animations()
        .map(|animation| {
            let at = json_path("animations", animation.index());
            let mut channels = Vec::new();
            for channel in animation.channels() {
                let c = format!("{at}.channels[{}]", channel.index());
                channels.push(read_channel(&channel, buffers, budget).with_context(|| c.clone())?);
            }
            let start = channels
                .iter()
                .map(|c| c.times[0])
                .fold(f32::INFINITY, f32::min);
            let end = channels
                .iter()
                .map(|c| *c.times.last().expect("a channel has keyframes"))
                .fold(f32::NEG_INFINITY, f32::max);
            let (start, end) = if channels.is_empty() {
                (0.0, 0.0)
            } else {
                (start, end)
            };
            Ok(Clip {
                info: AnimationInfo {
                    index: animation.index(),
                    name: animation.name().map(str::to_owned),
                    start,
                    end,
                },
                channels,
            })
        })
        .collect()
}

/// What the `gltf` crate's validation leaves unchecked in channels and its typed model would
/// panic on: a target path it could not read (a misspelling, or KHR_animation_pointer's
/// "pointer"), a target node or sampler accessor out of range, an unknown interpolation.
fn check_channels(document: &Document) -> Result<()> {
    use gltf::json::validation::Checked;
    let root = document.as_json();
    let (nodes, accessors) = (root.nodes.len(), root.accessors.len());
    for (a, animation) in root.animations.iter().enumerate() {
        let at = json_path("animations", a);
        for (c, channel) in animation.channels.iter().enumerate() {
            let at = format!("{at}.channels[{c}].target");
            if let Checked::Invalid = channel.target.path {
                bail!(
                    "{at}.path: not one of \"translation\", \"rotation\", \"scale\", \"weights\" \
                     (KHR_animation_pointer's \"pointer\" is not read)"
                );
            }
            let node = channel.target.node.value();
            if node >= nodes {
                bail!("{at}.node: node {node} does not exist (the file has {nodes})");
            }
        }
        for (k, sampler) in animation.samplers.iter().enumerate() {
            let at = format!("{at}.samplers[{k}]");
            if let Checked::Invalid = sampler.interpolation {
                bail!("{at}.interpolation: not one of \"LINEAR\", \"STEP\", \"CUBICSPLINE\"");
            }
            for (what, index) in [
                ("input", sampler.input.value()),
                ("output", sampler.output.value()),
            ] {
                if index >= accessors {
                    bail!(
                        "{at}.{what}: accessor {index} does not exist (the file has {accessors})"
                    );
                }
            }
        }
    }
    Ok(())
}

/// The animations a file holds.
pub(super) fn infos(clips: &[Clip]) -> Vec<AnimationInfo> {
    clips.iter().map(|c| c.info.clone()).collect()
}

fn read_channel(
    channel: &gltf::animation::Channel,
    buffers: &[Vec<u8>],
    budget: &Budget,
) -> Result<Channel> {
    let target = channel.target();
    let node = target.node();
    let sampler = channel.sampler();
    let s = format!("sampler {}", sampler.index());
    let path = match target.property() {
        Property::Translation => Path::Translation,
        Property::Rotation => Path::Rotation,
        Property::Scale => Path::Scale,
        Property::MorphTargetWeights => Path::Weights,
    };
    if path != Path::Weights {
        if let gltf::scene::Transform::Matrix { .. } = node.transform() {
            bail!(
                "target.node: {} has a matrix; a node an animation moves must give translation, \
                 rotation and scale instead (glTF 2.0 §3.11)",
                label("node", node.index(), node.name())
            );
        }
    }
    let width = match path {
        Path::Weights => {
            let targets = node
                .mesh()
                .and_then(|m| m.primitives().next())
                .map_or(0, |p| p.morph_targets().len());
            if targets == 0 {
                bail!(
                    "target.path: \"weights\", but {} has no mesh with morph targets",
                    label("node", node.index(), node.name())
                );
            }
            targets
        }
        _ => 1,
    };
    let input = sampler.input();
    let input_what = format!(
        "{s}: input = {}",
        label("accessor", input.index(), input.name())
    );
    let times = read_attribute(
        &input,
        buffers,
        None,
        budget,
        &[Dimensions::Scalar],
        &[],
        &[],
    )
    .context(input_what.clone())?;
    let times: Vec<f32> = times.iter().map(|t| t[0]).collect();
    if times.is_empty() {
        bail!("{input_what}: no keyframes");
    }
    if let Some(k) = times.iter().position(|t| !t.is_finite()) {
        bail!("{input_what}: keyframe {k}'s time is {}", times[k]);
    }
    if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
        bail!(
            "{input_what}: keyframe times must increase, but keyframe {} is at {} s after {} s",
            k + 1,
            times[k + 1],
            times[k]
        );
    }
    let output = sampler.output();
    let output_what = format!(
        "{s}: output = {}",
        label("accessor", output.index(), output.name())
    );
    // glTF 2.0 §3.11, "Animations": the accessor types each path allows.
    let normalized = [DataType::I8, DataType::U8, DataType::I16, DataType::U16];
    let (dims, normalized): (Dimensions, &[DataType]) = match path {
        Path::Translation | Path::Scale => (Dimensions::Vec3, &[]),
        Path::Rotation => (Dimensions::Vec4, &normalized),
        Path::Weights => (Dimensions::Scalar, &normalized),
    };
    let values = read_attribute(&output, buffers, None, budget, &[dims], normalized, &[])
        .context(output_what.clone())?;
    let per_key = width
        * match sampler.interpolation() {
            Interpolation::CubicSpline => 3,
            _ => 1,
        };
    if values.len() != times.len() * per_key {
        bail!(
            "{output_what}: {} elements, but {} keyframes of {:?} interpolation need {}",
            values.len(),
            times.len(),
            sampler.interpolation(),
            times.len() * per_key
        );
    }
    if let Some(k) = values.iter().position(|v| !v.iter().all(|x| x.is_finite())) {
        bail!("{output_what}: element {k} is not finite");
    }
    Ok(Channel {
        node: node.index(),
        path,
        interpolation: sampler.interpolation(),
        times,
        values,
        width,
    })
}

/// The clips `animations` names: none, all, or one by index or name (an unknown one is an
/// error that lists the file's animations).
fn chosen<'c>(clips: &'c [Clip], animations: &Animations) -> Result<Vec<&'c Clip>> {
    let list = || {
        if clips.is_empty() {
            "the file has no animations".to_owned()
        } else {
            format!(
                "its animations are: {}",
                clips
                    .iter()
                    .map(|c| c.info.describe())
                    .collect::<Vec<_>>()
                    .join("; ")
            )
        }
    };
    match animations {
        Animations::Static => Ok(Vec::new()),
        Animations::All if clips.is_empty() => {
            bail!("a moment of its animations was asked for, but the file has no animations")
        }
        Animations::All => Ok(clips.iter().collect()),
        Animations::One(which) => {
            let by_index = which.trim().parse::<usize>().ok();
            clips
                .iter()
                .find(|c| match by_index {
                    Some(n) => c.info.index == n,
                    None => c.info.name.as_deref() == Some(which.as_str()),
                })
                .map(|c| vec![c])
                .ok_or_else(|| {
                    anyhow!(
                        "--animation {which}: no animation of that index or name; {}",
                        list()
                    )
                })
        }
    }
}

/// The first and last keyframe times over the animations `animations` plays.
pub(super) fn span(clips: &[Clip], animations: &Animations) -> Result<(f32, f32)> {
    let chosen = chosen(clips, animations)?;
    let start = chosen
        .iter()
        .map(|c| c.info.start)
        .fold(f32::INFINITY, f32::min);
    let end = chosen
        .iter()
        .map(|c| c.info.end)
        .fold(f32::NEG_INFINITY, f32::max);
    Ok(if start <= end {
        (start, end)
    } else {
        (0.0, 0.0)
    })
}

/// The pose at `moment`: the static pose with every channel of the chosen animations applied
/// at its time (later animations over earlier ones where two move the same value).
pub(super) fn pose(document: &Document, clips: &[Clip], moment: &Moment) -> Result<Pose> {
    let mut pose = Pose::rest(document);
    let chosen = chosen(clips, &moment.animations)?;
    if chosen.is_empty() {
        return Ok(pose);
    }
    if !moment.time.is_finite() {
        bail!("--time {}: not a finite number of seconds", moment.time);
    }
    let mut trs: Vec<Option<(Vec3, Quat, Vec3)>> = vec![None; pose.locals.len()];
    for clip in chosen {
        for channel in &clip.channels {
            let value = channel.sample(moment.time);
            if channel.path == Path::Weights {
                pose.weights[channel.node] = Some(value.iter().map(|v| v[0]).collect());
                continue;
            }
            let node = document.nodes().nth(channel.node).expect("validated index");
            let entry = trs[channel.node].get_or_insert_with(|| {
                let (t, r, s) = node.transform().decomposed();
                (Vec3::from(t), Quat::from_array(r), Vec3::from(s))
            });
            let v = value[0];
            match channel.path {
                Path::Translation => entry.0 = Vec3::new(v[0], v[1], v[2]),
                Path::Rotation => entry.1 = Quat::from_array(v),
                Path::Scale => entry.2 = Vec3::new(v[0], v[1], v[2]),
                Path::Weights => unreachable!(),
            }
        }
    }
    for (local, trs) in pose.locals.iter_mut().zip(trs) {
        if let Some((t, r, s)) = trs {
            // A rotation of zero length (a degenerate keyframe) leaves the node unrotated.
            let r = if r.length_squared() > 0.0 {
                r.normalize()
            } else {
                Quat::IDENTITY
            };
            *local = Mat4::from_scale_rotation_translation(s, r, t);
        }
    }
    Ok(pose)
}

impl Channel {
    /// The channel's `width` values at time `t` (glTF 2.0 Appendix C).
    fn sample(&self, t: f32) -> Vec<[f32; 4]> {
        let w = self.width;
        let cubic = self.interpolation == Interpolation::CubicSpline;
        // Keyframe k's values (the spline vertices for CUBICSPLINE).
        let value = |k: usize| -> &[[f32; 4]] {
            let base = if cubic { 3 * w * k + w } else { w * k };
            &self.values[base..base + w]
        };
        let last = self.times.len() - 1;
        if t <= self.times[0] {
            return value(0).to_vec();
        }
        if t >= self.times[last] {
            return value(last).to_vec();
        }
        // The keyframe interval holding t: times[k] <= t < times[k + 1].
        let k = self.times.partition_point(|&time| time <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let td = t1 - t0;
        let s = (t - t0) / td;
        match self.interpolation {
            Interpolation::Step => value(k).to_vec(),
            Interpolation::Linear if self.path == Path::Rotation => {
                let (a, b) = (
                    Quat::from_array(value(k)[0]),
                    Quat::from_array(value(k + 1)[0]),
                );
                vec![slerp(a, b, s).to_array()]
            }
            Interpolation::Linear => value(k)
                .iter()
                .zip(value(k + 1))
                .map(|(a, b)| std::array::from_fn(|i| a[i] + s * (b[i] - a[i])))
                .collect(),
            Interpolation::CubicSpline => {
                // Appendix C, "Cubic Spline Interpolation": p(s) = (2s³ − 3s² + 1)·v_k +
                // td·(s³ − 2s² + s)·b_k + (−2s³ + 3s²)·v_k+1 + td·(s³ − s²)·a_k+1.
                let out_tangent = &self.values[3 * w * k + 2 * w..3 * w * k + 3 * w];
                let in_tangent = &self.values[3 * w * (k + 1)..3 * w * (k + 1) + w];
                let (s2, s3) = (s * s, s * s * s);
                let h = [
                    2.0 * s3 - 3.0 * s2 + 1.0,
                    td * (s3 - 2.0 * s2 + s),
                    -2.0 * s3 + 3.0 * s2,
                    td * (s3 - s2),
                ];
                let mut out: Vec<[f32; 4]> = (0..w)
                    .map(|j| {
                        std::array::from_fn(|i| {
                            h[0] * value(k)[j][i]
                                + h[1] * out_tangent[j][i]
                                + h[2] * value(k + 1)[j][i]
                                + h[3] * in_tangent[j][i]
                        })
                    })
                    .collect();
                if self.path == Path::Rotation {
                    let q = Quat::from_array(out[0]);
                    if q.length_squared() > 0.0 {
                        out[0] = q.normalize().to_array();
                    }
                }
                out
            }
        }
    }
}

/// Spherical linear interpolation along the shorter arc (glTF 2.0 Appendix C, "Spherical
/// Linear Interpolation"), linear where the two are nearly parallel.
fn slerp(a: Quat, b: Quat, s: f32) -> Quat {
    let mut d = a.dot(b);
    let b = if d < 0.0 {
        d = -d;
        -b
    } else {
        b
    };
    if d > 0.9995 {
        return (a * (1.0 - s) + b * s).normalize();
    }
    let angle = d.clamp(-1.0, 1.0).acos();
    let sin = angle.sin();
    (a * (((1.0 - s) * angle).sin() / sin) + b * ((s * angle).sin() / sin)).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(interpolation: Interpolation, path: Path, values: Vec<[f32; 4]>) -> Channel {
        Channel {
            node: 0,
            path,
            interpolation,
            times: vec![1.0, 2.0, 4.0],
            values,
            width: 1,
        }
    }

    #[test]
    fn step_linear_and_ends() {
        let v = vec![[0.0; 4], [1.0, 2.0, 3.0, 0.0], [3.0, 2.0, 1.0, 0.0]];
        let step = channel(Interpolation::Step, Path::Translation, v.clone());
        assert_eq!(step.sample(0.0)[0], v[0]);
        assert_eq!(step.sample(1.5)[0], v[0]);
        assert_eq!(step.sample(2.0)[0], v[1]);
        assert_eq!(step.sample(9.0)[0], v[2]);
        let linear = channel(Interpolation::Linear, Path::Translation, v);
        assert_eq!(linear.sample(1.5)[0], [0.5, 1.0, 1.5, 0.0]);
        assert_eq!(linear.sample(3.0)[0], [2.0, 2.0, 2.0, 0.0]);
    }

    #[test]
    fn cubic_spline_passes_its_vertices_and_follows_its_tangents() {
        // Tangents a_k = b_k = 1 on a constant 0: p(s) = td·(s³ − 2s² + s) + td·(s³ − s²).
        let mut values = Vec::new();
        for _ in 0..3 {
            values.extend([[1.0; 4], [0.0; 4], [1.0; 4]]);
        }
        let c = channel(Interpolation::CubicSpline, Path::Translation, values);
        assert_eq!(c.sample(2.0)[0][0], 0.0);
        let s: f32 = 0.25;
        let expected = 2.0 * (s.powi(3) - 2.0 * s * s + s) + 2.0 * (s.powi(3) - s * s);
        assert!((c.sample(2.5)[0][0] - expected).abs() < 1e-6);
    }

    #[test]
    fn slerp_takes_the_short_way_at_constant_speed() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(1.5);
        let half = slerp(a, -b, 0.5);
        assert!(half.angle_between(Quat::from_rotation_y(0.75)) < 1e-5);
        let third = slerp(a, b, 1.0 / 3.0);
        assert!(third.angle_between(Quat::from_rotation_y(0.5)) < 1e-5);
    }
}
