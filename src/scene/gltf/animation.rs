//! glTF animations posed at one moment (`LoadOptions::time`, in seconds): the channels that
//! target a node's translation, rotation, scale or morph weights, directly or through a
//! `KHR_animation_pointer` of the form `/nodes/N/translation` (…`rotation`, `scale`,
//! `weights`), are sampled there (STEP, LINEAR with spherical interpolation of rotations, and
//! CUBICSPLINE's Hermite curves; before the first key the first value holds, after the last the
//! last) and override the node's own values. Other pointers (materials, cameras, lights) are
//! left at the file's values. Animations are read from the JSON here because the gltf crate's
//! schema refuses valid pointer channels.

use super::container::{Loader, NodePose};
use crate::error::Result;
use crate::math::{Mat4, Quat, Vec3};
use serde_json::Value;
use std::collections::HashMap;

/// The property a channel animates.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Property {
    Translation,
    Rotation,
    Scale,
    Weights,
}

impl Property {
    fn named(name: &str) -> Option<Property> {
        match name {
            "translation" => Some(Property::Translation),
            "rotation" => Some(Property::Rotation),
            "scale" => Some(Property::Scale),
            "weights" => Some(Property::Weights),
            _ => None,
        }
    }
}

impl Loader {
    /// Every node's pose at `time` seconds (only the nodes some channel animates).
    pub(super) fn pose_at(&self, time: f32) -> Result<HashMap<usize, NodePose>> {
        let mut poses: HashMap<usize, NodePose> = HashMap::new();
        for (a, animation) in self.animations.iter().enumerate() {
            let object = format!("animation {a}");
            let channels = animation.get("channels").and_then(Value::as_array);
            let samplers = animation.get("samplers").and_then(Value::as_array);
            let (Some(channels), Some(samplers)) = (channels, samplers) else {
                return Err(self.err(&object, "needs 'channels' and 'samplers' lists"));
            };
            for (c, channel) in channels.iter().enumerate() {
                let object = format!("{object} channel {c}");
                let Some((node, property)) = channel_target(channel) else {
                    continue;
                };
                if node >= self.document.nodes().len() {
                    return Err(self.err(
                        &object,
                        format!("targets node {node}, which does not exist"),
                    ));
                }
                let sampler = channel
                    .get("sampler")
                    .and_then(Value::as_u64)
                    .and_then(|s| samplers.get(s as usize))
                    .ok_or_else(|| self.err(&object, "'sampler' must name one of the samplers"))?;
                let width = match property {
                    Property::Rotation => 4,
                    Property::Weights => self.weight_count(node),
                    _ => 3,
                };
                if width == 0 {
                    continue;
                }
                let value = self.sample_channel(sampler, property, width, time, &object)?;
                let pose = poses.entry(node).or_default();
                match property {
                    Property::Translation => pose.translation = Some(Vec3::from_slice(&value)),
                    Property::Scale => pose.scale = Some(Vec3::from_slice(&value)),
                    Property::Rotation => {
                        pose.rotation = Some(Quat::from_slice(&value).normalize());
                    }
                    Property::Weights => pose.weights = Some(value),
                }
            }
        }
        Ok(poses)
    }

    /// The number of morph weights of `node`'s mesh (its first primitive's targets).
    fn weight_count(&self, node: usize) -> usize {
        self.document
            .nodes()
            .nth(node)
            .and_then(|n| n.mesh())
            .and_then(|m| m.primitives().next())
            .map_or(0, |p| p.morph_targets().len())
    }

    /// A sampler's value (`width` numbers) at `time`.
    fn sample_channel(
        &self,
        sampler: &Value,
        property: Property,
        width: usize,
        time: f32,
        object: &str,
    ) -> Result<Vec<f32>> {
        let accessor = |key: &str| {
            sampler
                .get(key)
                .and_then(Value::as_u64)
                .and_then(|i| self.document.accessors().nth(i as usize))
                .ok_or_else(|| {
                    self.err(
                        object,
                        format!("the sampler's '{key}' must name an accessor"),
                    )
                })
        };
        let (input, output) = (accessor("input")?, accessor("output")?);
        for a in [&input, &output] {
            self.check_accessor_fits(a)?;
        }
        let times: Vec<f32> = self.read_accessor(&input, super::accessors::component_as_f32)?;
        let values: Vec<f32> = self.read_accessor(&output, super::accessors::component_as_f32)?;
        let interpolation = sampler
            .get("interpolation")
            .and_then(Value::as_str)
            .unwrap_or("LINEAR");
        let cubic = interpolation == "CUBICSPLINE";
        let per_key = if cubic { 3 * width } else { width };
        if times.is_empty() || values.len() != times.len() * per_key {
            return Err(self.err(
                object,
                format!(
                    "{} keys need {} output values ({interpolation}), found {}",
                    times.len(),
                    times.len() * per_key,
                    values.len()
                ),
            ));
        }
        if times.iter().any(|t| !t.is_finite()) || values.iter().any(|v| !v.is_finite()) {
            return Err(self.err(object, "a key time or value is NaN or infinite"));
        }
        // The value (or CUBICSPLINE's in-tangent 0, value 1, out-tangent 2) of key k.
        let key = |k: usize, part: usize| -> &[f32] {
            let start = k * per_key + if cubic { part * width } else { 0 };
            &values[start..start + width]
        };
        let last = times.len() - 1;
        let next = times.partition_point(|&t| t <= time);
        if next == 0 {
            return Ok(key(0, 1).to_vec());
        }
        if next > last {
            return Ok(key(last, 1).to_vec());
        }
        let (k, t0, t1) = (next - 1, times[next - 1], times[next]);
        let dt = t1 - t0;
        let s = if dt > 0.0 { (time - t0) / dt } else { 0.0 };
        Ok(match interpolation {
            "STEP" => key(k, 1).to_vec(),
            "CUBICSPLINE" => {
                let (s2, s3) = (s * s, s * s * s);
                let (h00, h10) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s);
                let (h01, h11) = (-2.0 * s3 + 3.0 * s2, s3 - s2);
                let (p0, m0, p1, m1) = (key(k, 1), key(k, 2), key(k + 1, 1), key(k + 1, 0));
                (0..width)
                    .map(|i| h00 * p0[i] + h10 * dt * m0[i] + h01 * p1[i] + h11 * dt * m1[i])
                    .collect()
            }
            _ if property == Property::Rotation => {
                let (a, b) = (Quat::from_slice(key(k, 1)), Quat::from_slice(key(k + 1, 1)));
                a.normalize().slerp(b.normalize(), s).to_array().to_vec()
            }
            _ => key(k, 1)
                .iter()
                .zip(key(k + 1, 1))
                .map(|(a, b)| a + (b - a) * s)
                .collect(),
        })
    }

    /// `node`'s local transform: its own, with what the pose at `LoadOptions::time` animates.
    pub(super) fn local_matrix(&self, node: &gltf::Node) -> Mat4 {
        let own = Mat4::from_cols_array_2d(&node.transform().matrix());
        let Some(pose) = self.pose.get(&node.index()) else {
            return own;
        };
        let (t, r, s) = node.transform().decomposed();
        Mat4::from_scale_rotation_translation(
            pose.scale.unwrap_or(Vec3::from(s)),
            pose.rotation.unwrap_or(Quat::from_array(r)),
            pose.translation.unwrap_or(Vec3::from(t)),
        )
    }

    /// The morph weights `node` shows: the pose's, else the node's, else its mesh's.
    pub(super) fn morph_weights(&self, node: &gltf::Node) -> Vec<f32> {
        if let Some(weights) = self.pose.get(&node.index()).and_then(|p| p.weights.clone()) {
            return weights;
        }
        node.weights()
            .or_else(|| node.mesh().and_then(|m| m.weights()))
            .map(<[f32]>::to_vec)
            .unwrap_or_default()
    }
}

/// The node and property a channel animates: its `target.node` and `path`, or a
/// `KHR_animation_pointer` of the form `/nodes/N/property`; `None` for anything else.
fn channel_target(channel: &Value) -> Option<(usize, Property)> {
    let target = channel.get("target")?;
    if let Some(node) = target.get("node").and_then(Value::as_u64) {
        let path = target.get("path").and_then(Value::as_str)?;
        return Some((node as usize, Property::named(path)?));
    }
    let pointer = target
        .get("extensions")?
        .get("KHR_animation_pointer")?
        .get("pointer")?
        .as_str()?;
    match pointer.split('/').collect::<Vec<_>>().as_slice() {
        ["", "nodes", node, property] => Some((node.parse().ok()?, Property::named(property)?)),
        _ => None,
    }
}
