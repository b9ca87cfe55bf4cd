//! Scenes: a glTF 2.0 loader and the CPU-side [`Scene`] it produces.
//!
//! [`Scene::load`] reads `.gltf` files (with external or `data:` URI buffers and images) and `.glb`
//! files, and returns the scene with the [`Warning`]s of what it skipped.
//!
//! # Two views of the same triangles
//!
//! * Per mesh, in object space: [`Mesh`]es and the [`Instance`]s that place them. One bottom level
//!   per mesh, made of a single geometry, so that a hit's primitive index is the index into
//!   [`Mesh::triangles`]: the software BVH's ([`Scene::blases`], whose leaf order the triangles
//!   are kept in) and the ray queries' acceleration structure, built from the same triangles; one
//!   top-level instance per [`Instance`], with [`Instance::transform_3x4`] as its
//!   `VkTransformMatrixKHR`.
//! * Flattened, in world space: [`Scene::world_triangles`], each triangle with its instance index,
//!   its primitive (triangle) index within the instance's mesh and its material, for the light
//!   tables and tests. Both views name a triangle by the same (instance, primitive) pair.
//!
//! All glTF primitives of a mesh are concatenated into one [`Mesh`], with a material per triangle.
//! Only what the scene has is stored: [`Scene::emissive_triangles`] is empty without emissive
//! materials, [`Scene::textures`] is empty without textures, [`Mesh::uvs`] is `None` without UVs.
//!
//! # Units
//!
//! Metres, and radiometric quantities. glTF gives punctual lights in photometric units: point and
//! spot lights in candela (lm/sr), directional lights in lux (lm/m²). The loader divides them by
//! [`LUMENS_PER_WATT`] (683 lm/W, the luminous efficacy of 555 nm light), so [`Light::intensity`]
//! is a radiant intensity in W/sr for point and spot lights and an irradiance in W/m² (on a
//! surface facing the light) for directional lights. glTF gives material emission no unit;
//! [`Material::emissive`] (`emissiveFactor` × `KHR_materials_emissive_strength`) is taken as a
//! radiance in W/(sr·m²). So a 683 cd point light 1 m from a surface facing it gives that surface
//! an irradiance of 1 W/m², and so does a large emitting surface of radiance 1/π in front of it.
//! Viewers that use glTF numbers as they are (candela as "1 unit") show point lights 683 times
//! brighter, relative to emissive surfaces, than this convention does.
//!
//! # Bad input
//!
//! No input makes the loader panic. Errors ([`Error::Scene`](crate::Error::Scene), naming the file
//! and the element at fault): an unreadable file; malformed JSON or GLB; a document that fails
//! glTF validation (such as a reference to an accessor that does not exist); an unsupported
//! extension in `extensionsRequired`; a buffer whose file is missing, whose `data:` URI is not
//! base64, or that is shorter than its `byteLength`; a buffer view or accessor that reads outside
//! its buffer; an accessor of the wrong type for its use; an index past the last vertex; a node with
//! a non-finite transform or a cycle in the node hierarchy; and a scene without triangles.
//!
//! Warnings and their fallback (each kind reported once, with the first element and a count):
//! triangles with a NaN or infinite vertex position and degenerate (zero-area) triangles are
//! dropped; invalid normals are recomputed; a texture whose image is missing or cannot be decoded
//! is dropped and the material uses its factor alone; non-triangle primitives, orthographic
//! cameras, extensions in `extensionsUsed` that the loader does not support, UV sets after the
//! first, vertex colours, tangents, skins, morph targets, animations, normal, occlusion and
//! metallic-roughness textures, and alpha modes other than opaque are ignored; nodes with a
//! singular transform, and lights and cameras with invalid parameters, are skipped.

pub mod bvh;
mod document;
mod geometry;
pub mod gpu_data;
pub mod lights;
mod loader;
pub mod procedural;
pub mod upload;

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use std::fmt;
use std::path::{Path, PathBuf};

use crate::Result;

/// Luminous efficacy (lm/W) that converts glTF's photometric light units to radiometric ones.
pub const LUMENS_PER_WATT: f32 = 683.0;

/// A scene loaded from a glTF file, in world space, ready for acceleration structures.
#[derive(Clone, Debug)]
pub struct Scene {
    /// The file it was loaded from.
    pub source: PathBuf,
    /// Meshes in object space; each has at least one triangle.
    pub meshes: Vec<Mesh>,
    /// Placements of meshes in the world; at least one.
    pub instances: Vec<Instance>,
    /// Materials, indexed by [`Mesh::materials`]: the file's, in its order, then a default one if
    /// some primitive has no material.
    pub materials: Vec<Material>,
    /// Decoded textures, indexed by the materials; empty when no material has one.
    pub textures: Vec<Texture>,
    /// Punctual lights (`KHR_lights_punctual`), one per node that holds one.
    pub lights: Vec<Light>,
    /// Perspective cameras, one per node that holds one, in node order.
    pub cameras: Vec<Camera>,
    /// Every world-space triangle with an emissive material; empty when there is none.
    pub emissive_triangles: Vec<EmissiveTriangle>,
    /// Bounds of all world-space triangles.
    pub bounds: Aabb,
    /// The software BVH's bottom level of each mesh, indexed like [`Scene::meshes`]; each mesh's
    /// triangles are in its leaf order.
    pub blases: Vec<bvh::Blas>,
}

impl Scene {
    /// Loads a `.gltf` or `.glb` file (recognised by its content, not its name).
    ///
    /// Returns the scene and what the loader skipped or repaired; see the [module](self) for which
    /// input is an error and which a warning.
    pub fn load(path: impl AsRef<Path>) -> Result<(Scene, Vec<Warning>)> {
        loader::load(path.as_ref())
    }

    /// Recomputes [`Scene::blases`] (reordering each mesh's triangles and their materials into
    /// the leaf order of its bottom level), [`Scene::bounds`] and [`Scene::emissive_triangles`]
    /// from the meshes, instances and materials: the loader's last step, and what a scene built
    /// in code calls once its parts are in place (and again after changing meshes).
    pub fn update_derived(&mut self) {
        use rayon::prelude::*;
        self.blases = self
            .meshes
            .par_iter_mut()
            .map(|mesh| {
                let (blas, order) = bvh::Blas::build(&mesh.positions, &mesh.triangles);
                mesh.triangles = order.iter().map(|&i| mesh.triangles[i as usize]).collect();
                mesh.materials = order.iter().map(|&i| mesh.materials[i as usize]).collect();
                blas
            })
            .collect();
        let mut bounds = Aabb::EMPTY;
        let mut emissive = Vec::new();
        for tri in self.world_triangles() {
            tri.vertices.iter().for_each(|&v| bounds.grow(v));
            let material = self.materials.get(tri.material as usize);
            if let Some(material) = material.filter(|m| m.is_emissive()) {
                let [a, b, c] = tri.vertices;
                emissive.push(EmissiveTriangle {
                    instance: tri.instance,
                    primitive: tri.primitive,
                    vertices: tri.vertices,
                    emission: material.emissive,
                    area: 0.5 * (b - a).cross(c - a).length(),
                });
            }
        }
        self.bounds = bounds;
        self.emissive_triangles = emissive;
    }

    /// Number of world-space triangles: the triangles of every instance's mesh.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh as usize].triangles.len())
            .sum()
    }

    /// Every triangle of every instance in world space, instance by instance, in mesh order.
    pub fn world_triangles(&self) -> impl Iterator<Item = WorldTriangle> + '_ {
        self.instances
            .iter()
            .enumerate()
            .flat_map(move |(instance, inst)| {
                let mesh = &self.meshes[inst.mesh as usize];
                (0..mesh.triangles.len()).map(move |primitive| {
                    world_triangle(inst, mesh, instance as u32, primitive as u32)
                })
            })
    }

    /// The world-space triangle `primitive` of `instance`, as a hit record names it.
    pub fn world_triangle(&self, instance: u32, primitive: u32) -> Option<WorldTriangle> {
        let inst = self.instances.get(instance as usize)?;
        let mesh = self.meshes.get(inst.mesh as usize)?;
        ((primitive as usize) < mesh.triangles.len())
            .then(|| world_triangle(inst, mesh, instance, primitive))
    }
}

fn world_triangle(inst: &Instance, mesh: &Mesh, instance: u32, primitive: u32) -> WorldTriangle {
    WorldTriangle {
        vertices: mesh
            .triangle(primitive as usize)
            .map(|v| inst.transform.transform_point3(v)),
        instance,
        primitive,
        material: mesh.materials[primitive as usize],
    }
}

/// A mesh in object space: all triangle primitives of a glTF mesh, concatenated.
///
/// Every vertex is used by some triangle, and every triangle has a non-zero area and finite
/// vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// The glTF mesh's name, or `meshes[i]`.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals, one per position: the file's (unit; invalid ones replaced by area-weighted
    /// face normals), or zero where the file gives none, which shades flat: the shading normal
    /// is then the geometric normal, as glTF requires.
    pub normals: Vec<Vec3>,
    /// First UV set (`TEXCOORD_0`), one per position (zero for primitives without one); `None` when
    /// no primitive of the mesh has UVs.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles as vertex indices, counter-clockwise seen from the front; the index of a triangle
    /// here is its primitive index.
    pub triangles: Vec<[u32; 3]>,
    /// Material of each triangle, an index into [`Scene::materials`].
    pub materials: Vec<u32>,
}

impl Mesh {
    /// Object-space vertices of triangle `primitive`.
    ///
    /// # Panics
    /// If `primitive` is out of range.
    pub fn triangle(&self, primitive: usize) -> [Vec3; 3] {
        self.triangles[primitive].map(|v| self.positions[v as usize])
    }
}

/// A mesh placed in the world by a glTF node.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// The node's name, or `nodes[i]`.
    pub name: String,
    /// Index of the glTF node.
    pub node: u32,
    /// Index into [`Scene::meshes`].
    pub mesh: u32,
    /// Object to world: the product of the node's and all its ancestors' transforms. Never
    /// singular.
    pub transform: Mat4,
}

impl Instance {
    /// The transform as three rows of four (row-major 3×4), the layout of `VkTransformMatrixKHR`.
    pub fn transform_3x4(&self) -> [[f32; 4]; 3] {
        let rows = self.transform.transpose().to_cols_array_2d();
        [rows[0], rows[1], rows[2]]
    }

    /// Transforms object-space normals to world space (then normalise them).
    pub fn normal_matrix(&self) -> Mat3 {
        Mat3::from_mat4(self.transform).inverse().transpose()
    }

    /// Whether the transform mirrors (negative determinant): world-space winding is then the
    /// reverse of object-space winding. Vulkan ray queries decide facing in object space.
    pub fn is_mirrored(&self) -> bool {
        self.transform.determinant() < 0.0
    }
}

/// A triangle in world space with the ids a hit reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldTriangle {
    /// World-space vertices, in the mesh's order.
    pub vertices: [Vec3; 3],
    /// Index into [`Scene::instances`].
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub primitive: u32,
    /// Index into [`Scene::materials`].
    pub material: u32,
}

/// A world-space triangle of an emissive material: an area light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissiveTriangle {
    /// Index into [`Scene::instances`].
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub primitive: u32,
    /// World-space vertices.
    pub vertices: [Vec3; 3],
    /// Emitted radiance, W/(sr·m²): the material's [`Material::emissive`], before its texture.
    pub emission: Vec3,
    /// World-space area, m².
    pub area: f32,
}

/// A metallic-roughness material, as far as the renderer uses it.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The glTF material's name, `materials[i]`, or `default`.
    pub name: String,
    /// Linear base colour and alpha (`baseColorFactor`).
    pub base_color: Vec4,
    /// Index into [`Scene::textures`] of the base colour texture (sRGB), which multiplies
    /// [`Material::base_color`].
    pub base_color_texture: Option<u32>,
    /// Emitted radiance, W/(sr·m²): `emissiveFactor` × `KHR_materials_emissive_strength`.
    pub emissive: Vec3,
    /// Index into [`Scene::textures`] of the emissive texture (sRGB), which multiplies
    /// [`Material::emissive`].
    pub emissive_texture: Option<u32>,
    /// `metallicFactor`; stored, not used yet.
    pub metallic: f32,
    /// `roughnessFactor`; stored, not used yet.
    pub roughness: f32,
    /// Whether the back face is lit like the front.
    pub double_sided: bool,
}

impl Default for Material {
    /// glTF's default material: white, fully metallic and rough, single-sided, not emissive.
    fn default() -> Self {
        Self {
            name: "default".to_owned(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            double_sided: false,
        }
    }
}

impl Material {
    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emissive.max_element() > 0.0
    }
}

/// A decoded texture: RGBA, 8 bits per channel, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// The image's name, its URI, or `images[i]`.
    pub name: String,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height × 4` bytes.
    pub rgba8: Vec<u8>,
    /// Whether the colour channels are sRGB-encoded (base colour and emissive textures are).
    pub srgb: bool,
    /// Wrapping of U and V (the glTF sampler's `wrapS`, `wrapT`).
    pub wrap: [Wrap; 2],
}

/// How texture coordinates outside [0, 1] wrap.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    /// Tile.
    Repeat,
    /// Tile, mirroring every other tile.
    MirroredRepeat,
    /// Clamp to the edge texels.
    ClampToEdge,
}

/// A punctual light (`KHR_lights_punctual`) in world space.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// The light's name, else its node's name (`nodes[i]` when unnamed).
    pub name: String,
    /// Point, spot or directional.
    pub kind: LightKind,
    /// Colour × intensity in radiometric units: W/sr for point and spot lights, W/m² for
    /// directional lights (see the [module](self) on units).
    pub intensity: Vec3,
    /// World-space position (unused for directional lights).
    pub position: Vec3,
    /// World-space unit direction the light shines in: its node's −Z (unused for point lights).
    pub direction: Vec3,
    /// Distance beyond which the light has no effect, if the file sets one.
    pub range: Option<f32>,
}

/// What kind of punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Shines equally in all directions from a point.
    Point,
    /// A point light limited to a cone around [`Light::direction`]: full intensity inside
    /// `inner_cone_angle`, none outside `outer_cone_angle` (radians from the axis, `0 <= inner <
    /// outer <= π/2`).
    Spot {
        /// Angle from the axis where the falloff starts.
        inner_cone_angle: f32,
        /// Angle from the axis where the light ends.
        outer_cone_angle: f32,
    },
    /// Parallel light from infinitely far away.
    Directional,
}

/// A perspective camera in world space. It looks down its local −Z with +Y up.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// The camera's name, else its node's name (`nodes[i]` when unnamed).
    pub name: String,
    /// Vertical field of view, radians.
    pub yfov: f32,
    /// Width over height, if the file sets it (otherwise the viewport's).
    pub aspect_ratio: Option<f32>,
    /// Near plane distance.
    pub znear: f32,
    /// Far plane distance; `None` for an infinite projection.
    pub zfar: Option<f32>,
    /// Camera to world (may hold a scale; the accessors below remove it).
    pub transform: Mat4,
}

impl Camera {
    /// World-space position.
    pub fn position(&self) -> Vec3 {
        self.transform.w_axis.truncate()
    }

    /// World-space unit viewing direction.
    pub fn forward(&self) -> Vec3 {
        (-self.transform.z_axis.truncate()).normalize()
    }

    /// World-space unit up direction.
    pub fn up(&self) -> Vec3 {
        self.transform.y_axis.truncate().normalize()
    }
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Aabb {
    /// The box that holds nothing; growing it by a point gives that point.
    pub const EMPTY: Self = Self {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// Grows the box to hold `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Whether the box holds no point.
    pub fn is_empty(&self) -> bool {
        !self.min.cmple(self.max).all()
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Edge lengths.
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// Something the loader skipped or repaired, once per kind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// The scene file.
    pub file: PathBuf,
    /// The first element where it happened (a glTF path such as `meshes[0] ("Box").primitives[1]`).
    pub element: String,
    /// What was skipped or repaired, and what the loader did instead.
    pub message: String,
    /// How many times it happened (elements, or triangles for dropped triangles).
    pub count: usize,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}: {}: {}",
            self.file.display(),
            self.element,
            self.message
        )?;
        if self.count > 1 {
            write!(f, " ({} in all, the first at this element)", self.count)?;
        }
        Ok(())
    }
}

/// Loads a scene of the repository's `scenes/` for unit tests.
#[cfg(test)]
pub(crate) fn test_scene(file: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(file);
    Scene::load(path).unwrap().0
}
