//! BlendScreenProbes: a spawned probe's 64 ray results binned into its cells, blended with its
//! history hemisphere and written, with its record and mask word, into its probe tile.
//!
//! One workgroup of 64 lanes per spawned probe; phases, with a barrier after each (the kernel and
//! [`blend_workgroup`] run the same functions in the same order):
//! 1. lane = ray: [`ray_source`] loads the ray's cell and `[radiance, hit distance]`, and the
//!    ray's cell probability, into workgroup memory (a ray with non-finite or negative radiance,
//!    or one not traced, is dropped);
//! 2. lane = cell: [`gather_rays`] averages the rays that landed in the cell and counts them,
//!    [`super::hysteresis::cell_change`] leaves that mean's relative change from the history in
//!    workgroup memory, and [`cell_estimate`] turns the mean into the cell's new value (guided
//!    rays: weighted by how many landed there against how many its probability expects, so that
//!    a cell the draw missed is an estimate of zero rather than a held history);
//! 3. lane = cell: [`blend_cell`] blends it with the history cell (hysteresis,
//!    [`FLAG_HYSTERESIS`], weighted by how much the probe's other cells changed:
//!    [`super::hysteresis::other_cells`]) or keeps the history cell where no ray landed;
//! 4. lane = cell: a cell still empty takes the radiance backup ([`FLAG_RADIANCE_BACKUP`](super::FLAG_RADIANCE_BACKUP):
//!    `radiance_backup::probe_backup` once per probe, `radiance_backup::backed_up_cell` per lane)
//!    and the lane writes it to the probe tile's atlas cell; lane 0
//!    writes the record ([`spawned_record`]) and the mask's mip-0 word (the seed).
//!
//! The ray radiance is not quantised: workgroup memory holds plain floats and each cell sums its
//! rays in lane order (the reference bins with fixed-point atomics, ×1e4).

use glam::{UVec2, Vec3, Vec4};

use super::LANES;
use super::hemisphere::{UNMAPPED, gather_linked_counted};
use super::hysteresis::{apply_hysteresis, hysteresis_weight};
#[cfg(not(target_arch = "spirv"))]
use super::hysteresis::{cell_change, other_cells};
use super::{
    EMPTY, FLAG_HYSTERESIS, GiFrameParams, PROBE_CELLS, ProbeRay, ProbeRecord, cell_is_filled,
    cell_radiance, make_cell,
};
use crate::camera::CameraParams;
use crate::packing::{pack_seed, pack_snorm10x3, unpack_seed};
use crate::primary_surface::primary_surface;
use crate::world_cache::RayRecord;

/// The record of the probe spawned at packed seed `seed`, from the seed pixel's G-buffer linear
/// `depth` and geometric normal (also used as the shading normal): its surface point (offset off
/// the surface, where its rays start), its packed normal, its seed, its depth and age 0.
/// [`ProbeRecord::NONE`] when the seed pixel sees no surface.
///
/// SampleScreenProbes and BlendScreenProbes both take the probe's hemisphere from this record
/// (`hemisphere::record_frame`), so the cells mean the same directions as in every later pass.
#[inline]
pub fn spawned_record(
    camera: &CameraParams,
    seed: u32,
    depth: f32,
    geometric_normal: Vec4,
) -> ProbeRecord {
    let pixel: UVec2 = unpack_seed(seed);
    let surface = primary_surface(camera, pixel, depth, geometric_normal, geometric_normal);
    if !surface.valid {
        return ProbeRecord::NONE;
    }
    ProbeRecord {
        position: surface.position.to_array(),
        normal: pack_snorm10x3(surface.geometric_normal),
        seed: pack_seed(pixel),
        depth,
        age: 0,
        _pad: 0,
    }
}

/// Whether every component of a ray's radiance is finite and not negative.
#[inline]
fn usable_radiance(r: Vec3) -> bool {
    r.is_finite() && r.x >= 0.0 && r.y >= 0.0 && r.z >= 0.0
}

/// Phase 1, lane = ray: the cell the ray sampled and `[radiance × cosine weight, hit distance]`
/// (the weight: `sh_projection::cosine_weight`, so that the cell's irradiance at the probe's
/// normal does not depend on where in the cell the light arrives), or ([`UNMAPPED`], [`EMPTY`])
/// for a ray to drop: not traced (zero direction), a cell out of range, non-finite or negative
/// radiance or weight, or a negative or NaN hit distance.
#[inline]
pub fn ray_source(ray: ProbeRay, record: RayRecord) -> (u32, [f32; 4]) {
    let radiance = Vec3::from_array(record.ray_radiance) * ray.cosine_weight;
    let traced = Vec3::from_array(ray.direction) != Vec3::ZERO;
    if traced && ray.cell < PROBE_CELLS && usable_radiance(radiance) && ray.hit_distance >= 0.0 {
        (ray.cell, make_cell(radiance, ray.hit_distance))
    } else {
        (UNMAPPED, EMPTY)
    }
}

/// Phase 2, lane = cell `target`: the mean of the rays that landed in it, on its list of
/// `hemisphere::link_mapped` (`heads`, `next`; [`EMPTY`] when none), how many did, and the probability (`probabilities`, per ray) they were drawn with
/// (0: not guided, or no ray), in one pass over the rays.
#[inline]
pub fn gather_rays(
    heads: &[u32; LANES],
    next: &[u32; LANES],
    cells: &[[f32; 4]; LANES],
    probabilities: &[f32; LANES],
    target: u32,
) -> ([f32; 4], u32, f32) {
    let (mean, n, last) = gather_linked_counted(heads, next, cells, target);
    let probability = if last < LANES {
        probabilities[last]
    } else {
        0.0
    };
    (mean, n, probability)
}

/// Phase 2, lane = cell: the cell's new value from the `mean` of the `rays` that landed in it
/// ([`EMPTY`] when none). Rays that each traced their own cell (`guided` false): the mean. Guided
/// rays: the cell's radiance sum over the count its `probability` leads one to expect,
/// `Σ L / (64 p)`, which estimates the cell's radiance without bias whichever cells the draw
/// reached; a cell no ray reached is an estimate of 0 (at the `history`'s hit distance, [`EMPTY`]
/// without history). Keeping the history there instead biased the probe toward what the
/// neighbourhood's history said of the cells guiding sends few rays to.
#[inline]
pub fn cell_estimate(
    guided: bool,
    mean: [f32; 4],
    rays: u32,
    probability: f32,
    history: [f32; 4],
) -> [f32; 4] {
    if !guided {
        return mean;
    }
    if rays == 0 || !cell_is_filled(mean) {
        return if cell_is_filled(history) {
            make_cell(Vec3::ZERO, history[3])
        } else {
            EMPTY
        };
    }
    let expected = PROBE_CELLS as f32 * probability;
    if expected > 0.0 && expected.is_finite() {
        make_cell(cell_radiance(mean) * (rays as f32 / expected), mean[3])
    } else {
        mean
    }
}

/// Phase 3, lane = cell: `new` (the mean of the cell's rays, [`EMPTY`] when none landed) against
/// the `history` cell, `others` the change sums of the probe's other cells
/// ([`super::hysteresis::other_cells`]).
/// Both filled: `new`'s radiance under the hysteresis (with [`FLAG_HYSTERESIS`]; else `new` as
/// is) and `new`'s hit distance. Only one filled: that one.
#[inline]
pub fn blend_cell(
    params: &GiFrameParams,
    new: [f32; 4],
    history: [f32; 4],
    others: [f32; 2],
) -> [f32; 4] {
    if !cell_is_filled(new) {
        return if cell_is_filled(history) {
            history
        } else {
            EMPTY
        };
    }
    if cell_is_filled(history) && params.has(FLAG_HYSTERESIS) {
        let blended = apply_hysteresis(
            cell_radiance(new),
            cell_radiance(history),
            hysteresis_weight(others),
        );
        return make_cell(blended, new[3]);
    }
    new
}

/// The CPU model of one BlendScreenProbes workgroup: the probe's 64 atlas cells from its rays,
/// their per-ray records (`ray_records[spawn × 64 + lane]`) and its history cells. Runs the
/// kernel's phases in order, each over the lanes in lane order.
#[cfg(not(target_arch = "spirv"))]
pub fn blend_workgroup(
    params: &GiFrameParams,
    rays: &[ProbeRay],
    ray_records: &[RayRecord],
    history: &[super::StoredCell],
) -> [[f32; 4]; LANES] {
    let mut mapped = [UNMAPPED; LANES];
    let mut cells = [EMPTY; LANES];
    let mut probabilities = [0.0; LANES];
    for lane in 0..LANES {
        if lane < rays.len() && lane < ray_records.len() {
            (mapped[lane], cells[lane]) = ray_source(rays[lane], ray_records[lane]);
            probabilities[lane] = rays[lane].cell_probability;
        }
    }
    let guided = probabilities[0] > 0.0;
    let mut new = [EMPTY; LANES];
    let mut changes = [[0.0; 2]; LANES];
    let h = |lane: usize| history.get(lane).map_or(EMPTY, |c| c.unpack());
    let (heads, next) = super::hemisphere::linked(&mapped);
    for lane in 0..LANES {
        let (mean, n, p) = gather_rays(&heads, &next, &cells, &probabilities, lane as u32);
        changes[lane] = cell_change(mean, h(lane));
        new[lane] = cell_estimate(guided, mean, n, p, h(lane));
    }
    let mut blended = [EMPTY; LANES];
    for lane in 0..LANES {
        let others = other_cells(&changes, lane as u32);
        blended[lane] = blend_cell(params, new[lane], h(lane), others);
    }
    let backup = super::radiance_backup::probe_backup(params, &blended);
    let mut out = [EMPTY; LANES];
    for lane in 0..LANES {
        out[lane] = super::radiance_backup::backed_up_cell(params, blended[lane], backup);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::screen_probes::{FLAG_HISTORY, FLAG_RADIANCE_BACKUP, MISS_DISTANCE};

    fn ray(cell: u32, hit_distance: f32) -> ProbeRay {
        ProbeRay {
            direction: [0.0, 0.0, 1.0],
            cell,
            hit_distance,
            cell_probability: 0.0,
            cosine_weight: 1.0,
            _pad: 0,
        }
    }

    fn radiance(r: f32) -> RayRecord {
        RayRecord {
            ray_radiance: [r, r * 0.5, r * 0.25],
            ..Default::default()
        }
    }

    fn params(flags: u32) -> GiFrameParams {
        GiFrameParams {
            flags,
            ..Default::default()
        }
    }

    /// Guided rays drawn from a CDF that is wrong about the cells (it favours the dark half)
    /// still give every cell its radiance on average, and the probe its total; a cell no ray
    /// reached reads 0, not its history.
    #[test]
    fn guided_cells_estimate_their_radiance_whichever_cells_the_draw_reaches() {
        use crate::random::Random;
        use crate::screen_probes::ray_guiding::{cell_share, guided_cell};
        let truth = |c: usize| if c % 8 < 2 { 10.0 } else { 0.5 };
        let mut cdf = [0.0f32; 64];
        let mut total = 0.0;
        for (c, v) in cdf.iter_mut().enumerate() {
            total += if c % 8 < 2 { 0.2 } else { 1.0 };
            *v = total;
        }
        let mut rng = Random::new(7, 0);
        let frames = 4000;
        let mut sums = [0.0f64; 64];
        let mut history = [make_cell(Vec3::splat(1.0), 1.0); 64];
        for _ in 0..frames {
            let mut rays = [ray(0, 1.0); 64];
            let mut records = [radiance(0.0); 64];
            for lane in 0..64 {
                let c = guided_cell(&cdf, rng.next_f32() * total);
                rays[lane] = ray(c, 1.0);
                rays[lane].cell_probability = cell_share(&cdf, c);
                records[lane] = radiance(truth(c as usize));
            }
            let out = blend_workgroup(
                &params(0),
                &rays,
                &records,
                &crate::screen_probes::stored_cells(&history),
            );
            for c in 0..64 {
                sums[c] += f64::from(out[c][0]);
            }
            history = out;
        }
        let mut probe = 0.0;
        let mut exact = 0.0;
        for (c, sum) in sums.iter().enumerate() {
            let mean = sum / f64::from(frames);
            let t = f64::from(truth(c));
            assert!((mean - t).abs() < 0.08 * t, "cell {c}: {mean} against {t}");
            probe += mean;
            exact += t;
        }
        assert!(
            (probe / exact - 1.0).abs() < 0.01,
            "{probe} against {exact}"
        );
        // An empty frame keeps nothing of the history: a cell no ray reached reads 0.
        let rays = [ray(3, 1.0); 64].map(|mut r| {
            r.cell_probability = 1.0;
            r
        });
        let history = crate::screen_probes::stored_cells(&history);
        let out = blend_workgroup(&params(0), &rays, &[radiance(1.0); 64], &history);
        assert_eq!(out[5], make_cell(Vec3::ZERO, history[5].unpack()[3]));
        assert!((out[3][0] - 1.0).abs() < 1e-6, "{:?}", out[3]);
    }

    /// The loop SampleScreenProbes and BlendScreenProbes close: rays drawn as the kernel draws
    /// them (`ray_guiding::sample_ray`) from a CDF of the probe's own blended cells, whose
    /// estimates the hysteresis then blends. One small bright cell and a noisy rest (each ray
    /// sees nothing or twice its cell's radiance). Over 40 000 frames the probe keeps its mean
    /// within 1 %, with the hysteresis and without, so the blend is not what makes the frame's
    /// mean depend on where the rays go (README, "Round 12").
    #[test]
    fn guided_rays_under_the_hysteresis_keep_the_probe_mean() {
        use crate::random::Random;
        use crate::screen_probes::FLAG_RAY_GUIDING;
        use crate::screen_probes::hemisphere::ProbeFrame;
        use crate::screen_probes::ray_guiding::{
            guiding_active, guiding_cdf, guiding_raw_weight, sample_ray,
        };
        let truth = |c: u32| match c {
            27 => 40.0,
            _ if c % 8 < 3 => 2.0,
            _ => 0.3,
        };
        let exact: f64 = (0..64).map(|c| f64::from(truth(c))).sum();
        let probe = ProbeFrame {
            position: Vec3::ZERO,
            normal: Vec3::Z,
        };
        for flags in [FLAG_RAY_GUIDING | FLAG_HYSTERESIS, FLAG_RAY_GUIDING] {
            let mut rng = Random::new(7, 0);
            let mut history = [EMPTY; 64];
            let (mut sum, mut frames) = (0.0f64, 0u32);
            for frame_index in 0..40_000 {
                let p = GiFrameParams {
                    flags,
                    frame_index,
                    ..Default::default()
                };
                let raw: [f32; 64] =
                    core::array::from_fn(|c| guiding_raw_weight(history[c], c as u32));
                let cdf: [f32; 64] = core::array::from_fn(|c| guiding_cdf(&raw, c as u32));
                let guided = guiding_active(&p, &cdf);
                let rays: [ProbeRay; 64] = core::array::from_fn(|lane| {
                    sample_ray(&p, &probe, 0, lane as u32, &cdf, guided)
                });
                let records = rays.map(|r| {
                    let seen = if rng.next_f32() < 0.5 { 0.0 } else { 2.0 };
                    radiance(truth(r.cell) * seen)
                });
                history = blend_workgroup(
                    &p,
                    &rays,
                    &records,
                    &crate::screen_probes::stored_cells(&history),
                );
                if frame_index >= 100 {
                    sum += history.iter().map(|c| f64::from(c[0])).sum::<f64>();
                    frames += 1;
                }
            }
            let bias = sum / f64::from(frames) / exact - 1.0;
            eprintln!(
                "hysteresis {}: probe mean {bias:+.4}",
                flags & FLAG_HYSTERESIS != 0
            );
            assert!(bias.abs() < 0.01, "flags {flags}: {bias}");
        }
    }

    /// Light that arrives at grazing angles keeps its irradiance at the probe's normal: rays
    /// through the whole pass (SampleScreenProbes' directions, BlendScreenProbes' binning) over
    /// radiance that lies in a band above the horizon, inside the rim cells. Each cell's value
    /// times its `∫ cos` must sum to `∫ L cos`; without the rays' cosine weight the band read
    /// 4.3 times its irradiance, the patch 2.1 times.
    #[test]
    fn grazing_light_keeps_its_irradiance_at_the_probe_normal() {
        use crate::screen_probes::hemisphere::{CELL_SOLID_ANGLE, ProbeFrame};
        use crate::screen_probes::ray_guiding::sample_ray;
        use crate::screen_probes::sh_projection::cell_mean_cosine;
        let probe = ProbeFrame {
            position: Vec3::ZERO,
            normal: Vec3::new(0.3, -0.5, 0.8).normalize(),
        };
        // (radiance of a world direction, its exact irradiance at the normal)
        let band_top = 0.1f32;
        // A plane through the normal halves the band.
        let side = probe.normal.cross(Vec3::X);
        let cases: [(&str, f64); 3] = [
            ("uniform", core::f64::consts::PI),
            (
                "band cos θ < 0.1",
                core::f64::consts::PI * f64::from(band_top * band_top),
            ),
            (
                "half band",
                core::f64::consts::PI * f64::from(band_top * band_top) / 2.0,
            ),
        ];
        for (name, exact) in cases {
            let light = |d: Vec3| {
                let z = d.dot(probe.normal);
                match name {
                    "uniform" => 1.0,
                    "band cos θ < 0.1" if z < band_top => 1.0,
                    "half band" if z < band_top && d.dot(side) > 0.0 => 1.0,
                    _ => 0.0,
                }
            };
            let mut sums = [0.0f64; 64];
            let frames = 4000;
            for frame_index in 0..frames {
                let p = GiFrameParams {
                    frame_index,
                    ..Default::default()
                };
                let rays: [ProbeRay; 64] = core::array::from_fn(|lane| {
                    sample_ray(&p, &probe, 0, lane as u32, &[0.0; 64], false)
                });
                let records = rays.map(|r| radiance(light(Vec3::from_array(r.direction))));
                let cells = blend_workgroup(&p, &rays, &records, &[]);
                for (sum, cell) in sums.iter_mut().zip(cells) {
                    *sum += f64::from(cell[0]);
                }
            }
            let estimate: f64 = (0..64)
                .map(|c| {
                    sums[c] / f64::from(frames)
                        * f64::from(cell_mean_cosine(c as u32) * CELL_SOLID_ANGLE)
                })
                .sum();
            let error = estimate / exact - 1.0;
            eprintln!("{name}: irradiance {estimate:.5} of {exact:.5} ({error:+.4})");
            assert!(error.abs() < 0.01, "{name}: {error}");
        }
    }

    #[test]
    fn rays_are_binned_into_their_cells() {
        // Lanes 0..4 all sampled cell 10; lane 4 sampled cell 3 and carries a NaN; lane 5 a
        // negative value; lane 6 was not traced; the rest sampled their own cell.
        let mut rays = [ray(0, 1.0); 64];
        let mut records = [radiance(0.0); 64];
        for lane in 0..64u32 {
            rays[lane as usize] = ray(lane, 2.0 + lane as f32);
            records[lane as usize] = radiance(lane as f32);
        }
        for (lane, r) in rays.iter_mut().enumerate().take(4) {
            *r = ray(10, 4.0 * lane as f32);
        }
        rays[4] = ray(3, 1.0);
        records[4].ray_radiance[1] = f32::NAN;
        records[5].ray_radiance[2] = -1.0;
        rays[6].direction = [0.0; 3];
        let history = [EMPTY; 64];
        let out = blend_workgroup(
            &params(0),
            &rays,
            &records,
            &crate::screen_probes::stored_cells(&history),
        );
        // Cell 10: its own ray (lane 10) and lanes 0..4: radiance mean of 0, 1, 2, 3, 10.
        let mean = (0.0 + 1.0 + 2.0 + 3.0 + 10.0) / 5.0;
        let expected = make_cell(
            Vec3::new(1.0, 0.5, 0.25) * mean,
            (0.0 + 4.0 + 8.0 + 12.0 + 12.0) / 5.0,
        );
        for k in 0..4 {
            assert!(
                (out[10][k] - expected[k]).abs() < 1e-5,
                "{:?} vs {expected:?}",
                out[10]
            );
        }
        // Cells 0..=3 lost their rays to cell 10 (lane 4's NaN in cell 3 is dropped); cells 4, 5
        // and 6 lost theirs to cell 3, the negative value and the untraced ray.
        for (c, cell) in out.iter().enumerate().take(7) {
            assert_eq!(*cell, EMPTY, "cell {c}");
        }
        assert_eq!(out[40], make_cell(Vec3::new(40.0, 20.0, 10.0), 42.0));
        // With the backup, the empty cells take the mean of the filled ones at the sky's distance.
        let out = blend_workgroup(
            &params(FLAG_RADIANCE_BACKUP),
            &rays,
            &records,
            &crate::screen_probes::stored_cells(&history),
        );
        assert_eq!(out[0][3], MISS_DISTANCE);
        assert_eq!(out[0], out[6]);
        assert!(out.iter().all(|&c| cell_is_filled(c)));
    }

    #[test]
    fn history_fills_unreached_cells_and_damps_fireflies() {
        let mut rays = [ray(0, 1.0); 64];
        let mut records = [radiance(1.0); 64];
        for lane in 0..64u32 {
            rays[lane as usize] = ray(lane, 1.0);
        }
        // Cell 7 gets no ray (lane 7 went to cell 8); cell 9 a firefly; cell 11 a shadow.
        rays[7] = ray(8, 1.0);
        records[9] = radiance(1000.0);
        records[11] = radiance(0.01);
        let history = [make_cell(Vec3::new(1.0, 0.5, 0.25), 3.0); 64];
        let flags = FLAG_HISTORY | FLAG_HYSTERESIS;
        let out = blend_workgroup(
            &params(flags),
            &rays,
            &records,
            &crate::screen_probes::stored_cells(&history),
        );
        assert_eq!(out[7], history[7]);
        // The other cells held still (cell 9 is left out of its own change; cell 11's shadow
        // counts 0.99 of 62 cells): the firefly is averaged in with weight about 7/8; its
        // distance is the ray's.
        let w = hysteresis_weight([0.99, 62.0]);
        assert!(w > 0.86 && w < 0.875, "{w}");
        let expected = 1000.0 + (1.0 - 1000.0) * w;
        assert!((out[9][0] - expected).abs() < 1e-2, "{:?}", out[9]);
        assert_eq!(out[9][3], 1.0);
        // The lone shadow is averaged in the same way (a probe-wide one passes at once:
        // `hysteresis` tests).
        let w = hysteresis_weight([0.999, 62.0]);
        let expected = 0.01 + (1.0 - 0.01) * w;
        assert!((out[11][0] - expected).abs() < 1e-4, "{:?}", out[11]);
        // Without hysteresis the firefly stays.
        let out = blend_workgroup(
            &params(FLAG_HISTORY),
            &rays,
            &records,
            &crate::screen_probes::stored_cells(&history),
        );
        assert_eq!(out[9][0], 1000.0);
    }

    #[test]
    fn a_record_needs_a_surface() {
        let camera = CameraParams::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 1.0, 32, 32);
        let seed = pack_seed(UVec2::new(16, 16));
        let n = Vec4::new(0.0, 0.0, 1.0, 1.0);
        let r = spawned_record(&camera, seed, 5.0, n);
        assert!(r.is_valid());
        assert_eq!(r.seed, seed);
        assert_eq!(r.depth, 5.0);
        assert!((r.world_position().z + 5.0).abs() < 1e-3, "{r:?}");
        assert!(r.world_position().truncate().length() < 0.2);
        assert!((r.world_normal() - Vec3::Z).length() < 1e-3);
        assert_eq!(spawned_record(&camera, seed, 0.0, n), ProbeRecord::NONE);
        assert_eq!(
            spawned_record(&camera, seed, 5.0, Vec4::ZERO),
            ProbeRecord::NONE
        );
    }
}
