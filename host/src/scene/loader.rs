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
use std::collections::HashMap;
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::path::Path;

use super::document::{Ctx, Document, label};
use super::geometry::{self, CleanPrimitive, RawPrimitive};
use super::{
    Aabb, Camera, Instance, LUMENS_PER_WATT, Light, LightKind, Material, Mesh, Scene, Texture,
    Warning, Wrap,
};
use crate::Result;

/// Deepest node hierarchy followed: deeper is taken for garbage (and would exhaust the stack).
const MAX_NODE_DEPTH: usize = 1024;

pub(super) fn load(path: &Path) -> Result<(Scene, Vec<Warning>)> {
    let mut ctx = Ctx::new(path);
    let bytes =
        std::fs::read(path).map_err(|e| ctx.error("file", format!("cannot read it: {e}")))?;
    let doc = Document::parse(&mut ctx, &bytes)?;
    let builder = Builder {
        ctx,
        doc: &doc,
        materials: Vec::new(),
        default_material: None,
        textures: Vec::new(),
        texture_slots: HashMap::new(),
        meshes: Vec::new(),
        mesh_slots: HashMap::new(),
        instances: Vec::new(),
        lights: Vec::new(),
        cameras: Vec::new(),
    };
    builder.build()
}

struct Builder<'d> {
    ctx: Ctx,
    doc: &'d Document,
    materials: Vec<Material>,
    /// Index of the default material, once a primitive without one needs it.
    default_material: Option<u32>,
    textures: Vec<Texture>,
    /// glTF texture index -> index into `textures`, `None` if it could not be loaded.
    texture_slots: HashMap<usize, Option<u32>>,
    meshes: Vec<Mesh>,
    /// glTF mesh index -> index into `meshes`, `None` if it has no triangles.
    mesh_slots: HashMap<usize, Option<u32>>,
    instances: Vec<Instance>,
    lights: Vec<Light>,
    cameras: Vec<Camera>,
}

impl Builder<'_> {
    fn build(mut self) -> Result<(Scene, Vec<Warning>)> {
        let root = &self.doc.root;
        if !root.skins.is_empty() {
            self.ctx.warn(
                "skins",
                "skins",
                "skins are ignored: skinned meshes are loaded in their bind pose",
                root.skins.len(),
            );
        }
        if !root.animations.is_empty() {
            self.ctx.warn(
                "animations",
                "animations",
                "animations are ignored: the scene is loaded in its static pose",
                root.animations.len(),
            );
        }
        for index in 0..root.materials.len() {
            let material = self.material(index);
            self.materials.push(material);
        }
        let (scene_element, roots) = self.roots();
        for node in roots {
            self.visit(node, Mat4::IDENTITY, &mut Vec::new())?;
        }

        let mut scene = Scene {
            source: self.ctx.file.clone(),
            meshes: self.meshes,
            instances: self.instances,
            materials: self.materials,
            textures: self.textures,
            lights: self.lights,
            cameras: self.cameras,
            emissive_triangles: Vec::new(),
            bounds: Aabb::EMPTY,
            blases: Vec::new(),
        };
        if scene.triangle_count() == 0 {
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
        scene.update_derived();
        Ok((scene, self.ctx.into_warnings()))
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

    /// Places node `index` and its descendants under `parent`; `path` holds its ancestors.
    fn visit(&mut self, index: usize, parent: Mat4, path: &mut Vec<usize>) -> Result<()> {
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
        if path.len() >= MAX_NODE_DEPTH {
            return Err(self.ctx.error(
                element,
                format!("the node hierarchy is deeper than {MAX_NODE_DEPTH} levels"),
            ));
        }
        let world = local_transform(node)
            .map(|local| parent * local)
            .filter(Mat4::is_finite)
            .ok_or_else(|| {
                self.ctx.error(
                    &element,
                    "has a transform that is not finite, or a zero rotation quaternion",
                )
            })?;
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
        path.push(index);
        for child in node.children.iter().flatten() {
            self.visit(child.value(), world, path)?;
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
        if !world.determinant().is_normal() {
            self.ctx.warn(
                "singular transform",
                element,
                "has a singular transform (a zero scale): its mesh is skipped",
                1,
            );
            return Ok(());
        }
        if let Some(mesh) = self.mesh(mesh)? {
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
        if m.alpha_mode != Checked::Valid(AlphaMode::Opaque) {
            self.ctx.warn(
                "alpha mode",
                &element,
                "alpha modes MASK and BLEND are not supported: the material is opaque",
                1,
            );
        }
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
        let emissive = emissive * strength;
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

    fn load_texture(&mut self, index: usize, user: &str) -> Option<u32> {
        let doc = self.doc;
        let texture = doc.root.textures.get(index)?;
        let image_index = texture.source.value();
        let image = doc.root.images.get(image_index)?;
        let file_uri = image.uri.as_deref().filter(|uri| !uri.starts_with("data:"));
        let element = match file_uri {
            Some(uri) => format!("images[{image_index}] (uri {uri:?})"),
            None => label("images", image_index, image.name.as_deref()),
        };
        let bytes = match (&image.uri, image.buffer_view) {
            (Some(uri), _) => self.ctx.read_uri(uri),
            (None, Some(view)) => doc
                .view(&self.ctx, view.value())
                .map(<[u8]>::to_vec)
                .map_err(|e| e.to_string()),
            (None, None) => Err("has neither a uri nor a bufferView".to_owned()),
        };
        let decoded = bytes.and_then(|bytes| {
            image::load_from_memory(&bytes).map_err(|e| format!("cannot decode it: {e}"))
        });
        let rgba = match decoded {
            Ok(decoded) => decoded.into_rgba8(),
            Err(why) => {
                self.ctx.warn(
                    &format!("image {image_index}"),
                    element,
                    format!("{why}; {user} is dropped and the factor used alone"),
                    1,
                );
                return None;
            }
        };
        let wrap = |mode: Checked<WrappingMode>| match mode {
            Checked::Valid(WrappingMode::ClampToEdge) => Wrap::ClampToEdge,
            Checked::Valid(WrappingMode::MirroredRepeat) => Wrap::MirroredRepeat,
            _ => Wrap::Repeat,
        };
        let sampler = texture
            .sampler
            .and_then(|s| doc.root.samplers.get(s.value()));
        self.textures.push(Texture {
            name: image
                .name
                .as_deref()
                .or(file_uri)
                .map_or_else(|| format!("images[{image_index}]"), str::to_owned),
            width: rgba.width(),
            height: rgba.height(),
            wrap: sampler.map_or([Wrap::Repeat; 2], |s| [wrap(s.wrap_s), wrap(s.wrap_t)]),
            rgba8: rgba.into_raw(),
            // Base colour and emissive, the only textures loaded, are sRGB-encoded in glTF.
            srgb: true,
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
