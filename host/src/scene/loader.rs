//! glTF document -> [`Scene`]: materials and textures, the node hierarchy, meshes, lights and
//! cameras.

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::json::{
    self,
    camera::Type as CameraType,
    extensions::scene::khr_lights_punctual::Type as LightType,
    material::AlphaMode,
    mesh::{Mode, Semantic},
    texture::WrappingMode,
    validation::Checked,
};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use std::collections::HashMap;
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::path::Path;
use std::time::Instant;

use super::animation::{Hierarchy, SceneAnimation, Visit};
use super::document::{Ctx, Document, label};
use super::geometry::{self, CleanPrimitive, RawPrimitive};
use super::texture_files;
use super::{
    Aabb, Camera, Instance, LUMENS_PER_WATT, Light, LightKind, LoadStage, MAX_EMISSION,
    MAX_WORLD_COORDINATE, Material, Mesh, Scene, Texture, Warning, Wrap,
};
use crate::Result;

/// Deepest node hierarchy followed: deeper is taken for garbage (and would exhaust the stack).
const MAX_NODE_DEPTH: usize = 1024;

/// Largest image file read: bounds what a URI naming a huge file makes the loader read.
const MAX_IMAGE_FILE_BYTES: u64 = 1 << 30;

/// Texture extensions whose image a texture prefers to its `source`, in order of preference.
const TEXTURE_EXTENSIONS: [&str; 2] = ["KHR_texture_basisu", "MSFT_texture_dds"];

pub(super) fn load(path: &Path) -> Result<(Scene, Vec<Warning>)> {
    let start = Instant::now();
    let bytes = std::fs::read(path)
        .map_err(|e| Ctx::new(path).error("file", format!("cannot read it: {e}")))?;
    load_bytes(path, &bytes, start)
}

/// Loads the file `path` whose bytes are `bytes`; `start` is when reading it began.
pub(super) fn load_bytes(
    path: &Path,
    bytes: &[u8],
    start: Instant,
) -> Result<(Scene, Vec<Warning>)> {
    let mut ctx = Ctx::new(path);
    let doc = Document::parse(&mut ctx, bytes)?;
    let builder = Builder {
        stages: vec![LoadStage {
            name: "parse",
            seconds: start.elapsed().as_secs_f64(),
        }],
        ctx,
        doc: &doc,
        materials: Vec::new(),
        default_material: None,
        textures: Vec::new(),
        texture_slots: HashMap::new(),
        meshes: Vec::new(),
        mesh_bounds: Vec::new(),
        mesh_slots: HashMap::new(),
        reached: vec![false; doc.root.nodes.len()],
        instances: Vec::new(),
        lights: Vec::new(),
        cameras: Vec::new(),
        hierarchy: Hierarchy::default(),
    };
    builder.build()
}

struct Builder<'d> {
    stages: Vec<LoadStage>,
    ctx: Ctx,
    doc: &'d Document,
    /// Materials; their texture indices point into `textures` until the textures are decoded.
    materials: Vec<Material>,
    /// Index of the default material, once a primitive without one needs it.
    default_material: Option<u32>,
    /// Textures to decode, in order of first use.
    textures: Vec<PendingTexture>,
    /// glTF texture index -> index into `textures`, `None` if it cannot be used.
    texture_slots: HashMap<usize, Option<u32>>,
    meshes: Vec<Mesh>,
    /// Object-space bounds of each of `meshes`.
    mesh_bounds: Vec<Aabb>,
    /// glTF mesh index -> index into `meshes`, `None` if it has no triangles.
    mesh_slots: HashMap<usize, Option<u32>>,
    /// Whether each glTF node has been visited: a node reached twice has two parents.
    reached: Vec<bool>,
    instances: Vec<Instance>,
    lights: Vec<Light>,
    cameras: Vec<Camera>,
    /// The nodes as visited, for the animation.
    hierarchy: Hierarchy,
}

/// A texture the materials use, to be decoded once the document has been walked.
struct PendingTexture {
    /// glTF texture index.
    index: usize,
    /// The first material slot that uses it, for warnings.
    user: String,
}

/// What decoding a texture gave: the texture, or `None` when none of its images could be used,
/// and why each image that failed did.
struct DecodedTexture {
    texture: Option<Texture>,
    /// (warning kind, element, why) of each image that could not be used.
    failures: Vec<(String, String, String)>,
    /// The image used and what its decoder reported.
    note: Option<(String, &'static str)>,
}

impl Builder<'_> {
    fn build(mut self) -> Result<(Scene, Vec<Warning>)> {
        let start = Instant::now();
        let root = &self.doc.root;
        if !root.skins.is_empty() {
            self.ctx.warn(
                "skins",
                "skins",
                "skins are ignored: skinned meshes are loaded in their bind pose",
                root.skins.len(),
            );
        }
        for index in 0..root.materials.len() {
            let material = self.material(index);
            self.materials.push(material);
        }
        let (scene_element, roots) = self.roots();
        for node in roots {
            self.visit(node, None, &mut Vec::new())?;
        }
        self.stage("geometry", start);

        let triangles: usize = self
            .instances
            .iter()
            .map(|i| self.meshes[i.mesh as usize].triangles.len())
            .sum();
        if triangles == 0 {
            let skipped: Vec<String> = self
                .ctx
                .warnings()
                .iter()
                .map(|w| format!("{}: {}", w.element, w.message))
                .collect();
            let why = match skipped.is_empty() {
                true => "has no triangles to trace".to_owned(),
                false => format!(
                    "has no triangles to trace (skipped: {})",
                    skipped.join("; ")
                ),
            };
            return Err(self.ctx.error(scene_element, why));
        }
        let start = Instant::now();
        let textures = self.decode_textures();
        self.stage("textures", start);

        let start = Instant::now();
        let mut scene = Scene {
            source: self.ctx.file.clone(),
            meshes: self.meshes,
            instances: self.instances,
            materials: self.materials,
            textures,
            lights: self.lights,
            cameras: self.cameras,
            emissive_triangles: Vec::new(),
            bounds: Aabb::EMPTY,
            load_stages: self.stages,
            animation: None,
            blases: Vec::new(),
        };
        scene.update_derived();
        if !self.doc.root.animations.is_empty() {
            scene.animation = SceneAnimation::new(
                &mut self.ctx,
                self.doc,
                &self.hierarchy,
                &scene.meshes,
                &scene.instances,
            );
        }
        scene.load_stages.push(LoadStage {
            name: "derived",
            seconds: start.elapsed().as_secs_f64(),
        });
        Ok((scene, self.ctx.into_warnings()))
    }

    fn stage(&mut self, name: &'static str, start: Instant) {
        self.stages.push(LoadStage {
            name,
            seconds: start.elapsed().as_secs_f64(),
        });
    }

    /// Decodes the pending textures and makes their mips, in parallel with a progress bar on
    /// stderr (hidden when stderr is no terminal); then warns, in texture order, about those that
    /// failed, drops them and points the materials at the rest.
    fn decode_textures(&mut self) -> Vec<Texture> {
        let bar = ProgressBar::with_draw_target(
            Some(self.textures.len() as u64),
            ProgressDrawTarget::stderr(),
        )
        .with_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} textures")
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        let (ctx, doc) = (&self.ctx, self.doc);
        let decoded: Vec<DecodedTexture> = self
            .textures
            .par_iter()
            .map(|pending| {
                let decoded = decode_texture(ctx, doc, pending.index);
                bar.inc(1);
                decoded
            })
            .collect();
        bar.finish_and_clear();
        let mut textures = Vec::new();
        let mut new_index = Vec::with_capacity(decoded.len());
        for (pending, decoded) in self.textures.iter().zip(decoded) {
            let fallback = match &decoded.texture {
                Some(t) => format!("{} is used instead", t.name),
                None => format!("{} is dropped and the factor used alone", pending.user),
            };
            for (kind, element, why) in decoded.failures {
                self.ctx
                    .warn(&kind, element, format!("{why}; {fallback}"), 1);
            }
            if let Some((element, note)) = decoded.note {
                self.ctx.warn(note, element, note, 1);
            }
            new_index.push(decoded.texture.map(|t| {
                textures.push(t);
                textures.len() as u32 - 1
            }));
        }
        let remap = |slot: Option<u32>| slot.and_then(|p| new_index[p as usize]);
        for m in &mut self.materials {
            m.base_color_texture = remap(m.base_color_texture);
            m.emissive_texture = remap(m.emissive_texture);
        }
        textures
    }

    /// The element that names the scene, and its root nodes: the default scene's, the first
    /// scene's, or without scenes every node that is no other node's child.
    fn roots(&mut self) -> (String, Vec<usize>) {
        let root = &self.doc.root;
        let chosen = root
            .scene
            .map(|s| s.value())
            .or((!root.scenes.is_empty()).then_some(0));
        if let Some((index, scene)) = chosen.and_then(|s| Some((s, root.scenes.get(s)?))) {
            let element = label("scenes", index, scene.name.as_deref());
            if root.scenes.len() > 1 {
                self.ctx.warn(
                    "other scenes",
                    &element,
                    format!(
                        "the file has {} scenes: only this one is loaded",
                        root.scenes.len()
                    ),
                    1,
                );
            }
            return (element, scene.nodes.iter().map(|n| n.value()).collect());
        }
        let mut is_child = vec![false; root.nodes.len()];
        for child in root
            .nodes
            .iter()
            .filter_map(|n| n.children.as_ref())
            .flatten()
        {
            if let Some(flag) = is_child.get_mut(child.value()) {
                *flag = true;
            }
        }
        if !root.nodes.is_empty() {
            self.ctx.warn(
                "no scene",
                "scenes",
                "the file has no scene: every root node is loaded",
                1,
            );
        }
        let roots = (0..root.nodes.len()).filter(|&n| !is_child[n]).collect();
        ("scenes".to_owned(), roots)
    }

    /// Places node `index` and its descendants under the visit `parent` (`None` at the root);
    /// `path` holds its ancestors.
    fn visit(&mut self, index: usize, parent: Option<u32>, path: &mut Vec<usize>) -> Result<()> {
        let doc = self.doc;
        let node = doc
            .root
            .nodes
            .get(index)
            .ok_or_else(|| self.ctx.error(format!("nodes[{index}]"), "does not exist"))?;
        let element = label("nodes", index, node.name.as_deref());
        if path.contains(&index) {
            return Err(self.ctx.error(
                element,
                "the node hierarchy has a cycle: this node is its own ancestor",
            ));
        }
        if std::mem::replace(&mut self.reached[index], true) {
            return Err(self.ctx.error(
                element,
                "is reached twice (the child of two nodes, or listed twice among the scene's \
                 roots): glTF node hierarchies must be disjoint trees",
            ));
        }
        if path.len() >= MAX_NODE_DEPTH {
            return Err(self.ctx.error(
                element,
                format!("the node hierarchy is deeper than {MAX_NODE_DEPTH} levels"),
            ));
        }
        let parent_world =
            parent.map_or(Mat4::IDENTITY, |p| self.hierarchy.visits[p as usize].world);
        let (local, world) = local_transform(node)
            .map(|local| (local, parent_world * local))
            .filter(|(local, world)| local.is_finite() && world.is_finite())
            .ok_or_else(|| {
                self.ctx.error(
                    &element,
                    "has a transform that is not finite, or a zero rotation quaternion",
                )
            })?;
        if let Some(m) = node.matrix
            && [m[3], m[7], m[11], m[15]] != [0.0, 0.0, 0.0, 1.0]
        {
            return Err(self.ctx.error(
                element,
                "has a matrix that is not affine (its last row is not 0 0 0 1): glTF node \
                 matrices must decompose into translation, rotation and scale",
            ));
        }
        let visit = self.hierarchy.visits.len() as u32;
        self.hierarchy.visits.push(Visit {
            node: index as u32,
            parent,
            local,
            world,
        });
        let name = node
            .name
            .clone()
            .unwrap_or_else(|| format!("nodes[{index}]"));
        if let Some(mesh) = node.mesh {
            self.instance(index, &element, &name, mesh.value(), world)?;
        }
        if let Some(camera) = node.camera {
            self.camera(camera.value(), &element, &name, world)?;
        }
        if let Some(light) = node
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
        {
            self.light(light.light.value(), &element, &name, world)?;
        }
        // Whatever this node placed was placed by this visit.
        let h = &mut self.hierarchy;
        for (placed, visits) in [
            (self.instances.len(), &mut h.instances),
            (self.lights.len(), &mut h.lights),
            (self.cameras.len(), &mut h.cameras),
        ] {
            visits.resize(placed, visit);
        }
        path.push(index);
        for child in node.children.iter().flatten() {
            self.visit(child.value(), Some(visit), path)?;
        }
        path.pop();
        Ok(())
    }

    fn instance(
        &mut self,
        node: usize,
        element: &str,
        name: &str,
        mesh: usize,
        world: Mat4,
    ) -> Result<()> {
        // In f64, so that a huge scale (refused below, by where it puts the mesh) does not
        // overflow into a NaN that reads as singular.
        let determinant = glam::Mat3::from_mat4(world).as_dmat3().determinant();
        if determinant.is_nan() || determinant.abs() < f64::from(f32::MIN_POSITIVE) {
            self.ctx.warn(
                "singular transform",
                element,
                "has a singular transform (a zero scale): its mesh is skipped",
                1,
            );
            return Ok(());
        }
        if let Some(mesh) = self.mesh(mesh)? {
            let Aabb { min, max } = self.mesh_bounds[mesh as usize];
            // The mesh lies inside its box, so its placed vertices lie inside the placed corners'.
            let reach = (0..8)
                .map(|c| {
                    let corner = Vec3::select(
                        glam::BVec3::new(c & 1 != 0, c & 2 != 0, c & 4 != 0),
                        max,
                        min,
                    );
                    world.transform_point3(corner).abs().max_element()
                })
                .fold(0.0f32, |a, b| match a.is_nan() || b.is_nan() {
                    true => f32::NAN,
                    false => a.max(b),
                });
            if reach.is_nan() || reach > MAX_WORLD_COORDINATE {
                self.ctx.warn(
                    "world overflow",
                    element,
                    format!(
                        "its mesh's world-space positions reach {reach:e}, beyond \
                         ±{MAX_WORLD_COORDINATE:e} where f32 arithmetic on positions stays \
                         finite: the instance is skipped"
                    ),
                    1,
                );
                return Ok(());
            }
            self.instances.push(Instance {
                name: name.to_owned(),
                node: node as u32,
                mesh,
                transform: world,
            });
        }
        Ok(())
    }

    /// Loads glTF mesh `index` once; `None` if it has no triangles.
    fn mesh(&mut self, index: usize) -> Result<Option<u32>> {
        if let Some(&slot) = self.mesh_slots.get(&index) {
            return Ok(slot);
        }
        let doc = self.doc;
        let gltf_mesh = doc
            .root
            .meshes
            .get(index)
            .ok_or_else(|| self.ctx.error(format!("meshes[{index}]"), "does not exist"))?;
        let element = label("meshes", index, gltf_mesh.name.as_deref());
        let mut parts = Vec::new();
        for (p, primitive) in gltf_mesh.primitives.iter().enumerate() {
            if let Some(part) = self.primitive(primitive, &format!("{element}.primitives[{p}]"))? {
                parts.push(part);
            }
        }
        let has_uvs = parts.iter().any(|(part, _)| part.uvs.is_some());
        let mut mesh = Mesh {
            name: gltf_mesh
                .name
                .clone()
                .unwrap_or_else(|| format!("meshes[{index}]")),
            uvs: has_uvs.then(Vec::new),
            ..Mesh::default()
        };
        for (part, material) in parts {
            let base = u32::try_from(mesh.positions.len() + part.positions.len())
                .map(|_| mesh.positions.len() as u32)
                .map_err(|_| self.ctx.error(&element, "has more than 2^32 vertices"))?;
            mesh.triangles
                .extend(part.triangles.iter().map(|t| t.map(|v| v + base)));
            mesh.materials
                .extend(std::iter::repeat_n(material, part.triangles.len()));
            if let Some(uvs) = &mut mesh.uvs {
                match part.uvs {
                    Some(part_uvs) => uvs.extend(part_uvs),
                    None => uvs.resize(uvs.len() + part.positions.len(), Vec2::ZERO),
                }
            }
            mesh.positions.extend(part.positions);
            mesh.normals.extend(part.normals);
        }
        let slot = (!mesh.triangles.is_empty()).then(|| {
            let bounds = mesh.positions.iter().fold(Aabb::EMPTY, |b, &p| Aabb {
                min: b.min.min(p),
                max: b.max.max(p),
            });
            self.mesh_bounds.push(bounds);
            self.meshes.push(mesh);
            self.meshes.len() as u32 - 1
        });
        self.mesh_slots.insert(index, slot);
        Ok(slot)
    }

    /// One primitive's triangles and material; `None` when it has none to trace.
    fn primitive(
        &mut self,
        primitive: &json::mesh::Primitive,
        element: &str,
    ) -> Result<Option<(CleanPrimitive, u32)>> {
        let doc = self.doc;
        let Checked::Valid(mode) = primitive.mode else {
            return Err(self.ctx.error(format!("{element}.mode"), "is invalid"));
        };
        if let Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip = mode {
            self.ctx.warn(
                &format!("mode {mode:?}"),
                element,
                format!("{mode:?} primitives are skipped: only triangles are traced"),
                1,
            );
            return Ok(None);
        }
        if primitive.targets.as_ref().is_some_and(|t| !t.is_empty()) {
            self.ctx.warn(
                "morph targets",
                element,
                "morph targets are ignored: the base shape is loaded",
                1,
            );
        }
        let (mut position, mut normal, mut uv) = (None, None, None);
        for (semantic, accessor) in &primitive.attributes {
            let attribute = format!("{element}.attributes.{}", semantic.to_string());
            let (kind, message) = match semantic {
                Checked::Valid(Semantic::Positions) => {
                    position = Some(accessor.value());
                    continue;
                }
                Checked::Valid(Semantic::Normals) => {
                    normal = Some(accessor.value());
                    continue;
                }
                Checked::Valid(Semantic::TexCoords(0)) => {
                    uv = Some(accessor.value());
                    continue;
                }
                Checked::Valid(Semantic::TexCoords(_)) => {
                    ("extra uv sets", "UV sets after TEXCOORD_0 are ignored")
                }
                Checked::Valid(Semantic::Colors(_)) => {
                    ("vertex colours", "vertex colours are ignored")
                }
                Checked::Valid(Semantic::Tangents) => (
                    "tangents",
                    "tangents are ignored (normal textures are not used)",
                ),
                Checked::Valid(Semantic::Joints(_) | Semantic::Weights(_)) => (
                    "skinning attributes",
                    "joints and weights are ignored: skinned meshes are loaded in their bind pose",
                ),
                Checked::Valid(Semantic::Extras(_)) => (
                    "custom attributes",
                    "application-specific attributes are ignored",
                ),
                Checked::Invalid => {
                    return Err(self.ctx.error(attribute, "is not a valid attribute name"));
                }
            };
            self.ctx.warn(kind, attribute, message, 1);
        }
        let Some(position) = position else {
            self.ctx.warn(
                "no positions",
                element,
                "primitives without POSITION are skipped",
                1,
            );
            return Ok(None);
        };
        let positions = doc.read_vec3(&self.ctx, position, &format!("POSITION of {element}"))?;
        let vertices = positions.len();
        let same_count = |accessor: usize, name: &str| -> Result<()> {
            let count = doc.accessor_count(accessor);
            if count == vertices {
                return Ok(());
            }
            Err(self.ctx.error(
                format!("accessors[{accessor}] ({name} of {element})"),
                format!("has {count} elements, POSITION has {vertices}"),
            ))
        };
        let normals = match normal {
            Some(a) => {
                same_count(a, "NORMAL")?;
                Some(doc.read_vec3(&self.ctx, a, &format!("NORMAL of {element}"))?)
            }
            None => None,
        };
        let uvs = match uv {
            Some(a) => {
                same_count(a, "TEXCOORD_0")?;
                Some(doc.read_vec2(&self.ctx, a, &format!("TEXCOORD_0 of {element}"))?)
            }
            None => None,
        };
        let indices = match primitive.indices {
            Some(accessor) => {
                let usage = format!("indices of {element}");
                let indices = doc.read_indices(&self.ctx, accessor.value(), &usage)?;
                if let Some((i, v)) = indices
                    .iter()
                    .enumerate()
                    .find(|&(_, &v)| v as usize >= vertices)
                {
                    return Err(self.ctx.error(
                        format!("accessors[{}] ({usage})", accessor.value()),
                        format!(
                            "index {v} at position {i} is out of range: POSITION has {vertices} \
                             vertices"
                        ),
                    ));
                }
                indices
            }
            None => (0..vertices as u32).collect(),
        };
        let (triangles, rest) = geometry::triangulate(mode, &indices);
        if rest > 0 {
            self.ctx.warn(
                "incomplete triangle",
                element,
                format!(
                    "{} vertices do not make whole triangles: the last {rest} are ignored",
                    indices.len()
                ),
                1,
            );
        }
        let (clean, repairs) = geometry::clean(RawPrimitive {
            positions,
            normals,
            uvs,
            triangles,
        });
        for (kind, count, message) in [
            (
                "non-finite positions",
                repairs.non_finite,
                "triangles with a NaN or infinite vertex position are dropped",
            ),
            (
                "degenerate triangles",
                repairs.degenerate,
                "degenerate (zero-area) triangles are dropped",
            ),
            (
                "bad normals",
                repairs.bad_normals,
                "normals that are zero or not finite are replaced by computed ones",
            ),
            (
                "bad uvs",
                repairs.bad_uvs,
                "UVs that are not finite are replaced by zero",
            ),
        ] {
            if count > 0 {
                self.ctx.warn(kind, element, message, count);
            }
        }
        let material = match primitive.material {
            Some(m) if m.value() < self.materials.len() => m.value() as u32,
            Some(m) => {
                return Err(self.ctx.error(
                    format!("{element}.material"),
                    format!("materials[{}] does not exist", m.value()),
                ));
            }
            None => *self.default_material.get_or_insert_with(|| {
                self.materials.push(Material::default());
                self.materials.len() as u32 - 1
            }),
        };
        Ok(Some((clean, material)))
    }

    fn material(&mut self, index: usize) -> Material {
        let doc = self.doc;
        let m = &doc.root.materials[index];
        let element = label("materials", index, m.name.as_deref());
        let pbr = &m.pbr_metallic_roughness;
        let alpha_cutoff = match m.alpha_mode {
            Checked::Valid(AlphaMode::Mask) => {
                let cutoff = m.alpha_cutoff.map_or(0.5, |c| c.0);
                // NaN and out-of-range cutoffs: glTF requires >= 0; 1 keeps only full alpha.
                Some(if cutoff.is_nan() {
                    0.5
                } else {
                    cutoff.clamp(0.0, 1.0)
                })
            }
            Checked::Valid(AlphaMode::Blend) => {
                self.ctx.warn(
                    "alpha mode BLEND",
                    &element,
                    "alphaMode BLEND is treated as MASK with cutoff 0.5 (no transparency)",
                    1,
                );
                Some(0.5)
            }
            _ => None,
        };
        let ignored = [
            (
                m.normal_texture.is_some(),
                "normalTexture",
                "normal textures are ignored: shading uses the vertex normals",
            ),
            (
                m.occlusion_texture.is_some(),
                "occlusionTexture",
                "occlusion textures are ignored",
            ),
            (
                pbr.metallic_roughness_texture.is_some(),
                "pbrMetallicRoughness.metallicRoughnessTexture",
                "metallic-roughness textures are ignored: the factors are kept",
            ),
        ];
        for (present, field, message) in ignored {
            if present {
                self.ctx
                    .warn(field, format!("{element}.{field}"), message, 1);
            }
        }
        let strength = m
            .extensions
            .as_ref()
            .and_then(|e| e.emissive_strength.as_ref())
            .map_or(1.0, |s| s.emissive_strength.0);
        let [strength] = self.factor([strength], &element, "emissiveStrength");
        let emissive = Vec3::from(self.factor(m.emissive_factor.0, &element, "emissiveFactor"));
        let mut emissive = emissive * strength;
        if emissive.max_element() > MAX_EMISSION {
            let field = match strength == 1.0 {
                true => "emissiveFactor",
                false => "emissiveStrength",
            };
            self.ctx.warn(
                "absurd emission",
                format!("{element}.{field}"),
                format!(
                    "emission {:e} is larger than {MAX_EMISSION:e} W/(sr·m²): a unit mistake or \
                     garbage, replaced by zero",
                    emissive.max_element()
                ),
                1,
            );
            emissive = Vec3::ZERO;
        }
        let base_color =
            Vec4::from(self.factor(pbr.base_color_factor.0, &element, "baseColorFactor"));
        let [metallic] = self.factor([pbr.metallic_factor.0], &element, "metallicFactor");
        let [roughness] = self.factor([pbr.roughness_factor.0], &element, "roughnessFactor");
        let base_color_texture = pbr
            .base_color_texture
            .as_ref()
            .and_then(|info| self.texture(info, &element, "baseColorTexture"));
        // An emissive texture multiplies the emissive factor: with a zero factor it shows nothing.
        let emissive_texture = m
            .emissive_texture
            .as_ref()
            .filter(|_| emissive != Vec3::ZERO)
            .and_then(|info| self.texture(info, &element, "emissiveTexture"));
        Material {
            name: m
                .name
                .clone()
                .unwrap_or_else(|| format!("materials[{index}]")),
            base_color,
            base_color_texture,
            emissive,
            emissive_texture,
            metallic,
            roughness,
            double_sided: m.double_sided,
            alpha_cutoff,
        }
    }

    /// A material factor with negative and non-finite components (a JSON number beyond `f32`)
    /// replaced by zero.
    fn factor<const N: usize>(&mut self, value: [f32; N], material: &str, field: &str) -> [f32; N] {
        let fixed = value.map(|v| if v.is_finite() && v >= 0.0 { v } else { 0.0 });
        if fixed != value {
            self.ctx.warn(
                "material factors",
                format!("{material}.{field}"),
                "negative or non-finite material factors are replaced by zero",
                1,
            );
        }
        fixed
    }

    /// The texture of a material's texture slot, loaded once; `None` (with a warning) if it cannot
    /// be used.
    fn texture(&mut self, info: &json::texture::Info, material: &str, slot: &str) -> Option<u32> {
        let element = format!("{material}.{slot}");
        if info.tex_coord != 0 {
            self.ctx.warn(
                "texture uv set",
                &element,
                format!(
                    "uses TEXCOORD_{}, but only TEXCOORD_0 is loaded: the texture is dropped and \
                     the factor used alone",
                    info.tex_coord
                ),
                1,
            );
            return None;
        }
        let index = info.index.value();
        if let Some(&slot) = self.texture_slots.get(&index) {
            return slot;
        }
        let slot = self.load_texture(index, &element);
        self.texture_slots.insert(index, slot);
        slot
    }

    /// Queues glTF texture `index` for decoding; `None` if it does not exist.
    fn load_texture(&mut self, index: usize, user: &str) -> Option<u32> {
        self.doc.root.textures.get(index)?;
        self.textures.push(PendingTexture {
            index,
            user: user.to_owned(),
        });
        Some(self.textures.len() as u32 - 1)
    }

    fn light(&mut self, index: usize, node: &str, node_name: &str, world: Mat4) -> Result<()> {
        let doc = self.doc;
        let light = doc
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .and_then(|l| l.lights.get(index))
            .ok_or_else(|| {
                self.ctx.error(
                    node,
                    format!("refers to KHR_lights_punctual light {index}, which does not exist"),
                )
            })?;
        let element = label("KHR_lights_punctual.lights", index, light.name.as_deref());
        let color = Vec3::from(light.color);
        if !color.is_finite()
            || color.min_element() < 0.0
            || !light.intensity.is_finite()
            || light.intensity < 0.0
        {
            self.ctx.warn(
                "invalid light",
                element,
                "colour or intensity is negative or not finite: the light is skipped",
                1,
            );
            return Ok(());
        }
        if light.intensity / LUMENS_PER_WATT * color.max_element() > MAX_EMISSION {
            self.ctx.warn(
                "absurd light",
                element,
                format!(
                    "intensity {:e} is larger than {:e} (cd, or lux for a directional light): a \
                     unit mistake or garbage, the light is skipped",
                    light.intensity,
                    MAX_EMISSION * LUMENS_PER_WATT
                ),
                1,
            );
            return Ok(());
        }
        let kind = match light.type_ {
            Checked::Valid(LightType::Point) => LightKind::Point,
            Checked::Valid(LightType::Directional) => LightKind::Directional,
            Checked::Valid(LightType::Spot) => {
                // The specification's defaults, should a spot light lack its parameters.
                let (inner, outer) = light.spot.as_ref().map_or((0.0, FRAC_PI_4), |s| {
                    (s.inner_cone_angle, s.outer_cone_angle)
                });
                if !(0.0 <= inner && inner < outer && outer <= FRAC_PI_2) {
                    self.ctx.warn(
                        "invalid spot cone",
                        element,
                        "spot cone angles must satisfy 0 <= inner < outer <= π/2: the light is \
                         skipped",
                        1,
                    );
                    return Ok(());
                }
                LightKind::Spot {
                    inner_cone_angle: inner,
                    outer_cone_angle: outer,
                }
            }
            Checked::Invalid => return Err(self.ctx.error(element, "has an invalid type")),
        };
        let direction = world.transform_vector3(Vec3::NEG_Z).normalize_or_zero();
        if direction == Vec3::ZERO && kind != LightKind::Point {
            self.ctx.warn(
                "singular light transform",
                node,
                "a light's node has a singular transform, so the light has no direction: skipped",
                1,
            );
            return Ok(());
        }
        let range = light.range.filter(|r| r.is_finite() && *r > 0.0);
        if light.range.is_some() && range.is_none() {
            self.ctx.warn(
                "invalid light range",
                &element,
                "a light range must be positive: the light's range is ignored",
                1,
            );
        }
        self.lights.push(Light {
            name: light.name.clone().unwrap_or_else(|| node_name.to_owned()),
            kind,
            intensity: color * (light.intensity / LUMENS_PER_WATT),
            position: world.w_axis.truncate(),
            direction: if direction == Vec3::ZERO {
                Vec3::NEG_Z
            } else {
                direction
            },
            range,
        });
        Ok(())
    }

    fn camera(&mut self, index: usize, node: &str, node_name: &str, world: Mat4) -> Result<()> {
        let doc = self.doc;
        let camera = doc.root.cameras.get(index).ok_or_else(|| {
            self.ctx
                .error(node, format!("cameras[{index}] does not exist"))
        })?;
        let element = label("cameras", index, camera.name.as_deref());
        let p = match (camera.type_, &camera.perspective) {
            (Checked::Valid(CameraType::Perspective), Some(p)) => p,
            (Checked::Valid(CameraType::Orthographic), _) => {
                self.ctx.warn(
                    "orthographic camera",
                    element,
                    "orthographic cameras are not supported: skipped",
                    1,
                );
                return Ok(());
            }
            _ => {
                return Err(self.ctx.error(
                    element,
                    "has no valid type, or lacks its perspective parameters",
                ));
            }
        };
        let valid = p.yfov > 0.0
            && p.yfov < PI
            && p.znear > 0.0
            && p.znear.is_finite()
            && p.zfar.is_none_or(|far| far > p.znear)
            && p.aspect_ratio.is_none_or(|a| a > 0.0 && a.is_finite());
        if !valid {
            self.ctx.warn(
                "invalid camera",
                element,
                "a camera needs 0 < yfov < π, 0 < znear < zfar and aspectRatio > 0: skipped",
                1,
            );
            return Ok(());
        }
        let axes = [world.y_axis.truncate(), world.z_axis.truncate()];
        if axes.iter().any(|a| !a.length().is_normal()) {
            self.ctx.warn(
                "singular camera transform",
                node,
                "a camera's node has a singular transform, so the camera has no direction: skipped",
                1,
            );
            return Ok(());
        }
        self.cameras.push(Camera {
            name: camera.name.clone().unwrap_or_else(|| node_name.to_owned()),
            yfov: p.yfov,
            aspect_ratio: p.aspect_ratio,
            znear: p.znear,
            zfar: p.zfar,
            transform: world,
        });
        Ok(())
    }
}

/// Decodes glTF texture `index` (which exists): the image of its first supported extension that
/// decodes, else its `source`.
fn decode_texture(ctx: &Ctx, doc: &Document, index: usize) -> DecodedTexture {
    let texture = &doc.root.textures[index];
    let element = label("textures", index, texture.name.as_deref());
    let extensions = texture.extensions.as_ref().map(|e| &e.others);
    let mut candidates: Vec<(String, Option<u64>)> = TEXTURE_EXTENSIONS
        .iter()
        .filter_map(|&ext| {
            let source = extensions?.get(ext)?.get("source");
            Some((
                format!("{element}.extensions.{ext}.source"),
                source.and_then(|s| s.as_u64()),
            ))
        })
        .collect();
    // A texture that only has an extension's image has no `source` (`u32::MAX` in gltf-json).
    let source = texture.source.value();
    if source != u32::MAX as usize {
        candidates.push((format!("{element}.source"), Some(source as u64)));
    }
    let mut failures = Vec::new();
    if candidates.is_empty() {
        failures.push((
            format!("texture {index} without image"),
            element,
            "has no image (no source, and no supported extension's)".to_owned(),
        ));
    }
    for (reference, image_index) in candidates {
        let Some(image) = image_index.and_then(|i| doc.root.images.get(usize::try_from(i).ok()?))
        else {
            failures.push((
                format!("bad image reference {reference}"),
                reference,
                "is not the index of an image".to_owned(),
            ));
            continue;
        };
        let image_index = image_index.unwrap_or_default() as usize;
        let file_uri = image.uri.as_deref().filter(|uri| !uri.starts_with("data:"));
        let image_element = match file_uri {
            Some(uri) => format!("images[{image_index}] (uri {uri:?})"),
            None => label("images", image_index, image.name.as_deref()),
        };
        let bytes = match (&image.uri, image.buffer_view) {
            (Some(uri), _) => ctx
                .read_uri(uri, MAX_IMAGE_FILE_BYTES + 1)
                .and_then(|bytes| match bytes.len() as u64 > MAX_IMAGE_FILE_BYTES {
                    true => Err(format!(
                        "the file is larger than the {} MiB an image file may have",
                        MAX_IMAGE_FILE_BYTES >> 20
                    )),
                    false => Ok(bytes),
                }),
            (None, Some(view)) => doc
                .view(ctx, view.value())
                .map(<[u8]>::to_vec)
                .map_err(|e| e.to_string()),
            (None, None) => Err("has neither a uri nor a bufferView".to_owned()),
        };
        // Base colour and emissive, the only textures loaded, are sRGB-encoded in glTF.
        let srgb = true;
        match bytes.and_then(|bytes| texture_files::decode(&bytes, srgb)) {
            Ok(decoded) => {
                let wrap = |mode: Checked<WrappingMode>| match mode {
                    Checked::Valid(WrappingMode::ClampToEdge) => Wrap::ClampToEdge,
                    Checked::Valid(WrappingMode::MirroredRepeat) => Wrap::MirroredRepeat,
                    _ => Wrap::Repeat,
                };
                let sampler = texture
                    .sampler
                    .and_then(|s| doc.root.samplers.get(s.value()));
                let texture = Texture {
                    name: image
                        .name
                        .as_deref()
                        .or(file_uri)
                        .map_or_else(|| format!("images[{image_index}]"), str::to_owned),
                    width: decoded.width,
                    height: decoded.height,
                    levels: decoded.levels,
                    srgb,
                    wrap: sampler.map_or([Wrap::Repeat; 2], |s| [wrap(s.wrap_s), wrap(s.wrap_t)]),
                };
                return DecodedTexture {
                    texture: Some(texture),
                    failures,
                    note: decoded.note.map(|note| (image_element, note)),
                };
            }
            Err(why) => failures.push((format!("image {image_index}"), image_element, why)),
        }
    }
    DecodedTexture {
        texture: None,
        failures,
        note: None,
    }
}

/// A node's local transform: its matrix, or translation × rotation × scale with the rotation
/// normalised (exporters write quaternions a rounding off unit length). `None` for a zero or
/// non-finite quaternion.
fn local_transform(node: &json::Node) -> Option<Mat4> {
    if let Some(m) = node.matrix {
        return Some(Mat4::from_cols_array(&m));
    }
    let rotation = Quat::from_array(node.rotation.map_or([0.0, 0.0, 0.0, 1.0], |r| r.0));
    if !rotation.length().is_normal() {
        return None;
    }
    Some(Mat4::from_scale_rotation_translation(
        Vec3::from(node.scale.unwrap_or([1.0; 3])),
        rotation.normalize(),
        Vec3::from(node.translation.unwrap_or_default()),
    ))
}

#[cfg(test)]
mod tests {
    use super::super::texture_files::tests::{bc1_block, dds_file, ktx2_file};
    use super::*;
    use base64::Engine;

    /// A folder of its own under the system's temporary folder.
    fn temp_dir(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("gi-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn ktx2_and_dds_textures_load_through_their_extensions() {
        let dir = temp_dir("texture-extensions");
        // BC1: red (RGB565 0xF800) everywhere.
        let red = bc1_block(0xF800, 0x001F, |_, _| 0);
        let ktx2 = ktx2_file(
            Some(ktx2::Format::BC1_RGB_SRGB_BLOCK),
            4,
            4,
            &[red.to_vec()],
            None,
        );
        std::fs::write(dir.join("red.ktx2"), ktx2).unwrap();
        let green: Vec<u8> = [0, 255, 0, 255].repeat(4);
        let dds = dds_file(ddsfile::DxgiFormat::R8G8B8A8_UNorm_sRGB, 2, 2, 1, &green);
        std::fs::write(dir.join("green.dds"), &dds).unwrap();
        std::fs::write(dir.join("broken.dds"), &dds[..dds.len() - 3]).unwrap();
        let basis = ktx2_file(
            None,
            4,
            4,
            &[vec![0; 16]],
            Some(ktx2::SupercompressionScheme::BasisLZ),
        );
        std::fs::write(dir.join("blue.ktx2"), basis).unwrap();
        image::save_buffer(
            dir.join("blue.png"),
            &[0, 0, 255, 255],
            1,
            1,
            image::ColorType::Rgba8,
        )
        .unwrap();

        let floats: Vec<f32> = vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 0., 1., 0., 0., 1.];
        let buffer =
            base64::engine::general_purpose::STANDARD.encode(bytemuck::cast_slice(&floats));
        let primitive = |m: usize| {
            format!(r#"{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": {m}}}"#)
        };
        let material = |t: usize| {
            format!(r#"{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": {t}}}}}}}"#)
        };
        let gltf = format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_texture_basisu", "MSFT_texture_dds"],
  "extensionsRequired": ["KHR_texture_basisu", "MSFT_texture_dds"],
  "buffers": [{{"byteLength": 60, "uri": "data:application/octet-stream;base64,{buffer}"}}],
  "bufferViews": [{{"buffer": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 24}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}}
  ],
  "images": [
    {{"uri": "broken.dds", "mimeType": "image/vnd-ms.dds"}},
    {{"uri": "red.ktx2", "mimeType": "image/ktx2"}},
    {{"uri": "green.dds"}},
    {{"uri": "blue.ktx2"}},
    {{"uri": "blue.png"}}
  ],
  "textures": [
    {{"extensions": {{"MSFT_texture_dds": {{"source": 0}}}}}},
    {{"extensions": {{"KHR_texture_basisu": {{"source": 1}}}}}},
    {{"extensions": {{"MSFT_texture_dds": {{"source": 2}}}}}},
    {{"source": 4, "extensions": {{"KHR_texture_basisu": {{"source": 3}}}}}}
  ],
  "materials": [{}, {}, {}, {}],
  "meshes": [{{"primitives": [{}, {}, {}, {}]}}],
  "nodes": [{{"mesh": 0}}],
  "scenes": [{{"nodes": [0]}}]
}}"#,
            material(0),
            material(1),
            material(2),
            material(3),
            primitive(0),
            primitive(1),
            primitive(2),
            primitive(3)
        );
        let path = dir.join("textured.gltf");
        std::fs::write(&path, gltf).unwrap();
        let (scene, warnings) = Scene::load(&path).unwrap();

        let names: Vec<&str> = scene.textures.iter().map(|t| t.name.as_str()).collect();
        assert_eq!(names, ["red.ktx2", "green.dds", "blue.png"]);
        let slots: Vec<Option<u32>> = scene
            .materials
            .iter()
            .map(|m| m.base_color_texture)
            .collect();
        assert_eq!(slots, [None, Some(0), Some(1), Some(2)]);
        let [red, green, blue] = &scene.textures[..] else {
            unreachable!()
        };
        assert_eq!((red.width, red.height, red.levels.len()), (4, 4, 3));
        assert!(
            red.levels
                .iter()
                .all(|l| l.chunks(4).all(|t| t == [255, 0, 0, 255]))
        );
        assert_eq!(green.levels, [green_texels(4), green_texels(1)]);
        assert_eq!(blue.levels, [vec![0, 0, 255, 255]]);

        assert_eq!(warnings.len(), 2, "{warnings:#?}");
        let broken = warnings
            .iter()
            .find(|w| w.element.contains("broken.dds"))
            .unwrap();
        assert!(broken.message.contains("truncated"), "{broken}");
        assert!(
            broken
                .message
                .contains("materials[0].baseColorTexture is dropped"),
            "{broken}"
        );
        let basis = warnings
            .iter()
            .find(|w| w.element.contains("blue.ktx2"))
            .unwrap();
        assert!(basis.message.contains("BasisLZ"), "{basis}");
        assert!(
            basis.message.contains("blue.png is used instead"),
            "{basis}"
        );

        let stages: Vec<&str> = scene.load_stages.iter().map(|s| s.name).collect();
        assert_eq!(stages, ["parse", "geometry", "textures", "derived"]);
        let report = scene.load_report();
        assert!(
            report.contains("textures") && report.contains("3 textures"),
            "{report}"
        );
        std::fs::remove_dir_all(dir).unwrap();
    }

    fn green_texels(count: usize) -> Vec<u8> {
        [0, 255, 0, 255].repeat(count)
    }
}
