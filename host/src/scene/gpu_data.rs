//! The scene's shading data in the layouts of `gi_shared::scene_data`: built on the CPU
//! ([`ShadingData`], which the CPU reference of the kernels reads too) and uploaded to storage
//! buffers and sampled images ([`GpuShadingData`]).
//!
//! Only what the scene has is stored: without textures there is no texture table (the kernels'
//! binding then gets a 16-byte placeholder, since a Vulkan buffer cannot be empty) and the
//! texture array stays unwritten. The vertices and triangles, which scale with the triangle
//! count, are split over up to [`SCENE_BUFFER_CHUNKS`] storage bindings ([`SplitBuffer`]); every
//! other buffer must fit one ([`MAX_STORAGE_BUFFER_BYTES`]). A scene that does not fit is an
//! error naming the scene and the buffer. Textures are images, one each, so their total size has
//! no such bound.

use super::{Instance, Scene, Texture, Wrap};
use crate::error::{Error, Result};
use crate::vulkan::{
    Buffer, Context, Resource, Samplers, SplitBuffer, TRIANGLES_BINDING, TextureImage,
    TextureLevels, VERTICES_BINDING, upload_textures,
};
use ash::vk;
use gi_shared::layout::{MAX_STORAGE_BUFFER_BYTES, SCENE_BUFFER_CHUNKS};
use gi_shared::scene_data::{
    GpuInstance, GpuMaterial, GpuMesh, GpuTriangle, GpuVertex, MESH_ALPHA_TESTED, NONE,
    SceneSurfaces,
};
use gi_shared::textures::{
    GpuTexture, WRAP_CLAMP_TO_EDGE, WRAP_MIRRORED_REPEAT, WRAP_REPEAT, level_offset, level_size,
};

/// The scene's shading data on the CPU, in GPU layouts.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadingData {
    /// One per `Scene::instances`.
    pub instances: Vec<GpuInstance>,
    /// One per `Scene::meshes`.
    pub meshes: Vec<GpuMesh>,
    /// Every mesh's vertices, concatenated.
    pub vertices: Vec<GpuVertex>,
    /// Every mesh's triangles, concatenated.
    pub triangles: Vec<GpuTriangle>,
    /// One per `Scene::materials`.
    pub materials: Vec<GpuMaterial>,
    /// The texture table, one per `Scene::textures`; empty without textures.
    pub textures: Vec<GpuTexture>,
    /// Every texture's RGBA8 texels (red in the low byte), each texture's levels after one
    /// another (`gi_shared::textures`); empty without textures. The CPU reference reads them; the
    /// device gets one image per texture.
    pub texels: Vec<u32>,
}

impl ShadingData {
    /// The buffers that shading a hit reads, as the shared code takes them.
    pub fn surfaces(&self) -> SceneSurfaces<'_> {
        SceneSurfaces {
            instances: &self.instances,
            meshes: &self.meshes,
            vertices: &self.vertices,
            triangles: &self.triangles,
            materials: &self.materials,
            textures: &self.textures,
        }
    }
}

fn wrap_code(w: Wrap) -> u32 {
    match w {
        Wrap::Repeat => WRAP_REPEAT,
        Wrap::MirroredRepeat => WRAP_MIRRORED_REPEAT,
        Wrap::ClampToEdge => WRAP_CLAMP_TO_EDGE,
    }
}

fn u32_index(scene: &Scene, what: &str, n: usize) -> Result<u32> {
    u32::try_from(n).map_err(|_| too_big(scene, what, n as u64 * 4))
}

fn too_big(scene: &Scene, buffer: &str, bytes: u64) -> Error {
    too_big_for(scene, buffer, bytes, MAX_STORAGE_BUFFER_BYTES as u64)
}

fn too_big_for(scene: &Scene, buffer: &str, bytes: u64, limit: u64) -> Error {
    Error::Scene {
        file: scene.source.clone(),
        element: format!("shading data buffer {buffer:?}"),
        why: format!(
            "{bytes} bytes exceed the {} MiB that every device can bind of it",
            limit >> 20
        ),
    }
}

/// Errors when `data` exceeds `limit` bytes.
fn check_size<T>(scene: &Scene, buffer: &str, data: &[T], limit: usize) -> Result<()> {
    let bytes = std::mem::size_of_val(data) as u64;
    if bytes > limit as u64 {
        return Err(too_big_for(scene, buffer, bytes, limit as u64));
    }
    Ok(())
}

impl ShadingData {
    /// Lays out `scene`'s shading data. Errors when a buffer would exceed what every device can
    /// bind of it ([`MAX_STORAGE_BUFFER_BYTES`], [`SCENE_BUFFER_CHUNKS`] times that for the
    /// vertices and triangles), naming the scene and the buffer.
    pub fn new(scene: &Scene) -> Result<Self> {
        let mut data = Self::default();
        let roots = super::bvh::mesh_roots(scene);
        for (m, mesh) in scene.meshes.iter().enumerate() {
            let first_vertex = u32_index(scene, "vertices", data.vertices.len())?;
            let first_triangle = u32_index(scene, "triangles", data.triangles.len())?;
            data.meshes.push(GpuMesh {
                first_triangle,
                triangle_count: u32_index(scene, "triangles", mesh.triangles.len())?,
                first_vertex,
                vertex_count: u32_index(scene, "vertices", mesh.positions.len())?,
                has_uvs: u32::from(mesh.uvs.is_some()),
                // A scene without bottom levels (not through `Scene::update_derived`) has none.
                bvh_root: roots.get(m).copied().unwrap_or(u32::MAX),
                flags: if mesh.alpha_tested(&scene.materials) {
                    MESH_ALPHA_TESTED
                } else {
                    0
                },
                _pad: 0,
            });
            for (i, (p, n)) in mesh.positions.iter().zip(&mesh.normals).enumerate() {
                let uv = mesh
                    .uvs
                    .as_ref()
                    .and_then(|uvs| uvs.get(i).copied())
                    .unwrap_or_default();
                data.vertices.push(GpuVertex {
                    position: p.to_array(),
                    u: uv.x,
                    normal: n.to_array(),
                    v: uv.y,
                });
            }
            data.triangles
                .extend(
                    mesh.triangles
                        .iter()
                        .zip(&mesh.materials)
                        .map(|(t, m)| GpuTriangle {
                            indices: *t,
                            material: *m,
                        }),
                );
        }
        data.instances = scene.instances.iter().map(gpu_instance).collect();
        data.materials = scene
            .materials
            .iter()
            .map(|m| GpuMaterial {
                base_color: m.base_color.to_array(),
                emissive: m.emissive.to_array(),
                base_color_texture: m.base_color_texture.unwrap_or(NONE),
                emissive_texture: m.emissive_texture.unwrap_or(NONE),
                metallic: m.metallic,
                roughness: m.roughness,
                double_sided: u32::from(m.double_sided),
                // MASK at 0 passes every alpha: opaque.
                alpha_cutoff: m.alpha_cutoff.unwrap_or(0.0),
                _pad: [0; 3],
            })
            .collect();
        for t in &scene.textures {
            let offset = u32_index(scene, "texels", data.texels.len())?;
            data.textures
                .push(push_texture(t, offset, &mut data.texels));
            u32_index(scene, "texels", data.texels.len())?;
        }
        let (one, split) = (
            MAX_STORAGE_BUFFER_BYTES,
            SCENE_BUFFER_CHUNKS * MAX_STORAGE_BUFFER_BYTES,
        );
        check_size(scene, "instances", &data.instances, one)?;
        check_size(scene, "meshes", &data.meshes, one)?;
        check_size(scene, "vertices", &data.vertices, split)?;
        check_size(scene, "triangles", &data.triangles, split)?;
        check_size(scene, "materials", &data.materials, one)?;
        check_size(scene, "textures", &data.textures, one)?;
        Ok(data)
    }
}

/// Appends `t`'s levels, one after another, to `texels` (which must hold `offset` texels) and
/// returns its table entry.
pub(crate) fn push_texture(t: &Texture, offset: u32, texels: &mut Vec<u32>) -> GpuTexture {
    for (l, level) in t.levels.iter().enumerate() {
        let (w, h) = level_size(t.width, t.height, l as u32);
        let texel_count = w as usize * h as usize;
        let start = texels.len();
        texels.extend(
            level
                .as_chunks::<4>()
                .0
                .iter()
                .take(texel_count)
                .map(|c| u32::from_le_bytes(*c)),
        );
        // A short level (the loader never makes one) still gets its full size, white.
        texels.resize(start + texel_count, u32::MAX);
    }
    GpuTexture {
        offset,
        width: t.width,
        height: t.height,
        srgb: u32::from(t.srgb),
        wrap_u: wrap_code(t.wrap[0]),
        wrap_v: wrap_code(t.wrap[1]),
        levels: t.levels.len() as u32,
        _pad: 0,
    }
}

/// The record of `inst` in the instances buffer: its transforms (object to world, world to object
/// computed in `f64`, normals to world) and its mesh.
pub fn gpu_instance(inst: &Instance) -> GpuInstance {
    let n = inst.normal_matrix().transpose().to_cols_array_2d();
    let inverse = inst
        .transform
        .as_dmat4()
        .inverse()
        .transpose()
        .to_cols_array_2d();
    let row = |r: [f64; 4]| r.map(|x| x as f32);
    GpuInstance {
        object_to_world: inst.transform_3x4(),
        world_to_object: [row(inverse[0]), row(inverse[1]), row(inverse[2])],
        normal_to_world: n.map(|r| [r[0], r[1], r[2], 0.0]),
        mesh: inst.mesh,
        winding: if inst.is_mirrored() { -1.0 } else { 1.0 },
        _pad: [0; 2],
    }
}

/// Names of the shading data's buffers, in binding order (the texture array follows them).
pub const BUFFER_NAMES: [&str; 6] = [
    "instances",
    "meshes",
    "vertices",
    "triangles",
    "materials",
    "textures",
];

/// The shading data on the device: storage buffers bound as the first six bindings of the
/// scene's set 2 in the order of [`BUFFER_NAMES`] (the vertices and triangles split), then the
/// texture array ([`crate::vulkan::TEXTURES_BINDING`]).
pub struct GpuShadingData {
    /// One per name of [`BUFFER_NAMES`]; `None` for a kind the scene does not have (the texture
    /// table of a scene without textures), and for the vertices and triangles.
    buffers: [Option<Buffer>; 6],
    /// The vertices, split.
    vertices: SplitBuffer,
    /// The triangles, split.
    triangles: SplitBuffer,
    /// 16 zero bytes, bound in place of absent kinds: too short for one record of any of them,
    /// so the kernels' bounds checks see an empty array. `None` when every kind is present.
    placeholder: Option<Buffer>,
    /// One image per texture, in table order.
    images: Vec<TextureImage>,
    /// Their descriptors: view, sampler (by wrap modes), layout.
    descriptors: Vec<vk::DescriptorImageInfo>,
    /// Kept alive as long as the descriptors.
    _samplers: Samplers,
}

impl GpuShadingData {
    /// Uploads `data` to device-local storage buffers and one sampled image per texture.
    pub fn new(ctx: &Context, data: &ShadingData) -> Result<Self> {
        Self::with_binding_limit(ctx, data, u64::MAX)
    }

    /// [`Self::new`], with the vertices and triangles split into bindings of at most
    /// `max_binding_bytes` (and the device's `maxStorageBufferRange`): what the tests of the
    /// splitting use. Errors when [`SCENE_BUFFER_CHUNKS`] such bindings cannot hold them.
    pub fn with_binding_limit(
        ctx: &Context,
        data: &ShadingData,
        max_binding_bytes: u64,
    ) -> Result<Self> {
        let limit = max_binding_bytes.min(ctx.capabilities().max_storage_buffer_range);
        let vertices = SplitBuffer::device_local(ctx, "vertices", &data.vertices, limit)?;
        let triangles = SplitBuffer::device_local(ctx, "triangles", &data.triangles, limit)?;
        let contents: [&[u8]; 6] = [
            bytemuck::cast_slice(&data.instances),
            bytemuck::cast_slice(&data.meshes),
            bytemuck::cast_slice(&data.vertices),
            bytemuck::cast_slice(&data.triangles),
            bytemuck::cast_slice(&data.materials),
            bytemuck::cast_slice(&data.textures),
        ];
        let mut buffers: [Option<Buffer>; 6] = Default::default();
        for (slot, (name, bytes)) in buffers
            .iter_mut()
            .zip(BUFFER_NAMES.into_iter().zip(contents))
        {
            if bytes.is_empty() || [BUFFER_NAMES[2], BUFFER_NAMES[3]].contains(&name) {
                continue;
            }
            *slot = Some(Buffer::device_local(
                ctx,
                name,
                bytes,
                vk::BufferUsageFlags::empty(),
            )?);
        }
        let absent = |(i, b): (usize, &Option<Buffer>)| {
            b.is_none() && i != VERTICES_BINDING && i != TRIANGLES_BINDING
        };
        let placeholder = match buffers.iter().enumerate().any(absent) {
            true => Some(Buffer::device_zeroed::<[u32; 4]>(
                ctx,
                "shading data placeholder",
                1,
            )?),
            false => None,
        };
        let slots = ctx.capabilities().scene_texture_slots();
        if data.textures.len() > slots as usize {
            return Err(Error::InvalidArgument {
                name: "textures",
                why: format!(
                    "the scene has {} textures; the device's texture array holds {slots}",
                    data.textures.len()
                ),
            });
        }
        let names: Vec<String> = (0..data.textures.len())
            .map(|i| format!("texture {i}"))
            .collect();
        let texel_bytes: &[u8] = bytemuck::cast_slice(&data.texels);
        let levels: Vec<TextureLevels<'_>> = data
            .textures
            .iter()
            .zip(&names)
            .map(|(t, name)| TextureLevels {
                name,
                width: t.width,
                height: t.height,
                srgb: t.srgb != 0,
                levels: (0..t.levels)
                    .map(|l| {
                        let (w, h) = level_size(t.width, t.height, l);
                        let start = (t.offset as usize + level_offset(t.width, t.height, l)) * 4;
                        &texel_bytes[start..start + w as usize * h as usize * 4]
                    })
                    .collect(),
            })
            .collect();
        let images = upload_textures(ctx, &levels)?;
        let mut samplers = Samplers::new(ctx);
        let descriptors = data
            .textures
            .iter()
            .zip(&images)
            .map(|(t, image)| {
                Ok(vk::DescriptorImageInfo::default()
                    .sampler(samplers.get(ctx, [t.wrap_u, t.wrap_v])?)
                    .image_view(image.view)
                    .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            buffers,
            vertices,
            triangles,
            placeholder,
            images,
            descriptors,
            _samplers: samplers,
        })
    }

    /// The six buffers (the placeholder in place of absent kinds) and the texture array: the
    /// first bindings of the scene's set 2 (`vulkan::SceneSet::Shading`).
    pub fn resources(&self) -> Vec<Resource<'_>> {
        let mut resources: Vec<Resource<'_>> = self
            .buffers
            .iter()
            .enumerate()
            .filter_map(|(i, b)| match i {
                VERTICES_BINDING => Some(Resource::Split(&self.vertices)),
                TRIANGLES_BINDING => Some(Resource::Split(&self.triangles)),
                _ => b
                    .as_ref()
                    .or(self.placeholder.as_ref())
                    .map(Resource::Buffer),
            })
            .collect();
        resources.push(Resource::Textures(&self.descriptors));
        resources
    }

    /// Whether the device holds buffer `name` of [`BUFFER_NAMES`] (false for the texture table of
    /// a scene without textures).
    pub fn has_buffer(&self, name: &str) -> bool {
        match name {
            "vertices" => !self.vertices.chunks().is_empty(),
            "triangles" => !self.triangles.chunks().is_empty(),
            _ => BUFFER_NAMES
                .iter()
                .zip(&self.buffers)
                .any(|(n, b)| *n == name && b.is_some()),
        }
    }

    /// The instances buffer (`GpuInstance`s, see [`gpu_instance`]); `None` for a scene without
    /// instances.
    pub fn instances(&self) -> Option<&Buffer> {
        self.buffers[0].as_ref()
    }

    /// Bytes of device memory the textures take, mip chains included, with their table.
    pub fn texture_bytes(&self) -> u64 {
        let table = self.buffers[5].as_ref().map_or(0, |b| b.size);
        table + self.images.iter().map(|i| i.bytes).sum::<u64>()
    }

    /// Bytes of device memory of the geometry and materials: instances, meshes, vertices,
    /// triangles, materials.
    pub fn geometry_bytes(&self) -> u64 {
        let whole: u64 = self.buffers[..5].iter().flatten().map(|b| b.size).sum();
        whole + self.vertices.bytes() + self.triangles.bytes()
    }

    /// Chunks (storage bindings) of the vertices and of the triangles.
    pub fn chunk_counts(&self) -> [usize; 2] {
        [self.vertices.chunks().len(), self.triangles.chunks().len()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::test_scene;

    #[test]
    fn cornell_box_has_no_texture_data() {
        let s = test_scene("cornell-box.gltf");
        let d = ShadingData::new(&s).unwrap();
        assert_eq!(d.instances.len(), s.instances.len());
        assert_eq!(d.meshes.len(), s.meshes.len());
        assert_eq!(d.materials.len(), s.materials.len());
        assert_eq!(
            d.triangles.len(),
            s.meshes.iter().map(|m| m.triangles.len()).sum::<usize>()
        );
        assert!(d.textures.is_empty() && d.texels.is_empty());
        assert!(d.meshes.iter().all(|m| m.has_uvs == 0));
        // Runs line up: each mesh's triangles index its own vertices.
        for m in &d.meshes {
            let tris = &d.triangles[m.first_triangle as usize..][..m.triangle_count as usize];
            assert!(
                tris.iter()
                    .flat_map(|t| t.indices)
                    .all(|i| i < m.vertex_count)
            );
        }
    }

    #[test]
    fn textured_scene_packs_texels_and_the_table() {
        let s = test_scene("textured.gltf");
        let d = ShadingData::new(&s).unwrap();
        let t = &s.textures[0];
        assert_eq!(d.textures.len(), 1);
        assert_eq!(
            (
                d.textures[0].width,
                d.textures[0].height,
                d.textures[0].srgb
            ),
            (t.width, t.height, 1)
        );
        assert_eq!(d.textures[0].wrap_u, WRAP_REPEAT);
        assert_eq!(d.textures[0].levels, t.levels.len() as u32);
        let texels: usize = (0..t.levels.len() as u32)
            .map(|l| {
                let (w, h) = level_size(t.width, t.height, l);
                (w * h) as usize
            })
            .sum();
        assert_eq!(d.texels.len(), texels);
        // Red in the low byte.
        let first = d.texels[0];
        assert_eq!(first & 0xff, u32::from(t.levels[0][0]));
        assert_eq!(first >> 24, u32::from(t.levels[0][3]));
        assert!(d.meshes.iter().all(|m| m.has_uvs == 1));
        assert_eq!(d.materials[0].base_color_texture, 0);
        assert_eq!(d.materials[0].emissive_texture, NONE);
    }

    #[test]
    fn a_buffer_over_the_binding_limit_is_an_error_naming_scene_and_buffer() {
        let s = test_scene("textured.gltf");
        // 2²² vertices of 32 bytes: 128 MiB, and one more.
        let vertices = vec![GpuVertex::ZERO; MAX_STORAGE_BUFFER_BYTES / 32 + 1];
        let err = check_size(&s, "vertices", &vertices, MAX_STORAGE_BUFFER_BYTES)
            .unwrap_err()
            .to_string();
        assert!(err.contains("textured.gltf"), "{err}");
        assert!(err.contains("\"vertices\""), "{err}");
        assert!(err.contains("128 MiB"), "{err}");
        assert!(check_size(&s, "vertices", &vertices[1..], MAX_STORAGE_BUFFER_BYTES).is_ok());
    }

    #[test]
    fn texture_levels_follow_one_another_in_the_texel_array() {
        let mut s = test_scene("textured.gltf");
        let t = &mut s.textures[0];
        (t.width, t.height) = (4, 2);
        t.levels = vec![vec![1; 32], vec![2; 8], vec![3; 4]];
        let d = ShadingData::new(&s).unwrap();
        assert_eq!(d.textures[0].levels, 3);
        assert_eq!(d.texels.len(), 8 + 2 + 1);
        assert_eq!(d.texels[8], 0x0202_0202);
        assert_eq!(d.texels[10], 0x0303_0303);
    }
}
