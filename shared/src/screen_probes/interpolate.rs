//! InterpolateScreenProbes (GI-1.0 step 21): each pixel's irradiance from at most four screen
//! probes' SH.
//!
//! 1. **Lookup pixel** ([`jitter_candidate`], [`accepts_jitter`]): the pixel is moved by blue
//!    noise by up to [`GiFrameParams::interpolation_jitter`] pixels each way (at most
//!    [`MAX_INTERPOLATION_JITTER_PIXELS`]; 0: not moved), and the move is kept only when the
//!    moved pixel's surface lies within [`JITTER_PLANE_TOLERANCE`] × the probe cell size of the
//!    pixel's plane; the jitter turns the probe grid's blockiness into noise the denoiser
//!    removes. The farther it reaches, the more a lit surface and its shadowed part share their
//!    probes: the radius trades the grid's blocks for light moved across shadow edges.
//! 2. **Probes** ([`gather_probes`]): the lookup pixel's probe tile in the mask's mip 0, or the
//!    first seed going coarser through the mip chain ([`nearest_probe_seed`]); then the mip-0
//!    probes of the tiles beside the closest probe's toward ±x, ±y and the diagonal, the side
//!    chosen by where the lookup pixel lies relative to that probe's seed. Duplicates removed, at
//!    most [`MAX_INTERPOLATION_PROBES`].
//! 3. **Weights** ([`probe_weight`]): `[saturate(1 − |Δ depth| / depth) × max(N · N_probe, 0)]^8`,
//!    zero for a probe farther than one probe cell size from the pixel's plane, times a tent
//!    over the screen distance from the lookup pixel to the probe's seed ([`screen_tent`]; the
//!    reference has none). All zero: with [`FLAG_RELAXED_FALLBACK`] equal weights and hint
//!    [`HINT_RELAXED`], else no irradiance.
//! 4. **Irradiance**: the weighted mean of the probes' SH irradiance (cosine lobe) at the pixel's
//!    shading normal, clamped to finite non-negative values; where screen-space GI finds the
//!    pixel occluded ([`crate::screen_space_gi`]), through the cone around its bent normal that
//!    holds its visibility.
//!
//! Output per pixel `[r, g, b, hint]`: hint [`HINT_WEIGHTED`] when the weights were used,
//! [`HINT_RELAXED`] for the relaxed fallback or no probe, [`HINT_SKY`] for sky pixels (black).
//! The occluders' own light, screen-space GI's near-field term, is added to the result.

use glam::{UVec2, Vec3, Vec4};

use super::probe_mask::{mask_texel, nearest_probe_seed};
use super::{
    FLAG_RELAXED_FALLBACK, GiFrameParams, NO_PROBE, PROBE_SIZE, ProbeRecord, RELAXED_COUNT,
};
use crate::atomics::AtomicWords;
use crate::camera::CameraParams;
use crate::math::{abs, floor_to_i32_clamped, max, min_u32, saturate};
use crate::packing::unpack_seed;
use crate::primary_surface::{PrimarySurface, primary_surface};
use crate::random::pixel_sample;
use crate::screen_space_gi::{NoNearField, Occlusion, RowMajor, horizon_occlusion};
use crate::sh::{SH_COEFFICIENT_COUNT, ShL2Rgb, ShLobe};

/// Largest jitter radius of the lookup pixel along each axis, in pixels (four probe tiles):
/// [`GiFrameParams::interpolation_jitter`] is clamped to it.
pub const MAX_INTERPOLATION_JITTER_PIXELS: u32 = 4 * PROBE_SIZE;
/// The jittered pixel's surface must lie within this many probe cell sizes of the pixel's plane.
pub const JITTER_PLANE_TOLERANCE: f32 = 0.5;
/// Most probes one pixel interpolates.
pub const MAX_INTERPOLATION_PROBES: usize = 4;
/// Output hint: the irradiance is the weighted interpolation.
pub const HINT_WEIGHTED: f32 = 1.0;
/// Output hint: relaxed fallback (equal weights) or no probe at all.
pub const HINT_RELAXED: f32 = 0.0;
/// Output hint: a sky pixel.
pub const HINT_SKY: f32 = -1.0;
/// The output of a sky pixel.
pub const SKY_IRRADIANCE: [f32; 4] = [0.0, 0.0, 0.0, HINT_SKY];

/// The blue-noise offset of `pixel`'s lookup in frame `frame_index`, each component in
/// `[-radius, radius]` (`radius` clamped to [`MAX_INTERPOLATION_JITTER_PIXELS`]).
#[inline]
pub fn jitter_offset(pixel: UVec2, frame_index: u32, radius: u32) -> [i32; 2] {
    let u = pixel_sample(pixel, frame_index);
    let r = min_u32(radius, MAX_INTERPOLATION_JITTER_PIXELS) as i32;
    let bins = (2 * r + 1) as f32;
    [
        floor_to_i32_clamped(u.x * bins, 0, 2 * r) - r,
        floor_to_i32_clamped(u.y * bins, 0, 2 * r) - r,
    ]
}

/// The jittered lookup pixel to test for `pixel`: `None` without jitter (a radius of 0), for a
/// zero offset, or when the moved pixel leaves the image.
#[inline]
pub fn jitter_candidate(frame: &GiFrameParams, pixel: UVec2) -> Option<UVec2> {
    if frame.interpolation_jitter == 0 {
        return None;
    }
    let [dx, dy] = jitter_offset(pixel, frame.frame_index, frame.interpolation_jitter);
    let x = pixel.x as i32 + dx;
    let y = pixel.y as i32 + dy;
    let inside = x >= 0
        && y >= 0
        && (x as u32) < frame.image_size[0]
        && (y as u32) < frame.image_size[1]
        && (dx != 0 || dy != 0);
    if inside {
        Some(UVec2::new(x as u32, y as u32))
    } else {
        None
    }
}

/// Whether the jittered lookup pixel's surface `candidate` may stand for `surface`: it sees a
/// surface within [`JITTER_PLANE_TOLERANCE`] × the probe cell size (at `surface`'s distance from
/// the eye) of `surface`'s plane.
#[inline]
pub fn accepts_jitter(
    frame: &GiFrameParams,
    surface: &PrimarySurface,
    candidate: &PrimarySurface,
) -> bool {
    if !surface.valid || !candidate.valid {
        return false;
    }
    let cell = frame.probe_cell_size((surface.position - Vec3::from_array(frame.eye)).length());
    let plane = abs((candidate.position - surface.position).dot(surface.geometric_normal));
    plane < JITTER_PLANE_TOLERANCE * cell
}

/// The mip-0 mask texel of probe tile `(x, y)`, [`NO_PROBE`] outside the grid (neighbours of
/// border tiles).
#[inline]
fn tile_seed(frame: &GiFrameParams, mask: &[u32], x: i32, y: i32) -> u32 {
    if x < 0 || y < 0 {
        NO_PROBE
    } else {
        mask_texel(mask, frame.probe_grid, 0, UVec2::new(x as u32, y as u32))
    }
}

/// The probes a pixel interpolates: their seeds (packed), the closest first.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeSet {
    /// Packed seeds; the first `count` are valid and distinct.
    pub seeds: [u32; MAX_INTERPOLATION_PROBES],
    /// Number of probes.
    pub count: u32,
}

impl ProbeSet {
    /// No probe.
    pub const EMPTY: Self = Self {
        seeds: [NO_PROBE; MAX_INTERPOLATION_PROBES],
        count: 0,
    };

    /// Adds `seed` unless it is [`NO_PROBE`], already present, or the set is full.
    #[inline]
    pub fn insert(&mut self, seed: u32) {
        if seed == NO_PROBE || self.count as usize >= MAX_INTERPOLATION_PROBES {
            return;
        }
        let mut i = 0;
        while i < self.count as usize {
            if self.seeds[i] == seed {
                return;
            }
            i += 1;
        }
        self.seeds[self.count as usize] = seed;
        self.count += 1;
    }
}

/// The probes of lookup pixel `lookup`: the closest probe ([`nearest_probe_seed`] of its tile)
/// and the mip-0 probes of the three tiles beside the closest probe's tile toward the lookup
/// pixel (along x, along y, diagonal).
#[inline]
pub fn gather_probes(frame: &GiFrameParams, mask: &[u32], lookup: UVec2) -> ProbeSet {
    let mut set = ProbeSet::EMPTY;
    let tile = lookup / PROBE_SIZE;
    let closest = nearest_probe_seed(mask, frame.probe_grid, tile);
    if closest == NO_PROBE {
        return set;
    }
    set.insert(closest);
    let seed = unpack_seed(closest);
    let tx = (seed.x / PROBE_SIZE) as i32;
    let ty = (seed.y / PROBE_SIZE) as i32;
    let dx = if lookup.x >= seed.x { 1 } else { -1 };
    let dy = if lookup.y >= seed.y { 1 } else { -1 };
    set.insert(tile_seed(frame, mask, tx + dx, ty));
    set.insert(tile_seed(frame, mask, tx, ty + dy));
    set.insert(tile_seed(frame, mask, tx + dx, ty + dy));
    set
}

/// The reach of [`screen_tent`] along each axis, in probe tiles.
pub const SCREEN_TENT_TILES: f32 = 1.5;
/// The least [`screen_tent`] weight along an axis: a matching probe beyond the tent's reach still
/// counts (a little) before the relaxed fallback does.
pub const SCREEN_TENT_FLOOR: f32 = 0.01;

/// The screen-space weight of a probe seeded at `seed` for lookup pixel `lookup`: a tent of
/// [`SCREEN_TENT_TILES`] per axis, at least [`SCREEN_TENT_FLOOR`]. Without it the up to four
/// probes around a pixel weighed alike wherever the pixel lay between them, a box filter two
/// tiles wide over the irradiance: at 128 × 72 the staircase's floor along its walls read 1.5–1.8
/// times the one-bounce path tracer, and the dark half +10.1 % with every smoothing technique
/// off (+6.9 % with the tent; README, "Round 24").
#[inline]
pub fn screen_tent(lookup: UVec2, seed: UVec2) -> f32 {
    let reach = SCREEN_TENT_TILES * PROBE_SIZE as f32;
    let dx = abs(lookup.x as f32 - seed.x as f32);
    let dy = abs(lookup.y as f32 - seed.y as f32);
    max(1.0 - dx / reach, SCREEN_TENT_FLOOR) * max(1.0 - dy / reach, SCREEN_TENT_FLOOR)
}

/// `x⁸` by squaring (the same operations on every device).
#[inline]
fn pow8(x: f32) -> f32 {
    let x2 = x * x;
    let x4 = x2 * x2;
    x4 * x4
}

/// The interpolation weight of `probe` for a pixel at `position` (its surface point) with linear
/// depth `depth` and unit geometric normal `normal`:
/// `[saturate(1 − |probe depth − depth| / depth) × max(normal · probe normal, 0)]^8`, zero when the
/// probe lies farther than one probe cell size (at the pixel's distance from the eye) from the
/// pixel's plane, for an invalid probe, or a non-positive depth.
#[inline]
pub fn probe_weight(
    frame: &GiFrameParams,
    position: Vec3,
    depth: f32,
    normal: Vec3,
    probe: &ProbeRecord,
) -> f32 {
    if !probe.is_valid() || depth <= 0.0 {
        return 0.0;
    }
    let cell = frame.probe_cell_size((position - Vec3::from_array(frame.eye)).length());
    let plane = abs((probe.world_position() - position).dot(normal));
    if plane.is_nan() || plane > cell {
        return 0.0;
    }
    let depth_term = saturate(1.0 - abs(probe.depth - depth) / depth);
    let normal_term = max(normal.dot(probe.world_normal()), 0.0);
    let w = pow8(depth_term * normal_term);
    if w.is_finite() { w } else { 0.0 }
}

/// Irradiance of the SH of probe tile `tile` (9 entries `[r, g, b, 0]` per tile) through `lobe`
/// (the pixel's [`Occlusion::lobe`]); black outside the buffer.
#[inline]
pub fn probe_irradiance(sh: &[[f32; 4]], tile: u32, lobe: &ShLobe) -> Vec3 {
    let base = tile as usize * SH_COEFFICIENT_COUNT;
    if base + SH_COEFFICIENT_COUNT > sh.len() {
        return Vec3::ZERO;
    }
    let mut probe = ShL2Rgb::ZERO;
    let mut i = 0;
    while i < SH_COEFFICIENT_COUNT {
        let c = sh[base + i];
        probe.coefficients[i] = Vec3::new(c[0], c[1], c[2]);
        i += 1;
    }
    probe.integrate(lobe)
}

/// Each component clamped to `[0, ∞)`, non-finite components zero.
#[inline]
fn clamp_irradiance(v: Vec3) -> Vec3 {
    let c = |x: f32| if x.is_finite() && x > 0.0 { x } else { 0.0 };
    Vec3::new(c(v.x), c(v.y), c(v.z))
}

/// What InterpolateScreenProbes writes for one pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interpolated {
    /// `[r, g, b, hint]`.
    pub irradiance: [f32; 4],
    /// Whether the relaxed fallback was taken (counted in [`RELAXED_COUNT`]).
    pub relaxed: bool,
}

/// The current frame's probes as InterpolateScreenProbes reads them.
#[derive(Clone, Copy, Debug)]
pub struct InterpolationProbes<'a> {
    /// Records, one per probe tile.
    pub records: &'a [ProbeRecord],
    /// The probe mask with its mip chain.
    pub mask: &'a [u32],
    /// The probes' irradiance SH.
    pub sh: &'a [[f32; 4]],
}

/// The G-buffer's depth and normal images as slices, row by row: what the CPU model of
/// InterpolateScreenProbes reads (the images' own texel encodings).
#[derive(Clone, Copy, Debug)]
pub struct GBufferSlices<'a> {
    /// Linear depth.
    pub depth: &'a [f32],
    /// Geometric normal texels.
    pub geometric_normal: &'a [Vec4],
    /// Shading normal texels.
    pub shading_normal: &'a [Vec4],
}

/// The interpolated irradiance of a surface pixel: `surface` (its primary surface), `depth` (its
/// linear depth), `occlusion` (screen-space GI's, [`Occlusion::open`] at its shading normal
/// without it), `lookup` (the lookup pixel, jittered or itself), the current `probes`.
#[inline]
pub fn interpolate_pixel(
    frame: &GiFrameParams,
    surface: &PrimarySurface,
    depth: f32,
    occlusion: &Occlusion,
    lookup: UVec2,
    probes: InterpolationProbes<'_>,
) -> Interpolated {
    let InterpolationProbes { records, mask, sh } = probes;
    if !surface.valid {
        return Interpolated {
            irradiance: SKY_IRRADIANCE,
            relaxed: false,
        };
    }
    let set = gather_probes(frame, mask, lookup);
    let lobe = occlusion.lobe();
    let mut weighted = Vec3::ZERO;
    let mut weight_sum = 0.0;
    let mut equal = Vec3::ZERO;
    let mut found = 0u32;
    let mut i = 0;
    while i < set.count as usize {
        let seed = unpack_seed(set.seeds[i]);
        let tile = frame.probe_tile_of(seed);
        if (tile as usize) < records.len() && tile < frame.probe_count {
            let record = records[tile as usize];
            if record.is_valid() {
                let e = probe_irradiance(sh, tile, &lobe);
                let w = probe_weight(
                    frame,
                    surface.position,
                    depth,
                    surface.geometric_normal,
                    &record,
                ) * screen_tent(lookup, seed);
                weighted += e * w;
                weight_sum += w;
                equal += e;
                found += 1;
            }
        }
        i += 1;
    }
    let mut out = Interpolated {
        irradiance: [0.0, 0.0, 0.0, HINT_RELAXED],
        relaxed: false,
    };
    let mut e = Vec3::ZERO;
    if weight_sum > 0.0 {
        e = clamp_irradiance(weighted / weight_sum);
        out.irradiance[3] = HINT_WEIGHTED;
    } else if found > 0 && frame.has(FLAG_RELAXED_FALLBACK) {
        e = clamp_irradiance(equal / found as f32);
        out.relaxed = true;
    }
    let e = e + occlusion.near_field;
    out.irradiance[0] = e.x;
    out.irradiance[1] = e.y;
    out.irradiance[2] = e.z;
    out
}

/// The whole pass on the CPU, in the kernel's steps: every pixel of `gbuffer` interpolated from
/// `probes` into `irradiance`, relaxed pixels counted in `counters`.
pub fn interpolate_image<C: AtomicWords + ?Sized>(
    frame: &GiFrameParams,
    camera: &CameraParams,
    gbuffer: GBufferSlices<'_>,
    probes: InterpolationProbes<'_>,
    irradiance: &mut [[f32; 4]],
    counters: &mut C,
) {
    let GBufferSlices {
        depth,
        geometric_normal,
        shading_normal,
    } = gbuffer;
    let [w, h] = frame.image_size;
    let at = |p: UVec2| (p.y * w + p.x) as usize;
    for y in 0..h {
        for x in 0..w {
            let pixel = UVec2::new(x, y);
            let i = at(pixel);
            let d = depth[i];
            let surface = primary_surface(camera, pixel, d, geometric_normal[i], shading_normal[i]);
            if !surface.valid {
                irradiance[i] = SKY_IRRADIANCE;
                continue;
            }
            let mut lookup = pixel;
            if let Some(c) = jitter_candidate(frame, pixel) {
                let j = at(c);
                let candidate = primary_surface(
                    camera,
                    c,
                    depth[j],
                    geometric_normal[j],
                    geometric_normal[j],
                );
                if accepts_jitter(frame, &surface, &candidate) {
                    lookup = c;
                }
            }
            let occlusion = horizon_occlusion(
                camera,
                frame.horizon_search(),
                pixel,
                d,
                surface.geometric_normal,
                surface.shading_normal,
                (
                    &RowMajor {
                        texels: depth,
                        width: w,
                    },
                    &RowMajor {
                        texels: geometric_normal,
                        width: w,
                    },
                    &RowMajor {
                        texels: &[],
                        width: w,
                    },
                ),
                &NoNearField,
            );
            let r = interpolate_pixel(frame, &surface, d, &occlusion, lookup, probes);
            irradiance[i] = r.irradiance;
            if r.relaxed && RELAXED_COUNT < counters.word_count() {
                counters.fetch_add(RELAXED_COUNT, 1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{GI_COUNTER_WORDS, mask_mip_count, mask_words};
    use super::*;
    use crate::camera::primary_ray;
    use crate::math::PI;
    use crate::packing::{pack_seed, pack_snorm10x3};
    use crate::screen_probes::{mask_mip_offset, mask_mip_size};

    const W: u32 = 32;
    const H: u32 = 24;

    fn camera() -> CameraParams {
        CameraParams::new(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, Vec3::Y, 0.8, W, H)
    }

    fn frame() -> GiFrameParams {
        let probe_grid = [W.div_ceil(8), H.div_ceil(8)];
        GiFrameParams {
            image_size: [W, H],
            probe_grid,
            probe_count: probe_grid[0] * probe_grid[1],
            mask_mips: mask_mip_count(probe_grid),
            eye: [0.0, 0.0, 5.0],
            // A cell of 0.05 at the wall's distance 5.
            probe_cell_const: 0.01,
            ..Default::default()
        }
    }

    /// A wall at z = 0 facing the camera (every pixel at depth 5), with a box face at z = 1 over
    /// the pixels `x >= step` when `step < W`.
    fn gbuffer(step: u32) -> (Vec<f32>, Vec<Vec4>) {
        let c = camera();
        let mut depth = Vec::new();
        for y in 0..H {
            for x in 0..W {
                let ray = primary_ray(&c, UVec2::new(x, y), c.jitter());
                let d = Vec3::from_array(ray.direction);
                let z = if x >= step { 1.0 } else { 0.0 };
                depth.push((5.0 - z) / -d.z * d.dot(c.forward()));
            }
        }
        let normals = vec![Vec4::new(0.0, 0.0, 1.0, 1.0); (W * H) as usize];
        (depth, normals)
    }

    fn surface_at(depth: &[f32], normals: &[Vec4], p: UVec2) -> PrimarySurface {
        let i = (p.y * W + p.x) as usize;
        primary_surface(&camera(), p, depth[i], normals[i], normals[i])
    }

    /// Records, mask chain and SH with one probe per tile listed in `probes` (tile, seed pixel,
    /// uniform radiance), built from the G-buffer as the probe passes would.
    fn probes(
        f: &GiFrameParams,
        depth: &[f32],
        normals: &[Vec4],
        probes: &[(u32, UVec2, f32)],
    ) -> (Vec<ProbeRecord>, Vec<u32>, Vec<[f32; 4]>) {
        let mut records = vec![ProbeRecord::NONE; f.probe_count as usize];
        let mut mask = vec![NO_PROBE; mask_words(f.probe_grid) as usize];
        let mut sh = vec![[0.0f32; 4]; f.probe_count as usize * 9];
        for &(tile, seed, radiance) in probes {
            let s = surface_at(depth, normals, seed);
            records[tile as usize] = ProbeRecord {
                position: s.position.to_array(),
                normal: pack_snorm10x3(s.geometric_normal),
                seed: pack_seed(seed),
                depth: depth[(seed.y * W + seed.x) as usize],
                age: 0,
                _pad: 0,
            };
            mask[tile as usize] = pack_seed(seed);
            // Uniform radiance L: c0 = L · ∫ Y0 = L · 2√π, irradiance π L.
            let c0 = radiance * 2.0 * PI.sqrt();
            sh[tile as usize * 9] = [c0, c0, c0, 0.0];
        }
        // The mip chain: first valid child in the order (0,0), (1,0), (0,1), (1,1).
        for mip in 1..f.mask_mips {
            let size = mask_mip_size(f.probe_grid, mip);
            let below = mask_mip_size(f.probe_grid, mip - 1);
            for y in 0..size[1] {
                for x in 0..size[0] {
                    let mut v = NO_PROBE;
                    for (cx, cy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let (px, py) = (2 * x + cx, 2 * y + cy);
                        if v == NO_PROBE && px < below[0] && py < below[1] {
                            v = mask[(mask_mip_offset(f.probe_grid, mip - 1) + py * below[0] + px)
                                as usize];
                        }
                    }
                    mask[(mask_mip_offset(f.probe_grid, mip) + y * size[0] + x) as usize] = v;
                }
            }
        }
        (records, mask, sh)
    }

    #[test]
    fn the_weight_follows_depth_normal_and_plane() {
        let f = frame();
        let p = Vec3::new(0.0, 0.0, 0.0);
        let probe = ProbeRecord {
            position: [0.3, 0.2, 0.0],
            normal: pack_snorm10x3(Vec3::Z),
            seed: pack_seed(UVec2::new(3, 4)),
            depth: 5.0,
            ..Default::default()
        };
        let w = probe_weight(&f, p, 5.0, Vec3::Z, &probe);
        assert!((w - 1.0).abs() < 1e-6, "{w}");
        // 10 % depth difference: 0.9⁸.
        let far = ProbeRecord {
            depth: 5.5,
            ..probe
        };
        let w = probe_weight(&f, p, 5.0, Vec3::Z, &far);
        assert!((w - 0.9f32.powi(8)).abs() < 1e-5, "{w}");
        // A tilted probe normal: cos⁸ (within the 10-bit packing).
        let n = Vec3::new(0.6, 0.0, 0.8);
        let tilted = ProbeRecord {
            normal: pack_snorm10x3(n),
            ..probe
        };
        let w = probe_weight(&f, p, 5.0, Vec3::Z, &tilted);
        assert!((w - 0.8f32.powi(8)).abs() < 2e-3, "{w}");
        // Off the plane by more than one cell (0.05 at distance 5): zero; within: kept.
        let off = ProbeRecord {
            position: [0.3, 0.2, 0.06],
            ..probe
        };
        assert_eq!(probe_weight(&f, p, 5.0, Vec3::Z, &off), 0.0);
        let near = ProbeRecord {
            position: [0.3, 0.2, 0.04],
            ..probe
        };
        assert!(probe_weight(&f, p, 5.0, Vec3::Z, &near) > 0.99);
        // Facing away, invalid, or no depth: zero.
        let away = ProbeRecord {
            normal: pack_snorm10x3(Vec3::NEG_Z),
            ..probe
        };
        assert_eq!(probe_weight(&f, p, 5.0, Vec3::Z, &away), 0.0);
        assert_eq!(probe_weight(&f, p, 5.0, Vec3::Z, &ProbeRecord::NONE), 0.0);
        assert_eq!(probe_weight(&f, p, 0.0, Vec3::Z, &probe), 0.0);
        assert_eq!(probe_weight(&f, Vec3::NAN, 5.0, Vec3::Z, &probe), 0.0);
    }

    #[test]
    fn the_closest_probe_is_found_through_the_mip_chain() {
        let f = frame();
        let (depth, normals) = gbuffer(W);
        // A single probe in tile (3, 2) (index 11).
        let seed = UVec2::new(26, 19);
        let (_, mask, _) = probes(&f, &depth, &normals, &[(11, seed, 1.0)]);
        assert_eq!(
            nearest_probe_seed(&mask, f.probe_grid, UVec2::new(3, 2)),
            pack_seed(seed)
        );
        // Tile (0, 0) finds it only at the 1 × 1 top mip.
        assert_eq!(
            nearest_probe_seed(&mask, f.probe_grid, UVec2::new(0, 0)),
            pack_seed(seed)
        );
        let empty = vec![NO_PROBE; mask.len()];
        assert_eq!(
            nearest_probe_seed(&empty, f.probe_grid, UVec2::new(1, 1)),
            NO_PROBE
        );
        assert_eq!(gather_probes(&f, &empty, UVec2::new(9, 9)).count, 0);
    }

    #[test]
    fn neighbours_are_taken_toward_the_pixel() {
        let f = frame();
        let (depth, normals) = gbuffer(W);
        let mut list = Vec::new();
        for ty in 0..3 {
            for tx in 0..4 {
                list.push((ty * 4 + tx, UVec2::new(tx * 8 + 4, ty * 8 + 4), 1.0));
            }
        }
        let (_, mask, _) = probes(&f, &depth, &normals, &list);
        let seed_of = |tx: u32, ty: u32| pack_seed(UVec2::new(tx * 8 + 4, ty * 8 + 4));
        // Right of and below the seed of tile (1, 1): +x, +y and the diagonal.
        let s = gather_probes(&f, &mask, UVec2::new(13, 14));
        assert_eq!(
            s.seeds,
            [seed_of(1, 1), seed_of(2, 1), seed_of(1, 2), seed_of(2, 2)]
        );
        // Left of and above it.
        let s = gather_probes(&f, &mask, UVec2::new(9, 10));
        assert_eq!(
            s.seeds,
            [seed_of(1, 1), seed_of(0, 1), seed_of(1, 0), seed_of(0, 0)]
        );
        // At the image corner the neighbours outside are left out.
        let s = gather_probes(&f, &mask, UVec2::new(1, 1));
        assert_eq!(s.count, 1);
        // Duplicates are not added twice.
        let mut grid = ProbeSet::EMPTY;
        for v in [5, 5, NO_PROBE, 7, 5, 8, 9, 10] {
            grid.insert(v);
        }
        assert_eq!((grid.count, grid.seeds), (4, [5, 7, 8, 9]));
    }

    #[test]
    fn jitter_stays_within_its_radius_and_on_the_plane() {
        let mut f = frame();
        assert_eq!(jitter_candidate(&f, UVec2::new(5, 5)), None);
        // Each radius (the largest clamped to the limit) reaches every offset within it, and no
        // farther.
        for (radius, reach) in [
            (1, 1),
            (16, 16),
            (u32::MAX, MAX_INTERPOLATION_JITTER_PIXELS),
        ] {
            let r = reach as i32;
            f.interpolation_jitter = radius;
            let mut seen = vec![false; 2 * reach as usize + 1];
            for frame_index in 0..1024 {
                f.frame_index = frame_index;
                for p in [UVec2::new(0, 0), UVec2::new(16, 12), UVec2::new(31, 23)] {
                    let [dx, dy] = jitter_offset(p, frame_index, radius);
                    assert!((-r..=r).contains(&dx) && (-r..=r).contains(&dy));
                    seen[(dx + r) as usize] = true;
                    if let Some(c) = jitter_candidate(&f, p) {
                        assert!(c.x < W && c.y < H);
                        assert_eq!(c.x as i32 - p.x as i32, dx);
                    }
                }
            }
            assert!(
                seen.iter().all(|&s| s),
                "radius {radius}: every offset occurs"
            );
        }
        f.interpolation_jitter = 16;
        // On the wall every candidate is accepted; across the step (1 unit off the plane) none.
        let (depth, normals) = gbuffer(16);
        let a = surface_at(&depth, &normals, UVec2::new(4, 4));
        assert!(accepts_jitter(
            &f,
            &a,
            &surface_at(&depth, &normals, UVec2::new(12, 9))
        ));
        assert!(!accepts_jitter(
            &f,
            &a,
            &surface_at(&depth, &normals, UVec2::new(20, 9))
        ));
        let sky = PrimarySurface { valid: false, ..a };
        assert!(!accepts_jitter(&f, &a, &sky));
    }

    #[test]
    fn irradiance_is_the_weighted_mean_of_the_probes() {
        let mut f = frame();
        let (depth, normals) = gbuffer(W);
        // Four probes around pixel (13, 14) with radiance 1, 2, 3, 4: all weights 1 on the wall.
        let list = [
            (5, UVec2::new(12, 12), 1.0),
            (6, UVec2::new(20, 12), 2.0),
            (9, UVec2::new(12, 20), 3.0),
            (10, UVec2::new(20, 20), 4.0),
        ];
        let (records, mask, sh) = probes(&f, &depth, &normals, &list);
        let grid = InterpolationProbes {
            records: &records,
            mask: &mask,
            sh: &sh,
        };
        let p = UVec2::new(13, 14);
        let s = surface_at(&depth, &normals, p);
        let d = depth[(p.y * W + p.x) as usize];
        let r = interpolate_pixel(&f, &s, d, &Occlusion::open(s.shading_normal), p, grid);
        // Each probe weighs its screen tent to the pixel (the other weights are 1 on the wall).
        let (sum, weights) = list
            .iter()
            .fold((0.0, 0.0), |(sum, weights), &(_, seed, l)| {
                let w = screen_tent(p, seed);
                (sum + w * l, weights + w)
            });
        let expected = PI * sum / weights;
        assert!(
            expected < PI * 2.2,
            "the nearest probe (1) weighs most: {expected}"
        );
        assert!(
            (r.irradiance[0] - expected).abs() < 1e-3 * expected,
            "{:?}",
            r.irradiance
        );
        assert_eq!(r.irradiance[3], HINT_WEIGHTED);
        assert!(!r.relaxed);
        // A probe on the box face (1 unit in front of the wall) gets no weight.
        let (depth2, _) = gbuffer(16);
        let (records2, mask2, sh2) = probes(
            &f,
            &depth2,
            &normals,
            &[(5, UVec2::new(12, 12), 1.0), (6, UVec2::new(20, 12), 100.0)],
        );
        let grid2 = InterpolationProbes {
            records: &records2,
            mask: &mask2,
            sh: &sh2,
        };
        f.flags = 0;
        let r = interpolate_pixel(&f, &s, d, &Occlusion::open(s.shading_normal), p, grid2);
        assert!(
            (r.irradiance[0] - PI).abs() < 1e-3 * PI,
            "{:?}",
            r.irradiance
        );
    }

    #[test]
    fn the_relaxed_fallback_and_sky() {
        let mut f = frame();
        let (depth, normals) = gbuffer(16);
        // Only a probe on the box face for a pixel on the wall: all weights zero.
        let (records, mask, sh) = probes(&f, &depth, &normals, &[(6, UVec2::new(20, 12), 2.0)]);
        let grid = InterpolationProbes {
            records: &records,
            mask: &mask,
            sh: &sh,
        };
        let p = UVec2::new(10, 10);
        let s = surface_at(&depth, &normals, p);
        let d = depth[(p.y * W + p.x) as usize];
        let r = interpolate_pixel(&f, &s, d, &Occlusion::open(s.shading_normal), p, grid);
        assert_eq!(r.irradiance, [0.0, 0.0, 0.0, HINT_RELAXED]);
        assert!(!r.relaxed);
        f.flags = FLAG_RELAXED_FALLBACK;
        let r = interpolate_pixel(&f, &s, d, &Occlusion::open(s.shading_normal), p, grid);
        assert!(
            (r.irradiance[0] - 2.0 * PI).abs() < 1e-3,
            "{:?}",
            r.irradiance
        );
        assert_eq!(r.irradiance[3], HINT_RELAXED);
        assert!(r.relaxed);
        // The whole image on the CPU: sky pixels, counted relaxed pixels.
        let mut depth_sky = depth.clone();
        depth_sky[0] = 0.0;
        let mut out = vec![[9.0f32; 4]; (W * H) as usize];
        let mut counters = [0u32; GI_COUNTER_WORDS];
        interpolate_image(
            &f,
            &camera(),
            GBufferSlices {
                depth: &depth_sky,
                geometric_normal: &normals,
                shading_normal: &normals,
            },
            grid,
            &mut out,
            &mut counters[..],
        );
        assert_eq!(out[0], SKY_IRRADIANCE);
        let relaxed = out.iter().filter(|v| v[3] == HINT_RELAXED).count() as u32;
        assert_eq!(counters[RELAXED_COUNT], relaxed);
        assert!(relaxed > 0);
        assert!(out.iter().all(|v| v[0].is_finite() && v[0] >= 0.0));
    }
}
