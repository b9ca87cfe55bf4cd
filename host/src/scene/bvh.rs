//! The BVH builder: binned SAH over world-space triangles, into the flat layout of
//! [`gi_shared::bvh`] that the CPU and the software-traversal kernels walk.
//!
//! Splits are chosen among [`SAH_BINS`] bins on each of the three centroid axes. Nodes of more
//! than [`MAX_LEAF_TRIANGLES`] triangles always split; smaller ones become leaves unless a split
//! is cheaper. When every centroid coincides (no bin boundary separates them), or when a split
//! would leave a child too deep to finish within [`BVH_MAX_DEPTH`], the node splits at the
//! object median instead, which bounds the depth of the whole tree (see [`Bvh::build`]).
//!
//! The build runs on all cores (`rayon`): the two subtrees of a node of at least
//! [`PARALLEL_SUBTREE`] triangles are built in parallel, and nodes of at least
//! [`PARALLEL_BINNING`] triangles also gather their bounds and bins in parallel. The result does
//! not depend on the number of threads.
//!
//! Degenerate and NaN triangles are kept (the loader filters them; here they only must not break
//! anything): bounds skip NaN coordinates, NaN centroids land in the first bin, and the traversal
//! never reports a hit on them.

use gi_shared::bvh::{
    BVH_MAX_DEPTH, BVH_MAX_INDEX, BVH_MAX_LEAF_TRIANGLES, BVH_TRIANGLE_MIRRORED, BvhChild, BvhNode,
    BvhTriangle, any_hit, closest_hit,
};
use gi_shared::layout::MAX_STORAGE_BUFFER_BYTES;
use gi_shared::ray::{HitRecord, Ray};
use rayon::prelude::*;

use crate::error::{Error, Result};

/// Bins per axis of the SAH sweep.
pub const SAH_BINS: usize = 16;
/// Most triangles in one leaf.
pub const MAX_LEAF_TRIANGLES: usize = 4;
/// SAH cost of visiting an interior node, relative to [`SAH_TRIANGLE_COST`].
pub const SAH_NODE_COST: f32 = 1.0;
/// SAH cost of one ray/triangle test.
pub const SAH_TRIANGLE_COST: f32 = 1.0;
/// Nodes of at least this many triangles build their two subtrees in parallel.
pub const PARALLEL_SUBTREE: usize = 1 << 12;
/// Nodes of at least this many triangles gather bounds and SAH bins in parallel.
pub const PARALLEL_BINNING: usize = 1 << 15;

const _: () = assert!(MAX_LEAF_TRIANGLES as u32 <= BVH_MAX_LEAF_TRIANGLES);

/// Which instance and which of its mesh's triangles a triangle is (reported in the hit record),
/// and whether the instance mirrors.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TriangleId {
    /// Instance index.
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub primitive: u32,
    /// Whether the instance's transform mirrors (`Instance::is_mirrored`): the traversal then
    /// reports the other face as the front one, as ray queries do.
    pub mirrored: bool,
}

/// What a build produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Nodes ([`BvhNode`]s, each holding two children).
    pub nodes: u32,
    /// Leaves.
    pub leaves: u32,
    /// Depth of the deepest leaf, the root node being at depth 0 and a leaf directly under it at
    /// depth 1 (a tree of a single leaf has depth 0); at most [`BVH_MAX_DEPTH`].
    pub max_depth: u32,
    /// Expected cost of a ray through the root: the sum over subtrees of their surface area
    /// relative to the root's, times [`SAH_NODE_COST`] for interior ones and
    /// [`SAH_TRIANGLE_COST`] per triangle for leaves. Areas count as 1 when the root's area is
    /// zero or not finite.
    pub sah_cost: f32,
}

/// A BVH in the GPU layout: upload `nodes` and `triangles` as two storage buffers.
///
/// An empty scene gives no nodes and no triangles (every ray misses); a GPU upload must then
/// bind a placeholder, since Vulkan buffers cannot be empty.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    /// Nodes; node 0 is the root.
    pub nodes: Vec<BvhNode>,
    /// Triangles in leaf order.
    pub triangles: Vec<BvhTriangle>,
    /// Build statistics.
    pub stats: BvhStats,
}

/// Axis-aligned bounds; `EMPTY` has `min > max`, and growing skips NaN coordinates.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    min: [f32; 3],
    max: [f32; 3],
}

impl Aabb {
    const EMPTY: Self = Self {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    #[inline]
    fn grow_point(&mut self, p: [f32; 3]) {
        self.grow(&Aabb { min: p, max: p });
    }

    /// `f32::min`/`max` return the other operand for NaN, so NaN coordinates are skipped.
    #[inline]
    fn grow(&mut self, b: &Aabb) {
        for a in 0..3 {
            self.min[a] = self.min[a].min(b.min[a]);
            self.max[a] = self.max[a].max(b.max[a]);
        }
    }

    #[inline]
    fn union(mut self, b: &Aabb) -> Self {
        self.grow(b);
        self
    }

    /// Surface area; 0 for an empty box. Infinite for unbounded ones.
    #[inline]
    fn area(&self) -> f32 {
        let d = [
            self.max[0] - self.min[0],
            self.max[1] - self.min[1],
            self.max[2] - self.min[2],
        ];
        if d[0] < 0.0 || d[1] < 0.0 || d[2] < 0.0 {
            return 0.0;
        }
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    }
}

/// A triangle's bounds and centroid, as the builder sorts it.
#[derive(Clone, Copy)]
struct Item {
    bounds: Aabb,
    centroid: [f32; 3],
}

/// How a node's triangle range was split: the left child takes `range[..mid]`.
struct Split {
    mid: usize,
    cost: f32,
}

/// A built subtree before it is laid out.
enum Subtree {
    /// Triangles `start .. start + count` in leaf order.
    Leaf { start: u32, count: u32 },
    /// An interior node with its two children.
    Interior(Box<[(Aabb, Subtree); 2]>),
}

/// A subtree with its bounds and what the statistics need from it.
struct Built {
    bounds: Aabb,
    tree: Subtree,
    leaves: u32,
    /// Depth of its deepest leaf, counted from the root of the whole tree.
    max_depth: u32,
    /// Sum of the areas of its interior nodes, and of its leaves' areas times their counts.
    area_interior: f64,
    area_leaves: f64,
}

/// Levels below a node of `n` triangles when every split is at the object median:
/// `⌈log2 ⌈n / MAX_LEAF_TRIANGLES⌉⌉`.
fn median_levels(n: usize) -> u32 {
    n.div_ceil(MAX_LEAF_TRIANGLES)
        .max(1)
        .next_power_of_two()
        .trailing_zeros()
}

/// The bin of centroid coordinate `c` for bins starting at `lo`, `scale` bins per unit.
/// NaN lands in bin 0 (a saturating cast), infinities clamp to the ends.
#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(SAH_BINS - 1)
}

impl Bvh {
    /// Builds the BVH of `triangles` (world space), `ids[i]` naming triangle `i`.
    ///
    /// Every leaf ends at depth `<=` [`BVH_MAX_DEPTH`], the traversal's limit: a node at depth
    /// `d` with `n` triangles keeps `d + ⌈log2 ⌈n/4⌉⌉ <= BVH_MAX_DEPTH`, taking an SAH split only
    /// when both children still satisfy it and the median split (which always does) otherwise.
    ///
    /// Errors with [`Error::InvalidArgument`] when `ids` and `triangles` differ in length, or
    /// when the node or triangle buffer would exceed the 128 MiB storage-buffer limit.
    pub fn build(triangles: &[[[f32; 3]; 3]], ids: &[TriangleId]) -> Result<Self> {
        Self::build_with_limits(triangles, ids, BVH_MAX_DEPTH, MAX_STORAGE_BUFFER_BYTES)
    }

    /// The closest hit of `ray` (the shared traversal, on the CPU).
    pub fn closest_hit(&self, ray: &Ray) -> HitRecord {
        closest_hit(&self.nodes, &self.triangles, ray)
    }

    /// Whether `ray` hits anything in `[t_min, t_max]` (the shared traversal, on the CPU).
    pub fn any_hit(&self, ray: &Ray) -> bool {
        any_hit(&self.nodes, &self.triangles, ray)
    }

    /// [`Bvh::build`] with the depth and buffer-size limits as parameters, for tests.
    fn build_with_limits(
        triangles: &[[[f32; 3]; 3]],
        ids: &[TriangleId],
        max_depth: u32,
        max_buffer_bytes: usize,
    ) -> Result<Self> {
        if ids.len() != triangles.len() {
            return Err(Error::InvalidArgument {
                name: "ids",
                why: format!(
                    "{} triangle ids for {} triangles",
                    ids.len(),
                    triangles.len()
                ),
            });
        }
        let triangle_bytes = triangles.len() * size_of::<BvhTriangle>();
        if triangle_bytes > max_buffer_bytes || triangles.len() >= BVH_MAX_INDEX as usize {
            return Err(too_big(
                "triangles",
                triangles.len(),
                triangle_bytes,
                max_buffer_bytes,
            ));
        }
        if triangles.is_empty() {
            return Ok(Self::default());
        }

        let items: Vec<Item> = triangles
            .par_iter()
            .map(|v| {
                let mut bounds = Aabb::EMPTY;
                for p in v {
                    bounds.grow_point(*p);
                }
                let centroid = [0, 1, 2].map(|a| 0.5 * (bounds.min[a] + bounds.max[a]));
                Item { bounds, centroid }
            })
            .collect();
        // `order[i]` is the input index of the triangle at leaf position `i`.
        let mut order: Vec<u32> = (0..triangles.len() as u32).collect();
        let builder = Builder {
            items: &items,
            max_depth,
        };
        let root = builder.build(&mut order, 0, 0);
        assert!(
            root.max_depth <= max_depth,
            "BVH depth {} exceeds the limit {max_depth}",
            root.max_depth
        );
        let root_area = root.bounds.area();
        let mut nodes = Vec::new();
        match root.tree {
            Subtree::Leaf { start, count } => nodes.push(BvhNode {
                left: child(&root.bounds, start, count),
                right: BvhChild::EMPTY,
            }),
            Subtree::Interior(children) => {
                lay_out(&children, &mut nodes);
            }
        }
        let node_bytes = nodes.len() * size_of::<BvhNode>();
        if node_bytes > max_buffer_bytes || nodes.len() >= BVH_MAX_INDEX as usize {
            return Err(too_big("nodes", nodes.len(), node_bytes, max_buffer_bytes));
        }
        let mut stats = BvhStats {
            nodes: nodes.len() as u32,
            leaves: root.leaves,
            max_depth: root.max_depth,
            sah_cost: 0.0,
        };
        stats.sah_cost = if root_area > 0.0 && root_area.is_finite() {
            ((f64::from(SAH_NODE_COST) * root.area_interior
                + f64::from(SAH_TRIANGLE_COST) * root.area_leaves)
                / f64::from(root_area)) as f32
        } else {
            // Without a usable root area every subtree weighs 1.
            let interior = f64::from(stats.leaves - 1);
            (f64::from(SAH_NODE_COST) * interior
                + f64::from(SAH_TRIANGLE_COST) * triangles.len() as f64) as f32
        };
        let triangles = order
            .par_iter()
            .map(|&i| {
                let id = ids[i as usize];
                let flags = if id.mirrored {
                    BVH_TRIANGLE_MIRRORED
                } else {
                    0
                };
                BvhTriangle::new(triangles[i as usize], id.instance, id.primitive, flags)
            })
            .collect();
        Ok(Self {
            nodes,
            triangles,
            stats,
        })
    }
}

/// A child record of `bounds` with its reference.
fn child(bounds: &Aabb, index: u32, count: u32) -> BvhChild {
    BvhChild {
        min: bounds.min,
        index,
        max: bounds.max,
        count,
    }
}

/// Appends the node of `children` and then its subtrees, depth first (the left subtree right
/// after its parent); returns the node's index.
fn lay_out(children: &[(Aabb, Subtree); 2], nodes: &mut Vec<BvhNode>) -> u32 {
    let me = nodes.len();
    nodes.push(BvhNode::default());
    let [left, right] = children.each_ref().map(|(bounds, tree)| match tree {
        Subtree::Leaf { start, count } => child(bounds, *start, *count),
        Subtree::Interior(grand) => {
            let index = lay_out(grand, nodes);
            child(bounds, index, 0)
        }
    });
    nodes[me] = BvhNode { left, right };
    me as u32
}

fn too_big(name: &'static str, count: usize, bytes: usize, limit: usize) -> Error {
    Error::InvalidArgument {
        name,
        why: format!(
            "the BVH's {count} {name} take {bytes} bytes, over the {limit}-byte storage-buffer limit; \
             split the scene"
        ),
    }
}

/// The recursive build over one set of triangles.
struct Builder<'a> {
    items: &'a [Item],
    max_depth: u32,
}

impl Builder<'_> {
    /// Builds the subtree of `range` (leaf positions `start ..`) at depth `depth`, reordering
    /// `range` into leaf order.
    fn build(&self, range: &mut [u32], start: usize, depth: u32) -> Built {
        let (bounds, centroids) = self.bounds(range);
        let area = bounds.area();
        let n = range.len();
        let leaf_cost = SAH_TRIANGLE_COST * n as f32;
        let split = match self.sah_split(range, &centroids, area) {
            // The depth invariant: each child can still finish with median splits.
            Some(s) if depth + 1 + median_levels(s.mid.max(n - s.mid)) <= self.max_depth => {
                (n > MAX_LEAF_TRIANGLES || s.cost < leaf_cost).then_some(s.mid)
            }
            _ => (n > MAX_LEAF_TRIANGLES).then(|| {
                median_split(self.items, range, &centroids);
                n / 2
            }),
        };
        let Some(mid) = split else {
            return Built {
                bounds,
                tree: Subtree::Leaf {
                    start: start as u32,
                    count: n as u32,
                },
                leaves: 1,
                max_depth: depth,
                area_interior: 0.0,
                area_leaves: f64::from(area) * n as f64,
            };
        };
        let (left, right) = range.split_at_mut(mid);
        let (l, r) = if n >= PARALLEL_SUBTREE {
            rayon::join(
                || self.build(left, start, depth + 1),
                || self.build(right, start + mid, depth + 1),
            )
        } else {
            (
                self.build(left, start, depth + 1),
                self.build(right, start + mid, depth + 1),
            )
        };
        Built {
            bounds,
            leaves: l.leaves + r.leaves,
            max_depth: l.max_depth.max(r.max_depth),
            area_interior: f64::from(area) + l.area_interior + r.area_interior,
            area_leaves: l.area_leaves + r.area_leaves,
            tree: Subtree::Interior(Box::new([(l.bounds, l.tree), (r.bounds, r.tree)])),
        }
    }

    /// Bounds of the triangles of `range`, and of their centroids.
    fn bounds(&self, range: &[u32]) -> (Aabb, Aabb) {
        let gather = |chunk: &[u32]| {
            let mut b = (Aabb::EMPTY, Aabb::EMPTY);
            for &i in chunk {
                let item = &self.items[i as usize];
                b.0.grow(&item.bounds);
                b.1.grow_point(item.centroid);
            }
            b
        };
        if range.len() >= PARALLEL_BINNING {
            range.par_chunks(PARALLEL_BINNING / 4).map(gather).reduce(
                || (Aabb::EMPTY, Aabb::EMPTY),
                |a, b| (a.0.union(&b.0), a.1.union(&b.1)),
            )
        } else {
            gather(range)
        }
    }

    /// The cheapest binned SAH split of `range` over the three axes, partitioning `range` so
    /// that the left child is `range[..mid]`. `None` when no bin boundary separates the
    /// centroids (or every cost is NaN, from unbounded geometry); `range` is then untouched.
    fn sah_split(&self, range: &mut [u32], centroids: &Aabb, area: f32) -> Option<Split> {
        let mut scales = [0.0f32; 3];
        for (axis, scale) in scales.iter_mut().enumerate() {
            let extent = centroids.max[axis] - centroids.min[axis];
            if extent > 0.0 && extent.is_finite() {
                *scale = SAH_BINS as f32 / extent;
            }
        }
        if scales == [0.0; 3] {
            return None;
        }
        let bins = if range.len() >= PARALLEL_BINNING {
            range
                .par_chunks(PARALLEL_BINNING / 4)
                .map(|chunk| self.bin(chunk, centroids, &scales))
                .reduce(|| [[Bin::EMPTY; SAH_BINS]; 3], merge_bins)
        } else {
            self.bin(range, centroids, &scales)
        };
        // Best (cost, axis, first bin of the right child).
        let mut best: Option<(f32, usize, usize)> = None;
        for axis in 0..3 {
            if scales[axis] == 0.0 {
                continue;
            }
            let bins = &bins[axis];
            // Sweep from the right: the area and count of bins `b..` for each boundary `b`.
            let mut right_area = [0.0f32; SAH_BINS];
            let mut right_count = [0u32; SAH_BINS];
            let mut acc = Bin::EMPTY;
            for b in (1..SAH_BINS).rev() {
                acc.bounds.grow(&bins[b].bounds);
                acc.count += bins[b].count;
                right_area[b] = acc.bounds.area();
                right_count[b] = acc.count;
            }
            let mut left = Bin::EMPTY;
            for b in 1..SAH_BINS {
                left.bounds.grow(&bins[b - 1].bounds);
                left.count += bins[b - 1].count;
                if left.count == 0 || right_count[b] == 0 {
                    continue;
                }
                let cost = SAH_NODE_COST
                    + SAH_TRIANGLE_COST
                        * (left.bounds.area() * left.count as f32
                            + right_area[b] * right_count[b] as f32)
                        / area;
                // `!(cost >= best)` would admit NaN; only a strictly lower number wins.
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, axis, b));
                }
            }
        }
        let (cost, axis, boundary) = best?;
        if cost.is_nan() {
            return None;
        }
        let lo = centroids.min[axis];
        let scale = scales[axis];
        let mid = partition(range, |i| {
            bin_of(self.items[i as usize].centroid[axis], lo, scale) < boundary
        });
        Some(Split { mid, cost })
    }

    /// The SAH bins of `chunk` on each axis with a non-zero `scales` entry.
    fn bin(&self, chunk: &[u32], centroids: &Aabb, scales: &[f32; 3]) -> [[Bin; SAH_BINS]; 3] {
        let mut bins = [[Bin::EMPTY; SAH_BINS]; 3];
        for &i in chunk {
            let item = &self.items[i as usize];
            for axis in 0..3 {
                if scales[axis] != 0.0 {
                    let b = bin_of(item.centroid[axis], centroids.min[axis], scales[axis]);
                    let bin = &mut bins[axis][b];
                    bin.bounds.grow(&item.bounds);
                    bin.count += 1;
                }
            }
        }
        bins
    }
}

/// One SAH bin: the bounds and number of the triangles whose centroid falls in it.
#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

impl Bin {
    const EMPTY: Self = Self {
        bounds: Aabb::EMPTY,
        count: 0,
    };
}

fn merge_bins(mut a: [[Bin; SAH_BINS]; 3], b: [[Bin; SAH_BINS]; 3]) -> [[Bin; SAH_BINS]; 3] {
    for (a, b) in a.iter_mut().flatten().zip(b.iter().flatten()) {
        a.bounds.grow(&b.bounds);
        a.count += b.count;
    }
    a
}

/// Reorders `range` so that the elements satisfying `left` come first; returns their count.
fn partition(range: &mut [u32], left: impl Fn(u32) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..range.len() {
        if left(range[i]) {
            range.swap(i, mid);
            mid += 1;
        }
    }
    mid
}

/// Splits `range` at its middle by centroid along the longest centroid axis (any order when all
/// centroids coincide). NaN centroids sort to one end (`total_cmp`), which keeps this total.
fn median_split(items: &[Item], range: &mut [u32], centroids: &Aabb) {
    let extent = [0, 1, 2].map(|a| centroids.max[a] - centroids.min[a]);
    let mut axis = 0;
    for a in 1..3 {
        if extent[a] > extent[axis] {
            axis = a;
        }
    }
    if extent[axis] > 0.0 {
        range.select_nth_unstable_by(range.len() / 2, |&a, &b| {
            items[a as usize].centroid[axis].total_cmp(&items[b as usize].centroid[axis])
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use gi_shared::bvh::closest_hit_brute_force;
    use gi_shared::random::Random;
    use std::time::Instant;

    /// The crate's PCG stream, with the draws the tests need.
    struct Rng(Random);

    impl Rng {
        fn new(seed: u32) -> Self {
            Self(Random::new(seed, 0))
        }

        fn next_u32(&mut self) -> u32 {
            self.0.next_u32()
        }

        fn range(&mut self, lo: f32, hi: f32) -> f32 {
            self.0.next_in(lo, hi)
        }

        fn vec(&mut self, lo: f32, hi: f32) -> [f32; 3] {
            [self.range(lo, hi), self.range(lo, hi), self.range(lo, hi)]
        }
    }

    fn ids(n: usize) -> Vec<TriangleId> {
        (0..n as u32)
            .map(|i| TriangleId {
                instance: i % 5,
                primitive: i,
                mirrored: i % 5 == 3,
            })
            .collect()
    }

    /// `n` random triangles of size up to `size` around centres in a cube, half of them in a
    /// few dense clusters so that the SAH has something to find.
    fn random_scene(rng: &mut Rng, n: usize, size: f32) -> Vec<[[f32; 3]; 3]> {
        let clusters: Vec<[f32; 3]> = (0..4).map(|_| rng.vec(-8.0, 8.0)).collect();
        (0..n)
            .map(|i| {
                let c = if i % 2 == 0 {
                    rng.vec(-10.0, 10.0)
                } else {
                    let k = clusters[i % clusters.len()];
                    let o = rng.vec(-0.5, 0.5);
                    [k[0] + o[0], k[1] + o[1], k[2] + o[2]]
                };
                [0, 1, 2].map(|_| {
                    let d = rng.vec(-size, size);
                    [c[0] + d[0], c[1] + d[1], c[2] + d[2]]
                })
            })
            .collect()
    }

    /// A ray from the scene's surroundings, most aimed at (or near) one of `scene`'s triangles.
    fn random_ray(rng: &mut Rng, scene: &[[[f32; 3]; 3]]) -> Ray {
        let origin = rng.vec(-15.0, 15.0);
        let jitter = rng.vec(-0.3, 0.3);
        let target = if scene.is_empty() || rng.next_u32().is_multiple_of(4) {
            rng.vec(-8.0, 8.0)
        } else {
            let t = scene[(rng.next_u32() % scene.len() as u32) as usize];
            [0, 1, 2].map(|a| (t[0][a] + t[1][a] + t[2][a]) / 3.0 + jitter[a])
        };
        let len = rng.range(0.1, 2.0);
        Ray {
            origin,
            t_min: 0.0,
            direction: [0, 1, 2].map(|a| (target[a] - origin[a]) * len),
            t_max: if rng.next_u32().is_multiple_of(2) {
                f32::INFINITY
            } else {
                rng.range(0.0, 1.5) / len
            },
        }
    }

    /// Closest hits and any-hits agree with brute force over the same triangles; returns the
    /// number of hits. Differing primitives are only allowed on an exact tie.
    fn assert_agrees_with_brute_force(
        bvh: &Bvh,
        scene: &[[[f32; 3]; 3]],
        rng: &mut Rng,
        rays: usize,
    ) -> usize {
        let mut hits = 0;
        for _ in 0..rays {
            let ray = random_ray(rng, scene);
            let got = bvh.closest_hit(&ray);
            let want = closest_hit_brute_force(&bvh.triangles, &ray);
            if !(got.primitive != want.primitive && got.t == want.t) {
                assert_eq!(got, want, "{ray:?}");
            }
            assert_eq!(bvh.any_hit(&ray), want.is_hit(), "{ray:?}");
            hits += usize::from(want.is_hit());
        }
        hits
    }

    /// The structural invariants: layout, bounds, leaf sizes, depth, each triangle once with its
    /// ids and flags, and statistics that match the tree.
    fn assert_well_formed(bvh: &Bvh, input: &[[[f32; 3]; 3]], ids: &[TriangleId]) {
        let contains = |outer: &BvhChild, min: [f32; 3], max: [f32; 3]| {
            (0..3).all(|a| {
                // Empty (all-NaN) children have no extent to contain.
                min[a] > max[a] || (outer.min[a] <= min[a] && max[a] <= outer.max[a])
            })
        };
        let mut seen = vec![0u32; bvh.triangles.len()];
        let (mut leaves, mut max_depth) = (0, 0);
        let single_leaf = bvh.nodes.len() == 1 && bvh.nodes[0].right == BvhChild::EMPTY;
        if single_leaf {
            assert!(bvh.nodes[0].left.is_leaf());
        }
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, depth)) = stack.pop() {
            let node = &bvh.nodes[i];
            for c in [&node.left, &node.right] {
                if single_leaf && c == &BvhChild::EMPTY {
                    continue;
                }
                if c.is_leaf() {
                    leaves += 1;
                    max_depth = max_depth.max(if single_leaf { 0 } else { depth + 1 });
                    assert!(c.count as usize <= MAX_LEAF_TRIANGLES);
                    for t in c.index..c.index + c.count {
                        seen[t as usize] += 1;
                        let tri = &bvh.triangles[t as usize];
                        let original = input[tri.primitive as usize];
                        let id = ids[tri.primitive as usize];
                        assert_eq!(id.instance, tri.instance);
                        assert_eq!(u32::from(id.mirrored) * BVH_TRIANGLE_MIRRORED, tri.flags);
                        // Vertices bit for bit, in the input's order.
                        assert_eq!(
                            [tri.v0, tri.v1, tri.v2].map(|v| v.map(f32::to_bits)),
                            original.map(|v| v.map(f32::to_bits))
                        );
                        for v in original {
                            for a in 0..3 {
                                let x = v[a];
                                assert!(
                                    x.is_nan() || (c.min[a] <= x && x <= c.max[a]),
                                    "leaf {c:?} of node {i} misses vertex {v:?}"
                                );
                            }
                        }
                    }
                } else {
                    let n = c.index as usize;
                    assert!(n > i && n < bvh.nodes.len());
                    for g in [&bvh.nodes[n].left, &bvh.nodes[n].right] {
                        assert!(contains(c, g.min, g.max), "{c:?} does not contain {g:?}");
                    }
                    stack.push((n, depth + 1));
                }
            }
        }
        assert!(
            seen.iter().all(|&n| n == 1),
            "a triangle is not in exactly one leaf"
        );
        let mut prims: Vec<u32> = bvh.triangles.iter().map(|t| t.primitive).collect();
        prims.sort_unstable();
        assert!(prims.iter().copied().eq(0..input.len() as u32));
        assert_eq!(bvh.stats.nodes as usize, bvh.nodes.len());
        assert_eq!(bvh.stats.leaves, leaves);
        assert_eq!(bvh.stats.max_depth, max_depth);
        assert!(max_depth <= BVH_MAX_DEPTH);
        assert!(bvh.stats.sah_cost.is_finite() && bvh.stats.sah_cost > 0.0);
    }

    #[test]
    fn bvh_agrees_with_brute_force_on_random_scenes() {
        let mut rng = Rng::new(7);
        for (n, size) in [
            (1, 1.0),
            (2, 1.0),
            (5, 1.0),
            (37, 2.0),
            (500, 0.5),
            (3000, 0.3),
        ] {
            let input = random_scene(&mut rng, n, size);
            let ids = ids(n);
            let bvh = Bvh::build(&input, &ids).unwrap();
            assert_well_formed(&bvh, &input, &ids);
            let hits = assert_agrees_with_brute_force(&bvh, &input, &mut rng, 3000);
            assert!(hits > 300, "only {hits} rays hit the {n} triangles");
        }
    }

    /// 10k triangles along a line, each gap 1.5% wider than the last: a binned SAH split can
    /// only cut off the few triangles in the far bins, so without the depth guard the tree is a
    /// long chain (depth 84).
    fn pathological() -> Vec<[[f32; 3]; 3]> {
        let mut x = 0.0f32;
        let mut gap = 1e-30f32;
        (0..10_000)
            .map(|_| {
                x += gap;
                gap *= 1.015;
                [[x, 0.0, 0.0], [x, 1.0, 0.0], [x, 0.0, 1.0]]
            })
            .collect()
    }

    #[test]
    fn depth_stays_within_the_traversal_limit_on_a_pathological_input() {
        let input = pathological();
        assert!(input.iter().flatten().flatten().all(|c| c.is_finite()));
        let ids = ids(input.len());
        let unbounded = Bvh::build_with_limits(&input, &ids, u32::MAX, usize::MAX).unwrap();
        assert!(
            unbounded.stats.max_depth > BVH_MAX_DEPTH,
            "not pathological: depth {}",
            unbounded.stats.max_depth
        );
        let bvh = Bvh::build(&input, &ids).unwrap();
        assert_well_formed(&bvh, &input, &ids);
        // The tightest possible limit holds too: 2500 leaves of 4 need depth ⌈log2 2500⌉ = 12.
        let tight = Bvh::build_with_limits(&input, &ids, 12, usize::MAX).unwrap();
        assert_well_formed(&tight, &input, &ids);
        assert_eq!(tight.stats.max_depth, 12);
        println!(
            "pathological input: depth {} unguarded, {} guarded (SAH cost {} vs {}), 12 at the tightest \
             (SAH cost {})",
            unbounded.stats.max_depth,
            bvh.stats.max_depth,
            unbounded.stats.sah_cost,
            bvh.stats.sah_cost,
            tight.stats.sah_cost
        );
        // Rays along the line, each starting in the plane of triangle `i`: `i` is hit at t = 0.
        let mut rng = Rng::new(8);
        for _ in 0..2000 {
            let i = (rng.next_u32() % input.len() as u32) as usize;
            let ray = Ray {
                origin: [input[i][0][0], 0.25, 0.25],
                t_min: 0.0,
                direction: [1.0, 0.0, 0.0],
                t_max: f32::INFINITY,
            };
            for b in [&bvh, &tight, &unbounded] {
                let hit = b.closest_hit(&ray);
                assert_eq!(hit, closest_hit_brute_force(&b.triangles, &ray));
                assert_eq!((hit.primitive, hit.t), (i as u32, 0.0));
            }
        }
    }

    #[test]
    fn nan_degenerate_and_coincident_triangles_do_not_break_the_build() {
        let mut rng = Rng::new(9);
        let mut input = random_scene(&mut rng, 400, 1.0);
        let nan = f32::NAN;
        input[3][1][2] = nan;
        input[10] = [[nan; 3]; 3];
        input[11] = [[nan; 3]; 3];
        input[20] = [[1.0, 2.0, 3.0]; 3];
        input[21] = [[0.0; 3], [1.0, 1.0, 1.0], [2.0, 2.0, 2.0]];
        // 300 copies of one triangle: coincident centroids force median splits.
        input.extend(std::iter::repeat_n(
            [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            300,
        ));
        let ids = ids(input.len());
        let bvh = Bvh::build(&input, &ids).unwrap();
        assert_well_formed(&bvh, &input, &ids);
        assert_agrees_with_brute_force(&bvh, &input, &mut rng, 3000);

        let all_nan = vec![[[nan; 3]; 3]; 9];
        let bvh = Bvh::build(&all_nan, &self::ids(9)).unwrap();
        assert!(bvh.stats.max_depth <= BVH_MAX_DEPTH);
        assert_eq!(bvh.triangles.len(), 9);
        assert!(!bvh.closest_hit(&random_ray(&mut rng, &[])).is_hit());

        let same = vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]; 1000];
        let ids = self::ids(1000);
        let bvh = Bvh::build(&same, &ids).unwrap();
        assert_well_formed(&bvh, &same, &ids);
        assert_eq!(bvh.stats.max_depth, median_levels(1000));
    }

    #[test]
    fn empty_input_gives_an_empty_bvh() {
        let bvh = Bvh::build(&[], &[]).unwrap();
        assert!(bvh.nodes.is_empty() && bvh.triangles.is_empty());
        assert_eq!(bvh.stats, BvhStats::default());
        assert!(
            !bvh.closest_hit(&random_ray(&mut Rng::new(10), &[]))
                .is_hit()
        );
    }

    #[test]
    fn bad_arguments_are_errors() {
        let input = random_scene(&mut Rng::new(11), 100, 1.0);
        let err = Bvh::build(&input, &ids(99)).unwrap_err();
        assert!(
            matches!(err, Error::InvalidArgument { name: "ids", .. }),
            "{err}"
        );
        // 100 triangles are 4800 bytes.
        let err = Bvh::build_with_limits(&input, &ids(100), BVH_MAX_DEPTH, 4799).unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidArgument {
                    name: "triangles",
                    ..
                }
            ),
            "{err}"
        );
        // Tiny triangles far apart: the SAH splits down to single triangles, so 99 nodes of 64
        // bytes outgrow the triangles.
        let sparse: Vec<[[f32; 3]; 3]> = (0..100)
            .map(|i| {
                let x = 10.0 * i as f32;
                [[x, 0.0, 0.0], [x + 0.01, 0.0, 0.0], [x, 0.01, 0.0]]
            })
            .collect();
        let bvh = Bvh::build(&sparse, &ids(100)).unwrap();
        assert_well_formed(&bvh, &sparse, &ids(100));
        assert_eq!((bvh.stats.nodes, bvh.stats.leaves), (99, 100));
        let err = Bvh::build_with_limits(&sparse, &ids(100), BVH_MAX_DEPTH, 4800).unwrap_err();
        assert!(
            matches!(err, Error::InvalidArgument { name: "nodes", .. }),
            "{err}"
        );
        assert!(err.to_string().contains("storage-buffer limit"), "{err}");
    }

    #[test]
    fn median_levels_counts_levels_below_a_node() {
        assert_eq!(median_levels(0), 0);
        assert_eq!(median_levels(4), 0);
        assert_eq!(median_levels(5), 1);
        assert_eq!(median_levels(8), 1);
        assert_eq!(median_levels(9), 2);
        assert_eq!(median_levels(10_000), 12);
    }

    /// Build time of 100k random triangles; prints it (run with `--release --nocapture` for the
    /// figure that matters) and checks the result is sound.
    #[test]
    fn build_100k_triangles() {
        let mut rng = Rng::new(12);
        let input = random_scene(&mut rng, 100_000, 0.3);
        let ids = ids(input.len());
        let start = Instant::now();
        let bvh = Bvh::build(&input, &ids).unwrap();
        let seconds = start.elapsed().as_secs_f64();
        println!(
            "BVH build of 100k triangles: {:.1} ms, {:?}",
            seconds * 1e3,
            bvh.stats
        );
        assert!(bvh.stats.max_depth <= BVH_MAX_DEPTH);
        assert_eq!(bvh.triangles.len(), input.len());
        assert_agrees_with_brute_force(&bvh, &input, &mut rng, 200);
    }
}

#[cfg(test)]
mod watertight;
