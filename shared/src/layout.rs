//! GPU buffer layouts shared by the host and the kernels, with the capacities that must respect the
//! device limits.
//!
//! Rules: `#[repr(C)]` + `Pod`; only `u32`/`i32`/`f32` and arrays of them (no `bool`, no `Vec3`,
//! whose 12-byte layout breaks std430 without scalar block layout); explicit padding; every struct's
//! size and field offsets are asserted by a test.
//!
//! These are the frame-wide limits and records; the hash grid's own layouts (its capacities, cell
//! records and pass parameters) are in [`crate::hash_cells::layout`].

use bytemuck::{Pod, Zeroable};
use glam::Vec2;

use crate::packing::{f16_to_f32, pack_half2, pack_radiance_half, unpack_half2};
use crate::reservoir::Reservoir;

/// Largest storage buffer binding we rely on: lavapipe's (and wgpu's default)
/// `maxStorageBufferRange` of 128 MiB.
pub const MAX_STORAGE_BUFFER_BYTES: usize = 128 << 20;
/// Most buffers (chunks) one of the scene's arrays that scale with its triangle count (vertices,
/// triangles, BVH nodes) is split into, each one storage binding (`crate::elements`): the length
/// of the descriptor array that binds it. 8 × [`MAX_STORAGE_BUFFER_BYTES`] = 1 GiB per array on
/// every device, e.g. 32 M vertices.
pub const SCENE_BUFFER_CHUNKS: usize = 8;
/// Push-constant bytes every Vulkan device guarantees (`maxPushConstantsSize` minimum).
pub const MAX_PUSH_CONSTANT_BYTES: usize = 128;

/// Largest frame width the buffers are sized for (seed packing allows up to 65534).
pub const MAX_FRAME_WIDTH: u32 = 3840;
/// Largest frame height the buffers are sized for.
pub const MAX_FRAME_HEIGHT: u32 = 2160;
/// Screen-probe resolution: 8 × 8 cells per probe, one probe tile of 8 × 8 pixels.
pub const PROBE_SIZE: u32 = 8;
/// Spawn tile of the quarter-spp sampling mode: one new probe per 16 × 16 pixels.
pub const PROBE_SPAWN_TILE_SIZE: u32 = 16;

/// Probes spawned per frame at most: `⌈W/16⌉ · ⌈H/16⌉`.
pub const fn max_probe_spawn_count(width: u32, height: u32) -> u32 {
    width.div_ceil(PROBE_SPAWN_TILE_SIZE) * height.div_ceil(PROBE_SPAWN_TILE_SIZE)
}

/// Probe rays per frame at most: one per cell of every spawned probe.
pub const fn max_ray_count(width: u32, height: u32) -> u32 {
    max_probe_spawn_count(width, height) * PROBE_SIZE * PROBE_SIZE
}

/// Rays per frame at [`MAX_FRAME_WIDTH`] × [`MAX_FRAME_HEIGHT`] (2 073 600).
pub const MAX_RAY_COUNT: u32 = max_ray_count(MAX_FRAME_WIDTH, MAX_FRAME_HEIGHT);

/// A reservoir in a buffer (`uint4`): light index; half2 sample parameters; `W` as `f32`;
/// half `M` (low) | half visibility (high).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PackedReservoir {
    /// Selected light.
    pub light_index: u32,
    /// Half2 sample parameters (e.g. the point on the light).
    pub sample_params: u32,
    /// Unbiased contribution weight `W`.
    pub ucw: f32,
    /// Half `M` in the low 16 bits, half visibility in the high 16 bits.
    pub m_visibility: u32,
}

impl PackedReservoir {
    /// Packs a finalised reservoir with its sample parameters and visibility. `M` up to 2048 is
    /// exact in a half.
    #[inline]
    pub fn new(reservoir: &Reservoir, sample_params: Vec2, visibility: f32) -> Self {
        Self {
            light_index: reservoir.sample,
            sample_params: pack_half2(sample_params),
            ucw: reservoir.ucw,
            m_visibility: pack_radiance_half(reservoir.m) | (pack_radiance_half(visibility) << 16),
        }
    }

    /// The reservoir (`w_sum` is not stored and comes back 0; merging only needs `W` and `M`).
    #[inline]
    pub fn reservoir(&self) -> Reservoir {
        Reservoir {
            sample: self.light_index,
            w_sum: 0.0,
            m: f16_to_f32(self.m_visibility & 0xffff),
            ucw: self.ucw,
        }
    }

    /// Sample parameters.
    #[inline]
    pub fn sample_params(&self) -> Vec2 {
        unpack_half2(self.sample_params)
    }

    /// Visibility.
    #[inline]
    pub fn visibility(&self) -> f32 {
        f16_to_f32(self.m_visibility >> 16)
    }
}

/// Bit 31 of [`PackedProbeHit::instance_backface`]: the ray hit a back face.
pub const BACKFACE_BIT: u32 = 1 << 31;
/// Largest instance index that fits beside [`BACKFACE_BIT`].
pub const MAX_INSTANCE_INDEX: u32 = BACKFACE_BIT - 1;

/// A probe ray's hit (`float4` bits): instance | back-face bit, geometry, primitive, half2
/// barycentrics.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct PackedProbeHit {
    /// Instance index (bits 0–30) and [`BACKFACE_BIT`].
    pub instance_backface: u32,
    /// Geometry index within the instance.
    pub geometry: u32,
    /// Primitive (triangle) index within the geometry.
    pub primitive: u32,
    /// Half2 barycentrics `(b1, b2)`.
    pub barycentrics: u32,
}

impl PackedProbeHit {
    /// Packs a hit; instance indices are masked to 31 bits.
    #[inline]
    pub fn new(instance: u32, backface: bool, geometry: u32, primitive: u32, bary: Vec2) -> Self {
        Self {
            instance_backface: (instance & MAX_INSTANCE_INDEX)
                | if backface { BACKFACE_BIT } else { 0 },
            geometry,
            primitive,
            barycentrics: pack_half2(bary),
        }
    }

    /// Instance index.
    #[inline]
    pub fn instance(&self) -> u32 {
        self.instance_backface & MAX_INSTANCE_INDEX
    }

    /// Whether the ray hit a back face.
    #[inline]
    pub fn is_backface(&self) -> bool {
        self.instance_backface & BACKFACE_BIT != 0
    }

    /// Barycentrics `(b1, b2)`; `b0 = 1 − b1 − b2`.
    #[inline]
    pub fn barycentrics(&self) -> Vec2 {
        unpack_half2(self.barycentrics)
    }
}

// Every buffer below must fit one storage binding.
// Two reservoirs per shadow ray.
const _: () = assert!(
    2 * MAX_RAY_COUNT as usize * core::mem::size_of::<PackedReservoir>()
        <= MAX_STORAGE_BUFFER_BYTES
);
const _: () = assert!(
    MAX_RAY_COUNT as usize * core::mem::size_of::<PackedProbeHit>() <= MAX_STORAGE_BUFFER_BYTES
);
// Seed pixels keep 16 bits per coordinate.
const _: () = assert!(
    MAX_FRAME_WIDTH <= crate::packing::SEED_MAX_COORD
        && MAX_FRAME_HEIGHT <= crate::packing::SEED_MAX_COORD
);

#[cfg(test)]
mod tests {
    use super::*;
    use core::mem::{offset_of, size_of};

    #[test]
    fn sizes_and_offsets() {
        assert_eq!(size_of::<PackedReservoir>(), 16);
        assert_eq!(offset_of!(PackedReservoir, light_index), 0);
        assert_eq!(offset_of!(PackedReservoir, sample_params), 4);
        assert_eq!(offset_of!(PackedReservoir, ucw), 8);
        assert_eq!(offset_of!(PackedReservoir, m_visibility), 12);

        assert_eq!(size_of::<PackedProbeHit>(), 16);
        assert_eq!(offset_of!(PackedProbeHit, instance_backface), 0);
        assert_eq!(offset_of!(PackedProbeHit, geometry), 4);
        assert_eq!(offset_of!(PackedProbeHit, primitive), 8);
        assert_eq!(offset_of!(PackedProbeHit, barycentrics), 12);
    }

    #[test]
    fn capacities() {
        assert_eq!(max_probe_spawn_count(1920, 1080), 120 * 68);
        assert_eq!(max_ray_count(1920, 1080), 120 * 68 * 64);
        assert_eq!(MAX_RAY_COUNT, 2_073_600);
    }

    #[test]
    fn reservoir_and_hit_round_trip() {
        let r = Reservoir {
            sample: 42,
            w_sum: 3.0,
            m: 20.0,
            ucw: 0.125,
        };
        let p = PackedReservoir::new(&r, Vec2::new(0.25, 0.75), 1.0);
        assert_eq!(p.reservoir(), Reservoir { w_sum: 0.0, ..r });
        assert_eq!(p.sample_params(), Vec2::new(0.25, 0.75));
        assert_eq!(p.visibility(), 1.0);

        let h = PackedProbeHit::new(0xffff_ffff, true, 3, 77, Vec2::new(0.5, 0.25));
        assert_eq!(h.instance(), MAX_INSTANCE_INDEX);
        assert!(h.is_backface());
        assert_eq!((h.geometry, h.primitive), (3, 77));
        assert_eq!(h.barycentrics(), Vec2::new(0.5, 0.25));
        let f = PackedProbeHit::new(12, false, 0, 0, Vec2::ZERO);
        assert_eq!((f.instance(), f.is_backface()), (12, false));
        // The struct is a float4 on the GPU side: 16 bytes that cast both ways.
        let bytes: [u8; 16] = bytemuck::cast(h);
        assert_eq!(bytemuck::cast::<_, PackedProbeHit>(bytes), h);
    }
}
