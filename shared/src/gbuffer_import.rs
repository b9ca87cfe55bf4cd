//! Importing an engine's G-buffer: the conventions an engine's images follow ([`Conventions`]),
//! what the `gbuffer_import` kernel reads of them ([`GBufferImportParams`]), and the per-pixel
//! conversion into our G-buffer ([`imported_texel`], the same on the CPU and the GPU).
//!
//! What an import produces, channel by channel (our channels: [`crate::gbuffer`]):
//!
//! * **depth**: linear depth decoded from the engine's depth ([`DepthEncoding`]); sky where the
//!   engine's depth is its clear value (or not a finite positive distance).
//! * **geometric normal**: rebuilt from depth, the cross product of the tangents from the pixel's
//!   world position to a neighbour's in x and in y, each towards the side whose next two pixels
//!   continue the pixel's plane best (1/z is linear across the screen on a plane: the side whose
//!   extrapolated 1/z misses least), so that an edge takes the surface's side; turned to face the
//!   camera. Where no neighbour is a surface, the
//!   shading normal stands in.
//! * **shading normal**: the engine's normal ([`NormalEncoding`]), normalised, turned to the
//!   geometric normal's side when it lies on the other.
//! * **albedo**, **emissive**: as read (emissive zero when the engine has none).
//! * **motion**: the engine's motion vectors converted to ours ([`MotionVectors`]), with the point's
//!   depth under the previous camera as the previous depth (exact for static points; for a point
//!   that moved in depth off by its depth change in one frame); without engine motion vectors,
//!   the camera's motion alone ([`motion_vector`] of a static point).
//! * **ids**: the import knows no instances, triangles or materials: [`IMPORTED_ID`] three times,
//!   then 1 (front face). The GI passes read the ids only to decide whether a pixel's emission
//!   counts (front face, or a double-sided material): an imported emission always counts, so an
//!   engine must write emission only where the camera should see it.

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, UVec4, Vec2, Vec3, Vec4};

use crate::camera::{CameraParams, primary_ray, to_clip};
use crate::gbuffer::{GBufferTexel, motion_vector};
use crate::math::abs;
use crate::octahedral::octahedral_decode;

/// Instance, primitive and material id of an imported surface pixel: not [`crate::gbuffer::SKY_ID`],
/// and no material of any scene (material lookups fail their bounds check).
pub const IMPORTED_ID: u32 = u32::MAX - 1;

/// Workgroup of the `gbuffer_import` kernel: `IMPORT_TILE × IMPORT_TILE` pixels.
pub const IMPORT_TILE: u32 = 8;

/// [`GBufferImportParams::normal_encoding`]: a world-space vector in `xyz`.
pub const NORMAL_WORLD: u32 = 0;
/// [`GBufferImportParams::normal_encoding`]: an octahedral-mapped direction in `xy`.
pub const NORMAL_OCTAHEDRAL: u32 = 1;

/// [`GBufferImportParams::flags`]: the engine gave motion vectors.
pub const FLAG_MOTION: u32 = 1;
/// [`GBufferImportParams::flags`]: the engine gave emission.
pub const FLAG_EMISSIVE: u32 = 2;
/// [`GBufferImportParams::flags`]: the normal image is UNORM: stored values are `0.5 + 0.5 · v`.
pub const FLAG_UNORM_NORMALS: u32 = 4;

/// How the engine's depth image encodes depth. `near` and `far` are the engine's projection's
/// planes, distances along the camera's forward axis (world units, like ours).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DepthEncoding {
    /// A standard Vulkan perspective depth: 0 at `near`, 1 at `far` (`f32::INFINITY` for an
    /// infinite far plane); sky is the clear value 1.
    Standard {
        /// Near plane distance, > 0.
        near: f32,
        /// Far plane distance, > `near`, or infinite.
        far: f32,
    },
    /// Reversed-Z: 1 at `near`, 0 at `far` (`f32::INFINITY` for an infinite far plane); sky is
    /// the clear value 0.
    ReversedZ {
        /// Near plane distance, > 0.
        near: f32,
        /// Far plane distance, > `near`, or infinite.
        far: f32,
    },
    /// Linear view depth: the distance along the camera's forward axis, as ours. Sky where it is
    /// not positive, not below `far`, or not finite.
    Linear {
        /// Depths from this on are sky (`f32::INFINITY` for none).
        far: f32,
    },
}

impl DepthEncoding {
    /// `[a, b, c, d]` with linear depth `(a + b·x) / (c + d·x)` for a stored depth `x`, and the
    /// open range of stored depths that are surfaces; `None` for planes out of range.
    #[cfg(not(target_arch = "spirv"))]
    fn map(self) -> Option<([f32; 4], [f32; 2])> {
        let planes_ok = |near: f32, far: f32| near > 0.0 && near.is_finite() && far > near;
        match self {
            Self::Standard { near, far } if planes_ok(near, far) => {
                Some(([1.0, 0.0, 1.0 / near, 1.0 / far - 1.0 / near], [-1.0, 1.0]))
            }
            Self::ReversedZ { near, far } if planes_ok(near, far) => {
                Some(([1.0, 0.0, 1.0 / far, 1.0 / near - 1.0 / far], [0.0, 2.0]))
            }
            Self::Linear { far } if far > 0.0 => Some(([0.0, 1.0, 1.0, 0.0], [0.0, far])),
            _ => None,
        }
    }

    /// The stored depth of a surface at linear depth `z` (the engine's side: for tests and
    /// examples that make engine images).
    pub fn encode(self, z: f32) -> f32 {
        match self {
            Self::Standard { near, far } => (1.0 / near - 1.0 / z) / (1.0 / near - 1.0 / far),
            Self::ReversedZ { near, far } => (1.0 / z - 1.0 / far) / (1.0 / near - 1.0 / far),
            Self::Linear { .. } => z,
        }
    }

    /// The stored depth of a pixel that sees no surface (the engine's clear value).
    pub fn sky(self) -> f32 {
        match self {
            Self::Standard { .. } => 1.0,
            Self::ReversedZ { .. } | Self::Linear { .. } => 0.0,
        }
    }
}

/// How the engine's normal image encodes world-space normals. For a UNORM format the stored
/// values are `0.5 + 0.5 · v` (the host derives this from the format); for SFLOAT and SNORM
/// formats they are `v` itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalEncoding {
    /// `xyz` is the normal (any length; it is normalised).
    World,
    /// `xy` is [`crate::octahedral::octahedral_encode`] of the normal.
    Octahedral,
}

/// What unit the engine's motion vectors are in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotionUnits {
    /// Pixels, `x` right and `y` down.
    Pixels,
    /// Fractions of the image's width and height (screen uv), `x` right and `y` down.
    Uv,
}

/// The engine's motion vectors: units and direction. Like ours they must carry no jitter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MotionVectors {
    /// Units.
    pub units: MotionUnits,
    /// True when a vector points from the pixel to where its surface was in the previous frame
    /// (previous − current, as DLSS and FSR take them); false for current − previous (ours).
    pub toward_previous: bool,
}

/// The conventions of an engine's G-buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conventions {
    /// Depth.
    pub depth: DepthEncoding,
    /// Normals.
    pub normal: NormalEncoding,
    /// Motion vectors (ignored without a motion image).
    pub motion: MotionVectors,
}

/// What the `gbuffer_import` kernel needs to know of the conventions: its push constants
/// (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GBufferImportParams {
    /// `[a, b, c, d]`: linear depth is `(a + b·x) / (c + d·x)` for a stored depth `x`.
    pub depth_map: [f32; 4],
    /// Stored depths strictly between these are surfaces; the rest is sky.
    pub surface_range: [f32; 2],
    /// Multiplies an engine motion vector into ours (pixels, current − previous).
    pub motion_scale: [f32; 2],
    /// [`NORMAL_WORLD`] or [`NORMAL_OCTAHEDRAL`].
    pub normal_encoding: u32,
    /// [`FLAG_MOTION`], [`FLAG_EMISSIVE`], [`FLAG_UNORM_NORMALS`].
    pub flags: u32,
    /// Explicit padding.
    pub _pad: [u32; 2],
}

impl GBufferImportParams {
    /// The parameters of `conventions` for images of `image_size` pixels, with `flags`
    /// ([`FLAG_MOTION`] etc.); an error naming the convention at fault when the depth's planes
    /// are out of range.
    #[cfg(not(target_arch = "spirv"))]
    pub fn new(
        conventions: &Conventions,
        image_size: UVec2,
        flags: u32,
    ) -> Result<Self, &'static str> {
        let (depth_map, surface_range) = conventions.depth.map().ok_or(
            "depth planes out of range: near must be finite and > 0, far > near (or infinite)",
        )?;
        let unit = match conventions.motion.units {
            MotionUnits::Pixels => Vec2::ONE,
            MotionUnits::Uv => image_size.as_vec2(),
        };
        let sign = if conventions.motion.toward_previous {
            -1.0
        } else {
            1.0
        };
        Ok(Self {
            depth_map,
            surface_range,
            motion_scale: (unit * sign).to_array(),
            normal_encoding: match conventions.normal {
                NormalEncoding::World => NORMAL_WORLD,
                NormalEncoding::Octahedral => NORMAL_OCTAHEDRAL,
            },
            flags,
            _pad: [0; 2],
        })
    }

    /// Whether `flag` is set.
    #[inline]
    pub fn has(&self, flag: u32) -> bool {
        self.flags & flag != 0
    }

    /// Linear depth of the stored depth `x`; [`crate::gbuffer::SKY_DEPTH`] (0) for sky.
    #[inline]
    pub fn linear_depth(&self, x: f32) -> f32 {
        let [a, b, c, d] = self.depth_map;
        let z = (a + b * x) / (c + d * x);
        // False for NaN too.
        let surface = x > self.surface_range[0] && x < self.surface_range[1];
        if surface && z > 0.0 && z.is_finite() {
            z
        } else {
            crate::gbuffer::SKY_DEPTH
        }
    }

    /// The unit world-space normal of a normal texel (zero when it holds none).
    #[inline]
    pub fn decode_normal(&self, texel: Vec4) -> Vec3 {
        let v = if self.has(FLAG_UNORM_NORMALS) {
            texel * 2.0 - Vec4::ONE
        } else {
            texel
        };
        if self.normal_encoding == NORMAL_OCTAHEDRAL {
            octahedral_decode(Vec2::new(v.x, v.y))
        } else {
            v.truncate().normalize_or_zero()
        }
    }
}

/// The engine's texels of one pixel, as read (stored values, not yet decoded).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EngineTexels {
    /// Stored depth of the pixel, then of the pixels 1 and 2 to its left, 1 and 2 to its right,
    /// 1 and 2 up, 1 and 2 down (NaN for a pixel outside the image).
    pub depth: [f32; 9],
    /// Normal texel.
    pub normal: Vec4,
    /// Albedo texel (linear: an sRGB format is decoded by the read).
    pub albedo: Vec4,
    /// Motion texel (`xy`), read when [`FLAG_MOTION`] is set.
    pub motion: Vec4,
    /// Emission texel (`xyz`), read when [`FLAG_EMISSIVE`] is set.
    pub emissive: Vec4,
}

/// World position of the surface at linear depth `z` seen through `pixel`.
#[inline]
fn position(camera: &CameraParams, pixel: UVec2, z: f32) -> Vec3 {
    let ray = primary_ray(camera, pixel, camera.jitter());
    Vec3::from_array(ray.origin) + Vec3::from_array(ray.direction) * z
}

/// How far the pixel's linear depth `z` is from the surface of one side: `z1`, `z2` are the
/// linear depths one and two pixels away (0 for sky or outside the image). With both, the error of
/// their linear extrapolation of 1/z (linear across the screen on a plane: zero when all three lie
/// on one plane), relative; with `z1` alone, the relative depth difference; infinite without.
#[inline]
fn side_error(z: f32, z1: f32, z2: f32) -> f32 {
    if z1 <= 0.0 {
        f32::INFINITY
    } else if z2 > 0.0 {
        abs((2.0 / z1 - 1.0 / z2) * z - 1.0)
    } else {
        abs(z1 - z) / z
    }
}

/// The tangent along one image axis at `p` (linear depth `z`, `pixel`), towards the side whose
/// depths continue the pixel's surface best ([`side_error`]): `before` holds the linear depths one
/// and two steps back, `after` one and two steps on; zero when neither side has a surface.
#[inline]
fn tangent(
    camera: &CameraParams,
    pixel: UVec2,
    step: UVec2,
    p: Vec3,
    z: f32,
    before: [f32; 2],
    after: [f32; 2],
) -> Vec3 {
    let before_error = side_error(z, before[0], before[1]);
    let after_error = side_error(z, after[0], after[1]);
    if after[0] > 0.0 && after_error <= before_error {
        position(camera, pixel + step, after[0]) - p
    } else if before[0] > 0.0 {
        p - position(camera, pixel - step, before[0])
    } else {
        Vec3::ZERO
    }
}

/// Our G-buffer pixel `pixel` of `camera` made from the engine's texels under `params`.
#[inline]
pub fn imported_texel(
    camera: &CameraParams,
    params: &GBufferImportParams,
    pixel: UVec2,
    texels: &EngineTexels,
) -> GBufferTexel {
    let z = params.linear_depth(texels.depth[0]);
    if z <= 0.0 {
        return GBufferTexel::SKY;
    }
    let p = position(camera, pixel, z);
    let direction = p - camera.position();
    let d = |i: usize| params.linear_depth(texels.depth[i]);
    let tx = tangent(camera, pixel, UVec2::X, p, z, [d(1), d(2)], [d(3), d(4)]);
    let ty = tangent(camera, pixel, UVec2::Y, p, z, [d(5), d(6)], [d(7), d(8)]);
    let mut shading = params.decode_normal(texels.normal);
    let mut geometric = tx.cross(ty).normalize_or_zero();
    if geometric == Vec3::ZERO {
        geometric = shading;
    }
    if geometric == Vec3::ZERO {
        // Neither depth nor the engine gives a normal: face the camera.
        geometric = -direction;
    }
    if geometric.dot(direction) > 0.0 {
        geometric = -geometric;
    }
    geometric = geometric.normalize_or_zero();
    if shading == Vec3::ZERO {
        shading = geometric;
    }
    if shading.dot(geometric) < 0.0 {
        shading = -shading;
    }
    let motion = if params.has(FLAG_MOTION) {
        let previous_depth = to_clip(&camera.previous_view_proj, p).w;
        if previous_depth > 0.0 {
            let m =
                Vec2::new(texels.motion.x, texels.motion.y) * Vec2::from_array(params.motion_scale);
            Vec4::new(m.x, m.y, previous_depth, 1.0)
        } else {
            Vec4::ZERO
        }
    } else {
        motion_vector(camera, p, p)
    };
    let emissive = if params.has(FLAG_EMISSIVE) {
        texels.emissive.truncate().extend(0.0)
    } else {
        Vec4::ZERO
    };
    GBufferTexel {
        depth: z,
        geometric_normal: geometric.extend(1.0),
        shading_normal: shading.extend(1.0),
        albedo: texels.albedo,
        emissive,
        motion,
        ids: UVec4::new(IMPORTED_ID, IMPORTED_ID, IMPORTED_ID, 1),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::view_projection;
    use crate::octahedral::octahedral_encode;

    const MOTION: MotionVectors = MotionVectors {
        units: MotionUnits::Pixels,
        toward_previous: false,
    };

    fn params(depth: DepthEncoding, normal: NormalEncoding, flags: u32) -> GBufferImportParams {
        let c = Conventions {
            depth,
            normal,
            motion: MOTION,
        };
        GBufferImportParams::new(&c, UVec2::new(32, 32), flags).unwrap()
    }

    #[test]
    fn layout() {
        assert_eq!(core::mem::size_of::<GBufferImportParams>(), 48);
    }

    #[test]
    fn depths_round_trip_and_sky_is_the_clear_value() {
        let encodings = [
            DepthEncoding::Standard {
                near: 0.1,
                far: 100.0,
            },
            DepthEncoding::Standard {
                near: 0.1,
                far: f32::INFINITY,
            },
            DepthEncoding::ReversedZ {
                near: 0.1,
                far: 100.0,
            },
            DepthEncoding::ReversedZ {
                near: 0.1,
                far: f32::INFINITY,
            },
            DepthEncoding::Linear { far: f32::INFINITY },
        ];
        for e in encodings {
            let p = params(e, NormalEncoding::World, 0);
            for z in [0.1, 0.5, 1.0, 3.9, 20.0, 99.0] {
                let back = p.linear_depth(e.encode(z));
                // Standard depth loses most: 1/z is a small difference of large numbers.
                assert!(
                    (back - z).abs() <= 2e-5 * z * z / 0.1,
                    "{e:?}: {z} → {back}"
                );
            }
            assert_eq!(p.linear_depth(e.sky()), 0.0, "{e:?}");
            assert_eq!(p.linear_depth(f32::NAN), 0.0, "{e:?}");
        }
        let bad = Conventions {
            depth: DepthEncoding::ReversedZ {
                near: 0.0,
                far: 1.0,
            },
            normal: NormalEncoding::World,
            motion: MOTION,
        };
        assert!(GBufferImportParams::new(&bad, UVec2::ONE, 0).is_err());
    }

    #[test]
    fn normals_decode_from_every_encoding() {
        let n = Vec3::new(0.3, -0.5, -0.8).normalize();
        let world = params(
            DepthEncoding::Linear { far: 10.0 },
            NormalEncoding::World,
            0,
        );
        assert!((world.decode_normal(n.extend(0.0) * 3.0) - n).length() < 1e-6);
        let unorm = params(
            DepthEncoding::Linear { far: 10.0 },
            NormalEncoding::World,
            FLAG_UNORM_NORMALS,
        );
        let stored = (n * 0.5 + Vec3::splat(0.5)).extend(1.0);
        assert!((unorm.decode_normal(stored) - n).length() < 1e-6);
        let oct = params(
            DepthEncoding::Linear { far: 10.0 },
            NormalEncoding::Octahedral,
            FLAG_UNORM_NORMALS,
        );
        let e = octahedral_encode(n) * 0.5 + Vec2::splat(0.5);
        assert!((oct.decode_normal(Vec4::new(e.x, e.y, 0.0, 0.0)) - n).length() < 1e-6);
    }

    /// A wall at z = -2 facing the camera at the origin, seen through pixel (10, 12).
    #[test]
    fn a_wall_gets_its_normals_and_motion() {
        let camera = CameraParams::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 32, 32);
        let e = DepthEncoding::ReversedZ {
            near: 0.1,
            far: f32::INFINITY,
        };
        let p = params(e, NormalEncoding::World, 0);
        let pixel = UVec2::new(10, 12);
        // Every ray's forward component is 1: linear depth 2 everywhere on the wall.
        let d = e.encode(2.0);
        let texels = EngineTexels {
            depth: [d, d, d, f32::NAN, f32::NAN, e.sky(), e.sky(), d, d],
            normal: Vec4::new(0.0, 0.0, 1.0, 0.0),
            albedo: Vec4::new(0.5, 0.25, 0.125, 1.0),
            motion: Vec4::ZERO,
            emissive: Vec4::ONE,
        };
        let t = imported_texel(&camera, &p, pixel, &texels);
        assert!((t.depth - 2.0).abs() < 1e-6);
        assert!((t.geometric_normal - Vec4::new(0.0, 0.0, 1.0, 1.0)).length() < 1e-5);
        assert_eq!(t.shading_normal, Vec4::new(0.0, 0.0, 1.0, 1.0));
        assert_eq!(t.albedo, texels.albedo);
        assert_eq!(t.emissive, Vec4::ZERO, "no emission without the flag");
        assert_eq!(t.motion, Vec4::new(0.0, 0.0, 2.0, 1.0));
        assert_eq!(t.ids, UVec4::new(IMPORTED_ID, IMPORTED_ID, IMPORTED_ID, 1));
        assert!(t.is_surface());

        // A back-facing engine normal turns to the camera's side; the engine's motion, in uv
        // and toward the previous frame, becomes ours.
        let mut previous = camera;
        previous.position = [0.5, 0.0, 0.0];
        previous.view_proj = view_projection(&previous);
        let moved = camera.with_previous(&previous);
        let c = Conventions {
            depth: e,
            normal: NormalEncoding::World,
            motion: MotionVectors {
                units: MotionUnits::Uv,
                toward_previous: true,
            },
        };
        let p =
            GBufferImportParams::new(&c, UVec2::new(32, 32), FLAG_MOTION | FLAG_EMISSIVE).unwrap();
        let ours = imported_texel(&moved, &params(e, NormalEncoding::World, 0), pixel, &texels);
        let engine_motion = -Vec2::new(ours.motion.x, ours.motion.y) / 32.0;
        let texels = EngineTexels {
            normal: Vec4::new(0.0, 0.0, -1.0, 0.0),
            motion: engine_motion.extend(0.0).extend(0.0),
            ..texels
        };
        let t = imported_texel(&moved, &p, pixel, &texels);
        assert!(
            ours.motion.x.abs() > 1.0,
            "the camera moved: {}",
            ours.motion
        );
        assert!(
            (t.motion - ours.motion).length() < 1e-5,
            "{} vs {}",
            t.motion,
            ours.motion
        );
        assert_eq!(t.shading_normal, Vec4::new(0.0, 0.0, 1.0, 1.0));
        assert_eq!(t.emissive, Vec4::new(1.0, 1.0, 1.0, 0.0));

        // Sky.
        let sky = EngineTexels {
            depth: [e.sky(); 9],
            ..texels
        };
        assert_eq!(imported_texel(&moved, &p, pixel, &sky), GBufferTexel::SKY);
    }
}
