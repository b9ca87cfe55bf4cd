//! The scene's shading data on the GPU: instances, meshes, vertices, triangles, materials and
//! textures, with the attribute fetch and texture sampling that the CPU and the kernels share.
//!
//! # Buffers
//!
//! All `#[repr(C)]` + [`Pod`], only `f32`/`u32`, explicit padding; sizes and offsets are asserted
//! by the tests below.
//!
//! * [`GpuInstance`] (160 bytes), indexed by the hit's instance.
//! * [`GpuMesh`] (32 bytes), indexed by [`GpuInstance::mesh`]; [`GpuMesh::bvh_root`] is the root
//!   of its bottom-level BVH in the node buffer (`crate::bvh`).
//! * [`GpuVertex`] (32 bytes): every mesh's vertices, concatenated, in object space.
//! * [`GpuTriangle`] (16 bytes): every mesh's triangles, concatenated; a hit's primitive indexes
//!   its mesh's run, in the leaf order of the mesh's bottom-level BVH.
//! * [`GpuMaterial`] (64 bytes).
//! * [`GpuTexture`] (32 bytes), the texture table, defined with the texture reads in
//!   [`crate::textures`]. The texels are sampled images on the device and one `u32` array on the
//!   CPU.
//!
//! # Robustness
//!
//! Nothing here panics or reads out of bounds: an instance, mesh, vertex, triangle, material or
//! texel index out of range falls back to a defined value (a zero transform, no vertices, the
//! default white material, a texture reading as 1), so a malformed upload gives wrong colours,
//! never a fault.

use crate::elements::Elements;
use crate::ray::{HitRecord, Ray};
use crate::ray_cone::RayFootprint;
use crate::textures::{GpuTexture, TextureImages, UvFootprint, sample_footprint};
use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3, Vec4};
use num_traits::Float;

/// A texture or material index meaning "none".
pub const NONE: u32 = u32::MAX;

/// One placement of a mesh (160 bytes).
///
/// | offset | field             |
/// |--------|-------------------|
/// | 0      | `object_to_world` |
/// | 48     | `world_to_object` |
/// | 96     | `normal_to_world` |
/// | 144    | `mesh`            |
/// | 148    | `winding`         |
/// | 152    | `_pad`            |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuInstance {
    /// Object to world, three rows of four (row-major 3×4).
    pub object_to_world: [[f32; 4]; 3],
    /// World to object, the inverse of `object_to_world` (computed in `f64`): the software
    /// traversal moves rays into the mesh's space with it.
    pub world_to_object: [[f32; 4]; 3],
    /// Rows of the inverse transpose of the upper 3×3 of `object_to_world` (`w` = 0): transforms
    /// object-space normals to world space (normalise afterwards).
    pub normal_to_world: [[f32; 4]; 3],
    /// Index of the mesh.
    pub mesh: u32,
    /// `-1.0` when the transform mirrors (negative determinant), so that world-space winding is the
    /// reverse of object-space winding; `1.0` otherwise.
    pub winding: f32,
    /// Explicit padding.
    pub _pad: [u32; 2],
}

impl GpuInstance {
    /// All zero: what an out-of-range instance index reads as. (`Zeroable::zeroed` does not
    /// compile for SPIR-V.)
    pub const ZERO: Self = Self {
        object_to_world: [[0.0; 4]; 3],
        world_to_object: [[0.0; 4]; 3],
        normal_to_world: [[0.0; 4]; 3],
        mesh: 0,
        winding: 0.0,
        _pad: [0; 2],
    };

    /// Transforms an object-space point to world space.
    #[inline]
    pub fn transform_point(&self, p: Vec3) -> Vec3 {
        transform_point_3x4(&self.object_to_world, p)
    }

    /// Transforms an object-space normal to world space (not normalised).
    #[inline]
    pub fn transform_normal(&self, n: Vec3) -> Vec3 {
        let h = n.extend(0.0);
        Vec3::new(
            Vec4::from_array(self.normal_to_world[0]).dot(h),
            Vec4::from_array(self.normal_to_world[1]).dot(h),
            Vec4::from_array(self.normal_to_world[2]).dot(h),
        )
    }
}

/// [`GpuMesh::flags`] bit: some of the mesh's triangles have an alpha-masked material, whose
/// alpha ([`alpha_visible`]) decides whether a hit counts. Both traversals test it on these meshes
/// alone (`crate::bvh`; with ray queries, only their bottom levels are built non-opaque).
pub const MESH_ALPHA_TESTED: u32 = 1;

/// Point `p` transformed by the 3×4 matrix whose rows are `rows` (the bottom row `0 0 0 1`).
#[inline]
pub fn transform_point_3x4(rows: &[[f32; 4]; 3], p: Vec3) -> Vec3 {
    let h = p.extend(1.0);
    Vec3::new(
        Vec4::from_array(rows[0]).dot(h),
        Vec4::from_array(rows[1]).dot(h),
        Vec4::from_array(rows[2]).dot(h),
    )
}

/// A mesh: a run of triangles and a run of vertices (32 bytes).
///
/// | offset | field            |
/// |--------|------------------|
/// | 0      | `first_triangle` |
/// | 4      | `triangle_count` |
/// | 8      | `first_vertex`   |
/// | 12     | `vertex_count`   |
/// | 16     | `has_uvs`        |
/// | 20     | `bvh_root`       |
/// | 24     | `flags`          |
/// | 28     | `_pad`           |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMesh {
    /// Index of the mesh's first [`GpuTriangle`].
    pub first_triangle: u32,
    /// Number of triangles.
    pub triangle_count: u32,
    /// Index of the mesh's first [`GpuVertex`]; triangle indices are relative to it.
    pub first_vertex: u32,
    /// Number of vertices.
    pub vertex_count: u32,
    /// 1 when the vertices carry UVs; 0 when the mesh has none (UVs then read as zero).
    pub has_uvs: u32,
    /// Index of the root node of the mesh's bottom-level BVH in the node buffer; its leaves
    /// hold triangle indices relative to `first_triangle`.
    pub bvh_root: u32,
    /// [`MESH_ALPHA_TESTED`] or 0.
    pub flags: u32,
    /// Explicit padding.
    pub _pad: u32,
}

impl GpuMesh {
    /// A mesh without triangles or vertices: what an out-of-range mesh index reads as.
    pub const EMPTY: Self = Self {
        first_triangle: 0,
        triangle_count: 0,
        first_vertex: 0,
        vertex_count: 0,
        has_uvs: 0,
        bvh_root: u32::MAX,
        flags: 0,
        _pad: 0,
    };
}

/// One vertex in object space (32 bytes).
///
/// | offset | field      |
/// |--------|------------|
/// | 0      | `position` |
/// | 12     | `u`        |
/// | 16     | `normal`   |
/// | 28     | `v`        |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuVertex {
    /// Position.
    pub position: [f32; 3],
    /// First UV set, u.
    pub u: f32,
    /// Unit normal.
    pub normal: [f32; 3],
    /// First UV set, v.
    pub v: f32,
}

impl GpuVertex {
    /// All zero: what an out-of-range vertex index reads as.
    pub const ZERO: Self = Self {
        position: [0.0; 3],
        u: 0.0,
        normal: [0.0; 3],
        v: 0.0,
    };
}

/// One triangle: its vertices relative to the mesh's first vertex, and its material (16 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// Vertex indices, counter-clockwise seen from the front.
    pub indices: [u32; 3],
    /// Index of the material.
    pub material: u32,
}

/// A material (64 bytes). Texture indices index the texture table, [`NONE`] for none.
///
/// | offset | field                |
/// |--------|----------------------|
/// | 0      | `base_color`         |
/// | 16     | `emissive`           |
/// | 28     | `base_color_texture` |
/// | 32     | `emissive_texture`   |
/// | 36     | `metallic`           |
/// | 40     | `roughness`          |
/// | 44     | `double_sided`       |
/// | 48     | `alpha_cutoff`       |
/// | 52     | `_pad`               |
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear base colour and alpha.
    pub base_color: [f32; 4],
    /// Emitted radiance, W/(sr·m²): emissive factor × strength.
    pub emissive: [f32; 3],
    /// Base colour texture (sRGB), multiplies `base_color`.
    pub base_color_texture: u32,
    /// Emissive texture (sRGB), multiplies `emissive`.
    pub emissive_texture: u32,
    /// Metalness.
    pub metallic: f32,
    /// Perceptual roughness.
    pub roughness: f32,
    /// 1 when the back face is lit like the front.
    pub double_sided: u32,
    /// glTF's `alphaCutoff` of an alpha-masked material: a point whose base colour alpha
    /// (factor × texture, level 0) is below it is not there ([`alpha_visible`], which tracing
    /// calls on the meshes flagged [`MESH_ALPHA_TESTED`]). 0 for an opaque material.
    pub alpha_cutoff: f32,
    /// Explicit padding.
    pub _pad: [u32; 3],
}

impl Default for GpuMaterial {
    /// White, not emissive, untextured, rough dielectric, single-sided.
    fn default() -> Self {
        Self {
            base_color: [1.0; 4],
            emissive: [0.0; 3],
            base_color_texture: NONE,
            emissive_texture: NONE,
            metallic: 0.0,
            roughness: 1.0,
            double_sided: 0,
            alpha_cutoff: 0.0,
            _pad: [0; 3],
        }
    }
}

/// The surface at a hit, in world space.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Surface {
    /// Position interpolated from the world-space vertices.
    pub position: Vec3,
    /// Unit normal of the triangle's front (counter-clockwise) face, from the world-space cross
    /// product (corrected for mirroring transforms); zero for a degenerate triangle.
    pub geometric_normal: Vec3,
    /// Unit interpolated vertex normal; the geometric normal when it vanishes.
    pub shading_normal: Vec3,
    /// Interpolated first UV set (zero without UVs).
    pub uv: Vec2,
    /// The triangle's material index.
    pub material: u32,
    /// World-space area of the triangle.
    pub area: f32,
    /// Area of the triangle in texture coordinates (UV units²; 0 without UVs): with `area`, the
    /// texture's density on the surface ([`crate::ray_cone`]).
    pub uv_area: f32,
    /// World-space gradients of the texture coordinates u and v along the triangle's plane: the
    /// UV change of a small step `d` on the surface is `(du · d, dv · d)` (zero without UVs or
    /// for a degenerate triangle). Pixel footprints map through them ([`crate::ray_cone`]).
    pub uv_gradients: [Vec3; 2],
    /// The triangle's size: its largest edge coordinate, in world space (see
    /// [`crate::ray::offset_ray_origin`]).
    pub size: f32,
}

/// The vertex `index` of `mesh`, or a zero vertex when out of range.
#[inline]
fn vertex(vertices: impl Elements<Item = GpuVertex>, mesh: &GpuMesh, index: u32) -> GpuVertex {
    let i = mesh.first_vertex as usize + index as usize;
    if index < mesh.vertex_count && i < vertices.len() {
        vertices.get(i)
    } else {
        GpuVertex::ZERO
    }
}

/// Instance `instance`, its mesh, the mesh's triangle `primitive` and that triangle's three vertices;
/// zero or empty parts when out of range.
#[inline]
fn instance_triangle(
    instances: &[GpuInstance],
    meshes: &[GpuMesh],
    vertices: impl Elements<Item = GpuVertex>,
    triangles: impl Elements<Item = GpuTriangle>,
    instance: u32,
    primitive: u32,
) -> (GpuInstance, GpuMesh, GpuTriangle, [GpuVertex; 3]) {
    let inst = if (instance as usize) < instances.len() {
        instances[instance as usize]
    } else {
        GpuInstance::ZERO
    };
    let mesh = if (inst.mesh as usize) < meshes.len() {
        meshes[inst.mesh as usize]
    } else {
        GpuMesh::EMPTY
    };
    let t = mesh.first_triangle as usize + primitive as usize;
    let tri = if primitive < mesh.triangle_count && t < triangles.len() {
        triangles.get(t)
    } else {
        GpuTriangle {
            indices: [0; 3],
            material: NONE,
        }
    };
    let a = vertex(vertices, &mesh, tri.indices[0]);
    let b = vertex(vertices, &mesh, tri.indices[1]);
    let c = vertex(vertices, &mesh, tri.indices[2]);
    (inst, mesh, tri, [a, b, c])
}

/// The object-space position of triangle `primitive` of `instance` at `barycentrics` (as for
/// [`fetch_surface`]): what the instance's previous transform moves to the point's previous
/// world position ([`crate::gbuffer`]'s motion vectors).
pub fn object_position(
    instances: &[GpuInstance],
    meshes: &[GpuMesh],
    vertices: impl Elements<Item = GpuVertex>,
    triangles: impl Elements<Item = GpuTriangle>,
    instance: u32,
    primitive: u32,
    barycentrics: Vec2,
) -> Vec3 {
    let (_, _, _, [a, b, c]) =
        instance_triangle(instances, meshes, vertices, triangles, instance, primitive);
    let pa = Vec3::from_array(a.position);
    let (e1, e2) = (
        Vec3::from_array(b.position) - pa,
        Vec3::from_array(c.position) - pa,
    );
    pa + e1 * barycentrics.x + e2 * barycentrics.y
}

/// The surface of triangle `primitive` of `instance` at `barycentrics` (weights of the second and
/// third vertex, as in [`crate::ray::HitRecord`]).
pub fn fetch_surface(
    instances: &[GpuInstance],
    meshes: &[GpuMesh],
    vertices: impl Elements<Item = GpuVertex>,
    triangles: impl Elements<Item = GpuTriangle>,
    instance: u32,
    primitive: u32,
    barycentrics: Vec2,
) -> Surface {
    let (inst, mesh, tri, [a, b, c]) =
        instance_triangle(instances, meshes, vertices, triangles, instance, primitive);
    let (w1, w2) = (barycentrics.x, barycentrics.y);
    let w0 = 1.0 - w1 - w2;

    let pa = inst.transform_point(Vec3::from_array(a.position));
    let pb = inst.transform_point(Vec3::from_array(b.position));
    let pc = inst.transform_point(Vec3::from_array(c.position));
    let (e1, e2) = (pb - pa, pc - pa);
    let cross = e1.cross(e2);
    let geometric_normal = (cross * inst.winding).normalize_or_zero();

    let n = Vec3::from_array(a.normal) * w0
        + Vec3::from_array(b.normal) * w1
        + Vec3::from_array(c.normal) * w2;
    let shading_normal = inst.transform_normal(n).normalize_or(geometric_normal);
    let (uv, uv_area, uv_gradients) = if mesh.has_uvs != 0 {
        let (ta, tb, tc) = (
            Vec2::new(a.u, a.v),
            Vec2::new(b.u, b.v),
            Vec2::new(c.u, c.v),
        );
        let (d1, d2) = (tb - ta, tc - ta);
        // The dual basis of the edges in the triangle's plane: b1 · e1 = 1, b1 · e2 = 0 and the
        // reverse for b2, so a step d = s·e1 + t·e2 has s = b1 · d and t = b2 · d.
        let length2 = cross.length_squared();
        let (b1, b2) = if length2 > 0.0 && length2.is_finite() {
            (e2.cross(cross) / length2, cross.cross(e1) / length2)
        } else {
            (Vec3::ZERO, Vec3::ZERO)
        };
        (
            ta * w0 + tb * w1 + tc * w2,
            0.5 * Float::abs(d1.perp_dot(d2)),
            [b1 * d1.x + b2 * d2.x, b1 * d1.y + b2 * d2.y],
        )
    } else {
        (Vec2::ZERO, 0.0, [Vec3::ZERO; 2])
    };
    Surface {
        // Relative to a vertex: rounding then depends on the triangle's size, not on how far from
        // the origin it lies.
        position: pa + e1 * w1 + e2 * w2,
        geometric_normal,
        shading_normal,
        uv,
        material: tri.material,
        area: 0.5 * cross.length(),
        uv_area,
        uv_gradients,
        size: e1.abs().max(e2.abs()).max((pc - pb).abs()).max_element(),
    }
}

/// The shading data's buffers that every pass shading a hit reads (the texture images stay
/// beside it: a composite holding the kernels' bindless array fails SPIR-V validation unless
/// every function that sees it is inlined). The arrays that scale with the triangle count are
/// read through [`Elements`]: slices on the CPU, split bindings in the kernels.
#[derive(Clone, Copy)]
pub struct SceneSurfaces<'a, V = &'a [GpuVertex], T = &'a [GpuTriangle]> {
    /// The instances; a hit's instance indexes them.
    pub instances: &'a [GpuInstance],
    /// The meshes.
    pub meshes: &'a [GpuMesh],
    /// Every mesh's vertices.
    pub vertices: V,
    /// Every mesh's triangles.
    pub triangles: T,
    /// The materials.
    pub materials: &'a [GpuMaterial],
    /// The texture table.
    pub textures: &'a [GpuTexture],
}

impl SceneSurfaces<'static> {
    /// No instances, meshes, vertices, triangles, materials or textures.
    pub const EMPTY: Self = Self {
        instances: &[],
        meshes: &[],
        vertices: &[],
        triangles: &[],
        materials: &[],
        textures: &[],
    };
}

impl<V: Elements<Item = GpuVertex>, T: Elements<Item = GpuTriangle>> SceneSurfaces<'_, V, T> {
    /// Triangle `primitive` of `instance` at `barycentrics` ([`fetch_surface`]).
    #[inline]
    pub fn surface(&self, instance: u32, primitive: u32, barycentrics: Vec2) -> Surface {
        fetch_surface(
            self.instances,
            self.meshes,
            self.vertices,
            self.triangles,
            instance,
            primitive,
            barycentrics,
        )
    }

    /// Material `material` at `uv`, its textures filtered over `footprint`
    /// ([`sample_material`]).
    #[inline]
    pub fn material<I: TextureImages + ?Sized>(
        &self,
        images: &I,
        material: u32,
        uv: Vec2,
        footprint: UvFootprint,
    ) -> MaterialSample {
        sample_material(
            self.materials,
            self.textures,
            images,
            material,
            uv,
            footprint,
        )
    }
}

/// Whether the surface of triangle `primitive` of `instance` exists at `barycentrics`: false only
/// where its material is alpha-masked and the base colour's alpha (factor × texture at level 0,
/// the exact coverage: no mip level erodes it) is below the cutoff. Meant for the triangles of
/// meshes flagged [`MESH_ALPHA_TESTED`]: both traversals call it on their hits.
pub fn alpha_visible<V, T, I>(
    surfaces: SceneSurfaces<'_, V, T>,
    images: &I,
    instance: u32,
    primitive: u32,
    barycentrics: Vec2,
) -> bool
where
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
{
    let s = surfaces.surface(instance, primitive, barycentrics);
    let materials = surfaces.materials;
    let cutoff = if (s.material as usize) < materials.len() {
        materials[s.material as usize].alpha_cutoff
    } else {
        0.0
    };
    // Opaque materials (and a NaN cutoff) skip the texture read.
    if cutoff.is_nan() || cutoff <= 0.0 {
        return true;
    }
    let m = surfaces.material(images, s.material, s.uv, UvFootprint::POINT);
    m.base_color.w >= cutoff
}

/// What a material looks like at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaterialSample {
    /// Linear base colour × texture, and alpha.
    pub base_color: Vec4,
    /// Emitted radiance × texture, W/(sr·m²).
    pub emissive: Vec3,
}

/// The surface `hit` (of `ray`) landed on and its material there, its textures filtered over the
/// ray's `footprint` there: what every pass that shades a hit needs.
#[inline]
pub fn hit_surface<V, T, I>(
    surfaces: SceneSurfaces<'_, V, T>,
    images: &I,
    ray: &Ray,
    footprint: RayFootprint,
    hit: &HitRecord,
) -> (Surface, MaterialSample)
where
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
{
    let surface = surfaces.surface(
        hit.instance,
        hit.primitive,
        Vec2::from_array(hit.barycentrics),
    );
    let material = surface_material(surfaces, images, ray, footprint, hit, &surface);
    (surface, material)
}

/// The material of `surface`, which `hit` (of `ray`) landed on ([`SceneSurfaces::surface`]), its
/// textures filtered over the ray's `footprint` there: [`hit_surface`] for a pass that has
/// fetched the surface already.
#[inline]
pub fn surface_material<V, T, I>(
    surfaces: SceneSurfaces<'_, V, T>,
    images: &I,
    ray: &Ray,
    footprint: RayFootprint,
    hit: &HitRecord,
    surface: &Surface,
) -> MaterialSample
where
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
{
    let uv_footprint = footprint.on_surface(
        Vec3::from_array(ray.direction),
        hit.t,
        surface.geometric_normal,
        surface.area,
        surface.uv_area,
        surface.uv_gradients,
    );
    surfaces.material(images, surface.material, surface.uv, uv_footprint)
}

/// Material `material` at texture coordinate `uv`, its textures filtered over `footprint`
/// ([`sample_footprint`]); the default material when out of range.
pub fn sample_material<I: TextureImages + ?Sized>(
    materials: &[GpuMaterial],
    textures: &[GpuTexture],
    images: &I,
    material: u32,
    uv: Vec2,
    footprint: UvFootprint,
) -> MaterialSample {
    let m = if (material as usize) < materials.len() {
        materials[material as usize]
    } else {
        GpuMaterial::default()
    };
    let base = Vec4::from_array(m.base_color)
        * sample_texture_index(textures, images, m.base_color_texture, uv, footprint);
    let emissive = Vec3::from_array(m.emissive)
        * sample_texture_index(textures, images, m.emissive_texture, uv, footprint).truncate();
    MaterialSample {
        base_color: base,
        emissive,
    }
}

/// Texture `index` of the table at `uv` filtered over `footprint`; 1 (the factor alone) for
/// [`NONE`] or out of range.
#[inline]
fn sample_texture_index<I: TextureImages + ?Sized>(
    textures: &[GpuTexture],
    images: &I,
    index: u32,
    uv: Vec2,
    footprint: UvFootprint,
) -> Vec4 {
    if (index as usize) < textures.len() {
        sample_footprint(images, &textures[index as usize], index, uv, footprint)
    } else {
        Vec4::ONE
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::textures::WRAP_CLAMP_TO_EDGE;
    use crate::textures::tests::two_by_two;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layouts() {
        assert_eq!(size_of::<GpuInstance>(), 160);
        assert_eq!(offset_of!(GpuInstance, object_to_world), 0);
        assert_eq!(offset_of!(GpuInstance, world_to_object), 48);
        assert_eq!(offset_of!(GpuInstance, normal_to_world), 96);
        assert_eq!(offset_of!(GpuInstance, mesh), 144);
        assert_eq!(offset_of!(GpuInstance, winding), 148);
        assert_eq!(offset_of!(GpuInstance, _pad), 152);

        assert_eq!(size_of::<GpuMesh>(), 32);
        assert_eq!(offset_of!(GpuMesh, first_triangle), 0);
        assert_eq!(offset_of!(GpuMesh, triangle_count), 4);
        assert_eq!(offset_of!(GpuMesh, first_vertex), 8);
        assert_eq!(offset_of!(GpuMesh, vertex_count), 12);
        assert_eq!(offset_of!(GpuMesh, has_uvs), 16);
        assert_eq!(offset_of!(GpuMesh, bvh_root), 20);
        assert_eq!(offset_of!(GpuMesh, flags), 24);
        assert_eq!(offset_of!(GpuMesh, _pad), 28);

        assert_eq!(size_of::<GpuVertex>(), 32);
        assert_eq!(offset_of!(GpuVertex, position), 0);
        assert_eq!(offset_of!(GpuVertex, u), 12);
        assert_eq!(offset_of!(GpuVertex, normal), 16);
        assert_eq!(offset_of!(GpuVertex, v), 28);

        assert_eq!(size_of::<GpuTriangle>(), 16);
        assert_eq!(offset_of!(GpuTriangle, indices), 0);
        assert_eq!(offset_of!(GpuTriangle, material), 12);

        assert_eq!(size_of::<GpuMaterial>(), 64);
        assert_eq!(offset_of!(GpuMaterial, base_color), 0);
        assert_eq!(offset_of!(GpuMaterial, emissive), 16);
        assert_eq!(offset_of!(GpuMaterial, base_color_texture), 28);
        assert_eq!(offset_of!(GpuMaterial, emissive_texture), 32);
        assert_eq!(offset_of!(GpuMaterial, metallic), 36);
        assert_eq!(offset_of!(GpuMaterial, roughness), 40);
        assert_eq!(offset_of!(GpuMaterial, double_sided), 44);
        assert_eq!(offset_of!(GpuMaterial, alpha_cutoff), 48);
        assert_eq!(offset_of!(GpuMaterial, _pad), 52);
    }

    #[test]
    fn bad_input_is_defined() {
        let m = sample_material(&[], &[], &[][..], 3, Vec2::ZERO, UvFootprint::POINT);
        assert_eq!(m.base_color, Vec4::ONE);
        assert_eq!(m.emissive, Vec3::ZERO);
        let s = fetch_surface(&[], &[], &[], &[], 0, 0, Vec2::splat(0.3));
        assert_eq!(s.material, NONE);
        assert!(s.position.is_finite() && s.shading_normal.is_finite());
    }

    #[test]
    fn alpha_masks_cut_where_alpha_is_below_the_cutoff() {
        // One triangle with UVs = its xy, a 2 × 2 texture whose right column has alpha 0.
        let v = |p: [f32; 2]| GpuVertex {
            position: [p[0], p[1], 0.0],
            u: p[0],
            normal: [0.0, 0.0, 1.0],
            v: p[1],
        };
        let vertices = [v([0.0, 0.0]), v([1.0, 0.0]), v([0.0, 1.0])];
        let triangles = [GpuTriangle {
            indices: [0, 1, 2],
            material: 0,
        }];
        let meshes = [GpuMesh {
            triangle_count: 1,
            vertex_count: 3,
            has_uvs: 1,
            flags: MESH_ALPHA_TESTED,
            ..GpuMesh::EMPTY
        }];
        let instances = [GpuInstance {
            object_to_world: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            world_to_object: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            normal_to_world: [
                [1.0, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0, 0.0],
            ],
            mesh: 0,
            winding: 1.0,
            _pad: [0; 2],
        }];
        let (mut texture, texels) = two_by_two(WRAP_CLAMP_TO_EDGE, 0);
        texture.offset = 1;
        let textures = [texture];
        // Texels: black, white / red, green with alpha 0 (see `two_by_two`): the bottom right
        // texel (u > 0.5, v > 0.5) is transparent; rows run along v.
        let masked = GpuMaterial {
            base_color_texture: 0,
            alpha_cutoff: 0.5,
            ..GpuMaterial::default()
        };
        let visible = |material: GpuMaterial, uv: Vec2| {
            // Barycentrics of (u, v) on this triangle: (u, v) themselves.
            alpha_visible(
                SceneSurfaces {
                    instances: &instances,
                    meshes: &meshes,
                    vertices: &vertices,
                    triangles: &triangles,
                    materials: &[material],
                    textures: &textures,
                },
                &texels[..],
                0,
                0,
                uv,
            )
        };
        assert!(visible(masked, Vec2::new(0.1, 0.1)));
        assert!(visible(masked, Vec2::new(0.1, 0.8)));
        // Texel (1, 1) alone has alpha 0; its centre (0.75, 0.75) lies outside the triangle, but
        // barycentrics are what count here.
        assert!(!visible(masked, Vec2::new(0.75, 0.75)));
        // The same point with an opaque material, or a cutoff of 0: visible.
        assert!(visible(GpuMaterial::default(), Vec2::new(0.75, 0.75)));
        let zero = GpuMaterial {
            alpha_cutoff: 0.0,
            ..masked
        };
        assert!(visible(zero, Vec2::new(0.75, 0.75)));
        // The factor's alpha multiplies the texture's.
        let faint = GpuMaterial {
            base_color: [1.0, 1.0, 1.0, 0.4],
            ..masked
        };
        assert!(!visible(faint, Vec2::new(0.1, 0.1)));
    }

    #[test]
    fn surface_of_a_mirrored_scaled_instance() {
        // One triangle in the z = 0 plane facing +z, placed with x mirrored, scaled and moved.
        let v = |p: [f32; 3], uv: [f32; 2]| GpuVertex {
            position: p,
            u: uv[0],
            normal: [0.0, 0.0, 1.0],
            v: uv[1],
        };
        let vertices = [
            v([0.0, 0.0, 0.0], [0.0, 0.0]),
            v([1.0, 0.0, 0.0], [1.0, 0.0]),
            v([0.0, 1.0, 0.0], [0.0, 1.0]),
        ];
        let triangles = [GpuTriangle {
            indices: [0, 1, 2],
            material: 7,
        }];
        let meshes = [GpuMesh {
            first_triangle: 0,
            triangle_count: 1,
            first_vertex: 0,
            vertex_count: 3,
            has_uvs: 1,
            bvh_root: 0,
            flags: 0,
            _pad: 0,
        }];
        let instances = [GpuInstance {
            object_to_world: [
                [-2.0, 0.0, 0.0, 5.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 3.0, 1.0],
            ],
            world_to_object: [
                [-0.5, 0.0, 0.0, 2.5],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0 / 3.0, -1.0 / 3.0],
            ],
            normal_to_world: [
                [-0.5, 0.0, 0.0, 0.0],
                [0.0, 1.0, 0.0, 0.0],
                [0.0, 0.0, 1.0 / 3.0, 0.0],
            ],
            mesh: 0,
            winding: -1.0,
            _pad: [0; 2],
        }];
        let s = fetch_surface(
            &instances,
            &meshes,
            &vertices,
            &triangles,
            0,
            0,
            Vec2::new(0.25, 0.5),
        );
        assert_eq!(s.material, 7);
        assert!((s.position - Vec3::new(4.5, 0.5, 1.0)).length() < 1e-6);
        assert!((s.uv - Vec2::new(0.25, 0.5)).length() < 1e-6);
        // The front face still faces +z after mirroring x.
        assert!(
            (s.geometric_normal - Vec3::Z).length() < 1e-6,
            "{}",
            s.geometric_normal
        );
        assert!((s.shading_normal - Vec3::Z).length() < 1e-6);
        // u = x_object = (5 - x) / 2 and v = y in world space: their gradients.
        assert!((s.uv_gradients[0] - Vec3::new(-0.5, 0.0, 0.0)).length() < 1e-6);
        assert!((s.uv_gradients[1] - Vec3::Y).length() < 1e-6);
        // Out-of-range primitive: material NONE, no fault.
        let bad = fetch_surface(&instances, &meshes, &vertices, &triangles, 0, 1, Vec2::ZERO);
        assert_eq!(bad.material, NONE);
    }
}
