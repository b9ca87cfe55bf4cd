//! The BVH builder: binned SAH over world-space triangles, into the flat layout of
//! [`gi_shared::bvh`] that the CPU and the software-traversal kernels walk.
//!
//! Splits are chosen among [`SAH_BINS`] bins on each of the three centroid axes. Nodes of more
//! than [`MAX_LEAF_TRIANGLES`] triangles always split; smaller ones become leaves unless a split
//! is cheaper. When every centroid coincides (no bin boundary separates them), or when a split
//! would leave a child too deep to finish within [`BVH_MAX_DEPTH`], the node splits at the
//! object median instead, which bounds the depth of the whole tree (see [`Bvh::build`]).
//!
//! Degenerate and NaN triangles are kept (the loader filters them; here they only must not break
//! anything): bounds skip NaN coordinates, NaN centroids land in the first bin, and the traversal
//! never reports a hit on them.

use gi_shared::bvh::{BVH_MAX_DEPTH, BvhNode, BvhTriangle, any_hit, closest_hit};
use gi_shared::layout::MAX_STORAGE_BUFFER_BYTES;
use gi_shared::ray::{HitRecord, Ray};

use crate::error::{Error, Result};

/// Bins per axis of the SAH sweep.
pub const SAH_BINS: usize = 16;
/// Most triangles in one leaf.
pub const MAX_LEAF_TRIANGLES: usize = 4;
/// SAH cost of visiting an interior node, relative to [`SAH_TRIANGLE_COST`].
pub const SAH_NODE_COST: f32 = 1.0;
/// SAH cost of one ray/triangle test.
pub const SAH_TRIANGLE_COST: f32 = 1.0;

/// Which instance and which of its mesh's triangles a triangle is; reported in the hit record.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct TriangleId {
    /// Instance index.
    pub instance: u32,
    /// Triangle index within the instance's mesh.
    pub primitive: u32,
}

/// What a build produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Nodes, interior and leaves.
    pub nodes: u32,
    /// Leaves.
    pub leaves: u32,
    /// Depth of the deepest leaf, the root being at depth 0; at most [`BVH_MAX_DEPTH`].
    pub max_depth: u32,
    /// Expected cost of a ray through the root: the sum over nodes of their surface area
    /// relative to the root's, times [`SAH_NODE_COST`] for interior nodes and
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

/// How a node's triangle range `[start, end)` was split: the left child takes `[start, mid)`.
struct Split {
    mid: usize,
    cost: f32,
}

/// A node waiting to be built.
struct Task {
    node: usize,
    start: usize,
    end: usize,
    depth: u32,
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
        if triangle_bytes > max_buffer_bytes {
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
            .iter()
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
        let mut nodes = Vec::with_capacity(triangles.len());
        nodes.push(BvhNode::default());
        let mut stats = BvhStats::default();
        let mut root_area = 0.0;
        let mut area_sum_interior = 0.0f64;
        let mut area_sum_leaves = 0.0f64;

        let mut tasks = vec![Task {
            node: 0,
            start: 0,
            end: triangles.len(),
            depth: 0,
        }];
        while let Some(Task {
            node,
            start,
            end,
            depth,
        }) = tasks.pop()
        {
            let range = &mut order[start..end];
            let mut bounds = Aabb::EMPTY;
            let mut centroids = Aabb::EMPTY;
            for &i in range.iter() {
                let item = &items[i as usize];
                bounds.grow(&item.bounds);
                centroids.grow_point(item.centroid);
            }
            nodes[node].min = bounds.min;
            nodes[node].max = bounds.max;
            let area = bounds.area();
            if node == 0 {
                root_area = area;
            }
            let n = end - start;
            let leaf_cost = SAH_TRIANGLE_COST * n as f32;

            let sah = sah_split(&items, range, &centroids, area);
            let split = match sah {
                // The depth invariant: each child can still finish with median splits.
                Some(s) if depth + 1 + median_levels((s.mid).max(n - s.mid)) <= max_depth => {
                    (n > MAX_LEAF_TRIANGLES || s.cost < leaf_cost).then_some(s.mid)
                }
                _ => (n > MAX_LEAF_TRIANGLES).then(|| {
                    median_split(&items, range, &centroids);
                    n / 2
                }),
            };

            match split {
                None => {
                    nodes[node].index = start as u32;
                    nodes[node].count = n as u32;
                    stats.leaves += 1;
                    stats.max_depth = stats.max_depth.max(depth);
                    area_sum_leaves += f64::from(area) * n as f64;
                }
                Some(mid) => {
                    let left = nodes.len();
                    nodes[node].index = left as u32;
                    nodes[node].count = 0;
                    nodes.push(BvhNode::default());
                    nodes.push(BvhNode::default());
                    area_sum_interior += f64::from(area);
                    // Right first so the left subtree is built (and laid out) first.
                    tasks.push(Task {
                        node: left + 1,
                        start: start + mid,
                        end,
                        depth: depth + 1,
                    });
                    tasks.push(Task {
                        node: left,
                        start,
                        end: start + mid,
                        depth: depth + 1,
                    });
                }
            }
        }
        assert!(
            stats.max_depth <= max_depth,
            "BVH depth {} exceeds the limit {max_depth}",
            stats.max_depth
        );

        let node_bytes = nodes.len() * size_of::<BvhNode>();
        if node_bytes > max_buffer_bytes {
            return Err(too_big("nodes", nodes.len(), node_bytes, max_buffer_bytes));
        }
        stats.nodes = nodes.len() as u32;
        stats.sah_cost = if root_area > 0.0 && root_area.is_finite() {
            ((f64::from(SAH_NODE_COST) * area_sum_interior
                + f64::from(SAH_TRIANGLE_COST) * area_sum_leaves)
                / f64::from(root_area)) as f32
        } else {
            // Without a usable root area every node weighs 1.
            let interior = f64::from(stats.nodes - stats.leaves);
            (f64::from(SAH_NODE_COST) * interior
                + f64::from(SAH_TRIANGLE_COST) * triangles.len() as f64) as f32
        };
        let triangles = order
            .iter()
            .map(|&i| {
                let id = ids[i as usize];
                BvhTriangle::new(triangles[i as usize], id.instance, id.primitive)
            })
            .collect();
        Ok(Self {
            nodes,
            triangles,
            stats,
        })
    }
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

/// The cheapest binned SAH split of `range` over the three axes, partitioning `range` so that
/// the left child is `range[..mid]`. `None` when no bin boundary separates the centroids (or
/// every cost is NaN, from unbounded geometry); `range` is then untouched.
fn sah_split(items: &[Item], range: &mut [u32], centroids: &Aabb, area: f32) -> Option<Split> {
    #[derive(Clone, Copy)]
    struct Bin {
        bounds: Aabb,
        count: u32,
    }
    let empty = Bin {
        bounds: Aabb::EMPTY,
        count: 0,
    };
    // Best (cost, axis, first bin of the right child).
    let mut best: Option<(f32, usize, usize)> = None;
    let mut scales = [0.0f32; 3];
    for axis in 0..3 {
        let extent = centroids.max[axis] - centroids.min[axis];
        if !(extent > 0.0 && extent.is_finite()) {
            continue;
        }
        let scale = SAH_BINS as f32 / extent;
        scales[axis] = scale;
        let mut bins = [empty; SAH_BINS];
        for &i in range.iter() {
            let item = &items[i as usize];
            let b = &mut bins[bin_of(item.centroid[axis], centroids.min[axis], scale)];
            b.bounds.grow(&item.bounds);
            b.count += 1;
        }
        // Sweep from the right: the area and count of bins `b..` for each boundary `b`.
        let mut right_area = [0.0f32; SAH_BINS];
        let mut right_count = [0u32; SAH_BINS];
        let mut acc = empty;
        for b in (1..SAH_BINS).rev() {
            acc.bounds.grow(&bins[b].bounds);
            acc.count += bins[b].count;
            right_area[b] = acc.bounds.area();
            right_count[b] = acc.count;
        }
        let mut left = empty;
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
        bin_of(items[i as usize].centroid[axis], lo, scale) < boundary
    });
    Some(Split { mid, cost })
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

    /// The structural invariants: layout, bounds, leaf sizes, depth, each triangle once, and
    /// statistics that match the tree.
    fn assert_well_formed(bvh: &Bvh, input: &[[[f32; 3]; 3]], ids: &[TriangleId]) {
        let contains = |outer: &BvhNode, min: [f32; 3], max: [f32; 3]| {
            (0..3).all(|a| {
                // Empty (all-NaN) children have no extent to contain.
                min[a] > max[a] || (outer.min[a] <= min[a] && max[a] <= outer.max[a])
            })
        };
        let mut seen = vec![0u32; bvh.triangles.len()];
        let (mut leaves, mut max_depth) = (0, 0);
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, depth)) = stack.pop() {
            let node = &bvh.nodes[i];
            if node.is_leaf() {
                leaves += 1;
                max_depth = max_depth.max(depth);
                assert!(node.count as usize <= MAX_LEAF_TRIANGLES);
                for t in node.index..node.index + node.count {
                    seen[t as usize] += 1;
                    let tri = &bvh.triangles[t as usize];
                    let original = input[tri.primitive as usize];
                    assert_eq!(ids[tri.primitive as usize].instance, tri.instance);
                    for v in original {
                        for a in 0..3 {
                            let c = v[a];
                            assert!(
                                c.is_nan() || (node.min[a] <= c && c <= node.max[a]),
                                "leaf {i} {node:?} misses vertex {v:?}"
                            );
                        }
                    }
                }
            } else {
                let left = node.index as usize;
                assert!(left > i && left + 1 < bvh.nodes.len());
                for child in [left, left + 1] {
                    let c = &bvh.nodes[child];
                    assert!(
                        contains(node, c.min, c.max),
                        "{node:?} does not contain {c:?}"
                    );
                    stack.push((child, depth + 1));
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
        // 100 triangles are 4800 bytes; their ≥ 51 nodes 1632 or more.
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
        let err = Bvh::build_with_limits(&input, &ids(100), BVH_MAX_DEPTH, 4800).unwrap_err();
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
