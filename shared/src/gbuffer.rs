//! The G-buffer: what one primary ray per pixel sees, as the GI passes read it. The same function,
//! [`gbuffer_texel`], runs in the `gbuffer` kernel and on the CPU.
//!
//! # Images
//!
//! * **depth**, `R32_SFLOAT`: linear depth, the distance along the camera's forward axis;
//!   [`SKY_DEPTH`] (0) for sky.
//! * **geometric normal**, `R16G16B16A16_SFLOAT`: world-space unit normal of the triangle (from the
//!   world-space cross product), turned to face the camera; `w` = 1. Sky: all zero.
//! * **shading normal**, `R16G16B16A16_SFLOAT`: world-space unit interpolated vertex normal, turned
//!   with the geometric normal when the ray hit a back face; `w` = 1. Sky: all zero.
//! * **albedo**, `R8G8B8A8_UNORM`: linear base colour × texture, and alpha. Sky: zero.
//! * **emissive**, `R16G16B16A16_SFLOAT`: emitted radiance × texture, W/(sr·m²); `w` = 0.
//!   Sky: zero.
//! * **motion**, `R32G32B32A32_SFLOAT`: `xy` = this frame's screen position of the surface point
//!   minus its position under the previous camera, in pixels; `z` = its linear depth under the
//!   previous camera; `w` = 1 when valid. All zero for sky and for points not in front of the
//!   previous camera.
//! * **ids**, `R32G32B32A32_UINT`: instance, primitive (triangle within the instance's mesh),
//!   material, front face (1 when the ray hit the counter-clockwise side, else 0). Sky:
//!   [`SKY_ID`] three times, then 0.
//!
//! The two-channel formats (`R32G32_SFLOAT`, `R32G32_UINT`) would need the SPIR-V capability
//! `StorageImageExtendedFormats`; four-channel ones need nothing beyond `Shader`, and the spare
//! channels carry what reprojection wants next (previous depth, validity, material, facing).
//!
//! Motion vectors project the hit point with this frame's and the previous frame's
//! view-projection; equal matrices (a static camera) give exactly zero. Neither matrix holds the
//! jitter: motion vectors carry no jitter.

use glam::{UVec2, UVec4, Vec3, Vec4};

use crate::camera::{CameraParams, to_clip, uv_of_clip};
use crate::ray::{HitRecord, Ray};
use crate::ray_cone::RayCone;
use crate::scene_data::{
    GpuInstance, GpuMaterial, GpuMesh, GpuTexture, GpuTriangle, GpuVertex, hit_surface,
};
use crate::textures::TextureImages;

/// Workgroup of the `gbuffer` kernel: `GBUFFER_TILE × GBUFFER_TILE` pixels.
pub const GBUFFER_TILE: u32 = 8;

/// Depth of a pixel that sees no surface.
pub const SKY_DEPTH: f32 = 0.0;

/// Id of a pixel that sees no surface (instance, primitive and material).
pub const SKY_ID: u32 = u32::MAX;

/// One pixel of every G-buffer image, as the kernel writes it (before format conversion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GBufferTexel {
    /// Linear depth; [`SKY_DEPTH`] for sky.
    pub depth: f32,
    /// Geometric normal facing the camera, `w` = 1.
    pub geometric_normal: Vec4,
    /// Shading normal, `w` = 1.
    pub shading_normal: Vec4,
    /// Linear albedo and alpha.
    pub albedo: Vec4,
    /// Emitted radiance, `w` = 0.
    pub emissive: Vec4,
    /// Motion in pixels, previous depth, validity.
    pub motion: Vec4,
    /// Instance, primitive, material, front face.
    pub ids: UVec4,
}

impl GBufferTexel {
    /// A pixel that sees no surface.
    pub const SKY: Self = Self {
        depth: SKY_DEPTH,
        geometric_normal: Vec4::ZERO,
        shading_normal: Vec4::ZERO,
        albedo: Vec4::ZERO,
        emissive: Vec4::ZERO,
        motion: Vec4::ZERO,
        ids: UVec4::new(SKY_ID, SKY_ID, SKY_ID, 0),
    };

    /// Whether the pixel sees a surface.
    #[inline]
    pub fn is_surface(&self) -> bool {
        self.ids.x != SKY_ID
    }
}

/// Motion of world position `p` between the previous frame and this one, as stored in the motion
/// image: `(this − previous screen position in pixels, previous linear depth, 1)`, or zero when
/// `p` is not in front of the previous camera.
#[inline]
pub fn motion_vector(camera: &CameraParams, p: Vec3) -> Vec4 {
    let previous = to_clip(&camera.previous_view_proj, p);
    // False for a NaN depth too.
    let in_front = previous.w > 0.0;
    if !in_front {
        return Vec4::ZERO;
    }
    // Exactly zero for a static camera, whatever a compiler makes of the two projections.
    if rows_equal(&camera.view_proj, &camera.previous_view_proj) {
        return Vec4::new(0.0, 0.0, previous.w, 1.0);
    }
    let current = to_clip(&camera.view_proj, p);
    let size = camera.image_size_f32();
    let pixels = (uv_of_clip(current) - uv_of_clip(previous)) * size;
    Vec4::new(pixels.x, pixels.y, previous.w, 1.0)
}

/// Whether two matrices are equal, row by row.
#[inline]
fn rows_equal(a: &[[f32; 4]; 4], b: &[[f32; 4]; 4]) -> bool {
    Vec4::from_array(a[0]) == Vec4::from_array(b[0])
        && Vec4::from_array(a[1]) == Vec4::from_array(b[1])
        && Vec4::from_array(a[2]) == Vec4::from_array(b[2])
        && Vec4::from_array(a[3]) == Vec4::from_array(b[3])
}

/// The G-buffer pixel of `ray` (a primary ray of `camera`) with closest hit `hit`, reading the
/// scene's shading data (see [`crate::scene_data`]).
#[allow(
    clippy::too_many_arguments,
    reason = "rust-gpu cannot keep storage-buffer slices in a struct: one argument per buffer"
)]
pub fn gbuffer_texel<I: TextureImages + ?Sized>(
    camera: &CameraParams,
    ray: &Ray,
    hit: &HitRecord,
    instances: &[GpuInstance],
    meshes: &[GpuMesh],
    vertices: &[GpuVertex],
    triangles: &[GpuTriangle],
    materials: &[GpuMaterial],
    textures: &[GpuTexture],
    images: &I,
) -> GBufferTexel {
    if !hit.is_hit() {
        return GBufferTexel::SKY;
    }
    let cone = RayCone::pixel(camera.tan_half_fov_y, camera.image_size[1]);
    let (surface, material) = hit_surface(
        instances, meshes, vertices, triangles, materials, textures, images, ray, cone, hit,
    );
    let direction = Vec3::from_array(ray.direction);
    // The point on the ray, not the interpolated one: depth and motion then agree with the
    // pixel the ray went through, whatever the rounding of the vertex data.
    let position = Vec3::from_array(ray.origin) + direction * hit.t;
    let depth = hit.t * direction.dot(camera.forward());
    let mut geometric = surface.geometric_normal;
    let mut shading = surface.shading_normal;
    if geometric.dot(direction) > 0.0 {
        geometric = -geometric;
        shading = -shading;
    }
    if geometric == Vec3::ZERO {
        // A degenerate triangle: face the camera.
        geometric = -direction.normalize_or_zero();
    }
    GBufferTexel {
        depth,
        geometric_normal: geometric.extend(1.0),
        shading_normal: shading.extend(1.0),
        albedo: material.base_color,
        emissive: material.emissive.extend(0.0),
        motion: motion_vector(camera, position),
        ids: UVec4::new(
            hit.instance,
            hit.primitive,
            surface.material,
            hit.front_face,
        ),
    }
}

/// Whether `pixel` lies in `camera`'s image.
#[inline]
pub fn in_image(camera: &CameraParams, pixel: UVec2) -> bool {
    pixel.x < camera.image_size[0] && pixel.y < camera.image_size[1]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{primary_ray, view_projection};
    use crate::scene_data::NONE;
    use glam::Vec2;

    /// The G-buffer pixel (16, 16) of `camera` for `hit` on a unit quad at z = -2 made of two
    /// triangles with a red, emissive material: facing +z (towards a camera at the origin looking
    /// down -z), or -z when `back`.
    fn texel_of(camera: &CameraParams, hit: &HitRecord, back: bool) -> GBufferTexel {
        let nz = if back { -1.0 } else { 1.0 };
        let v = |x: f32, y: f32| GpuVertex {
            position: [x, y, -2.0],
            u: 0.0,
            normal: [0.0, 0.0, nz],
            v: 0.0,
        };
        let vertices = [v(-1.0, -1.0), v(1.0, -1.0), v(1.0, 1.0), v(-1.0, 1.0)];
        let triangle = |a: u32, b: u32, c: u32| GpuTriangle {
            indices: if back { [a, c, b] } else { [a, b, c] },
            material: 0,
        };
        let triangles = [triangle(0, 1, 2), triangle(0, 2, 3)];
        let identity_rows = [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ];
        let instances = [GpuInstance {
            object_to_world: identity_rows,
            world_to_object: identity_rows,
            normal_to_world: identity_rows,
            mesh: 0,
            winding: 1.0,
            _pad: [0; 2],
        }];
        let meshes = [GpuMesh {
            first_triangle: 0,
            triangle_count: 2,
            first_vertex: 0,
            vertex_count: 4,
            has_uvs: 0,
            bvh_root: u32::MAX,
            flags: 0,
            _pad: 0,
        }];
        let materials = [GpuMaterial {
            base_color: [0.8, 0.1, 0.1, 1.0],
            emissive: [2.0, 1.0, 0.5],
            base_color_texture: NONE,
            emissive_texture: NONE,
            metallic: 0.0,
            roughness: 1.0,
            double_sided: 0,
            alpha_cutoff: 0.0,
            _pad: [0; 3],
        }];
        let ray = primary_ray(camera, UVec2::new(16, 16), Vec2::ZERO);
        gbuffer_texel(
            camera,
            &ray,
            hit,
            &instances,
            &meshes,
            &vertices,
            &triangles,
            &materials,
            &[],
            &[][..],
        )
    }

    fn camera() -> CameraParams {
        CameraParams::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 32, 32)
    }

    #[test]
    fn a_hit_fills_every_image() {
        let c = camera();
        // The centre ray of pixel (16, 16) hits z = -2 at t = 2.
        let hit = HitRecord {
            t: 2.0,
            instance: 0,
            primitive: 0,
            front_face: 1,
            barycentrics: [0.25, 0.25],
            _pad: [0; 2],
        };
        let t = texel_of(&c, &hit, false);
        assert!(t.is_surface());
        assert!((t.depth - 2.0).abs() < 1e-6);
        assert_eq!(t.geometric_normal, Vec4::new(0.0, 0.0, 1.0, 1.0));
        assert_eq!(t.shading_normal, Vec4::new(0.0, 0.0, 1.0, 1.0));
        assert_eq!(t.albedo, Vec4::new(0.8, 0.1, 0.1, 1.0));
        assert_eq!(t.emissive, Vec4::new(2.0, 1.0, 0.5, 0.0));
        assert_eq!(t.motion, Vec4::new(0.0, 0.0, t.motion.z, 1.0));
        assert!((t.motion.z - 2.0).abs() < 1e-6);
        assert_eq!(t.ids, UVec4::new(0, 0, 0, 1));
    }

    #[test]
    fn back_faces_turn_both_normals_to_the_camera() {
        let c = camera();
        let hit = HitRecord {
            t: 2.0,
            instance: 0,
            primitive: 1,
            front_face: 0,
            barycentrics: [0.25, 0.25],
            _pad: [0; 2],
        };
        let t = texel_of(&c, &hit, true);
        assert!((t.geometric_normal - Vec4::new(0.0, 0.0, 1.0, 1.0)).length() < 1e-6);
        assert!((t.shading_normal - Vec4::new(0.0, 0.0, 1.0, 1.0)).length() < 1e-6);
        assert_eq!(t.ids.w, 0);
    }

    #[test]
    fn sky_and_motion() {
        let c = camera();
        let t = texel_of(&c, &HitRecord::miss(), false);
        assert_eq!(t, GBufferTexel::SKY);
        assert!(!t.is_surface());

        // The camera moved 0.5 to the right since the previous frame: a point now straight ahead
        // at depth 2 was right of the previous screen's centre, so it moved left.
        let mut previous = c;
        previous.position = [-0.5, 0.0, 0.0];
        previous.view_proj = view_projection(&previous);
        let moved = c.with_previous(&previous);
        let m = motion_vector(&moved, Vec3::new(0.0, 0.0, -2.0));
        // Previous screen x: ndc = 0.5 / (2 · tan 0.5) → pixels 16 · (1 + ndc).
        let expected = -16.0 * 0.5 / (2.0 * 0.5f32.tan());
        assert!((m.x - expected).abs() < 1e-4, "{m} vs {expected}");
        assert_eq!(m.y, 0.0);
        assert_eq!((m.z, m.w), (2.0, 1.0));
        // Behind the previous camera: invalid.
        assert_eq!(motion_vector(&moved, Vec3::new(0.0, 0.0, 1.0)), Vec4::ZERO);
        assert!(in_image(&c, UVec2::new(31, 31)) && !in_image(&c, UVec2::new(32, 0)));
    }
}
