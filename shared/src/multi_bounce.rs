//! Multi-bounce through the world cache: every cache query that takes a light sample also
//! traces one cosine ray from its hit (the bounce ray) and reads the previous frame's filtered
//! radiance of the cell that ray lands in (the way Bevy Solari's world cache and SHaRC sample
//! themselves). The cell's sample becomes `direct + albedo × L(bounce hit)`, so a cell holds the
//! hit's whole reflected light, each bounce one frame older than the last: light keeps bouncing
//! through the cache, not only through the screen (temporal feedback), and light that bounces
//! off-screen is no longer lost.
//!
//! # Cells that only bounce rays reach
//!
//! A cell exists where a query landed, and cells are keyed by the ray's direction bin: a bounce
//! ray leaving a surface the camera does not see often arrives from a bin no probe ray used (40%
//! of the bounce rays in a closed furnace). Such a bounce ray, and one whose cell no query has
//! touched for [`REFRESH_FRAMES`] frames, carries its hit over to the next frame as a query of its
//! own ([`carried_query`], `QUERY_CARRIED`): that query inserts and refreshes the cell with its
//! own light sample and bounce, like any other, and traces no ray into the image. Only the
//! queries of rays carry (a carried query's bounce reads the cache but carries nothing), so the
//! carried list, one query per ray ([`carried_capacity`]), never overflows: which queries are
//! carried never depends on the order the GPU ran them in.

//! # Each light path once
//!
//! A cell holds reflected light only (a query's emission reaches its ray in TraceCacheRays, never
//! the cell), and the query's light sample already samples every emitter and the importance-
//! sampled environment. So the bounce ray adds the cell at its hit and nothing for the emitter it
//! may hit, and a miss adds the sky only where the sky is not a light of the light buffer.
//! Queries lit by temporal feedback take the screen's radiance (all bounces) and trace no bounce
//! ray.
//!
//! # Stability
//!
//! The cache's fixed point is `R = albedo · (direct + R')`: each frame of the running blend moves
//! a cell a share `1/cap` toward it, so the loop's gain per frame is below one whenever albedo is.
//! Albedo enters the bounce clamped to [`MAX_BOUNCE_ALBEDO`], so a white (albedo 1) room keeps a
//! finite radiance (20 × its direct light) instead of growing without bound, and when a light goes
//! off its bounced light decays geometrically instead of lingering. A lookup only ever reads
//! blended, finite cell values ([`crate::world_cache::finite_sample`]).
//!
//! # Light leaks
//!
//! A bounce hit closer than its cell's size (a corner, a wall beside the query) reads no cell
//! there: it takes the query's own cell, on the query's side, as the radiance one cell away
//! (light-leak fix 2, as a probe ray bypasses its cell). Cells still straddle thin walls, and a
//! bounce reads them whatever the short-ray flag: in `scenes/light-leak.gltf` at 64 × 64 (cells of
//! metres) the dark room gets 1.53 × the path tracer's light with multi-bounce, 1.13 × without
//! (`switching_a_technique_off_moves_the_error_the_expected_way`).
//!
//! # Known bias
//!
//! A bounce ray whose cell has no sample yet adds nothing (a bounce miss,
//! [`crate::world_cache::BOUNCE_MISSES`], printed per frame by `gi cache-view`): the first frames
//! after a cell appears. A bounce keys its hit where a query at that hit would be keyed
//! ([`crate::secondary_hits::keyed_hit_point`]); keyed at the raw hit, which rounds to either side
//! of a surface lying on a cell border (a floor at `y = 0`), it read an empty cell beneath the
//! floor every frame, and the indirect room lost 4.8 points of its mean (README, "Round 28"). Each further bounce arrives a frame and a blend later: with a history
//! that never fades a cell blends by samples, not frames, and sparsely sampled cells converged
//! over thousands of frames (the `balanced` GI frame of a 32 × 32 closed furnace of albedo 0.8
//! was 4.9% short after 1280 frames); the presets' fading history
//! ([`crate::hash_cells::update`], 12 frames) brings it within 2.5% after 800.
//!
//! # The bounce copy
//!
//! A bounce reads each cell's bounce copy ([`crate::hash_cells::update::update_bounce_copy`]): the
//! same samples blended with a history of [`crate::hash_cells::BOUNCE_HISTORY_FRAMES`] (2) updates
//! instead of 12, at the level the cell's own history picks. The loop `R = albedo · (direct + R')`
//! then gains a bounce every few frames, not every 12 blends, while the screen's probes read the
//! quieter 12-frame history; both hold the same mean once the light holds, so the converged image
//! does not move. Cost: one more value per cell (16 bytes, 85 per tile) where multi-bounce is on.
//! At 320 × 180, `balanced`, the 64th frame, without → with the copy: the Bitterli staircase
//! −8.5 → −6.3 %, the indirect room −5.0 → −3.5 % (README, "Round 18" with 3 updates, "Round 19"
//! with 2).

use glam::{Vec2, Vec3};

use crate::atomics::AtomicWords;
use crate::hash_cells::layout::{HashCellValue, HashCellsRead};
use crate::hash_cells::purge::tile_age;
use crate::hash_cells::read::bounce_filtered_radiance;
use crate::hash_cells::storage::find_tile;
use crate::lights::sky_radiance;
use crate::path_tracer::sample_folded_cosine;
use crate::ray::{HitRecord, Ray};
use crate::scene_data::{MaterialSample, Surface};
use crate::secondary_hits::{keyed_hit_point, surface_query};
use crate::world_cache::{
    CARRIED_QUERY_BIT, CachePassParams, CacheQuery, FLAG_ENVIRONMENT_LIGHT, NO_TILE, QUERY_CARRIED,
    finite_sample, hit_descriptor, is_bypass,
};

/// A bounce ray whose cell no query touched for this many frames carries its hit over as a query
/// that refreshes it: cells only bounce rays read stay at most this many frames old, at the cost
/// of one carried query per such cell and refresh.
pub const REFRESH_FRAMES: u32 = 4;
/// Queries the carried list holds for a frame of `rays` rays: one per ray (at least 64), since
/// each ray's query carries at most one. Memory: one query (80 bytes) each, plus a query and a
/// shadow ray of the frame's lists.
#[inline]
pub fn carried_capacity(rays: u32) -> u32 {
    if rays < 64 { 64 } else { rays }
}

/// Largest albedo a bounce carries, per channel: bounds the energy of the cache's feedback loop
/// where albedo is near 1 (a closed white room converges to 20 × its direct light, not to
/// infinity). No real material reaches it (fresh snow is about 0.9).
pub const MAX_BOUNCE_ALBEDO: f32 = 0.95;

/// The bounce ray of `query`: a direction of the folded cosine lobe around the query's normals
/// (the path tracer's BSDF sampling), from its offset hit; `u` uniform in `[0, 1)²`. Untraceable
/// when the direction degenerates.
#[inline]
pub fn bounce_ray(query: &CacheQuery, u: Vec2) -> Ray {
    let ng = crate::packing::unpack_snorm10x3(query.geometric_normal);
    let d = sample_folded_cosine(query.shading_normal(), ng, u);
    Ray {
        origin: query.hit_position,
        t_min: 0.0,
        direction: d.to_array(),
        t_max: if d == Vec3::ZERO || !query.position().is_finite() {
            -1.0
        } else {
            f32::INFINITY
        },
    }
}

/// What one bounce ray brought back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounce {
    /// What it adds to the query's cell sample: `albedo × L` (cosine sampling cancels the
    /// Lambertian BRDF's `cos/π` against its density).
    pub radiance: Vec3,
    /// It hit a surface whose cell had no sample (it adds nothing).
    pub missed_cell: bool,
    /// Its hit should be carried over to the next frame ([`carried_query`]): its cell had no
    /// sample, or no query touched it for [`REFRESH_FRAMES`] frames.
    pub carry: bool,
}

/// A bounce ray's closest hit, as the cache reads it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BounceHit {
    /// Its distance along the ray, in world units.
    pub distance: f32,
    /// Where it is keyed: its [`keyed_hit_point`], as its
    /// query would be.
    pub point: Vec3,
}

impl BounceHit {
    /// The closest hit `hit` of `ray` on `surface`, `None` on a miss.
    #[inline]
    pub fn of(ray: &Ray, hit: &HitRecord, surface: &Surface) -> Option<Self> {
        if !hit.is_hit() {
            return None;
        }
        let direction = Vec3::from_array(ray.direction);
        Some(Self {
            distance: hit.t * direction.length(),
            point: keyed_hit_point(direction.normalize_or_zero(), surface),
        })
    }
}

/// The bounce of `query` along `ray` (from [`bounce_ray`]) with closest hit `hit` (`None` on a
/// miss): the previous frame's filtered radiance of the hit's cell (keyed as
/// InsertRadianceCache keys a query: the frame's eye, the ray's direction and, with the
/// short-ray flag, its length), or on a miss the
/// sky where the light sample does not sample it. `keys`, `last_touch` and `values` are the hash
/// grid's, `bounce_values` its bounce copy (read where it holds the cell,
/// [`bounce_filtered_radiance`]); the frame's updates have not run yet, so both hold the previous
/// frame's blend.
#[inline]
pub fn bounce_radiance<K: AtomicWords + ?Sized, T: AtomicWords + ?Sized>(
    cells: HashCellsRead<'_, K, T>,
    bounce_values: &[HashCellValue],
    params: &CachePassParams,
    environment: &[[f32; 4]],
    query: &CacheQuery,
    ray: &Ray,
    hit: Option<BounceHit>,
) -> Bounce {
    let HashCellsRead {
        keys,
        last_touch,
        values,
    } = cells;
    let mut out = Bounce {
        radiance: Vec3::ZERO,
        missed_cell: false,
        carry: false,
    };
    let direction = Vec3::from_array(ray.direction);
    if ray.t_max < 0.0 || direction == Vec3::ZERO {
        return out;
    }
    let albedo = query
        .albedo()
        .clamp(Vec3::ZERO, Vec3::splat(MAX_BOUNCE_ALBEDO));
    let view = &params.view;
    let grid = &params.grid;
    let light = if let Some(BounceHit { distance, point }) = hit {
        let desc = hit_descriptor(params, point, direction.normalize_or_zero(), distance);
        // Light-leak fix 2 for bounce rays: a hit closer than its cell reads no cell there
        // (cells straddle thin walls), but the query's own cell, on the query's side, as the
        // radiance one cell away; only a cell read at the hit is carried or refreshed.
        let short = is_bypass(view, distance, desc.cell_size());
        let (tile, cell) = if short {
            let own = if query.tile == NO_TILE {
                None
            } else {
                Some(query.tile)
            };
            (own, query.cell_xy())
        } else {
            (find_tile(keys, &desc, grid), desc.cell)
        };
        let found = match tile {
            Some(t) => {
                bounce_filtered_radiance(values, bounce_values, t, cell, grid.read_min_samples())
            }
            None => None,
        };
        let stale = match tile {
            Some(t) if (t as usize) < last_touch.word_count() => {
                tile_age(grid.frame_index, last_touch.load(t as usize)) >= REFRESH_FRAMES
            }
            _ => true,
        };
        out.carry = !short && (stale || found.is_none());
        match found {
            Some(l) => l,
            None => {
                out.missed_cell = true;
                Vec3::ZERO
            }
        }
    } else if view.has(FLAG_ENVIRONMENT_LIGHT) {
        Vec3::ZERO
    } else {
        sky_radiance(view.environment_size, view.sky, environment, direction)
    };
    out.radiance = finite_sample(albedo * finite_sample(light));
    out
}

/// The query `parent`'s bounce ray `ray` carries over to the next frame, from its closest hit
/// `hit` shaded as `surface` with `material`: flagged `QUERY_CARRIED`, keyed by its parent's ray
/// (`ray_index` with `CARRIED_QUERY_BIT` set). `None` for a degenerate or non-finite hit.
#[inline]
pub fn carried_query(
    parent: &CacheQuery,
    ray: &Ray,
    hit: &HitRecord,
    surface: &Surface,
    material: &MaterialSample,
) -> Option<CacheQuery> {
    let mut query = surface_query(
        ray,
        hit,
        surface,
        material,
        parent.ray_index | CARRIED_QUERY_BIT,
    )?;
    query.flags = QUERY_CARRIED;
    Some(query)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::hash_cells::layout::HashCellValue;
    use crate::hash_cells::layout::HashGridParams;
    use crate::hash_cells::storage::{TileInsert, insert_tile};
    use crate::hash_cells::{CELLS_PER_TILE, TILE_CELL_RATIO, cell_descriptor, cell_index};
    use crate::packing::{pack_albedo10x3, pack_octahedral16, pack_snorm10x3};
    use crate::world_cache::{CacheFrameParams, NO_TILE};
    use glam::Vec4;

    /// The hash grid of slices as a bounce reads it.
    fn cells<'a>(
        keys: &'a [u32],
        touch: &'a [u32],
        values: &'a [HashCellValue],
    ) -> HashCellsRead<'a, [u32], [u32]> {
        HashCellsRead {
            keys,
            last_touch: touch,
            values,
        }
    }

    fn query(albedo: Vec3) -> CacheQuery {
        CacheQuery {
            hit_position: [0.0, 0.0, 0.0],
            ray_index: 7,
            direction: pack_octahedral16(-Vec3::Y),
            hit_distance: 5.0,
            normal: pack_octahedral16(Vec3::Y),
            geometric_normal: pack_snorm10x3(Vec3::Y),
            albedo: pack_albedo10x3(albedo),
            tile: NO_TILE,
            cell: 0,
            flags: 0,
        }
    }

    fn params() -> CachePassParams {
        let mut grid = HashGridParams::new(Vec3::new(0.0, 3.0, 0.0), 0.01, 4);
        grid.num_buckets_log2 = 6;
        grid.tiles_per_bucket_log2 = 2;
        CachePassParams {
            grid,
            view: CacheFrameParams {
                sky: [0.5, 0.25, 1.0],
                ..Default::default()
            },
        }
    }

    fn hit_at(t: f32) -> HitRecord {
        HitRecord {
            t,
            instance: 0,
            primitive: 0,
            front_face: 1,
            barycentrics: [0.3, 0.3],
            _pad: [0; 2],
        }
    }

    const MISS: HitRecord = HitRecord::miss();

    /// Where `hit_at(2.0)` of a ray up the y axis from the origin lies.
    const HIT_POINT: Vec3 = Vec3::new(0.0, 2.0, 0.0);

    #[test]
    fn bounce_rays_leave_the_upper_hemisphere_from_the_hit() {
        let q = query(Vec3::ONE);
        for i in 0..64 {
            let u = Vec2::new((i % 8) as f32 / 8.0 + 0.03, (i / 8) as f32 / 8.0 + 0.01);
            let ray = bounce_ray(&q, u);
            assert!(ray.t_max > 0.0 && ray.direction[1] > 0.0, "{ray:?}");
            assert_eq!(ray.origin, q.hit_position);
        }
        let mut nan = q;
        nan.hit_position[0] = f32::NAN;
        assert!(bounce_ray(&nan, Vec2::splat(0.5)).t_max < 0.0);
    }

    #[test]
    fn a_hit_reads_the_cell_times_the_clamped_albedo() {
        let p = params();
        let q = query(Vec3::new(0.5, 1.0, 2.0));
        let ray = Ray {
            origin: [0.0, 0.0, 0.0],
            t_min: 0.0,
            direction: [0.0, 1.0, 0.0],
            t_max: f32::INFINITY,
        };
        let tiles = 1usize << (p.grid.num_buckets_log2 + p.grid.tiles_per_bucket_log2);
        let mut keys = vec![0u32; tiles];
        let mut values = vec![HashCellValue::ZERO; tiles * CELLS_PER_TILE as usize];
        // Every tile last touched this frame (frame 4).
        let mut touch = vec![4u32; tiles];
        let read = |keys: &[u32], touch: &[u32], values: &[HashCellValue], q: &CacheQuery| {
            bounce_radiance(
                cells(keys, touch, values),
                &[],
                &p,
                &[],
                q,
                &ray,
                Some(BounceHit {
                    distance: 2.0,
                    point: HIT_POINT,
                }),
            )
        };
        // No tile: a cell miss that adds nothing and is carried over.
        let b = read(&keys, &touch, &values, &q);
        assert_eq!(b.radiance, Vec3::ZERO);
        assert!(b.missed_cell && b.carry);
        // The tile exists but its cell holds no sample: still a miss.
        let desc = cell_descriptor(
            p.grid.eye(),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::Y,
            2.0,
            &p.grid,
        );
        let TileInsert::Inserted(tile) = insert_tile(&mut keys[..], &desc, &p.grid) else {
            panic!("insert failed");
        };
        assert!(read(&keys, &touch, &values, &q).missed_cell);
        // Sixteen samples of 3: the cell answers 3, times the albedo clamped to 0.95.
        let c = cell_index(tile, 0, desc.cell[0], desc.cell[1]) as usize;
        assert!(desc.cell[0] < TILE_CELL_RATIO);
        values[c] = HashCellValue::new(Vec3::splat(48.0), 16.0);
        let b = read(&keys, &touch, &values, &q);
        assert!(!b.missed_cell && !b.carry);
        // (Albedo 0.5 travels as gamma-2 10 bits: within 0.1 %.)
        let expected = Vec3::new(1.5, 3.0 * MAX_BOUNCE_ALBEDO, 3.0 * MAX_BOUNCE_ALBEDO);
        assert!(
            (b.radiance - expected).abs().max_element() < 2e-3,
            "{}",
            b.radiance
        );
        // Touched 3 frames ago it is still fresh; 4 frames ago it is carried to be refreshed,
        // its value still read.
        touch[tile as usize] = 1;
        assert!(!read(&keys, &touch, &values, &q).carry);
        touch[tile as usize] = 0;
        let b = read(&keys, &touch, &values, &q);
        assert!(b.carry && !b.missed_cell && b.radiance.x == 3.0 * q.albedo().x);
        touch[tile as usize] = 4;
        // A cell cannot hold a non-finite value: +∞ saturates.
        values[c] = HashCellValue::new(Vec3::splat(f32::INFINITY), 16.0);
        let b = read(&keys, &touch, &values, &q);
        assert!(
            b.radiance.is_finite() && b.radiance.x > 1e18,
            "{}",
            b.radiance
        );
        // A NaN albedo adds nothing either.
        values[c] = HashCellValue::new(Vec3::splat(48.0), 16.0);
        let bad = query(Vec3::new(f32::NAN, 0.5, 0.5));
        let b = read(&keys, &touch, &values, &bad);
        assert!(b.radiance.is_finite());
    }

    /// A floor at `y = 0` lies on a cell border at every level of detail. Its hit rounds to
    /// either side of it, but a query and a bounce both key the point offset toward the ray's
    /// origin, so the bounce reads the cell the query filled (keyed at the raw hit, half of the
    /// floor's bounces read an empty cell beneath it every frame).
    #[test]
    fn a_bounce_keys_the_cell_its_query_fills_on_a_cell_border() {
        let grey = || MaterialSample {
            base_color: Vec4::splat(0.5),
            emissive: Vec3::ZERO,
        };
        let p = params();
        let down = Vec3::new(0.1, -1.0, 0.2).normalize();
        for (x, z, y) in [(0.3, 0.7, 0.0), (1.5, -2.25, -1e-7), (-0.6, 0.1, 1e-7)] {
            let surface = Surface {
                position: Vec3::new(x, y, z),
                geometric_normal: Vec3::Y,
                shading_normal: Vec3::Y,
                size: 1.0,
                ..Surface::default()
            };
            let t = 2.0;
            let ray = Ray {
                origin: (surface.position - down * t).to_array(),
                t_min: 0.0,
                direction: down.to_array(),
                t_max: f32::INFINITY,
            };
            let BounceHit { distance, point } =
                BounceHit::of(&ray, &hit_at(t), &surface).expect("a hit");
            assert!(point.y > 0.0, "{point}");
            assert_eq!(distance, t);
            let query = surface_query(&ray, &hit_at(t), &surface, &grey(), 0).expect("a query");
            assert_eq!(query.position(), point);
            let keyed = hit_descriptor(&p, point, down, t);
            assert_eq!(
                keyed,
                hit_descriptor(&p, query.position(), query.ray_direction(), t)
            );
            // The raw hit below the floor keys another cell.
            let below = Vec3::new(x, -1e-7, z);
            assert_ne!(keyed, hit_descriptor(&p, below, down, t));
        }
    }

    #[test]
    fn a_miss_sees_the_sky_unless_the_light_sample_does() {
        let mut p = params();
        let q = query(Vec3::splat(0.5));
        let ray = bounce_ray(&q, Vec2::splat(0.5));
        let keys = vec![0u32; 256];
        let touch = vec![0u32; 256];
        let miss = |p: &CachePassParams, ray: &Ray| {
            bounce_radiance(
                cells(&keys, &touch, &[]),
                &[],
                p,
                &[],
                &q,
                ray,
                BounceHit::of(ray, &MISS, &Surface::default()),
            )
        };
        let b = miss(&p, &ray);
        assert_eq!(b.radiance, Vec3::new(0.5, 0.25, 1.0) * q.albedo());
        assert!((q.albedo() - Vec3::splat(0.5)).abs().max_element() < 1e-3);
        assert!(!b.missed_cell && !b.carry);
        p.view.flags |= FLAG_ENVIRONMENT_LIGHT;
        let b = miss(&p, &ray);
        assert_eq!(b.radiance, Vec3::ZERO);
        // An untraceable ray brings nothing.
        let mut dead = ray;
        dead.t_max = -1.0;
        p.view.flags = 0;
        assert_eq!(miss(&p, &dead).radiance, Vec3::ZERO);
    }

    #[test]
    fn carried_queries_keep_their_parents_ray_and_are_flagged() {
        use crate::world_cache::{CARRIED_QUERY_BIT, QUERY_CARRIED};
        let parent = query(Vec3::splat(0.5));
        let ray = Ray {
            origin: [0.0, 0.0, 0.0],
            t_min: 0.0,
            direction: [0.0, 2.0, 0.0],
            t_max: f32::INFINITY,
        };
        let surface = Surface {
            position: Vec3::new(0.0, 3.0, 0.0),
            geometric_normal: Vec3::Y,
            shading_normal: Vec3::Y,
            size: 1.0,
            ..Default::default()
        };
        let material = MaterialSample {
            base_color: Vec4::new(0.25, 0.5, 0.75, 1.0),
            emissive: Vec3::ZERO,
        };
        let q = carried_query(&parent, &ray, &hit_at(1.5), &surface, &material).unwrap();
        assert_eq!(q.ray_index, 7 | CARRIED_QUERY_BIT);
        assert_eq!(q.flags, QUERY_CARRIED);
        assert_eq!(q.hit_distance, 3.0);
        assert_eq!(q.albedo, pack_albedo10x3(Vec3::new(0.25, 0.5, 0.75)));
        // Normals face the ray's origin; the hit is offset toward it.
        assert_eq!(q.shading_normal(), -Vec3::Y);
        assert!(q.hit_position[1] < 3.0);
        // A degenerate triangle carries nothing.
        let flat = Surface {
            geometric_normal: Vec3::ZERO,
            ..surface
        };
        assert!(carried_query(&parent, &ray, &hit_at(1.5), &flat, &material).is_none());
        assert_eq!(carried_capacity(0), 64);
        assert_eq!(carried_capacity(4096), 4096);
    }
}
