//! The light grid of GI-1.0's light sampling at secondary hits ("build a light grid to help pick
//! the best candidates"), after Capsaicin v1.2's `LightSamplerGridStream`.
//!
//! # Passes
//!
//! 1. **Bounds.** Every secondary hit of the frame is reported with [`report_hit_bounds`]: atomic
//!    min/max of [`ordered_bits`] words ([`LIGHT_GRID_BOUNDS_WORDS`] of them, cleared with
//!    [`clear_hit_bounds`]).
//! 2. **Grid.** One invocation reads them ([`read_hit_bounds`]) and computes the
//!    [`LightGridParams`] ([`light_grid_params`]): cubic cells, [`light_grid_cells_per_axis`]
//!    along the longest axis (at most [`LIGHT_GRID_MAX_CELLS_PER_AXIS`], fewer for fewer lights),
//!    the other axes rounded up. Hits outside the grid use the
//!    nearest border cell.
//! 3. **Build.** Each cell holds [`LIGHT_GRID_RESERVOIRS_PER_CELL`] entries, each a light drawn
//!    by weight (an irradiance estimate over the cell's volume) from the light clusters
//!    ([`crate::light_clusters`]: each light alone up to
//!    [`LIGHT_GRID_MAX_CLUSTERS`](crate::light_clusters::LIGHT_GRID_MAX_CLUSTERS) lights, weighed
//!    by [`light_grid_weight`](crate::light_clusters::light_grid_weight); runs of consecutive
//!    lights beyond, weighed by [`cluster_weight`], a light then drawn inside its cluster by
//!    power). One workgroup of 64 lanes per cell: lane `k` streams over clusters `k`, `k + 64`, …
//!    ([`light_grid_lane`]: a streaming-RIS pick and its weight sum `W_k`), then each lane draws
//!    its entry from the lanes ([`light_grid_entry_from_lanes`]). The cost is `cells × clusters`
//!    weight evaluations (at most 4096 × 256), whatever the light count: 100,000 emissive
//!    triangles, weighed one by one, took 2.4 s of a 2.7 s frame on lavapipe at 320 × 180. The
//!    grid only covers this frame's hits.
//! 4. **Sampling** ("GenerateReservoirs"): [`sample_light_grid`] looks the hit's cell up (the
//!    position jittered by `(u − 0.25) × cell size`), "fast merge": the 64 entries are split in
//!    [`LIGHT_GRID_SEGMENTS`] segments, each collapsed to one candidate, then RIS over those
//!    candidates with target the luminance of the unshadowed diffuse contribution
//!    `albedo/π · Le · cos / pdf` at the hit. It returns one light sample for one shadow ray and
//!    its [`Reservoir`].
//!
//! # Unbiasedness
//!
//! The RIS candidates must come from a *known* source pmf. Each entry is an independent draw
//! (its own random stream) from the cell's mixture
//!
//! `p(l) = (1 − α) · w_c / W · q_l + α / N`, with `W = Σ_c w_c`
//!
//! for light `l` of cluster `c` (`q_l` its share of the cluster,
//! [`member_probability`]; 1 for a light alone) and `α` = [`LIGHT_GRID_DEFENSIVE_FRACTION`]
//! (α = 1 when `W` is zero or not finite): lane `k` picks `c` among its clusters with probability
//! `w_c / W_k`, an entry takes lane `k` with probability `W_k / W`, so it holds `c` with
//! probability `w_c / W`, then draws `l` in it with probability `q_l`; with probability α it
//! takes a uniformly drawn light instead. `W = Σ W_k` is known exactly, so the entry stores
//! `p(l)` itself ([`LightGridEntry::pmf`]). A segment collapses to *one of its entries chosen
//! uniformly*, whose pmf is again `p` — taking the expectation over the random build. RIS with
//! weights `p̂ / (p(l) · pdf)` and `M` = [`LIGHT_GRID_SEGMENTS`] is unbiased as long as each
//! candidate's own (marginal) pmf is the `p` it is weighted with: the estimate is a mean over
//! the candidates, and the expectation of a sum needs no independence. The entries of a cell
//! share the 64 lanes' picks, so the same light repeats among them more often than among
//! independent draws: some variance, for a build 64 times cheaper. (Collapsing a segment by
//! resampling its entries instead would make the candidate's pmf depend on the other entries'
//! lights.) The 64 entries are a cached sample of `p`: a lookup reads 8 of them instead of
//! passing over all lights. Hits that share a cell in a frame share its entries: their estimates
//! are correlated, each is unbiased.
//!
//! The defensive term gives every light a probability of at least `α / N`, so no light with a
//! contribution is missed however badly the weight heuristic rates it — a hit outside the grid
//! (it uses the border cell), a jittered lookup that lands in the neighbouring cell, an
//! environment whose [`LightGridParams::environment_irradiance`] is left at zero, a NaN weight.
//! The talk's culling of lights "when contribution falls below threshold" is not done: culling
//! is what the floor would have to repair, and it does not save the build's pass over all lights.
//!
//! # Samples
//!
//! A sample is the pair (light index, `u`), `u ∈ [0, 1)²` the numbers that place it on the light
//! ([`sample_light`]), drawn as one 32-bit word ([`sample_params_uv`]) so that a stored sample is
//! exactly the one that was evaluated. In that primary sample space the source density is `p(l)`
//! alone and the target is the contribution divided by the light's own sample density, so a
//! sample keeps its meaning at another shading point (world-space ReSTIR re-evaluates it there,
//! [`light_contribution`]). The target uses a triangle's radiance without its emissive texture;
//! the kernel may shade with the textured radiance (the target only steers the choice).

use bytemuck::{Pod, Zeroable};
use glam::{UVec2, UVec3, Vec2, Vec3};

use crate::atomics::{AtomicWords, from_ordered_bits, ordered_bits};
use crate::color::luminance;
use crate::hash::pcg_chain;
use crate::light_clusters::{LightCluster, cluster_weight, member_probability, pick_in_cluster};
use crate::lights::{
    EXACT_DIRECT_LIGHTS, GpuLight, LIGHT_TRIANGLE, LightSample, LightSources, sample_light,
    sample_triangle_light_ray_by_solid_angle,
};
use crate::math::{
    INV_PI, floor, floor_to_i32_clamped, max, min_u32, positive_or_zero, to_u32_clamped,
};
use crate::random::Random;
use crate::reservoir::Reservoir;

/// Most cells along the grid's longest axis.
pub const LIGHT_GRID_MAX_CELLS_PER_AXIS: u32 = 16;
/// Most cells of a grid: the size of the entry buffer is this × [`LIGHT_GRID_RESERVOIRS_PER_CELL`].
pub const LIGHT_GRID_MAX_CELLS: u32 =
    LIGHT_GRID_MAX_CELLS_PER_AXIS * LIGHT_GRID_MAX_CELLS_PER_AXIS * LIGHT_GRID_MAX_CELLS_PER_AXIS;
/// Entries ("reservoirs") per cell, each one light drawn from the cell's distribution.
pub const LIGHT_GRID_RESERVOIRS_PER_CELL: u32 = 64;
/// Cells a grid has per light, about: [`light_grid_cells_per_axis`] gives `N` lights
/// `⌈∛(16 N)⌉` cells along the longest axis, so that 256 lights and more keep the reference's
/// 16³ and fewer lights a coarser grid (17 lights: 7³), whose build costs a twelfth.
pub const LIGHT_GRID_CELLS_PER_LIGHT: u32 = 16;

/// Cells along the grid's longest axis for `light_count` lights: the least `a` with
/// `a³ ≥` [`LIGHT_GRID_CELLS_PER_LIGHT`] `× light_count`, from 1 to
/// [`LIGHT_GRID_MAX_CELLS_PER_AXIS`]. The grid's resolution follows the lights (a cell's entries
/// are drawn from the same few lights wherever it is) and its extent this frame's hits.
#[inline]
pub fn light_grid_cells_per_axis(light_count: u32) -> u32 {
    // Past `MAX_CELLS / CELLS_PER_LIGHT` lights the largest grid it is (no overflow).
    let wanted = min_u32(
        light_count,
        LIGHT_GRID_MAX_CELLS / LIGHT_GRID_CELLS_PER_LIGHT,
    ) * LIGHT_GRID_CELLS_PER_LIGHT;
    let mut a = 1;
    while a < LIGHT_GRID_MAX_CELLS_PER_AXIS && a * a * a < wanted {
        a += 1;
    }
    a
}

/// Most cells a grid for `light_count` lights has ([`light_grid_cells_per_axis`] cubed): what its
/// entry buffer holds, × [`LIGHT_GRID_RESERVOIRS_PER_CELL`].
#[inline]
pub fn light_grid_max_cells(light_count: u32) -> u32 {
    let a = light_grid_cells_per_axis(light_count);
    a * a * a
}
/// Segments of a cell's entries in the fast merge: one candidate each, so this is the number of
/// RIS candidates per lookup (the talk's "random subset (8 in our implementation)").
pub const LIGHT_GRID_SEGMENTS: u32 = 8;
/// Entries per segment.
pub const LIGHT_GRID_SEGMENT_SIZE: u32 = LIGHT_GRID_RESERVOIRS_PER_CELL / LIGHT_GRID_SEGMENTS;
/// Probability that an entry holds a uniformly drawn light rather than the streaming pick: the
/// floor `α / N` on every light's probability (see the [module](self)).
pub const LIGHT_GRID_DEFENSIVE_FRACTION: f32 = 1.0 / 16.0;
/// Lookups jitter the position by `(u − LIGHT_GRID_JITTER_OFFSET) × cell size` per axis, `u`
/// uniform in `[0, 1)`: the reference's offset, which blurs the cell boundaries.
pub const LIGHT_GRID_JITTER_OFFSET: f32 = 0.25;
/// Words of the hit bounds: min x, y, z then max x, y, z, as [`ordered_bits`].
pub const LIGHT_GRID_BOUNDS_WORDS: usize = 6;

/// The grid's header (48 bytes), computed from the hit bounds by [`light_grid_params`].
///
/// | offset | field                    |
/// |--------|--------------------------|
/// | 0      | `origin`                 |
/// | 12     | `cell_size`              |
/// | 16     | `dims`                   |
/// | 28     | `light_count`            |
/// | 32     | `environment_size`       |
/// | 40     | `environment_irradiance` |
/// | 44     | `emissive_multiplier`    |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightGridParams {
    /// World-space minimum corner of cell (0, 0, 0).
    pub origin: [f32; 3],
    /// Edge of the cubic cells.
    pub cell_size: f32,
    /// Cells along x, y and z, each 1 to [`LIGHT_GRID_MAX_CELLS_PER_AXIS`].
    pub dims: [u32; 3],
    /// Number of lights in the light buffer.
    pub light_count: u32,
    /// Width and height of the environment image (zero for none).
    pub environment_size: [u32; 2],
    /// Grid weight of the [`LIGHT_ENVIRONMENT`](crate::lights::LIGHT_ENVIRONMENT) light: an estimate of the irradiance it gives,
    /// e.g. `¼ ∫ luminance(L) dω` over the sphere (exact for a uniform sky).
    pub environment_irradiance: f32,
    /// Factor on the radiance of triangle lights.
    pub emissive_multiplier: f32,
}

impl crate::layout::FloatLayout for LightGridParams {
    const FLOAT_WORDS: &'static [u32] = &[0, 1, 2, 3, 10, 11];
}

impl LightGridParams {
    /// Number of cells.
    #[inline]
    pub fn cell_count(&self) -> u32 {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// Number of entries: [`LightGridParams::cell_count`] × [`LIGHT_GRID_RESERVOIRS_PER_CELL`].
    #[inline]
    pub fn entry_count(&self) -> u32 {
        self.cell_count() * LIGHT_GRID_RESERVOIRS_PER_CELL
    }

    /// The cell holding `p`, clamped to the grid (NaN coordinates count as the grid's first
    /// cell along that axis).
    #[inline]
    pub fn cell_of(&self, p: Vec3) -> UVec3 {
        let q = (p - Vec3::from_array(self.origin)) / self.cell_size;
        let axis = |x: f32, n: u32| floor_to_i32_clamped(x, 0, n as i32 - 1) as u32;
        UVec3::new(
            axis(q.x, self.dims[0]),
            axis(q.y, self.dims[1]),
            axis(q.z, self.dims[2]),
        )
    }

    /// Linear index of cell `c`: `x + dims.x · (y + dims.y · z)`.
    #[inline]
    pub fn cell_index(&self, c: UVec3) -> u32 {
        c.x + self.dims[0] * (c.y + self.dims[1] * c.z)
    }

    /// The cell of linear index `index` (inverse of [`LightGridParams::cell_index`]).
    #[inline]
    pub fn cell_coords(&self, index: u32) -> UVec3 {
        let (nx, ny) = (self.dims[0], self.dims[1]);
        UVec3::new(index % nx, (index / nx) % ny, index / (nx * ny))
    }

    /// Minimum corner of cell `c`.
    #[inline]
    pub fn cell_min(&self, c: UVec3) -> Vec3 {
        Vec3::from_array(self.origin) + c.as_vec3() * self.cell_size
    }
}

/// What [`clear_hit_bounds`] writes into each min word: `ordered_bits(+∞)`.
pub const LIGHT_GRID_BOUNDS_MIN_CLEAR: u32 = 0xff80_0000;
/// What [`clear_hit_bounds`] writes into each max word: `ordered_bits(−∞)`.
pub const LIGHT_GRID_BOUNDS_MAX_CLEAR: u32 = 0x007f_ffff;
/// The six words of empty hit bounds (min +∞, max −∞), for a host-side clear.
pub const LIGHT_GRID_BOUNDS_CLEAR: [u32; LIGHT_GRID_BOUNDS_WORDS] = [
    LIGHT_GRID_BOUNDS_MIN_CLEAR,
    LIGHT_GRID_BOUNDS_MIN_CLEAR,
    LIGHT_GRID_BOUNDS_MIN_CLEAR,
    LIGHT_GRID_BOUNDS_MAX_CLEAR,
    LIGHT_GRID_BOUNDS_MAX_CLEAR,
    LIGHT_GRID_BOUNDS_MAX_CLEAR,
];

/// Empties the hit bounds at `words[base .. base + 6]`.
#[inline]
pub fn clear_hit_bounds<W: AtomicWords + ?Sized>(words: &mut W, base: usize) {
    let mut i = 0;
    while i < 3 {
        words.store(base + i, LIGHT_GRID_BOUNDS_MIN_CLEAR);
        words.store(base + 3 + i, LIGHT_GRID_BOUNDS_MAX_CLEAR);
        i += 1;
    }
}

/// Grows the hit bounds at `words[base .. base + 6]` to hold `p`; a point with a non-finite
/// coordinate is ignored.
#[inline]
pub fn report_hit_bounds<W: AtomicWords + ?Sized>(words: &mut W, base: usize, p: Vec3) {
    if !p.is_finite() {
        return;
    }
    let a = p.to_array();
    let mut i = 0;
    while i < 3 {
        let b = ordered_bits(a[i]);
        words.fetch_min(base + i, b);
        words.fetch_max(base + 3 + i, b);
        i += 1;
    }
}

/// The hit bounds (min, max) at `words[base .. base + 6]`; (+∞, −∞) when nothing was reported.
#[inline]
pub fn read_hit_bounds<W: AtomicWords + ?Sized>(words: &W, base: usize) -> (Vec3, Vec3) {
    let at = |i: usize| from_ordered_bits(words.load(base + i));
    (
        Vec3::new(at(0), at(1), at(2)),
        Vec3::new(at(3), at(4), at(5)),
    )
}

/// The grid over the box `[lo, hi]` for `light_count` lights: cubic cells,
/// [`light_grid_cells_per_axis`] along the longest axis, the other axes rounded up. An empty or non-finite box gives one unit cell at the
/// origin (every lookup then uses it: still unbiased, see the [module](self)); a flat or point box
/// gets cells of at least `10⁻⁶ ×` its magnitude. The other fields are copied in.
pub fn light_grid_params(
    lo: Vec3,
    hi: Vec3,
    light_count: u32,
    environment_size: UVec2,
    environment_irradiance: f32,
    emissive_multiplier: f32,
) -> LightGridParams {
    let mut params = LightGridParams {
        origin: [0.0; 3],
        cell_size: 1.0,
        dims: [1; 3],
        light_count,
        environment_size: environment_size.to_array(),
        environment_irradiance,
        emissive_multiplier,
    };
    if !(lo.is_finite() && hi.is_finite() && hi.x >= lo.x && hi.y >= lo.y && hi.z >= lo.z) {
        return params;
    }
    let extent = hi - lo;
    let magnitude = max(lo.abs().max_element(), hi.abs().max_element());
    let cells = light_grid_cells_per_axis(light_count);
    let cell = max(
        extent.max_element() / cells as f32,
        1e-6 * max(magnitude, 1.0),
    );
    let axis = |e: f32| {
        // Ceil, at least one cell, and rounding can never push the longest axis past the maximum.
        let n = to_u32_clamped(-floor(-e / cell));
        min_u32(if n == 0 { 1 } else { n }, cells)
    };
    params.origin = lo.to_array();
    params.cell_size = cell;
    params.dims = [axis(extent.x), axis(extent.y), axis(extent.z)];
    params
}

/// One entry of a cell (8 bytes): a light drawn from the cell's distribution and its probability
/// there.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct LightGridEntry {
    /// Index of the light.
    pub light: u32,
    /// The probability `p(light)` with which any entry of this cell draws it (see the
    /// [module](self)); 0 for an entry of an empty light list.
    pub pmf: f32,
}

impl crate::layout::FloatLayout for LightGridEntry {
    const FLOAT_WORDS: &'static [u32] = &[1];
}

/// Lane `lane`'s share of cell `cell`'s pass over the light clusters for this frame's `seed`
/// (`crate::light_clusters`; one light each up to
/// [`LIGHT_GRID_MAX_CLUSTERS`](crate::light_clusters::LIGHT_GRID_MAX_CLUSTERS) lights): a
/// streaming-RIS pick among clusters `lane`, `lane + 64`, … by [`cluster_weight`], its weight,
/// and the sum of their weights `W_lane` (0 and cluster 0 when they weigh nothing). The `build`
/// kernel runs one workgroup of [`LIGHT_GRID_RESERVOIRS_PER_CELL`] lanes per cell, then
/// [`light_grid_entry_from_lanes`] per lane.
pub fn light_grid_lane(
    params: &LightGridParams,
    lights: &[GpuLight],
    clusters: &[LightCluster],
    cell: u32,
    lane: u32,
    seed: u32,
) -> LanePick {
    let cell_min = params.cell_min(params.cell_coords(cell));
    let mut rng = Random::new(pcg_chain([cell, lane, LANE_STREAM]), seed);
    let mut reservoir = Reservoir::EMPTY;
    let mut weight = 0.0;
    let mut i = lane;
    while (i as usize) < clusters.len() {
        let w = weight_of_cluster(params, lights, clusters, cell_min, i);
        if reservoir.update(i, w, rng.next_f32()) {
            weight = w;
        }
        i += LIGHT_GRID_RESERVOIRS_PER_CELL;
    }
    LanePick {
        cluster: reservoir.sample,
        weight,
        sum: reservoir.w_sum,
    }
}

/// One lane's share of a cell's pass over the clusters ([`light_grid_lane`]), kept in workgroup
/// memory for the entries to draw from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LanePick {
    /// The cluster the lane picked.
    pub cluster: u32,
    /// Its weight for the cell: an entry drawn from it needs no second evaluation.
    pub weight: f32,
    /// The sum of the weights the lane streamed, `W_lane`.
    pub sum: f32,
}

/// Distinguishes the lanes' random streams from the entries'.
const LANE_STREAM: u32 = 0x6c61_6e65;

/// Cluster `i`'s weight for the cell whose minimum corner is `cell_min` (0 when not positive and
/// finite, or out of range).
#[inline]
fn weight_of_cluster(
    params: &LightGridParams,
    lights: &[GpuLight],
    clusters: &[LightCluster],
    cell_min: Vec3,
    i: u32,
) -> f32 {
    if i as usize >= clusters.len() {
        return 0.0;
    }
    cluster_weight(
        &clusters[i as usize],
        lights,
        cell_min,
        params.cell_size,
        params.environment_irradiance,
        params.emissive_multiplier,
    )
}

/// Entry `entry` of cell `cell` from the lanes' picks and weight sums ([`light_grid_lane`]):
/// lane `k` chosen with probability `W_k / W` gives its cluster, so the entry holds cluster `c`
/// with probability `w_c / W` exactly, then a light of it with its share of the cluster
/// ([`pick_in_cluster`]); with probability [`LIGHT_GRID_DEFENSIVE_FRACTION`], a uniformly drawn
/// light instead. Stores that probability (see the [module](self)).
pub fn light_grid_entry_from_lanes(
    params: &LightGridParams,
    lights: &[GpuLight],
    clusters: &[LightCluster],
    cell: u32,
    entry: u32,
    lanes: &[LanePick; LIGHT_GRID_RESERVOIRS_PER_CELL as usize],
    seed: u32,
) -> LightGridEntry {
    let n = min_u32(params.light_count, lights.len() as u32);
    if n == 0 {
        return LightGridEntry::default();
    }
    let mut total = 0.0;
    let mut k = 0;
    while k < LIGHT_GRID_RESERVOIRS_PER_CELL as usize {
        total += lanes[k].sum;
        k += 1;
    }
    let mut rng = Random::new(pcg_chain([cell, entry]), seed);
    let alpha = if total.is_finite() && total > 0.0 {
        LIGHT_GRID_DEFENSIVE_FRACTION
    } else {
        1.0
    };
    // The lane whose share of the total holds `u · W` (the last one with weight where rounding
    // leaves `u · W` past the running sum).
    let target = rng.next_f32() * total;
    let mut cluster = 0;
    let mut cluster_weight = 0.0;
    let mut running = 0.0;
    let mut found = false;
    k = 0;
    while k < LIGHT_GRID_RESERVOIRS_PER_CELL as usize {
        let lane = lanes[k];
        if lane.sum > 0.0 && !found {
            cluster = lane.cluster;
            cluster_weight = lane.weight;
            running += lane.sum;
            found = target < running;
        }
        k += 1;
    }
    let defensive = rng.next_f32() < alpha;
    let light = if defensive {
        min_u32(to_u32_clamped(rng.next_f32() * n as f32), n - 1)
    } else if (cluster as usize) < clusters.len() {
        let c = &clusters[cluster as usize];
        // A lone light draws nothing more (the stream stays as it was before clusters).
        let u = if c.count > 1 { rng.next_f32() } else { 0.0 };
        pick_in_cluster(c, lights, u).0
    } else {
        0
    };
    let light = min_u32(light, n - 1);
    let from_weights = if alpha < 1.0 {
        let c = lights[light as usize].cluster;
        if (c as usize) < clusters.len() {
            // A light of the lane's cluster has the lane's weight; a defensive draw's own
            // cluster is weighed again.
            let w = if !defensive && c == cluster {
                cluster_weight
            } else {
                let cell_min = params.cell_min(params.cell_coords(cell));
                weight_of_cluster(params, lights, clusters, cell_min, c)
            };
            (1.0 - alpha) * w / total * member_probability(&clusters[c as usize], lights, light)
        } else {
            0.0
        }
    } else {
        0.0
    };
    LightGridEntry {
        light,
        pmf: from_weights + alpha / n as f32,
    }
}

/// Every entry of cell `cell`: the lanes, then each entry from them (the CPU's version of the
/// `build` kernel's workgroup).
pub fn build_light_grid_cell(
    params: &LightGridParams,
    lights: &[GpuLight],
    clusters: &[LightCluster],
    cell: u32,
    seed: u32,
) -> [LightGridEntry; LIGHT_GRID_RESERVOIRS_PER_CELL as usize] {
    let lanes: [LanePick; LIGHT_GRID_RESERVOIRS_PER_CELL as usize] = core::array::from_fn(|lane| {
        light_grid_lane(params, lights, clusters, cell, lane as u32, seed)
    });
    core::array::from_fn(|entry| {
        light_grid_entry_from_lanes(params, lights, clusters, cell, entry as u32, &lanes, seed)
    })
}

/// A secondary hit as light sampling shades it: a diffuse surface (the reference forces the
/// material diffuse there).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiffuseHit {
    /// World-space position, already offset off the surface for the shadow ray.
    pub position: Vec3,
    /// Unit normal, facing the side the light is gathered on.
    pub normal: Vec3,
    /// Diffuse albedo.
    pub albedo: Vec3,
}

/// The unshadowed contribution of one light sample at a hit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightContribution {
    /// The light sample (shadow ray, radiance before emissive textures).
    pub sample: LightSample,
    /// `albedo/π · cos / pdf`: times `sample.radiance` (or the textured radiance) it is the
    /// outgoing radiance this sample estimates for its light; zero when the sample is unusable.
    pub weight: Vec3,
    /// RIS target `p̂`: the luminance of `weight × sample.radiance`.
    pub target: f32,
}

/// Samples light `index` with `u` (see [`sample_light`]) from `hit` and evaluates its unshadowed
/// diffuse contribution: the target of the light grid's RIS and of world-space ReSTIR. An index
/// out of range gives nothing.
#[inline]
pub fn light_contribution(
    params: &LightGridParams,
    lighting: LightSources<'_>,
    hit: &DiffuseHit,
    index: u32,
    u: Vec2,
) -> LightContribution {
    let LightSources {
        lights,
        environment,
        environment_cdf,
    } = lighting;
    let light = if index < min_u32(params.light_count, lights.len() as u32) {
        lights[index as usize]
    } else {
        GpuLight::ZERO
    };
    let sample = if light.kind == LIGHT_TRIANGLE {
        // In solid angle: a cache cell's samples by a light (a room's corners, a lamp's
        // surroundings) would otherwise carry `1 / r²` fireflies into every bounce.
        let mut s = sample_triangle_light_ray_by_solid_angle(&light, hit.position, u);
        s.radiance *= params.emissive_multiplier;
        s
    } else {
        sample_light(
            &light,
            hit.position,
            UVec2::from_array(params.environment_size),
            environment,
            environment_cdf,
            u,
        )
    };
    let cosine = hit.normal.dot(sample.direction);
    let mut weight = Vec3::ZERO;
    if cosine > 0.0 && sample.pdf > 0.0 {
        weight = hit.albedo * (INV_PI * cosine / sample.pdf);
    }
    let target = positive_or_zero(luminance(weight * sample.radiance));
    if target == 0.0 {
        weight = Vec3::ZERO;
    }
    LightContribution {
        sample,
        weight,
        target,
    }
}

/// The `u ∈ (0, 1)²` of a sample's 32 random bits: 16 bits per coordinate, at the centre of its
/// `1/65536` interval (a sample packs into one word without loss).
#[inline]
pub fn sample_params_uv(bits: u32) -> Vec2 {
    let scale = 1.0 / 65536.0;
    Vec2::new(
        ((bits >> 16) as f32 + 0.5) * scale,
        ((bits & 0xffff) as f32 + 0.5) * scale,
    )
}

/// What [`sample_light_grid`] chose for one shadow ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightGridSample {
    /// The reservoir: `sample` is the light index, `ucw` the unbiased contribution weight `W`,
    /// `m` the number of candidates. `ucw` = 0 when there is nothing to trace.
    pub reservoir: Reservoir,
    /// The bits that placed the sample on its light ([`sample_params_uv`]).
    pub params: u32,
    /// The chosen sample at the hit; its `target` is `p̂` of the reservoir's sample.
    pub contribution: LightContribution,
    /// Outgoing radiance toward the probe when the shadow ray is unoccluded:
    /// `weight × radiance × W`.
    pub radiance: Vec3,
}

impl LightGridSample {
    /// Nothing to trace.
    pub const NONE: Self = Self {
        reservoir: Reservoir::EMPTY,
        params: 0,
        contribution: LightContribution {
            sample: LightSample {
                direction: Vec3::ZERO,
                radiance: Vec3::ZERO,
                pdf: 0.0,
                ray: crate::ray::Ray {
                    origin: [0.0; 3],
                    t_min: 0.0,
                    direction: [0.0; 3],
                    t_max: 0.0,
                },
                barycentrics: Vec2::ZERO,
            },
            weight: Vec3::ZERO,
            target: 0.0,
        },
        radiance: Vec3::ZERO,
    };
}

/// Light sampling at a secondary hit through the grid (see the [module](self)): jittered cell
/// lookup, fast merge of the cell's entries into [`LIGHT_GRID_SEGMENTS`] candidates, RIS with the
/// unshadowed diffuse contribution as target. `entries` holds the grid's
/// [`LightGridParams::entry_count`] entries, cell after cell.
pub fn sample_light_grid(
    params: &LightGridParams,
    entries: &[LightGridEntry],
    lighting: LightSources<'_>,
    hit: &DiffuseHit,
    rng: &mut Random,
) -> LightGridSample {
    let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32())
        - Vec3::splat(LIGHT_GRID_JITTER_OFFSET);
    let cell = params.cell_index(params.cell_of(hit.position + jitter * params.cell_size));
    let first = cell * LIGHT_GRID_RESERVOIRS_PER_CELL;
    let mut reservoir = Reservoir::EMPTY;
    let mut chosen = LightGridSample::NONE;
    let mut segment = 0;
    while segment < LIGHT_GRID_SEGMENTS {
        let pick = min_u32(
            to_u32_clamped(rng.next_f32() * LIGHT_GRID_SEGMENT_SIZE as f32),
            LIGHT_GRID_SEGMENT_SIZE - 1,
        );
        let at = (first + segment * LIGHT_GRID_SEGMENT_SIZE + pick) as usize;
        let entry = if at < entries.len() {
            entries[at]
        } else {
            LightGridEntry::default()
        };
        let bits = rng.next_u32();
        let c = light_contribution(params, lighting, hit, entry.light, sample_params_uv(bits));
        // Every candidate counts in M, even an unusable one: it was a draw from p.
        let w = if entry.pmf > 0.0 {
            c.target / entry.pmf
        } else {
            0.0
        };
        if reservoir.update(entry.light, w, rng.next_f32()) {
            chosen.params = bits;
            chosen.contribution = c;
        }
        segment += 1;
    }
    finish_sample(reservoir, chosen)
}

/// The sample RIS chose (`chosen`, its contribution and sample bits) with its finalized
/// `reservoir` and radiance; [`LightGridSample::NONE`] (with the reservoir) when nothing usable
/// was drawn.
#[inline]
fn finish_sample(mut reservoir: Reservoir, mut chosen: LightGridSample) -> LightGridSample {
    reservoir.finalize(chosen.contribution.target);
    if reservoir.ucw <= 0.0 {
        return LightGridSample {
            reservoir,
            ..LightGridSample::NONE
        };
    }
    chosen.reservoir = reservoir;
    chosen.radiance =
        chosen.contribution.weight * chosen.contribution.sample.radiance * reservoir.ucw;
    chosen
}

/// Whether a frame with `light_count` lights builds the light grid: only beyond
/// [`EXACT_DIRECT_LIGHTS`], the count the primary hit sums exactly. With fewer, a secondary hit
/// weighs every light itself ([`sample_each_light`]), which costs at most 16 evaluations instead
/// of a grid of up to 4096 cells × 64 entries (the Cornell box's two lights, `balanced`, 320 ×
/// 180, lavapipe: UpdateLightGrid 39 ms of a 110 ms frame with the grid, 0.09 ms without).
#[inline]
pub fn light_grid_needed(light_count: u32) -> bool {
    light_count > EXACT_DIRECT_LIGHTS
}

/// Light sampling at a secondary hit without the grid (at most [`EXACT_DIRECT_LIGHTS`] lights,
/// [`light_grid_needed`]): every light is a candidate `⌈LIGHT_GRID_SEGMENTS / N⌉` times, each
/// with its own point on the light, and RIS with the grid's target picks one. Each candidate
/// counts as a uniformly drawn light (probability `1 / N`), so the estimate is the grid's with a
/// uniform source pmf, stratified over the lights (which only lowers its variance); `M` is the
/// number of candidates. With no lights it returns [`LightGridSample::NONE`].
pub fn sample_each_light(
    params: &LightGridParams,
    lighting: LightSources<'_>,
    hit: &DiffuseHit,
    rng: &mut Random,
) -> LightGridSample {
    let n = min_u32(params.light_count, lighting.lights.len() as u32);
    if n == 0 {
        return LightGridSample::NONE;
    }
    let candidates = n * LIGHT_GRID_SEGMENTS.div_ceil(n);
    let mut reservoir = Reservoir::EMPTY;
    let mut chosen = LightGridSample::NONE;
    let mut i = 0;
    while i < candidates {
        let light = i % n;
        let bits = rng.next_u32();
        let c = light_contribution(params, lighting, hit, light, sample_params_uv(bits));
        if reservoir.update(light, c.target * n as f32, rng.next_f32()) {
            chosen.params = bits;
            chosen.contribution = c;
        }
        i += 1;
    }
    finish_sample(reservoir, chosen)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::environment::distribution_len;
    use crate::light_clusters::{LIGHT_GRID_MAX_CLUSTERS, build_light_clusters};
    use crate::lights::{EMIT_BACK, EMIT_FRONT};
    use crate::math::PI;
    use core::mem::{offset_of, size_of};

    #[test]
    fn layout() {
        use crate::layout::{FloatLayout, float_field_words};
        assert_eq!(
            LightGridEntry::FLOAT_WORDS,
            float_field_words(&[(offset_of!(LightGridEntry, pmf), 1)])
        );
        assert_eq!(
            LightGridParams::FLOAT_WORDS,
            float_field_words(&[
                (offset_of!(LightGridParams, origin), 3),
                (offset_of!(LightGridParams, cell_size), 1),
                (offset_of!(LightGridParams, environment_irradiance), 1),
                (offset_of!(LightGridParams, emissive_multiplier), 1)
            ])
        );
        assert_eq!(size_of::<LightGridParams>(), 48);
        assert_eq!(offset_of!(LightGridParams, origin), 0);
        assert_eq!(offset_of!(LightGridParams, cell_size), 12);
        assert_eq!(offset_of!(LightGridParams, dims), 16);
        assert_eq!(offset_of!(LightGridParams, light_count), 28);
        assert_eq!(offset_of!(LightGridParams, environment_size), 32);
        assert_eq!(offset_of!(LightGridParams, environment_irradiance), 40);
        assert_eq!(offset_of!(LightGridParams, emissive_multiplier), 44);
        assert_eq!(size_of::<LightGridEntry>(), 8);
        assert_eq!(LIGHT_GRID_SEGMENT_SIZE * LIGHT_GRID_SEGMENTS, 64);
    }

    #[test]
    fn sample_params_cover_the_unit_square() {
        assert_eq!(sample_params_uv(0), Vec2::splat(0.5 / 65536.0));
        let top = sample_params_uv(u32::MAX);
        assert!(top.x < 1.0 && top.y < 1.0 && top.x == top.y);
        assert_eq!(
            sample_params_uv(0x8000_4000),
            Vec2::new(0.5, 0.25) + 0.5 / 65536.0
        );
    }

    #[test]
    fn bounds_reduce_and_make_a_grid() {
        let mut words = [0u32; 8];
        clear_hit_bounds(&mut words[..], 2);
        let (lo, hi) = read_hit_bounds(&words[..], 2);
        assert_eq!((lo, hi), (Vec3::INFINITY, Vec3::NEG_INFINITY));
        assert_eq!(words[2..], LIGHT_GRID_BOUNDS_CLEAR);
        assert_eq!(LIGHT_GRID_BOUNDS_MIN_CLEAR, ordered_bits(f32::INFINITY));
        assert_eq!(LIGHT_GRID_BOUNDS_MAX_CLEAR, ordered_bits(f32::NEG_INFINITY));
        // Nothing reported: one unit cell.
        let empty = light_grid_params(lo, hi, 256, UVec2::ZERO, 0.0, 1.0);
        assert_eq!(
            (empty.dims, empty.cell_size, empty.origin),
            ([1; 3], 1.0, [0.0; 3])
        );
        for p in [
            Vec3::new(-1.0, 2.0, 0.5),
            Vec3::new(7.0, 2.5, -0.5),
            Vec3::new(f32::NAN, 100.0, 0.0),
            Vec3::new(0.0, f32::INFINITY, 0.0),
            Vec3::new(3.0, 3.0, 0.0),
        ] {
            report_hit_bounds(&mut words[..], 2, p);
        }
        assert_eq!(words[0..2], [0, 0]);
        let (lo, hi) = read_hit_bounds(&words[..], 2);
        assert_eq!(lo, Vec3::new(-1.0, 2.0, -0.5));
        assert_eq!(hi, Vec3::new(7.0, 3.0, 0.5));
        // 256 lights: the full 16 cells. 8 m along x in 16 cells of 0.5 m; 1 m along y and z in
        // 2 cells.
        let g = light_grid_params(lo, hi, 256, UVec2::new(8, 4), 2.0, 1.0);
        assert_eq!(g.cell_size, 0.5);
        assert_eq!(g.dims, [16, 2, 2]);
        assert_eq!(g.cell_count(), 64);
        assert_eq!(g.entry_count(), 64 * 64);
        assert_eq!(g.cell_of(lo), UVec3::ZERO);
        assert_eq!(g.cell_of(hi), UVec3::new(15, 1, 1));
        assert_eq!(g.cell_of(Vec3::new(0.9, 2.6, 0.0)), UVec3::new(3, 1, 1));
        assert_eq!(g.cell_of(Vec3::splat(-1e30)), UVec3::ZERO);
        assert_eq!(g.cell_of(Vec3::splat(f32::NAN)), UVec3::ZERO);
        for i in 0..g.cell_count() {
            assert_eq!(g.cell_index(g.cell_coords(i)), i);
        }
        // A point box gets a tiny grid of one cell.
        let p = Vec3::new(1e3, 0.0, 0.0);
        let point = light_grid_params(p, p, 1, UVec2::ZERO, 0.0, 1.0);
        assert_eq!(point.dims, [1; 3]);
        assert!(point.cell_size > 0.0 && point.cell_size <= 1e-3);
        // Rounding never gives more than 16 cells along an axis.
        let odd = light_grid_params(
            Vec3::splat(0.1),
            Vec3::new(0.7, 0.3, 0.69999),
            1000,
            UVec2::ZERO,
            0.0,
            1.0,
        );
        assert_eq!(odd.dims[0], 16);
        assert!(odd.dims[2] <= 16 && odd.dims[1] == 6);
    }

    /// The grid's resolution follows the light count: about 16 cells per light, the reference's
    /// 16³ from 256 lights on, never more; the grid's cells never exceed what its entry buffer
    /// holds for that many lights.
    #[test]
    fn the_grid_follows_the_light_count() {
        let cases = [
            (0, 1),
            (1, 3),
            (17, 7),
            (64, 11),
            (255, 16),
            (256, 16),
            (100_000, 16),
            (u32::MAX, 16),
        ];
        for (lights, axis) in cases {
            assert_eq!(light_grid_cells_per_axis(lights), axis, "{lights} lights");
            let a = light_grid_cells_per_axis(lights);
            assert!(a * a * a >= (lights.saturating_mul(LIGHT_GRID_CELLS_PER_LIGHT)).min(4096));
            for (lo, hi) in [
                (Vec3::ZERO, Vec3::new(8.0, 1.0, 1.0)),
                (Vec3::splat(-1e5), Vec3::splat(1e5)),
                (Vec3::ZERO, Vec3::new(1e-3, 7.0, 3.0)),
            ] {
                let g = light_grid_params(lo, hi, lights, UVec2::ZERO, 0.0, 1.0);
                assert_eq!(
                    g.dims.into_iter().max(),
                    Some(axis),
                    "{lights}: {:?}",
                    g.dims
                );
                assert!(g.cell_count() <= light_grid_max_cells(lights));
            }
        }
        assert_eq!(light_grid_max_cells(17), 343);
        assert_eq!(light_grid_max_cells(256), LIGHT_GRID_MAX_CELLS);
    }

    #[test]
    fn concurrent_bounds_match_sequential() {
        use crate::hash_cells::shared_words::SharedWords;
        use core::sync::atomic::{AtomicU32, Ordering};
        let words: Vec<AtomicU32> = LIGHT_GRID_BOUNDS_CLEAR
            .iter()
            .map(|&w| AtomicU32::new(w))
            .collect();
        let points = |t: u32| {
            let mut rng = Random::new(t, 5);
            (0..1000).map(move |_| {
                Vec3::new(
                    rng.next_in(-3.0, 5.0),
                    rng.next_in(-1.0, 1.0),
                    rng.next_in(2.0, 9.0),
                )
            })
        };
        std::thread::scope(|s| {
            for t in 0..4 {
                let mut view = SharedWords(&words);
                s.spawn(move || {
                    for p in points(t) {
                        report_hit_bounds(&mut view, 0, p);
                    }
                });
            }
        });
        let mut sequential = LIGHT_GRID_BOUNDS_CLEAR;
        for t in 0..4 {
            for p in points(t) {
                report_hit_bounds(&mut sequential[..], 0, p);
            }
        }
        let concurrent: Vec<u32> = words.iter().map(|w| w.load(Ordering::SeqCst)).collect();
        assert_eq!(concurrent, sequential);
        let (lo, hi) = read_hit_bounds(&sequential[..], 0);
        assert!(
            lo.cmpge(Vec3::new(-3.0, -1.0, 2.0)).all()
                && lo.cmplt(Vec3::new(-2.9, -0.9, 2.1)).all()
        );
        assert!(
            hi.cmplt(Vec3::new(5.0, 1.0, 9.0)).all() && hi.cmpgt(Vec3::new(4.9, 0.9, 8.9)).all()
        );
    }

    /// A box of 64 point lights on a 4 × 4 × 4 lattice 8 m apart, a spot, a sun, three
    /// triangles (one-sided, double-sided, one facing away) and an environment.
    struct Scene {
        lights: Vec<GpuLight>,
        environment: Vec<[f32; 4]>,
        cdf: Vec<f32>,
        size: UVec2,
    }

    impl Scene {
        fn lighting(&self) -> LightSources<'_> {
            LightSources {
                lights: &self.lights,
                environment: &self.environment,
                environment_cdf: &self.cdf,
            }
        }
    }

    fn scene() -> Scene {
        let mut lights = Vec::new();
        let mut rng = Random::new(3, 0);
        for z in 0..4 {
            for y in 0..4 {
                for x in 0..4 {
                    let p = Vec3::new(x as f32, y as f32, z as f32) * 8.0 + Vec3::splat(-12.0);
                    let c = Vec3::new(rng.next_in(0.5, 3.0), rng.next_in(0.5, 3.0), 1.0);
                    lights.push(GpuLight::point(p, c));
                }
            }
        }
        lights.push(GpuLight::spot(
            Vec3::new(0.5, 3.0, 0.0),
            Vec3::NEG_Y,
            Vec3::splat(20.0),
            0.3,
            0.6,
        ));
        lights.push(GpuLight::directional(
            Vec3::new(0.3, -1.0, 0.2).normalize(),
            Vec3::new(1.0, 0.9, 0.8),
        ));
        let tri = |o: Vec3, sides: u32, flip: bool| {
            let (a, b) = (Vec3::X * 0.6, Vec3::Z * 0.6);
            let v = if flip {
                [o, o + a, o + b]
            } else {
                [o, o + b, o + a]
            };
            GpuLight::triangle(0, 0, v, Vec3::new(4.0, 3.0, 2.0), sides)
        };
        // Above the shading points, emitting down (front is (b − o) × (a − o) = −Y).
        lights.push(tri(Vec3::new(-0.5, 2.0, -0.5), EMIT_FRONT, false));
        lights.push(tri(Vec3::new(1.0, 1.5, 0.5), EMIT_FRONT | EMIT_BACK, true));
        // Emitting up only: nothing reaches the points below.
        lights.push(tri(Vec3::new(0.0, 2.5, 1.0), EMIT_FRONT, true));
        lights.push(GpuLight::ENVIRONMENT);
        // An 8 × 4 sky, brighter toward the top.
        let size = UVec2::new(8, 4);
        let environment: Vec<[f32; 4]> = (0..32)
            .map(|i| {
                let y = (i / 8) as f32;
                let x = (i % 8) as f32;
                [0.4 / (1.0 + y), 0.3 + 0.05 * x, 0.2, 0.0]
            })
            .collect();
        let cdf = distribution(size, &environment);
        Scene {
            lights,
            environment,
            cdf,
            size,
        }
    }

    /// The environment's distribution, built as the host does (luminance × sin θ).
    fn distribution(size: UVec2, texels: &[[f32; 4]]) -> Vec<f32> {
        let (w, h) = (size.x as usize, size.y as usize);
        let mut cdf = vec![0.0f32; distribution_len(size.x, size.y)];
        let mut rows = vec![0.0f64; h];
        for y in 0..h {
            let sin = ((y as f64 + 0.5) / h as f64 * core::f64::consts::PI).sin();
            let first = (h + 1) + y * (w + 1);
            let mut sum = 0.0f64;
            let weights: Vec<f64> = (0..w)
                .map(|x| {
                    let t = texels[y * w + x];
                    f64::from(luminance(Vec3::new(t[0], t[1], t[2]))) * sin
                })
                .collect();
            let total: f64 = weights.iter().sum();
            for x in 0..w {
                cdf[first + x] = (sum / total) as f32;
                sum += weights[x];
            }
            cdf[first + w] = 1.0;
            rows[y] = total;
        }
        let total: f64 = rows.iter().sum();
        let mut sum = 0.0;
        for y in 0..h {
            cdf[y] = (sum / total) as f32;
            sum += rows[y];
        }
        cdf[h] = 1.0;
        cdf
    }

    fn params_for(s: &Scene, hits: &[Vec3]) -> LightGridParams {
        let mut words = LIGHT_GRID_BOUNDS_CLEAR;
        for &p in hits {
            report_hit_bounds(&mut words[..], 0, p);
        }
        let (lo, hi) = read_hit_bounds(&words[..], 0);
        // ¼ ∫ L dω of the sky, roughly.
        light_grid_params(lo, hi, s.lights.len() as u32, s.size, 0.3 * PI, 1.0)
    }

    /// `lights` grouped into at most `capacity` clusters, as the host groups them.
    fn clustered(lights: &[GpuLight], capacity: usize) -> (Vec<GpuLight>, Vec<LightCluster>) {
        let mut lights = lights.to_vec();
        let mut clusters = vec![LightCluster::default(); capacity];
        let count = build_light_clusters(&mut lights, &mut clusters);
        clusters.truncate(count as usize);
        (lights, clusters)
    }

    fn build(
        params: &LightGridParams,
        lights: &[GpuLight],
        capacity: usize,
        seed: u32,
    ) -> Vec<LightGridEntry> {
        let (lights, clusters) = clustered(lights, capacity);
        (0..params.cell_count())
            .flat_map(|cell| build_light_grid_cell(params, &lights, &clusters, cell, seed))
            .collect()
    }

    /// Every light its own cluster.
    const ALONE: usize = LIGHT_GRID_MAX_CLUSTERS as usize;

    /// Exact sum over all lights of each light's unshadowed contribution, each estimated by
    /// sampling that light alone many times (f64), with its standard error.
    fn brute_force(s: &Scene, params: &LightGridParams, hit: &DiffuseHit) -> (f64, f64) {
        let (mut total, mut var) = (0.0f64, 0.0f64);
        let mut rng = Random::new(11, 0);
        for i in 0..s.lights.len() as u32 {
            let n = 20_000;
            let (mut a, mut a2) = (0.0f64, 0.0f64);
            for _ in 0..n {
                let c = light_contribution(params, s.lighting(), hit, i, rng.next_vec2());
                let v = f64::from(luminance(c.weight * c.sample.radiance));
                a += v;
                a2 += v * v;
            }
            let mean = a / n as f64;
            total += mean;
            var += (a2 / n as f64 - mean * mean).max(0.0) / n as f64;
        }
        (total, var.sqrt())
    }

    fn hits() -> [DiffuseHit; 3] {
        [
            DiffuseHit {
                position: Vec3::ZERO,
                normal: Vec3::Y,
                albedo: Vec3::splat(0.8),
            },
            DiffuseHit {
                position: Vec3::new(1.3, 0.2, 0.9),
                normal: Vec3::new(0.3, 1.0, -0.2).normalize(),
                albedo: Vec3::new(0.9, 0.5, 0.3),
            },
            DiffuseHit {
                position: Vec3::new(-0.8, 0.6, 1.7),
                normal: Vec3::X,
                albedo: Vec3::splat(0.5),
            },
        ]
    }

    /// Estimates `f` over `builds` independent builds of the grid, `per_build` lookups each:
    /// the mean, its standard error (from the per-build means: lookups into one build are
    /// correlated) and the variance of one lookup.
    fn over_builds(
        params: &LightGridParams,
        lights: &[GpuLight],
        capacity: usize,
        builds: u32,
        per_build: u32,
        mut f: impl FnMut(&[LightGridEntry]) -> f32,
    ) -> (f64, f64, f64) {
        let (mut all, mut all2, mut means) = (0.0f64, 0.0f64, Vec::new());
        for b in 0..builds {
            let entries = build(params, lights, capacity, b);
            let mut sum = 0.0f64;
            for _ in 0..per_build {
                let v = f64::from(f(&entries));
                assert!(v.is_finite() && v >= 0.0, "{v}");
                sum += v;
                all2 += v * v;
            }
            all += sum;
            means.push(sum / per_build as f64);
        }
        let n = f64::from(builds * per_build);
        let mean = all / n;
        let between = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / f64::from(builds - 1);
        (
            mean,
            (between / f64::from(builds)).sqrt(),
            all2 / n - mean * mean,
        )
    }

    /// Mean and standard error of `n` luminance estimates.
    fn stats(n: u32, mut f: impl FnMut(u32) -> f32) -> (f64, f64) {
        let (mut a, mut a2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let v = f64::from(f(i));
            assert!(v.is_finite() && v >= 0.0, "{v}");
            a += v;
            a2 += v * v;
        }
        let mean = a / n as f64;
        (
            mean,
            ((a2 / n as f64 - mean * mean).max(0.0) / n as f64).sqrt(),
        )
    }

    /// The grid-RIS estimate, averaged over fresh builds and lookups, is the brute-force sum over
    /// all lights at each shading point: with every light its own cluster, and with the 70
    /// lights in 16 clusters (of up to 6 lights; the triangles in one).
    #[test]
    fn grid_sampling_is_unbiased() {
        let s = scene();
        let hs = hits();
        let points: Vec<Vec3> = hs.iter().map(|h| h.position).collect();
        let params = params_for(&s, &points);
        assert!(params.cell_count() > 1);
        for (k, hit) in hs.iter().enumerate() {
            let (exact, exact_se) = brute_force(&s, &params, hit);
            for capacity in [ALONE, 16] {
                let mut rng = Random::new(100 + k as u32, 0);
                // Clusters make builds differ more (a build may hold few entries of the spot,
                // which shares its cluster with far lights): more of them, fewer lookups each.
                let (builds, lookups) = if capacity == ALONE {
                    (40, 5_000)
                } else {
                    (200, 1_000)
                };
                let (mean, se, _) =
                    over_builds(&params, &s.lights, capacity, builds, lookups, |entries| {
                        let g = sample_light_grid(&params, entries, s.lighting(), hit, &mut rng);
                        assert!(g.radiance.is_finite());
                        luminance(g.radiance)
                    });
                let tol = 4.0 * (se * se + exact_se * exact_se).sqrt();
                println!(
                    "hit {k}, {capacity} clusters: grid {mean:.5} ± {se:.5}, brute force \
                     {exact:.5} ± {exact_se:.5}"
                );
                assert!(
                    (mean - exact).abs() < tol,
                    "hit {k}, {capacity} clusters: {mean} vs {exact} (tol {tol})"
                );
                assert!(se < 0.05 * exact, "{se}");
            }
        }
    }

    /// Many local lights: 400 point lights 6 m apart, 2 m above a 120 m × 120 m floor. The grid's
    /// candidates come from lights near the hit, so at equal candidate count its variance is far
    /// below uniform light selection's.
    #[test]
    fn grid_sampling_beats_uniform_selection_with_many_lights() {
        let mut rng = Random::new(17, 0);
        let lights: Vec<GpuLight> = (0..400)
            .map(|i| {
                let p = Vec3::new(
                    (i % 20) as f32 * 6.0 - 57.0,
                    2.0,
                    (i / 20) as f32 * 6.0 - 57.0,
                );
                GpuLight::point(p, Vec3::splat(rng.next_in(0.5, 2.0)))
            })
            .collect();
        let s = Scene {
            lights,
            environment: Vec::new(),
            cdf: Vec::new(),
            size: UVec2::ZERO,
        };
        let floor: Vec<Vec3> = (0..64)
            .map(|i| {
                Vec3::new(
                    (i % 8) as f32 * 16.0 - 56.0,
                    0.0,
                    (i / 8) as f32 * 16.0 - 56.0,
                )
            })
            .collect();
        let params = params_for(&s, &floor);
        assert_eq!(params.dims[1], 1);
        let hit = DiffuseHit {
            position: Vec3::new(3.3, 0.0, -4.1),
            normal: Vec3::Y,
            albedo: Vec3::splat(0.7),
        };
        let (exact, exact_se) = brute_force(&s, &params, &hit);
        let mut rng = Random::new(5, 0);
        let n = 40_000;
        let count = s.lights.len() as u32;
        let (uniform, uniform_se) = stats(n, |_| {
            let mut r = Reservoir::EMPTY;
            let mut value = 0.0;
            for _ in 0..LIGHT_GRID_SEGMENTS {
                let l = to_u32_clamped(rng.next_f32() * count as f32);
                let c = light_contribution(
                    &params,
                    LightSources {
                        lights: &s.lights,
                        ..LightSources::EMPTY
                    },
                    &hit,
                    l,
                    rng.next_vec2(),
                );
                if r.update(l, c.target * count as f32, rng.next_f32()) {
                    value = c.target;
                }
            }
            r.finalize(value);
            value * r.ucw
        });
        let uniform_var = uniform_se * uniform_se * f64::from(n);
        // 400 lights: in clusters of 2 at the full capacity, of 10 (half a row) with 40.
        for capacity in [ALONE, 40] {
            let (grid, grid_se, grid_var) =
                over_builds(&params, &s.lights, capacity, 200, 400, |entries| {
                    let g = sample_light_grid(
                        &params,
                        entries,
                        LightSources {
                            lights: &s.lights,
                            ..LightSources::EMPTY
                        },
                        &hit,
                        &mut rng,
                    );
                    luminance(g.radiance)
                });
            println!(
                "{capacity} clusters: exact {exact:.4} ± {exact_se:.4}; grid {grid:.4} ± \
                 {grid_se:.4} (variance {grid_var:.5}); uniform {uniform:.4} ± {uniform_se:.4} \
                 (variance {uniform_var:.5})"
            );
            for (mean, se) in [(grid, grid_se), (uniform, uniform_se)] {
                assert!((mean - exact).abs() < 4.0 * (se * se + exact_se * exact_se).sqrt());
            }
            // A cluster draws its lights by power, not by distance: coarser clusters cost
            // variance (0.037 / 0.26 of uniform selection's with 2 / 10 lights per cluster).
            let bound = if capacity == ALONE { 0.1 } else { 0.3 };
            assert!(grid_var < bound * uniform_var, "{capacity} clusters");
        }
    }

    /// No lights, black lights, NaN positions and normals: zero, never NaN.
    #[test]
    fn degenerate_inputs_give_zero() {
        let s = scene();
        let params = params_for(&s, &[Vec3::ZERO, Vec3::ONE]);
        let entries = build(&params, &s.lights, ALONE, 1);
        let empty = LightGridParams {
            light_count: 0,
            ..params
        };
        let none = build(&empty, &[], ALONE, 0);
        assert!(none.iter().all(|e| *e == LightGridEntry::default()));
        let mut rng = Random::new(1, 2);
        let hit = hits()[0];
        let nan = Vec3::splat(f32::NAN);
        for _ in 0..200 {
            let g = sample_light_grid(&empty, &none, LightSources::EMPTY, &hit, &mut rng);
            assert_eq!((g.radiance, g.reservoir.ucw), (Vec3::ZERO, 0.0));
            for bad in [
                DiffuseHit {
                    position: nan,
                    ..hit
                },
                DiffuseHit { normal: nan, ..hit },
                DiffuseHit { albedo: nan, ..hit },
                DiffuseHit {
                    position: Vec3::splat(f32::INFINITY),
                    ..hit
                },
            ] {
                let g = sample_light_grid(&params, &entries, s.lighting(), &bad, &mut rng);
                assert!(
                    !g.radiance.is_nan() && g.reservoir.ucw.is_finite(),
                    "{bad:?}: {g:?}"
                );
            }
        }
        // A NaN light weighs nothing but can still be drawn through the uniform floor.
        let mut black = s.lights.clone();
        for l in &mut black {
            l.intensity = [0.0; 3];
        }
        let black_params = LightGridParams {
            environment_irradiance: 0.0,
            ..params
        };
        for capacity in [ALONE, 8] {
            let (black, clusters) = clustered(&black, capacity);
            for e in build_light_grid_cell(&black_params, &black, &clusters, 0, 0) {
                assert_eq!(e.pmf, 1.0 / black.len() as f32);
            }
            let mut nan_light = s.lights.clone();
            nan_light[3].intensity = [f32::NAN; 3];
            let (nan_light, clusters) = clustered(&nan_light, capacity);
            for e in build_light_grid_cell(&params, &nan_light, &clusters, 0, 0) {
                assert!(e.pmf > 0.0 && e.pmf <= 1.0, "{e:?}");
            }
        }
    }

    /// Every entry's stored probability is the cell's mixture: the light frequencies over many
    /// builds follow it (and each light has at least α/N), with every light its own cluster and
    /// with the 70 lights in 8 clusters.
    #[test]
    fn entries_follow_their_stored_probabilities() {
        let s = scene();
        let params = params_for(&s, &[Vec3::new(-1.0, 0.0, -1.0), Vec3::new(2.0, 1.0, 2.0)]);
        let n = s.lights.len();
        let cell = params.cell_index(params.cell_of(Vec3::ZERO));
        for capacity in [ALONE, 8] {
            let (lights, clusters) = clustered(&s.lights, capacity);
            let mut counts = vec![0u32; n];
            let mut pmf = vec![0.0f32; n];
            // One entry per build: entries of one build share the lanes' picks, so only entries
            // of different builds are independent draws.
            let trials = 100_000;
            for t in 0..trials {
                let e =
                    build_light_grid_cell(&params, &lights, &clusters, cell, t)[(t % 64) as usize];
                counts[e.light as usize] += 1;
                assert!(pmf[e.light as usize] == 0.0 || pmf[e.light as usize] == e.pmf);
                pmf[e.light as usize] = e.pmf;
            }
            let floor = LIGHT_GRID_DEFENSIVE_FRACTION / n as f32;
            let mut chi2 = 0.0;
            let mut seen = 0.0;
            for i in 0..n {
                if counts[i] == 0 {
                    continue;
                }
                assert!(pmf[i] >= floor * 0.999);
                seen += f64::from(pmf[i]);
                let e = f64::from(pmf[i]) * trials as f64;
                chi2 += (f64::from(counts[i]) - e).powi(2) / e;
            }
            // The lights never drawn carry almost no probability; the others fit (p = 0.001 for
            // about 70 degrees of freedom is 112).
            assert!(seen > 0.999, "{capacity} clusters: {seen}");
            assert!(chi2 < 112.0, "{capacity} clusters: chi2 {chi2}");
        }
    }

    /// Without the grid (at most 16 lights), the estimate over every light is the brute-force sum
    /// at each shading point, for 1 and for 10 lights of every kind.
    #[test]
    fn sampling_each_light_is_unbiased() {
        let all = scene();
        for first in [69, 60] {
            let s = Scene {
                lights: all.lights[first..].to_vec(),
                environment: all.environment.clone(),
                cdf: all.cdf.clone(),
                size: all.size,
            };
            assert!(!light_grid_needed(s.lights.len() as u32));
            let hs = hits();
            let points: Vec<Vec3> = hs.iter().map(|h| h.position).collect();
            let params = params_for(&s, &points);
            for (k, hit) in hs.iter().enumerate() {
                let (exact, exact_se) = brute_force(&s, &params, hit);
                let mut rng = Random::new(200 + k as u32, 0);
                let (mean, se) = stats(100_000, |_| {
                    let g = sample_each_light(&params, s.lighting(), hit, &mut rng);
                    assert!(g.radiance.is_finite());
                    luminance(g.radiance)
                });
                let tol = 4.0 * (se * se + exact_se * exact_se).sqrt();
                println!(
                    "{} lights, hit {k}: each light {mean:.5} ± {se:.5}, brute force \
                     {exact:.5} ± {exact_se:.5}",
                    s.lights.len()
                );
                assert!((mean - exact).abs() < tol, "hit {k}: {mean} vs {exact}");
            }
        }
        let none = LightGridParams {
            light_count: 0,
            ..LightGridParams::default()
        };
        let g = sample_each_light(
            &none,
            LightSources::EMPTY,
            &hits()[0],
            &mut Random::new(1, 1),
        );
        assert_eq!((g.radiance, g.reservoir.ucw), (Vec3::ZERO, 0.0));
        assert!(light_grid_needed(EXACT_DIRECT_LIGHTS + 1));
    }
}
