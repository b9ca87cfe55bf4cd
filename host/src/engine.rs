//! The engine integration API: our GI passes recorded into an engine's frame, on its device.
//!
//! 1. Create the device with what [`DeviceRequirements::new`] lists (extensions, and features
//!    through [`FeatureChain::chain`]), then wrap it: [`Context::from_external`] (the engine's
//!    allocator or one of ours). [`Context::new`] makes a device of its own instead.
//! 2. Build the scene: from glTF ([`Scene::load`]) or from the engine's meshes in memory
//!    ([`scene_from_meshes`]), then [`GpuScene::upload_lit`].
//! 3. [`GiRenderer::new`] with a [`GiSettings`] (or a [`Preset`]); each frame,
//!    [`GiRenderer::record`] into the engine's command buffer with a [`FrameInputs`] and the
//!    engine's [`OutputImage`]s; [`GiRenderer::resize`] and [`GiRenderer::change_scene`] without
//!    a rebuild.
//!
//! Per-frame parameters are written inside the command buffer (`vkCmdUpdateBuffer`), so frames
//! may be in flight while the next is recorded; every frame starts with a barrier on the work
//! submitted before it on the same queue, so consecutive frames need no semaphore between them.
//! The renderer's buffers are one set: frames run one after the other on the GPU.

pub use crate::gi::renderer::GiRenderer;
pub use crate::gi::{GiSettings, Preset, ViewOptions};
pub use crate::scene::Scene;
pub use crate::scene::upload::GpuScene;
pub use crate::vulkan::{Context, DeviceRequirements, ExternalDevice, FeatureChain};

use crate::error::{Error, Result};
use crate::scene::lights::LightSet;
use crate::scene::{Instance, Light, Material, Mesh};
use ash::vk;
use gi_shared::camera::CameraParams;
use glam::Mat4;

/// The one format an [`OutputImage`] may have: the renderer's `[f32; 4]` texels, copied as they
/// are (linear, HDR).
pub const OUTPUT_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// The stage of the renderer's only use of an [`OutputImage`] (a buffer-to-image copy), first
/// and last: the engine's barrier before [`GiRenderer::record`] has it as destination stage, its
/// barrier after as source stage.
pub const OUTPUT_STAGE: vk::PipelineStageFlags = vk::PipelineStageFlags::TRANSFER;

/// The access of that use.
pub const OUTPUT_ACCESS: vk::AccessFlags = vk::AccessFlags::TRANSFER_WRITE;

/// An image the engine owns, written by [`GiRenderer::record`].
///
/// Requirements: 2D, [`OUTPUT_FORMAT`], the renderer's size, one mip level and layer, created
/// with `VK_IMAGE_USAGE_TRANSFER_DST_BIT`, on the device of the context. Before the recorded
/// frame it must be in `layout` (`TRANSFER_DST_OPTIMAL`, or `GENERAL`, which the validation
/// layer reports as a performance warning) with the engine's earlier accesses made available to
/// [`OUTPUT_STAGE`]/[`OUTPUT_ACCESS`]; the frame leaves it in the same layout, written at
/// [`OUTPUT_STAGE`]/[`OUTPUT_ACCESS`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputImage {
    /// The image.
    pub image: vk::Image,
    /// Its format: [`OUTPUT_FORMAT`].
    pub format: vk::Format,
    /// Its width in pixels.
    pub width: u32,
    /// Its height in pixels.
    pub height: u32,
    /// Its layout during the frame: `TRANSFER_DST_OPTIMAL` or `GENERAL`.
    pub layout: vk::ImageLayout,
}

impl OutputImage {
    /// An error naming `what` unless the image can take a `width × height` frame.
    pub(crate) fn check(&self, what: &'static str, width: u32, height: u32) -> Result<()> {
        let bad = |why: String| Err(Error::InvalidArgument { name: what, why });
        if self.format != OUTPUT_FORMAT {
            return bad(format!(
                "format {:?}; the renderer writes {OUTPUT_FORMAT:?}",
                self.format
            ));
        }
        if [self.width, self.height] != [width, height] {
            return bad(format!(
                "{} × {} for a renderer of {width} × {height} (GiRenderer::resize first)",
                self.width, self.height
            ));
        }
        if ![
            vk::ImageLayout::GENERAL,
            vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        ]
        .contains(&self.layout)
        {
            return bad(format!(
                "layout {:?}; GENERAL or TRANSFER_DST_OPTIMAL",
                self.layout
            ));
        }
        if self.image == vk::Image::null() {
            return bad("a null image".into());
        }
        Ok(())
    }
}

/// The engine's images a frame writes; each is optional.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameOutputs {
    /// The final image: direct light plus the denoised indirect light times the albedo, plus
    /// emission (linear HDR radiance in RGB; alpha unspecified).
    pub image: Option<OutputImage>,
    /// The denoised indirect irradiance per pixel, before the albedo (RGB; alpha unspecified).
    pub irradiance: Option<OutputImage>,
}

/// Where a frame's G-buffer comes from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GBufferSource {
    /// Our G-buffer pass traces primary rays through the scene.
    #[default]
    Traced,
    /// The engine recorded writes into [`GiRenderer::gbuffer`]'s images (its formats) earlier in
    /// the same command buffer, by compute shaders or transfers: the frame starts with a
    /// barrier that makes them visible and skips the G-buffer pass.
    Written,
}

/// A pose change of the uploaded scene, applied before the frame ([`GpuScene::set_pose`]).
#[derive(Clone, Copy, Debug)]
pub struct SceneUpdate<'a> {
    /// The scene in its new pose (the same meshes and instances as uploaded).
    pub scene: &'a Scene,
    /// Its lights, made from the posed scene (punctual lights may have moved or changed).
    pub lights: &'a LightSet,
    /// Each instance's object-to-world transform in the frame before (motion vectors).
    pub previous_transforms: &'a [Mat4],
}

/// Everything that changes from one frame to the next.
#[derive(Clone, Copy, Debug)]
pub struct FrameInputs<'a> {
    /// This frame's camera; its `image_size` must be the renderer's. Jitter is ignored (the
    /// denoiser expects none).
    pub camera: CameraParams,
    /// The camera of the frame before, for reprojection; `None`: the camera of the last frame
    /// the renderer recorded.
    pub previous_camera: Option<CameraParams>,
    /// Drop the screen-space history (probes, denoiser) as after a camera cut; the world cache
    /// is kept.
    pub camera_cut: bool,
    /// Moved instances and changed lights, or `None`. Applied with one submission on the
    /// context's queue that waits for it (and, by queue order, for every frame submitted
    /// before): not recorded into the frame's command buffer.
    pub scene_update: Option<SceneUpdate<'a>>,
    /// Where the G-buffer comes from.
    pub gbuffer: GBufferSource,
}

impl FrameInputs<'_> {
    /// A frame seen by `camera`, the previous camera remembered, nothing else changed, our
    /// G-buffer.
    pub fn new(camera: CameraParams) -> Self {
        Self {
            camera,
            previous_camera: None,
            camera_cut: false,
            scene_update: None,
            gbuffer: GBufferSource::Traced,
        }
    }
}

/// One mesh instance of [`scene_from_meshes`]: which mesh, where.
#[derive(Clone, Debug)]
pub struct MeshInstance {
    /// Index into the meshes.
    pub mesh: u32,
    /// Object-to-world transform (finite, invertible).
    pub transform: Mat4,
}

/// A [`Scene`] from an engine's meshes in memory, without glTF: `meshes` in object space (each
/// with positions, one normal per position or none (flat shading), optional UVs, triangles as
/// indices, and a material index per triangle), `materials`, `instances` placing the meshes, and
/// punctual `lights`. Builds each mesh's BVH ([`Scene::update_derived`]).
///
/// Errors (naming the mesh, triangle or instance at fault) for: no instances; a mesh without
/// triangles; an index or material out of range; per-vertex arrays of another length than the
/// positions; a position, normal, UV, transform or material value that is not finite.
pub fn scene_from_meshes(
    name: &str,
    mut meshes: Vec<Mesh>,
    materials: Vec<Material>,
    instances: &[MeshInstance],
    lights: Vec<Light>,
) -> Result<Scene> {
    let bad = |name: &'static str, why: String| Err(Error::InvalidArgument { name, why });
    if instances.is_empty() {
        return bad("instances", "none: a scene needs at least one".into());
    }
    for (m, material) in materials.iter().enumerate() {
        let values = material.base_color.to_array().into_iter().chain([
            material.metallic,
            material.roughness,
            material.emissive.x,
            material.emissive.y,
            material.emissive.z,
        ]);
        if values.into_iter().any(|v| !v.is_finite()) {
            return bad(
                "materials",
                format!(
                    "material {m} ({:?}) has a value that is not finite",
                    material.name
                ),
            );
        }
        if material.base_color_texture.is_some() || material.emissive_texture.is_some() {
            return bad(
                "materials",
                format!(
                    "material {m} ({:?}) names a texture; scenes from meshes have none",
                    material.name
                ),
            );
        }
    }
    for (i, mesh) in meshes.iter_mut().enumerate() {
        let at = |why: String| format!("mesh {i} ({:?}): {why}", mesh.name);
        let n = mesh.positions.len();
        if mesh.triangles.is_empty() {
            return bad("meshes", at("no triangles".into()));
        }
        if mesh.normals.is_empty() {
            mesh.normals = vec![glam::Vec3::ZERO; n];
        }
        let uvs = mesh.uvs.as_ref().map_or(n, Vec::len);
        if mesh.normals.len() != n || uvs != n {
            return bad(
                "meshes",
                at(format!(
                    "{n} positions but {} normals and {uvs} UVs",
                    mesh.normals.len()
                )),
            );
        }
        if mesh.materials.len() != mesh.triangles.len() {
            return bad(
                "meshes",
                at(format!(
                    "{} triangles but {} material indices",
                    mesh.triangles.len(),
                    mesh.materials.len()
                )),
            );
        }
        if let Some(v) = mesh.positions.iter().position(|p| !p.is_finite()) {
            return bad("meshes", at(format!("position {v} is not finite")));
        }
        if let Some(v) = mesh.normals.iter().position(|p| !p.is_finite()) {
            return bad("meshes", at(format!("normal {v} is not finite")));
        }
        if let Some(v) = mesh.uvs.iter().flatten().position(|p| !p.is_finite()) {
            return bad("meshes", at(format!("UV {v} is not finite")));
        }
        for (t, tri) in mesh.triangles.iter().enumerate() {
            if let Some(&v) = tri.iter().find(|&&v| v as usize >= n) {
                return bad(
                    "meshes",
                    at(format!("triangle {t} has index {v}, but {n} positions")),
                );
            }
            let material = mesh.materials[t];
            if material as usize >= materials.len() {
                return bad(
                    "meshes",
                    at(format!(
                        "triangle {t} has material {material}, but {} materials",
                        materials.len()
                    )),
                );
            }
        }
    }
    for (i, inst) in instances.iter().enumerate() {
        if inst.mesh as usize >= meshes.len() {
            return bad(
                "instances",
                format!(
                    "instance {i} shows mesh {}, but {} meshes",
                    inst.mesh,
                    meshes.len()
                ),
            );
        }
        if !inst.transform.is_finite() || inst.transform.determinant() == 0.0 {
            return bad(
                "instances",
                format!("instance {i}: transform is not finite or not invertible"),
            );
        }
    }
    let instances = instances
        .iter()
        .enumerate()
        .map(|(i, inst)| Instance {
            name: format!("instance {i}"),
            node: i as u32,
            mesh: inst.mesh,
            transform: inst.transform,
        })
        .collect();
    Ok(Scene::from_parts(
        name,
        meshes,
        instances,
        materials,
        Vec::new(),
        lights,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec3, Vec4};

    fn quad() -> Mesh {
        Mesh {
            name: "quad".into(),
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE],
            normals: vec![],
            uvs: None,
            triangles: vec![[0, 1, 2], [2, 1, 3]],
            materials: vec![0, 0],
        }
    }

    fn build(mesh: Mesh, materials: Vec<Material>, instance: MeshInstance) -> Result<Scene> {
        scene_from_meshes("engine", vec![mesh], materials, &[instance], vec![])
    }

    const AT_ORIGIN: MeshInstance = MeshInstance {
        mesh: 0,
        transform: Mat4::IDENTITY,
    };

    #[test]
    fn meshes_in_memory_make_a_scene_with_its_bvh() {
        let emissive = Material {
            emissive: Vec3::ONE,
            ..Material::default()
        };
        let scene = build(quad(), vec![emissive], AT_ORIGIN).unwrap();
        assert_eq!(scene.triangle_count(), 2);
        assert_eq!(scene.blases.len(), 1);
        assert_eq!(scene.emissive_triangles.len(), 2);
        assert_eq!(scene.meshes[0].normals, vec![Vec3::ZERO; 4]);
        assert_eq!(scene.bounds.max, Vec3::new(1.0, 1.0, 1.0));
    }

    #[test]
    fn bad_meshes_are_refused_by_name() {
        let error = |mesh: Mesh, materials: Vec<Material>, inst: MeshInstance| {
            build(mesh, materials, inst).unwrap_err().to_string()
        };
        let mut out_of_range = quad();
        out_of_range.triangles[1][2] = 4;
        let e = error(out_of_range, vec![Material::default()], AT_ORIGIN);
        assert!(e.contains("triangle 1 has index 4, but 4 positions"), "{e}");

        let mut nan = quad();
        nan.positions[2].y = f32::NAN;
        let e = error(nan, vec![Material::default()], AT_ORIGIN);
        assert!(e.contains("\"quad\"") && e.contains("position 2"), "{e}");

        let e = error(quad(), vec![], AT_ORIGIN);
        assert!(e.contains("material 0, but 0 materials"), "{e}");

        let bad_material = Material {
            base_color: Vec4::splat(f32::INFINITY),
            ..Material::default()
        };
        let e = error(quad(), vec![bad_material], AT_ORIGIN);
        assert!(e.contains("material 0") && e.contains("not finite"), "{e}");

        let mut short_normals = quad();
        short_normals.normals = vec![Vec3::Z; 3];
        let e = error(short_normals, vec![Material::default()], AT_ORIGIN);
        assert!(e.contains("4 positions but 3 normals"), "{e}");

        let flat = MeshInstance {
            mesh: 0,
            transform: Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0)),
        };
        let e = error(quad(), vec![Material::default()], flat);
        assert!(
            e.contains("instance 0") && e.contains("not invertible"),
            "{e}"
        );

        let missing = MeshInstance {
            mesh: 1,
            transform: Mat4::IDENTITY,
        };
        let e = error(quad(), vec![Material::default()], missing);
        assert!(e.contains("shows mesh 1, but 1 meshes"), "{e}");

        let e = scene_from_meshes("engine", vec![quad()], vec![], &[], vec![])
            .unwrap_err()
            .to_string();
        assert!(e.contains("instances"), "{e}");
    }
}
