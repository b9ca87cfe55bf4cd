//! Rigid glTF node animation: keyframed translation, rotation and scale, played back on the CPU.
//!
//! # Playback
//!
//! All of a file's animations play together on one clock, looping over the longest of them:
//! [`Scene::set_time`](super::Scene::set_time)`(t)` poses the scene at `t` modulo
//! [`SceneAnimation::duration`] (a non-finite `t` is taken as 0). A channel shorter than the
//! longest animation holds its last value until the loop restarts; before its first keyframe it
//! holds its first. Where two channels animate the same property of the same node, the later one
//! (in file order) wins.
//!
//! Samplers interpolate as glTF says: `STEP` holds the previous keyframe, `LINEAR` interpolates
//! linearly (rotations by spherical linear interpolation along the shorter arc), `CUBICSPLINE`
//! follows the Hermite spline of each keyframe's in- and out-tangents. Interpolated rotations are
//! normalised.
//!
//! # What follows the animation
//!
//! The loader keeps the node hierarchy as it visited it (a node reached twice is visited twice, as
//! the loader places it twice). A node is *dynamic* when it or an ancestor is animated. Per frame,
//! only dynamic nodes are recomputed (world = parent's world × animated local transform), then the
//! instances, punctual lights and cameras on dynamic nodes, the emissive triangles of instances
//! that moved, and the scene's bounds: O(channels + dynamic nodes + their instances and emissive
//! triangles), with no allocation.
//!
//! [`Scene::bounds`](super::Scene::bounds) then holds the exact bounds of the static instances
//! grown by the object-space boxes of the dynamic instances' meshes, transformed: it contains
//! every world triangle, but may be larger than their tight bounds.
//!
//! # Bad input
//!
//! A channel that cannot be played is dropped with a warning naming the animation and channel:
//! a target node or sampler that does not exist, a node given by `matrix` (glTF forbids animating
//! it), an invalid interpolation or path, an input that is not a float `SCALAR` accessor or whose
//! times are not finite and strictly increasing, an output of the wrong type, of the wrong count
//! (one value per keyframe, three for `CUBICSPLINE`) or with non-finite values, and a rotation
//! keyframe that is the zero quaternion. `weights` (morph target) channels are ignored with a
//! warning. A pose whose transform is singular (a scale through zero) leaves the instance at its
//! last transform, so that [`Instance::transform`](super::Instance::transform) stays invertible.
//! Instances whose node has a singular transform at rest are skipped at load and never appear.

use glam::{Mat4, Quat, Vec3};
use gltf::json::{
    self,
    accessor::{ComponentType, GenericComponentType, Type},
    animation::{Interpolation, Property},
    validation::Checked,
};

use super::document::{Ctx, Document, label};
use super::{Aabb, Camera, EmissiveTriangle, Instance, Light, Mesh};

/// The node hierarchy as the loader visited it, and which visit placed each instance, light and
/// camera: what [`SceneAnimation::new`] needs to recompute world transforms.
#[derive(Default)]
pub(super) struct Hierarchy {
    /// Visits in order, each parent before its children.
    pub visits: Vec<Visit>,
    /// Visit of each [`Scene::instances`](super::Scene::instances) entry.
    pub instances: Vec<u32>,
    /// Visit of each [`Scene::lights`](super::Scene::lights) entry.
    pub lights: Vec<u32>,
    /// Visit of each [`Scene::cameras`](super::Scene::cameras) entry.
    pub cameras: Vec<u32>,
}

/// One visit of a glTF node.
pub(super) struct Visit {
    /// Index of the glTF node.
    pub node: u32,
    /// The parent's visit; `None` for a root.
    pub parent: Option<u32>,
    /// Local transform at rest.
    pub local: Mat4,
    /// World transform at rest.
    pub world: Mat4,
}

/// A translation, rotation and scale: the animatable local transform of a node.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Trs {
    translation: Vec3,
    rotation: Quat,
    scale: Vec3,
}

impl Trs {
    fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// The animated property of a channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Path {
    Translation,
    Rotation,
    Scale,
}

impl Path {
    fn components(self) -> usize {
        match self {
            Path::Rotation => 4,
            Path::Translation | Path::Scale => 3,
        }
    }
}

/// A playable channel: one property of one animated node, sampled from its keyframes.
#[derive(Clone, Debug)]
struct Channel {
    /// Index into [`SceneAnimation::rest`].
    slot: u32,
    path: Path,
    interpolation: Interpolation,
    /// Keyframe times, finite and strictly increasing; at least one.
    times: Vec<f32>,
    /// Per keyframe, [`Path::components`] floats, or for `CUBICSPLINE` three groups of them (in
    /// tangent, value, out tangent). Rotation values of `LINEAR` and `STEP` are unit quaternions.
    values: Vec<f32>,
}

impl Channel {
    /// The channel's value at `t` (clamped to its keyframes): 3 or 4 components in `out`.
    fn sample(&self, t: f32, out: &mut [f32; 4]) {
        let n = self.path.components();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        // The value of keyframe `k`, or one of its tangents (`part` 0: in, 2: out) when cubic.
        let key = |k: usize, part: usize| {
            let at = if cubic { (3 * k + part) * n } else { k * n };
            &self.values[at..at + n]
        };
        let last = self.times.len() - 1;
        // Index of the last keyframe at or before `t`.
        let k = self.times.partition_point(|&time| time <= t);
        if k == 0 || k > last {
            out[..n].copy_from_slice(key(k.min(last), 1));
        } else {
            let k = k - 1;
            let (t0, t1) = (self.times[k], self.times[k + 1]);
            let dt = t1 - t0;
            let s = (t - t0) / dt;
            match self.interpolation {
                Interpolation::Step => out[..n].copy_from_slice(key(k, 1)),
                Interpolation::Linear if self.path == Path::Rotation => {
                    let q = quat(key(k, 1)).slerp(quat(key(k + 1, 1)), s);
                    out.copy_from_slice(&q.to_array());
                }
                Interpolation::Linear => {
                    for (c, o) in out[..n].iter_mut().enumerate() {
                        *o = key(k, 1)[c] + s * (key(k + 1, 1)[c] - key(k, 1)[c]);
                    }
                }
                Interpolation::CubicSpline => {
                    let (s2, s3) = (s * s, s * s * s);
                    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                    let h10 = dt * (s3 - 2.0 * s2 + s);
                    let h01 = -2.0 * s3 + 3.0 * s2;
                    let h11 = dt * (s3 - s2);
                    let (v0, b0, a1, v1) = (key(k, 1), key(k, 2), key(k + 1, 0), key(k + 1, 1));
                    for (c, o) in out[..n].iter_mut().enumerate() {
                        *o = h00 * v0[c] + h10 * b0[c] + h01 * v1[c] + h11 * a1[c];
                    }
                }
            }
        }
        if self.path == Path::Rotation {
            let q = quat(&out[..4]).normalize();
            // A cubic spline may pass through the zero quaternion: then no rotation.
            let q = if q.is_finite() { q } else { Quat::IDENTITY };
            out.copy_from_slice(&q.to_array());
        }
    }
}

fn quat(v: &[f32]) -> Quat {
    Quat::from_xyzw(v[0], v[1], v[2], v[3])
}

/// A dynamic instance (one whose node or an ancestor is animated).
#[derive(Clone, Debug)]
struct DynamicInstance {
    instance: u32,
    /// Index of its node's visit in [`SceneAnimation::dynamic`].
    visit: u32,
    /// Object-space bounds of its mesh.
    mesh_bounds: Aabb,
}

/// The local transform of a dynamic visit.
#[derive(Clone, Copy, Debug)]
enum Local {
    /// An animated node: index into [`SceneAnimation::rest`].
    Animated(u32),
    /// A node below an animated one, itself still.
    Still(Mat4),
}

/// Where a dynamic visit hangs.
#[derive(Clone, Copy, Debug)]
enum Parent {
    /// Under a still node (or at the root): its world transform.
    Still(Mat4),
    /// Under a dynamic visit: its index in [`SceneAnimation::dynamic`].
    Moving(u32),
}

/// A dynamic visit: recomputed every frame.
#[derive(Clone, Copy, Debug)]
struct DynamicVisit {
    parent: Parent,
    local: Local,
}

/// A scene's animations, ready to pose it at any time; see the [module](self).
#[derive(Clone, Debug)]
pub struct SceneAnimation {
    duration: f32,
    channels: Vec<Channel>,
    /// Rest pose of each animated node, indexed by [`Channel::slot`].
    rest: Vec<Trs>,
    /// Dynamic visits, parents before children.
    dynamic: Vec<DynamicVisit>,
    instances: Vec<DynamicInstance>,
    /// (index into the scene's lights, index into `dynamic`), for lights on dynamic nodes.
    lights: Vec<(u32, u32)>,
    /// (index into the scene's cameras, index into `dynamic`), for cameras on dynamic nodes.
    cameras: Vec<(u32, u32)>,
    /// Bounds of the static instances' world triangles.
    static_bounds: Aabb,
    /// Per-frame state, kept to avoid allocating.
    scratch: Scratch,
}

#[derive(Clone, Debug, Default)]
struct Scratch {
    /// Pose of each animated node.
    poses: Vec<Trs>,
    /// World transform of each dynamic visit.
    worlds: Vec<Mat4>,
    /// Instances that moved in the last [`SceneAnimation::apply`].
    moved: Vec<u32>,
}

/// What [`SceneAnimation::apply`] updates: the parts of a scene that follow the animation.
pub(super) struct Posed<'a> {
    pub meshes: &'a [Mesh],
    pub instances: &'a mut [Instance],
    pub lights: &'a mut [Light],
    pub cameras: &'a mut [Camera],
    pub emissive_triangles: &'a mut [EmissiveTriangle],
    pub bounds: &'a mut Aabb,
}

impl SceneAnimation {
    /// Parses the document's animations for the scene the loader built from `hierarchy`; `None`
    /// when no channel can be played (the warnings say why).
    pub(super) fn new(
        ctx: &mut Ctx,
        doc: &Document,
        hierarchy: &Hierarchy,
        meshes: &[Mesh],
        instances: &[Instance],
    ) -> Option<Self> {
        let nodes = &doc.root.nodes;
        // glTF node -> its slot in `rest`, once a channel animates it.
        let mut slots: Vec<Option<u32>> = vec![None; nodes.len()];
        let mut rest = Vec::new();
        let mut channels = Vec::new();
        for (a, animation) in doc.root.animations.iter().enumerate() {
            let element = label("animations", a, animation.name.as_deref());
            for (c, channel) in animation.channels.iter().enumerate() {
                let element = format!("{element}.channels[{c}]");
                match parse_channel(ctx, doc, animation, channel, &element) {
                    Ok(Some(mut parsed)) => {
                        let node = channel.target.node.value();
                        let slot = *slots[node].get_or_insert_with(|| {
                            rest.push(rest_pose(&nodes[node]));
                            rest.len() as u32 - 1
                        });
                        parsed.slot = slot;
                        channels.push(parsed);
                    }
                    Ok(None) => {}
                    // One warning per dropped channel, each naming it.
                    Err(why) => ctx.warn(
                        &format!("dropped {element}"),
                        element,
                        format!("{why}: the channel is dropped"),
                        1,
                    ),
                }
            }
        }
        if channels.is_empty() {
            return None;
        }
        let duration = channels
            .iter()
            .map(|c| c.times[c.times.len() - 1])
            .fold(0.0f32, f32::max);

        let visits = &hierarchy.visits;
        // Visit -> its index in `dynamic`, for visits that move.
        let mut dynamic_index: Vec<Option<u32>> = vec![None; visits.len()];
        let mut dynamic = Vec::new();
        for (v, visit) in visits.iter().enumerate() {
            let slot = slots[visit.node as usize];
            let parent = match visit.parent {
                Some(p) => match dynamic_index[p as usize] {
                    Some(d) => Parent::Moving(d),
                    None => Parent::Still(visits[p as usize].world),
                },
                None => Parent::Still(Mat4::IDENTITY),
            };
            if slot.is_none() && matches!(parent, Parent::Still(_)) {
                continue;
            }
            dynamic_index[v] = Some(dynamic.len() as u32);
            dynamic.push(DynamicVisit {
                parent,
                local: slot.map_or(Local::Still(visit.local), Local::Animated),
            });
        }
        let on_dynamic = |visits: &[u32]| -> Vec<(u32, u32)> {
            (visits.iter().enumerate())
                .filter_map(|(i, &v)| Some((i as u32, dynamic_index[v as usize]?)))
                .collect()
        };
        let mut static_bounds = Aabb::EMPTY;
        let mut dynamic_instances = Vec::new();
        for (i, (instance, &visit)) in instances.iter().zip(&hierarchy.instances).enumerate() {
            let mesh = &meshes[instance.mesh as usize];
            if let Some(visit) = dynamic_index[visit as usize] {
                let mut mesh_bounds = Aabb::EMPTY;
                mesh.positions.iter().for_each(|&p| mesh_bounds.grow(p));
                dynamic_instances.push(DynamicInstance {
                    instance: i as u32,
                    visit,
                    mesh_bounds,
                });
            } else {
                for p in &mesh.positions {
                    static_bounds.grow(instance.transform.transform_point3(*p));
                }
            }
        }
        Some(Self {
            duration,
            channels,
            scratch: Scratch {
                poses: rest.clone(),
                worlds: vec![Mat4::IDENTITY; dynamic.len()],
                moved: Vec::with_capacity(dynamic_instances.len()),
            },
            rest,
            dynamic,
            lights: on_dynamic(&hierarchy.lights),
            cameras: on_dynamic(&hierarchy.cameras),
            instances: dynamic_instances,
            static_bounds,
        })
    }

    /// Length of one loop in seconds: the last keyframe time of all channels (0 when every
    /// channel has a single keyframe at time 0 or before).
    pub fn duration(&self) -> f32 {
        self.duration
    }

    /// Number of playable channels (node properties animated).
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// Indices of the instances that follow the animation (their node or an ancestor is
    /// animated), in increasing order; the others never move.
    pub fn dynamic_instances(&self) -> impl ExactSizeIterator<Item = u32> + '_ {
        self.instances.iter().map(|d| d.instance)
    }

    /// `seconds` wrapped into one loop, as playback uses it.
    pub fn loop_time(&self, seconds: f32) -> f32 {
        match (seconds.is_finite(), self.duration > 0.0) {
            (true, true) => seconds.rem_euclid(self.duration),
            (true, false) => seconds,
            (false, _) => 0.0,
        }
    }

    /// Poses every dynamic visit at loop time `t`, into `scratch.worlds`.
    fn evaluate(&self, t: f32, scratch: &mut Scratch) {
        scratch.poses.copy_from_slice(&self.rest);
        let mut value = [0.0; 4];
        for channel in &self.channels {
            channel.sample(t, &mut value);
            let pose = &mut scratch.poses[channel.slot as usize];
            let [x, y, z, w] = value;
            match channel.path {
                Path::Translation => pose.translation = Vec3::new(x, y, z),
                Path::Rotation => pose.rotation = Quat::from_xyzw(x, y, z, w),
                Path::Scale => pose.scale = Vec3::new(x, y, z),
            }
        }
        for (i, d) in self.dynamic.iter().enumerate() {
            let local = match d.local {
                Local::Animated(slot) => scratch.poses[slot as usize].matrix(),
                Local::Still(local) => local,
            };
            let parent = match d.parent {
                Parent::Still(world) => world,
                Parent::Moving(p) => scratch.worlds[p as usize],
            };
            scratch.worlds[i] = parent * local;
        }
    }

    /// World transform of every instance at `seconds` (looped), without changing the scene.
    pub(super) fn pose_at(&self, seconds: f32, instances: &[Instance]) -> Vec<Mat4> {
        let mut scratch = self.scratch.clone();
        self.evaluate(self.loop_time(seconds), &mut scratch);
        let mut pose: Vec<Mat4> = instances.iter().map(|i| i.transform).collect();
        for d in &self.instances {
            let world = scratch.worlds[d.visit as usize];
            if world.determinant().is_normal() {
                pose[d.instance as usize] = world;
            }
        }
        pose
    }

    /// Poses the scene at `seconds` (looped); returns the instances whose transform changed.
    pub(super) fn apply(&mut self, seconds: f32, mut scene: Posed<'_>) -> &[u32] {
        let mut scratch = std::mem::take(&mut self.scratch);
        self.evaluate(self.loop_time(seconds), &mut scratch);
        scratch.moved.clear();
        let mut bounds = self.static_bounds;
        for d in &self.instances {
            let instance = &mut scene.instances[d.instance as usize];
            let world = scratch.worlds[d.visit as usize];
            if world != instance.transform && world.determinant().is_normal() {
                instance.transform = world;
                scratch.moved.push(d.instance);
            }
            for corner in 0..8 {
                let pick = |bit: u32, lo: f32, hi: f32| if corner & bit == 0 { lo } else { hi };
                let (lo, hi) = (d.mesh_bounds.min, d.mesh_bounds.max);
                let p = Vec3::new(
                    pick(1, lo.x, hi.x),
                    pick(2, lo.y, hi.y),
                    pick(4, lo.z, hi.z),
                );
                bounds.grow(instance.transform.transform_point3(p));
            }
        }
        *scene.bounds = bounds;
        for &i in &scratch.moved {
            update_emissive(i, &mut scene);
        }
        for &(l, v) in &self.lights {
            let world = scratch.worlds[v as usize];
            let light = &mut scene.lights[l as usize];
            light.position = world.w_axis.truncate();
            let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
            if direction != Vec3::ZERO {
                light.direction = direction;
            }
        }
        for &(c, v) in &self.cameras {
            let world = scratch.worlds[v as usize];
            let axes = [world.y_axis.truncate(), world.z_axis.truncate()];
            if axes.iter().all(|a| a.length().is_normal()) {
                scene.cameras[c as usize].transform = world;
            }
        }
        self.scratch = scratch;
        &self.scratch.moved
    }
}

/// Recomputes the world-space vertices and areas of instance `i`'s emissive triangles (the
/// emissive triangles are in instance order).
fn update_emissive(i: u32, scene: &mut Posed<'_>) {
    let start = scene.emissive_triangles.partition_point(|t| t.instance < i);
    let instance = &scene.instances[i as usize];
    let mesh = &scene.meshes[instance.mesh as usize];
    for tri in scene.emissive_triangles[start..].iter_mut() {
        if tri.instance != i {
            break;
        }
        let [a, b, c] = mesh
            .triangle(tri.primitive as usize)
            .map(|v| instance.transform.transform_point3(v));
        tri.vertices = [a, b, c];
        tri.area = 0.5 * (b - a).cross(c - a).length();
    }
}

/// A node's rest pose, with the rotation normalised (the loader refused zero quaternions).
fn rest_pose(node: &json::Node) -> Trs {
    Trs {
        translation: Vec3::from(node.translation.unwrap_or_default()),
        rotation: Quat::from_array(node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |r| r.0)).normalize(),
        scale: Vec3::from(node.scale.unwrap_or([1.0; 3])),
    }
}

/// Parses one channel; `Ok(None)` for channels ignored on purpose (morph weights).
fn parse_channel(
    ctx: &mut Ctx,
    doc: &Document,
    animation: &json::Animation,
    channel: &json::animation::Channel,
    element: &str,
) -> Result<Option<Channel>, String> {
    let node_index = channel.target.node.value();
    let node = doc
        .root
        .nodes
        .get(node_index)
        .ok_or_else(|| format!("its target node {node_index} does not exist"))?;
    let path = match channel.target.path {
        Checked::Valid(Property::Translation) => Path::Translation,
        Checked::Valid(Property::Rotation) => Path::Rotation,
        Checked::Valid(Property::Scale) => Path::Scale,
        Checked::Valid(Property::MorphTargetWeights) => {
            ctx.warn(
                "animation channel: morph weights",
                element,
                "morph target weights are not animated: the channel is ignored",
                1,
            );
            return Ok(None);
        }
        Checked::Invalid => return Err("its target path is invalid".into()),
    };
    if node.matrix.is_some() {
        return Err(format!(
            "its target, {}, is given by a matrix, which glTF forbids animating",
            label("nodes", node_index, node.name.as_deref())
        ));
    }
    let sampler_index = channel.sampler.value();
    let sampler = animation
        .samplers
        .get(sampler_index)
        .ok_or_else(|| format!("its sampler {sampler_index} does not exist"))?;
    let Checked::Valid(interpolation) = sampler.interpolation else {
        return Err(format!(
            "samplers[{sampler_index}] has an invalid interpolation"
        ));
    };
    let input = sampler.input.value();
    let output = sampler.output.value();
    let times = read_floats(doc, ctx, input, Type::Scalar, "input", true)?;
    if times.is_empty() {
        return Err(format!("its input accessors[{input}] is empty"));
    }
    if let Some(k) = (0..times.len()).find(|&k| !times[k].is_finite()) {
        return Err(format!(
            "keyframe {k} of its input accessors[{input}] is not a finite time"
        ));
    }
    if let Some(k) = (1..times.len()).find(|&k| times[k] <= times[k - 1]) {
        return Err(format!(
            "the times of its input accessors[{input}] do not increase at keyframe {k} \
                 ({} then {})",
            times[k - 1],
            times[k]
        ));
    }
    let ty = match path {
        Path::Rotation => Type::Vec4,
        Path::Translation | Path::Scale => Type::Vec3,
    };
    let mut values = read_floats(doc, ctx, output, ty, "output", false)?;
    let n = path.components();
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    if values.len() != times.len() * per_key * n {
        return Err(format!(
            "its output accessors[{output}] has {} values for {} keyframes ({} expected with \
                 {interpolation:?})",
            values.len() / n,
            times.len(),
            times.len() * per_key
        ));
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(format!(
            "its output accessors[{output}] holds non-finite values"
        ));
    }
    if path == Path::Rotation {
        for (k, q) in values.as_chunks_mut::<4>().0.iter_mut().enumerate() {
            // Cubic-spline tangents may be zero; the values (middle of each triple) may not.
            if per_key == 3 && k % 3 != 1 {
                continue;
            }
            let unit = quat(q).normalize();
            if !unit.is_finite() {
                return Err(format!(
                    "rotation {} of its output accessors[{output}] is zero",
                    k / per_key
                ));
            }
            if per_key == 1 {
                *q = unit.to_array();
            }
        }
    }
    Ok(Some(Channel {
        slot: 0,
        path,
        interpolation,
        times,
        values,
    }))
}

/// Accessor `index` as floats of type `ty`; `float_only` refuses integer components (keyframe
/// times must be floats).
fn read_floats(
    doc: &Document,
    ctx: &Ctx,
    index: usize,
    ty: Type,
    role: &str,
    float_only: bool,
) -> Result<Vec<f32>, String> {
    let accessor = doc
        .root
        .accessors
        .get(index)
        .ok_or_else(|| format!("its {role} accessors[{index}] does not exist"))?;
    let float = matches!(
        accessor.component_type,
        Checked::Valid(GenericComponentType(ComponentType::F32))
    );
    if float_only && !float {
        return Err(format!(
            "its {role} accessors[{index}] does not hold floats"
        ));
    }
    doc.read_floats(ctx, index, &format!("animation {role}"), ty)
        .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn channel(path: Path, interpolation: Interpolation, times: &[f32], values: &[f32]) -> Channel {
        Channel {
            slot: 0,
            path,
            interpolation,
            times: times.to_vec(),
            values: values.to_vec(),
        }
    }

    fn sample3(c: &Channel, t: f32) -> Vec3 {
        let mut out = [0.0; 4];
        c.sample(t, &mut out);
        Vec3::new(out[0], out[1], out[2])
    }

    fn sample_quat(c: &Channel, t: f32) -> Quat {
        let mut out = [0.0; 4];
        c.sample(t, &mut out);
        Quat::from_array(out)
    }

    #[test]
    fn linear_interpolates_and_clamps() {
        let c = channel(
            Path::Translation,
            Interpolation::Linear,
            &[1.0, 3.0],
            &[0.0, 0.0, 0.0, 2.0, 4.0, -6.0],
        );
        assert_eq!(sample3(&c, 1.5), Vec3::new(0.5, 1.0, -1.5));
        assert_eq!(sample3(&c, 2.0), Vec3::new(1.0, 2.0, -3.0));
        // Before the first and after the last keyframe: clamped.
        assert_eq!(sample3(&c, 0.0), Vec3::ZERO);
        assert_eq!(sample3(&c, 7.0), Vec3::new(2.0, 4.0, -6.0));
    }

    #[test]
    fn step_holds_the_previous_keyframe() {
        let c = channel(
            Path::Scale,
            Interpolation::Step,
            &[0.0, 1.0, 2.0],
            &[1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 3.0, 3.0, 3.0],
        );
        assert_eq!(sample3(&c, 0.99), Vec3::ONE);
        assert_eq!(sample3(&c, 1.0), Vec3::splat(2.0));
        assert_eq!(sample3(&c, 1.999), Vec3::splat(2.0));
        assert_eq!(sample3(&c, 2.5), Vec3::splat(3.0));
    }

    #[test]
    fn cubic_spline_follows_the_hermite_basis() {
        // Keyframes at 0 and 2 s: values 0 and 2, out tangent of the first 3, in tangent of the
        // second 1 (x only). Unused tangents are set to values that would show if read.
        #[rustfmt::skip]
        let values = [
            9.0, 0.0, 0.0,   0.0, 0.0, 0.0,   3.0, 0.0, 0.0, // in, value, out at t = 0
            1.0, 0.0, 0.0,   2.0, 0.0, 0.0,   9.0, 0.0, 0.0, // in, value, out at t = 2
        ];
        let c = channel(
            Path::Translation,
            Interpolation::CubicSpline,
            &[0.0, 2.0],
            &values,
        );
        // s = 1/2, dt = 2: h00 = h01 = 1/2, h10 = 2 (1/8 - 1/2 + 1/2) = 1/4, h11 = 2 (1/8 - 1/4)
        // = -1/4: 0 + 3/4 + 1 - 1/4.
        assert!((sample3(&c, 1.0).x - 1.5).abs() < 1e-6);
        // s = 1/4: h10 = 2 (1/64 - 1/8 + 1/4) = 9/32, h01 = -1/32 + 3/16 = 5/32, h11 = 2 (1/64 -
        // 1/16) = -3/32: 27/32 + 10/32 - 3/32 = 34/32.
        assert!((sample3(&c, 0.5).x - 1.0625).abs() < 1e-6);
        // Keyframes themselves, and clamping, give the values, never the tangents.
        assert_eq!(sample3(&c, 0.0).x, 0.0);
        assert_eq!(sample3(&c, 2.0).x, 2.0);
        assert_eq!(sample3(&c, -1.0).x, 0.0);
        assert_eq!(sample3(&c, 5.0).x, 2.0);
    }

    #[test]
    fn rotations_slerp_along_the_shorter_arc() {
        let quarter = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        // The second keyframe is the same rotation with the opposite sign: the long way round
        // would pass 180° - 45° = 135° at the middle.
        let values: Vec<f32> = [Quat::IDENTITY, -quarter]
            .iter()
            .flat_map(|q| q.to_array())
            .collect();
        let c = channel(Path::Rotation, Interpolation::Linear, &[0.0, 1.0], &values);
        let q = sample_quat(&c, 0.5);
        assert!((q.length() - 1.0).abs() < 1e-6);
        let x = q * Vec3::X;
        let half = std::f32::consts::FRAC_1_SQRT_2;
        assert!((x - Vec3::new(half, 0.0, -half)).length() < 1e-5, "{x}");
    }

    #[test]
    fn cubic_rotations_are_normalised() {
        let q = Quat::from_rotation_z(1.0).to_array();
        let zero = [0.0; 4];
        let values: Vec<f32> = [zero, Quat::IDENTITY.to_array(), zero, zero, q, zero].concat();
        let c = channel(
            Path::Rotation,
            Interpolation::CubicSpline,
            &[0.0, 1.0],
            &values,
        );
        for t in [0.1, 0.5, 0.9] {
            assert!((sample_quat(&c, t).length() - 1.0).abs() < 1e-6);
        }
    }
}
