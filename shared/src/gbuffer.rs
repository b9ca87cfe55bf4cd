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
//! Motion vectors project the hit point with this frame's view-projection and its previous world
//! position with the previous frame's. The previous world position is the point itself, unless
//! its instance moved: then the instance's previous object-to-world transform
//! ([`PreviousTransform`], one per instance, bound beside the images) carries the point's
//! object-space position (interpolated from the object-space vertices) to where it was. A static
//! camera and a static instance give exactly zero. Neither matrix holds the jitter: motion
//! vectors carry no jitter.
//!
//! The GI passes find a pixel's surface in the previous frame with [`previous_point`]: from the
//! motion image where the object moved, else by reprojecting the point with the previous camera.

use bytemuck::{Pod, Zeroable};
use glam::{Mat3, UVec2, UVec4, Vec2, Vec3, Vec4};

use crate::camera::{CameraParams, to_clip, uv_of_clip};
use crate::elements::Elements;
use crate::ray::{HitRecord, Ray};
use crate::ray_cone::RayFootprint;
use crate::scene_data::{GpuTriangle, GpuVertex, SceneSurfaces, hit_surface, object_position};
use crate::textures::TextureImages;

/// One instance's object-to-world transform in the previous frame, as the `gbuffer` kernel reads
/// it (set 0, binding 8; one per instance, indexed like the instances). An instance without an
/// entry, or whose entry has `moved` = 0, did not move: a scene without moving instances binds one
/// [`PreviousTransform::STATIC`] entry.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PreviousTransform {
    /// The first three rows of the previous object-to-world matrix.
    pub object_to_world: [[f32; 4]; 3],
    /// 1 when the instance's transform changed since the previous frame, else 0.
    pub moved: u32,
    /// Explicit padding.
    pub _pad: [u32; 3],
}

impl PreviousTransform {
    /// An instance that did not move.
    pub const STATIC: Self = Self {
        object_to_world: [[0.0; 4]; 3],
        moved: 0,
        _pad: [0; 3],
    };

    /// An instance that moved from `rows` (the first three rows of its previous object-to-world
    /// matrix).
    pub fn moved_from(rows: [[f32; 4]; 3]) -> Self {
        Self {
            object_to_world: rows,
            moved: 1,
            _pad: [0; 3],
        }
    }

    /// The world position of `object` under the previous transform.
    #[inline]
    pub fn transform_point(&self, object: Vec3) -> Vec3 {
        crate::scene_data::transform_point_3x4(&self.object_to_world, object)
    }
}

/// Largest distance, in pixels, between the motion image's previous position of a pixel and the
/// previous camera's projection of its surface point under which [`previous_point`] takes the
/// surface as static (the two differ by rounding only, the G-buffer's point being the ray's and
/// the GI passes' the one rebuilt from depth).
pub const STATIC_MOTION_PIXELS: f32 = 1.0 / 32.0;

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

/// Motion of the surface point at world position `p`, which was at `previous_p` in the previous
/// frame, as stored in the motion image: `(this − previous screen position in pixels, previous
/// linear depth, 1)`, or zero when `previous_p` is not in front of the previous camera.
#[inline]
pub fn motion_vector(camera: &CameraParams, p: Vec3, previous_p: Vec3) -> Vec4 {
    let previous = to_clip(&camera.previous_view_proj, previous_p);
    // False for a NaN depth too.
    let in_front = previous.w > 0.0;
    if !in_front {
        return Vec4::ZERO;
    }
    // Exactly zero for a static camera and point, whatever a compiler makes of the projections.
    if p == previous_p && rows_equal(&camera.view_proj, &camera.previous_view_proj) {
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

/// The world position that `camera`'s previous view-projection projects to the continuous pixel
/// position `pixel_position` (pixel centres at integer coordinates) at linear depth `depth`.
/// The view-projection has no depth row: its x, y and w rows, a 3 × 3 system, are inverted.
#[inline]
pub fn unproject_previous(camera: &CameraParams, pixel_position: Vec2, depth: f32) -> Vec3 {
    let m = &camera.previous_view_proj;
    let uv = (pixel_position + Vec2::splat(0.5)) / camera.image_size_f32();
    let ndc = uv * 2.0 - Vec2::ONE;
    let rows = Mat3::from_cols(
        Vec3::new(m[0][0], m[0][1], m[0][2]),
        Vec3::new(m[1][0], m[1][1], m[1][2]),
        Vec3::new(m[3][0], m[3][1], m[3][2]),
    )
    .transpose();
    let rhs = Vec3::new(
        ndc.x * depth - m[0][3],
        ndc.y * depth - m[1][3],
        depth - m[3][3],
    );
    rows.inverse() * rhs
}

/// Where a pixel's surface point was in the previous frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreviousPoint {
    /// Continuous pixel position in the previous image (pixel centres at integer coordinates);
    /// may lie off the image.
    pub pixel_position: Vec2,
    /// Previous world position.
    pub position: Vec3,
    /// Whether the point moved with its object (the motion image disagrees with the camera's
    /// reprojection).
    pub moved: bool,
    /// False when the point was behind the previous camera or is not finite: no history.
    pub valid: bool,
}

impl PreviousPoint {
    /// No previous point.
    pub const NONE: Self = Self {
        pixel_position: Vec2::ZERO,
        position: Vec3::ZERO,
        moved: false,
        valid: false,
    };
}

/// A pixel's G-buffer as reprojection reads it: linear depth, geometric normal and motion
/// texels (the images' own encodings).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ReprojectionTexel {
    /// Linear depth (0: sky).
    pub depth: f32,
    /// The geometric normal texel.
    pub geometric_normal: Vec4,
    /// The motion texel ([`previous_point`]).
    pub motion: Vec4,
}

/// Where the surface point `position` seen through `pixel` (G-buffer motion texel `motion`) was in
/// the previous frame ([`PreviousPoint::NONE`] when it was behind the previous camera or is not
/// finite).
///
/// Without `object_motion`, and wherever the motion image agrees with the previous camera's
/// projection of `position` within [`STATIC_MOTION_PIXELS`] (a static object), the point is
/// `position` projected with the previous camera: camera-only reprojection, bit for bit. Where
/// they disagree, the object moved: the previous pixel is `pixel + jitter − motion.xy` and the
/// previous world position is unprojected from it at the previous depth `motion.z`.
#[inline]
pub fn previous_point(
    camera: &CameraParams,
    pixel: UVec2,
    position: Vec3,
    motion: Vec4,
    object_motion: bool,
) -> PreviousPoint {
    let clip = to_clip(&camera.previous_view_proj, position);
    // False for NaN too.
    let camera_only = clip.w > 0.0 && clip.is_finite();
    let projected = uv_of_clip(clip) * camera.image_size_f32() - Vec2::splat(0.5);
    let static_point = PreviousPoint {
        pixel_position: projected,
        position,
        moved: false,
        valid: camera_only,
    };
    // Without a motion texel (an engine's G-buffer may leave it empty) the camera decides.
    let has_motion = motion.w > 0.0;
    if !object_motion || !has_motion {
        return static_point;
    }
    let from_motion =
        Vec2::new(pixel.x as f32, pixel.y as f32) + camera.jitter() - Vec2::new(motion.x, motion.y);
    if camera_only && (from_motion - projected).abs().max_element() <= STATIC_MOTION_PIXELS {
        return static_point;
    }
    let previous = unproject_previous(camera, from_motion, motion.z);
    PreviousPoint {
        pixel_position: from_motion,
        position: previous,
        moved: true,
        valid: previous.is_finite() && from_motion.is_finite(),
    }
}

/// The G-buffer pixel of `ray` (a primary ray of `camera`) with closest hit `hit`, reading the
/// scene's shading data (see [`crate::scene_data`]) and the instances' previous transforms
/// (`previous`, see [`PreviousTransform`]).
pub fn gbuffer_texel<I: TextureImages + ?Sized>(
    camera: &CameraParams,
    ray: &Ray,
    hit: &HitRecord,
    previous: &[PreviousTransform],
    surfaces: SceneSurfaces<'_, impl Elements<Item = GpuVertex>, impl Elements<Item = GpuTriangle>>,
    images: &I,
) -> GBufferTexel {
    if !hit.is_hit() {
        return GBufferTexel::SKY;
    }
    let (surface, material) = hit_surface(surfaces, images, ray, RayFootprint::pixel(camera), hit);
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
    let i = hit.instance as usize;
    let previous_position = if i < previous.len() && previous[i].moved != 0 {
        previous[i].transform_point(object_position(
            surfaces.instances,
            surfaces.meshes,
            surfaces.vertices,
            surfaces.triangles,
            hit.instance,
            hit.primitive,
            Vec2::from_array(hit.barycentrics),
        ))
    } else {
        position
    };
    GBufferTexel {
        depth,
        geometric_normal: geometric.extend(1.0),
        shading_normal: shading.extend(1.0),
        albedo: material.base_color,
        emissive: material.emissive.extend(0.0),
        motion: motion_vector(camera, position, previous_position),
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
    use crate::scene_data::{GpuInstance, GpuMaterial, GpuMesh};

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
            &[],
            SceneSurfaces {
                instances: &instances,
                meshes: &meshes,
                vertices: &vertices,
                triangles: &triangles,
                materials: &materials,
                textures: &[],
            },
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
        let m = motion_vector(&moved, Vec3::new(0.0, 0.0, -2.0), Vec3::new(0.0, 0.0, -2.0));
        // Previous screen x: ndc = 0.5 / (2 · tan 0.5) → pixels 16 · (1 + ndc).
        let expected = -16.0 * 0.5 / (2.0 * 0.5f32.tan());
        assert!((m.x - expected).abs() < 1e-4, "{m} vs {expected}");
        assert_eq!(m.y, 0.0);
        assert_eq!((m.z, m.w), (2.0, 1.0));
        // Behind the previous camera: invalid.
        let behind = Vec3::new(0.0, 0.0, 1.0);
        assert_eq!(motion_vector(&moved, behind, behind), Vec4::ZERO);
        assert!(in_image(&c, UVec2::new(31, 31)) && !in_image(&c, UVec2::new(32, 0)));
    }

    #[test]
    fn previous_points_follow_the_motion_image_where_an_object_moved() {
        let c = camera();
        let mut previous = c;
        previous.position = [0.3, -0.2, 0.5];
        previous.view_proj = view_projection(&previous);
        let moved = c.with_previous(&previous);
        // The point is at `now`; it was at `before` (its object moved).
        let (now, before) = (Vec3::new(0.1, 0.2, -2.0), Vec3::new(-0.2, 0.25, -2.3));
        let pixel = UVec2::new(17, 19);
        let m = motion_vector(&moved, now, before);
        let clip = to_clip(&moved.previous_view_proj, before);
        let expected = uv_of_clip(clip) * moved.image_size_f32() - Vec2::splat(0.5);
        // The motion of `now` as seen through `pixel`: shift the texel to that pixel.
        let seen = uv_of_clip(to_clip(&moved.view_proj, now)) * moved.image_size_f32();
        let shift = Vec2::new(pixel.x as f32 + 0.5, pixel.y as f32 + 0.5) - seen;
        let texel = Vec4::new(m.x + shift.x, m.y + shift.y, m.z, m.w);
        let p = previous_point(&moved, pixel, now, texel, true);
        assert!(p.valid && p.moved);
        assert!(
            (p.pixel_position - expected).length() < 1e-3,
            "{p:?} vs {expected}"
        );
        assert!((p.position - before).length() < 1e-4, "{p:?} vs {before}");
        // Camera-only: the point where it is now, projected with the previous camera.
        let q = previous_point(&moved, pixel, now, texel, false);
        assert!(q.valid && !q.moved);
        assert_eq!(q.position, now);
        // A static point: the motion agrees with the camera, and the camera-only answer stands.
        let s = motion_vector(&moved, now, now);
        let texel = Vec4::new(s.x + shift.x, s.y + shift.y, s.z, s.w);
        assert_eq!(
            previous_point(&moved, pixel, now, texel, true),
            previous_point(&moved, pixel, now, texel, false)
        );
        // Behind the previous camera: no history.
        assert!(!previous_point(&moved, pixel, Vec3::new(0.0, 0.0, 3.0), Vec4::ZERO, true).valid);
    }

    #[test]
    fn previous_transforms_move_hit_points() {
        let t = PreviousTransform::moved_from([
            [1.0, 0.0, 0.0, 0.5],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, -1.0],
        ]);
        assert_eq!(t.transform_point(Vec3::ONE), Vec3::new(1.5, 1.0, 0.0));
        assert_eq!(PreviousTransform::STATIC.moved, 0);
    }
}
