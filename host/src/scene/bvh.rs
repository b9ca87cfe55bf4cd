//! The BVH builders: binned SAH, into the flat two-level layout of [`gi_shared::bvh`] that the
//! CPU and the software-traversal kernels walk.
//!
//! * [`Blas::build`]: a mesh's bottom level, in object space, over its triangles, once per mesh
//!   whatever its number of instances. It returns the leaf order, which [`Scene::update_derived`]
//!   applies to the mesh's triangles, so that a triangle's index in the mesh is the same for the
//!   software BVH, ray queries, the light tables and the CPU reference.
//! * [`build_tlas`]: the top level over the instances' world bounds ([`instance_bounds`]), one
//!   instance per leaf, cheap enough to redo per frame when instances move.
//! * [`Bvh::new`]: the node buffer the traversal reads, the top level (always
//!   [`tlas_node_count`] nodes) followed by every mesh's bottom level at [`mesh_roots`].
//!
//! Splits are chosen among [`SAH_BINS`] bins on each of the three centroid axes. Nodes of more
//! than the level's leaf size always split; smaller ones become leaves unless a split is cheaper.
//! When every centroid coincides (no bin boundary separates them), or when a split would leave a
//! child too deep to finish within the level's depth limit ([`BVH_TLAS_MAX_DEPTH`],
//! [`BVH_BLAS_MAX_DEPTH`]), the node splits at the object median instead, which bounds the depth
//! of the whole tree.
//!
//! The builds run on all cores (`rayon`): meshes' bottom levels in parallel, and within a level
//! the two subtrees of a node of at least [`PARALLEL_SUBTREE`] items, nodes of at least
//! [`PARALLEL_BINNING`] items also gathering their bounds and bins in parallel. The result does
//! not depend on the number of threads.
//!
//! Degenerate and NaN triangles are kept (the loader filters them; here they only must not break
//! anything): bounds skip NaN coordinates, NaN centroids land in the first bin, and the traversal
//! never reports a hit on them.

use gi_shared::bvh::{
    BVH_BLAS_MAX_DEPTH, BVH_MAX_INDEX, BVH_MAX_LEAF_TRIANGLES, BVH_TLAS_MAX_DEPTH, BvhChild,
    BvhNode, BvhScene, any_hit, closest_hit,
};
use gi_shared::layout::{MAX_STORAGE_BUFFER_BYTES, SCENE_BUFFER_CHUNKS};
use gi_shared::ray::{HitRecord, Ray};
use glam::{DMat4, DVec3, Vec3};
use rayon::prelude::*;

use super::Scene;
use super::gpu_data::ShadingData;
use crate::error::{Error, Result};

/// Bins per axis of the SAH sweep.
pub const SAH_BINS: usize = 16;
/// Most triangles in one bottom-level leaf.
pub const MAX_LEAF_TRIANGLES: usize = 4;
/// SAH cost of visiting an interior node, relative to [`SAH_TRIANGLE_COST`].
pub const SAH_NODE_COST: f32 = 1.0;
/// SAH cost of one ray/triangle test.
pub const SAH_TRIANGLE_COST: f32 = 1.0;
/// Nodes of at least this many items build their two subtrees in parallel.
pub const PARALLEL_SUBTREE: usize = 1 << 12;
/// Nodes of at least this many items gather bounds and SAH bins in parallel.
pub const PARALLEL_BINNING: usize = 1 << 15;
/// Relative margin by which an instance's world bounds are widened: the corners are transformed
/// in `f64` and rounded to `f32`, and the traversal's object-space ray is rounded too.
const INSTANCE_BOUNDS_MARGIN: f64 = 1e-5;

const _: () = assert!(MAX_LEAF_TRIANGLES as u32 <= BVH_MAX_LEAF_TRIANGLES);

/// What a build produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Nodes ([`BvhNode`]s, each holding two children).
    pub nodes: u32,
    /// Leaves.
    pub leaves: u32,
    /// Depth of the deepest leaf, the root node being at depth 0 and a leaf directly under it at
    /// depth 1 (a tree of a single leaf has depth 0); at most the level's limit.
    pub max_depth: u32,
    /// Expected cost of a ray through the root: the sum over subtrees of their surface area
    /// relative to the root's, times [`SAH_NODE_COST`] for interior ones and
    /// [`SAH_TRIANGLE_COST`] per item for leaves. Areas count as 1 when the root's area is zero
    /// or not finite.
    pub sah_cost: f32,
}

/// Axis-aligned bounds: `min` then `max`. Empty bounds have `min > max`.
pub type Bounds = [[f32; 3]; 2];

/// A mesh's bottom level, in object space, with node indices relative to its root (node 0):
/// [`Bvh::new`] moves it to its place in the node buffer.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Blas {
    /// Nodes; node 0 is the root. Leaves index the mesh's triangles in leaf order.
    pub nodes: Vec<BvhNode>,
    /// Bounds of the mesh (of its finite vertex coordinates).
    pub bounds: Bounds,
    /// Number of triangles it was built over.
    pub triangles: u32,
    /// Build statistics.
    pub stats: BvhStats,
}

impl Blas {
    /// Builds the bottom level of the mesh `triangles` (indices into `positions`; an index out
    /// of range counts as a NaN vertex). Returns it and the leaf order: `order[i]` is the input
    /// triangle that must become triangle `i` for the leaves to be right.
    ///
    /// Every leaf ends at depth `<=` [`BVH_BLAS_MAX_DEPTH`].
    pub fn build(positions: &[Vec3], triangles: &[[u32; 3]]) -> (Self, Vec<u32>) {
        Self::build_with_depth(positions, triangles, BVH_BLAS_MAX_DEPTH)
    }

    fn build_with_depth(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        max_depth: u32,
    ) -> (Self, Vec<u32>) {
        let items: Vec<Item> = triangles
            .par_iter()
            .map(|t| {
                let mut bounds = Aabb::EMPTY;
                for &i in t {
                    let p = positions.get(i as usize).copied().unwrap_or(Vec3::NAN);
                    bounds.grow_point(p.to_array());
                }
                Item::of(bounds)
            })
            .collect();
        let tree = build_tree(&items, MAX_LEAF_TRIANGLES, max_depth);
        let blas = Self {
            nodes: tree.nodes,
            bounds: [tree.bounds.min, tree.bounds.max],
            triangles: triangles.len() as u32,
            stats: tree.stats,
        };
        (blas, tree.order)
    }
}

/// The top level over instances of world bounds `bounds` (see [`instance_bounds`]): one instance
/// per leaf, its `index` the instance index; [`tlas_node_count`] nodes. Every leaf ends at depth
/// `<=` [`BVH_TLAS_MAX_DEPTH`].
pub fn build_tlas(bounds: &[Bounds]) -> (Vec<BvhNode>, BvhStats) {
    let items: Vec<Item> = bounds
        .iter()
        .map(|b| {
            Item::of(Aabb {
                min: b[0],
                max: b[1],
            })
        })
        .collect();
    let mut tree = build_tree(&items, 1, BVH_TLAS_MAX_DEPTH);
    for node in &mut tree.nodes {
        for c in [&mut node.left, &mut node.right] {
            if c.is_leaf() {
                c.index = tree.order[c.index as usize];
            }
        }
    }
    (tree.nodes, tree.stats)
}

/// Nodes of the top level over `instances` instances: a binary tree of one instance per leaf
/// has one node fewer than leaves, and a single leaf takes a root of its own.
pub fn tlas_node_count(instances: usize) -> usize {
    match instances {
        0 => 0,
        1 => 1,
        n => n - 1,
    }
}

/// Where each mesh's bottom level starts in the node buffer of [`Bvh::new`]: after the top level,
/// in mesh order. `GpuMesh::bvh_root`.
pub fn mesh_roots(scene: &Scene) -> Vec<u32> {
    let mut next = tlas_node_count(scene.instances.len());
    scene
        .blases
        .iter()
        .map(|b| {
            let root = next as u32;
            next += b.nodes.len();
            root
        })
        .collect()
}

/// World bounds of every instance: its mesh's bounds ([`Blas::bounds`]) through its transform,
/// in `f64`, widened by a small margin so that rounding never culls a hit.
pub fn instance_bounds(scene: &Scene) -> Vec<Bounds> {
    scene
        .instances
        .iter()
        .map(|inst| {
            let Some(b) = scene.blases.get(inst.mesh as usize).map(|b| b.bounds) else {
                return [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
            };
            let m = inst.transform.as_dmat4();
            world_bounds(&m, b)
        })
        .collect()
}

fn world_bounds(m: &DMat4, b: Bounds) -> Bounds {
    let (lo, hi) = (
        DVec3::from(b[0].map(f64::from)),
        DVec3::from(b[1].map(f64::from)),
    );
    if !(lo.cmple(hi).all()) {
        return [[f32::INFINITY; 3], [f32::NEG_INFINITY; 3]];
    }
    let mut min = DVec3::INFINITY;
    let mut max = DVec3::NEG_INFINITY;
    for c in 0..8 {
        let p = DVec3::new(
            if c & 1 == 0 { lo.x } else { hi.x },
            if c & 2 == 0 { lo.y } else { hi.y },
            if c & 4 == 0 { lo.z } else { hi.z },
        );
        let w = m.transform_point3(p);
        min = min.min(w);
        max = max.max(w);
    }
    let margin = INSTANCE_BOUNDS_MARGIN * (max - min).max_element().max(1e-30)
        + INSTANCE_BOUNDS_MARGIN * min.abs().max(max.abs()).max_element();
    let round = |v: DVec3, down: bool| {
        v.to_array().map(|x| {
            let f = x as f32;
            // Outward after rounding to `f32`.
            if down && f64::from(f) > x {
                f.next_down()
            } else if !down && f64::from(f) < x {
                f.next_up()
            } else {
                f
            }
        })
    };
    [
        round(min - DVec3::splat(margin), true),
        round(max + DVec3::splat(margin), false),
    ]
}

/// The two-level BVH in the GPU layout: upload `nodes` as one storage buffer. The triangles are
/// the shading data's own (`gi_shared::bvh::BvhScene`).
///
/// An empty scene gives no nodes (every ray misses); a GPU upload must then bind a placeholder,
/// since Vulkan buffers cannot be empty.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    /// The top level from node 0, then every mesh's bottom level at [`mesh_roots`].
    pub nodes: Vec<BvhNode>,
    /// Statistics of the top level.
    pub tlas: BvhStats,
}

impl Bvh {
    /// Lays out `scene`'s bottom levels ([`Scene::blases`]) after a top level built over its
    /// instances now.
    ///
    /// Errors with [`Error::InvalidArgument`] when the scene's bottom levels do not match its
    /// meshes (a scene built in code must call [`Scene::update_derived`]), or when the node
    /// buffer would exceed what every device binds of it: [`SCENE_BUFFER_CHUNKS`] storage
    /// bindings of 128 MiB ([`MAX_STORAGE_BUFFER_BYTES`]).
    pub fn new(scene: &Scene) -> Result<Self> {
        Self::new_with_limit(scene, SCENE_BUFFER_CHUNKS * MAX_STORAGE_BUFFER_BYTES)
    }

    fn new_with_limit(scene: &Scene, max_buffer_bytes: usize) -> Result<Self> {
        let stale = scene.blases.len() != scene.meshes.len()
            || scene
                .blases
                .iter()
                .zip(&scene.meshes)
                .any(|(b, m)| b.triangles as usize != m.triangles.len());
        if stale {
            return Err(Error::InvalidArgument {
                name: "scene",
                why: format!(
                    "{}: the meshes' bottom-level BVHs are missing or out of date; call \
                     Scene::update_derived after changing meshes",
                    scene.source.display()
                ),
            });
        }
        let roots = mesh_roots(scene);
        let count = tlas_node_count(scene.instances.len())
            + scene.blases.iter().map(|b| b.nodes.len()).sum::<usize>();
        let bytes = count * size_of::<BvhNode>();
        if bytes > max_buffer_bytes || count >= BVH_MAX_INDEX as usize {
            return Err(Error::InvalidArgument {
                name: "nodes",
                why: format!(
                    "{}: the BVH's {count} nodes take {bytes} bytes, over the \
                     {max_buffer_bytes}-byte storage-buffer limit; split the scene",
                    scene.source.display()
                ),
            });
        }
        let (mut nodes, tlas) = build_tlas(&instance_bounds(scene));
        debug_assert_eq!(nodes.len(), tlas_node_count(scene.instances.len()));
        nodes.resize(count, BvhNode::default());
        let mut rest = &mut nodes[tlas_node_count(scene.instances.len())..];
        let mut parts = Vec::with_capacity(scene.blases.len());
        for b in &scene.blases {
            let (part, tail) = rest.split_at_mut(b.nodes.len());
            parts.push(part);
            rest = tail;
        }
        parts
            .into_par_iter()
            .zip(scene.blases.par_iter().zip(&roots))
            .for_each(|(dst, (blas, &root))| {
                for (d, s) in dst.iter_mut().zip(&blas.nodes) {
                    *d = *s;
                    for c in [&mut d.left, &mut d.right] {
                        if !c.is_leaf() && *c != BvhChild::EMPTY {
                            c.index += root;
                        }
                    }
                }
            });
        Ok(Self { nodes, tlas })
    }

    /// What the traversal reads: these nodes and `shading`'s geometry (laid out from the same
    /// scene).
    pub fn scene<'a>(&'a self, shading: &'a ShadingData) -> BvhScene<'a, &'a [BvhNode]> {
        BvhScene {
            nodes: &self.nodes,
            surfaces: shading.surfaces(),
        }
    }

    /// The closest hit of `ray` (the shared traversal, on the CPU, alpha test included).
    pub fn closest_hit(&self, shading: &ShadingData, ray: &Ray) -> HitRecord {
        closest_hit(self.scene(shading), &shading.texels[..], ray)
    }

    /// Whether `ray` hits anything in `[t_min, t_max]` (the shared traversal, on the CPU, alpha
    /// test included).
    pub fn any_hit(&self, shading: &ShadingData, ray: &Ray) -> bool {
        any_hit(self.scene(shading), &shading.texels[..], ray)
    }
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

/// An item's (triangle's or instance's) bounds and centroid, as the builder sorts it.
#[derive(Clone, Copy)]
struct Item {
    bounds: Aabb,
    centroid: [f32; 3],
}

impl Item {
    fn of(bounds: Aabb) -> Self {
        let centroid = [0, 1, 2].map(|a| 0.5 * (bounds.min[a] + bounds.max[a]));
        Self { bounds, centroid }
    }
}

/// How a node's item range was split: the left child takes `range[..mid]`.
struct Split {
    mid: usize,
    cost: f32,
}

/// A built subtree before it is laid out.
enum Subtree {
    /// Items `start .. start + count` in leaf order.
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

/// Levels below a node of `n` items when every split is at the object median with leaves of up
/// to `leaf` items: `⌈log2 ⌈n / leaf⌉⌉`.
fn median_levels(n: usize, leaf: usize) -> u32 {
    n.div_ceil(leaf).max(1).next_power_of_two().trailing_zeros()
}

/// The bin of centroid coordinate `c` for bins starting at `lo`, `scale` bins per unit.
/// NaN lands in bin 0 (a saturating cast), infinities clamp to the ends.
#[inline]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    (((c - lo) * scale) as usize).min(SAH_BINS - 1)
}

/// One level laid out: nodes from index 0, leaves referring to leaf positions.
struct Tree {
    nodes: Vec<BvhNode>,
    /// `order[i]` is the input item at leaf position `i`.
    order: Vec<u32>,
    bounds: Aabb,
    stats: BvhStats,
}

/// Builds one level over `items` with leaves of at most `max_leaf` items and every leaf at
/// depth `<= max_depth`: a node at depth `d` with `n` items keeps
/// `d + median_levels(n) <= max_depth`, taking an SAH split only when both children still
/// satisfy it and the median split (which always does) otherwise.
fn build_tree(items: &[Item], max_leaf: usize, max_depth: u32) -> Tree {
    let mut order: Vec<u32> = (0..items.len() as u32).collect();
    if items.is_empty() {
        return Tree {
            nodes: Vec::new(),
            order,
            bounds: Aabb::EMPTY,
            stats: BvhStats::default(),
        };
    }
    let builder = Builder {
        items,
        max_depth,
        max_leaf,
    };
    let root = builder.build(&mut order, 0, 0);
    assert!(
        root.max_depth <= max_depth,
        "BVH depth {} exceeds the limit {max_depth}",
        root.max_depth
    );
    let root_area = root.bounds.area();
    let mut nodes = Vec::new();
    match &root.tree {
        Subtree::Leaf { start, count } => nodes.push(BvhNode {
            left: child(&root.bounds, *start, *count),
            right: BvhChild::EMPTY,
        }),
        Subtree::Interior(children) => {
            lay_out(children, &mut nodes);
        }
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
        (f64::from(SAH_NODE_COST) * interior + f64::from(SAH_TRIANGLE_COST) * items.len() as f64)
            as f32
    };
    Tree {
        nodes,
        order,
        bounds: root.bounds,
        stats,
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

/// The recursive build over one set of triangles.
struct Builder<'a> {
    items: &'a [Item],
    max_depth: u32,
    max_leaf: usize,
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
            Some(s)
                if depth + 1 + median_levels(s.mid.max(n - s.mid), self.max_leaf)
                    <= self.max_depth =>
            {
                (n > self.max_leaf || s.cost < leaf_cost).then_some(s.mid)
            }
            _ => (n > self.max_leaf).then(|| {
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
    use crate::scene::procedural;
    use crate::scene::{Mesh, Scene};
    use gi_shared::bvh::closest_hit_brute_force;
    use gi_shared::random::Random;
    use glam::{Mat4, Quat};
    use std::time::Instant;

    type Tri = [[f32; 3]; 3];

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

    /// `n` random triangles of size up to `size` around centres in a cube, half of them in a
    /// few dense clusters so that the SAH has something to find.
    fn random_soup(rng: &mut Rng, n: usize, size: f32) -> Vec<Tri> {
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

    fn soup_mesh(soup: &[Tri]) -> Mesh {
        procedural::triangle_soup("soup", soup)
    }

    /// A ray from the scene's surroundings, most aimed at (or near) one of its world triangles.
    fn random_ray(rng: &mut Rng, scene: &Scene) -> Ray {
        let origin = rng.vec(-15.0, 15.0);
        let jitter = rng.vec(-0.3, 0.3);
        let n = scene.instances.len() as u32;
        let target = if rng.next_u32().is_multiple_of(4) {
            rng.vec(-8.0, 8.0)
        } else {
            let instance = rng.next_u32() % n;
            let m = &scene.meshes[scene.instances[instance as usize].mesh as usize];
            let primitive = rng.next_u32() % m.triangles.len() as u32;
            let t = scene.world_triangle(instance, primitive).unwrap().vertices;
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

    /// Closest hits and any-hits agree with brute force over the same scene; returns the number
    /// of hits. Differing triangles are only allowed on an exact tie.
    fn assert_agrees_with_brute_force(scene: &Scene, rng: &mut Rng, rays: usize) -> usize {
        let bvh = Bvh::new(scene).unwrap();
        let shading = ShadingData::new(scene).unwrap();
        let mut hits = 0;
        for _ in 0..rays {
            let ray = random_ray(rng, scene);
            let got = bvh.closest_hit(&shading, &ray);
            let want = closest_hit_brute_force(bvh.scene(&shading), &shading.texels[..], &ray);
            if !((got.instance, got.primitive) != (want.instance, want.primitive)
                && got.t == want.t)
            {
                assert_eq!(got, want, "{ray:?}");
            }
            assert_eq!(bvh.any_hit(&shading, &ray), want.is_hit(), "{ray:?}");
            hits += usize::from(want.is_hit());
        }
        hits
    }

    /// The structural invariants of a mesh's bottom level: layout, bounds, leaf sizes, depth,
    /// each triangle once, and statistics that match the tree.
    fn assert_well_formed(blas: &Blas, mesh: &Mesh, max_depth: u32) {
        let contains = |outer: &BvhChild, min: [f32; 3], max: [f32; 3]| {
            (0..3).all(|a| {
                // Empty (all-NaN) children have no extent to contain.
                min[a] > max[a] || (outer.min[a] <= min[a] && max[a] <= outer.max[a])
            })
        };
        let nodes = &blas.nodes;
        let mut seen = vec![0u32; mesh.triangles.len()];
        let (mut leaves, mut deepest) = (0, 0);
        let single_leaf = nodes.len() == 1 && nodes[0].right == BvhChild::EMPTY;
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, depth)) = stack.pop() {
            let node = &nodes[i];
            for c in [&node.left, &node.right] {
                if single_leaf && c == &BvhChild::EMPTY {
                    continue;
                }
                if c.is_leaf() {
                    leaves += 1;
                    deepest = deepest.max(if single_leaf { 0 } else { depth + 1 });
                    assert!(c.count as usize <= MAX_LEAF_TRIANGLES);
                    for t in c.index..c.index + c.count {
                        seen[t as usize] += 1;
                        for v in mesh.triangle(t as usize) {
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
                    assert!(n > i && n < nodes.len());
                    for g in [&nodes[n].left, &nodes[n].right] {
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
        assert_eq!(blas.stats.nodes as usize, nodes.len());
        assert_eq!(blas.stats.leaves, leaves);
        assert_eq!(blas.stats.max_depth, deepest);
        assert!(deepest <= max_depth);
        assert!(blas.stats.sah_cost.is_finite() && blas.stats.sah_cost > 0.0);
    }

    fn one_instance(soup: &[Tri]) -> Scene {
        procedural::scene(vec![soup_mesh(soup)], &[(0, Mat4::IDENTITY)]).unwrap()
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
            let input = random_soup(&mut rng, n, size);
            let scene = one_instance(&input);
            assert_well_formed(&scene.blases[0], &scene.meshes[0], BVH_BLAS_MAX_DEPTH);
            // The mesh holds the same triangles, reordered.
            let mut a: Vec<_> = input
                .iter()
                .map(|t| t.map(|v| v.map(f32::to_bits)))
                .collect();
            let mut b: Vec<_> = (0..n)
                .map(|i| {
                    scene.meshes[0]
                        .triangle(i)
                        .map(|v| v.to_array().map(f32::to_bits))
                })
                .collect();
            a.sort_unstable();
            b.sort_unstable();
            assert_eq!(a, b);
            let hits = assert_agrees_with_brute_force(&scene, &mut rng, 3000);
            assert!(hits > 300, "only {hits} rays hit the {n} triangles");
        }
    }

    /// One mesh placed 1000 times, mirrored, scaled, rotated: one bottom level shared by all, a
    /// top level of 999 nodes, and the same hits as brute force.
    #[test]
    fn instances_share_one_bottom_level() {
        let mut rng = Rng::new(13);
        let mesh = procedural::icosphere(2);
        let placements: Vec<(u32, Mat4)> = (0..1000)
            .map(|i| {
                let axis = Vec3::from(rng.vec(-1.0, 1.0)).normalize_or(Vec3::Z);
                let rotation = Quat::from_axis_angle(axis, rng.range(0.0, 6.0));
                let s = rng.range(0.05, 0.6);
                let scale = match i % 3 {
                    0 => Vec3::new(-s, s, s),
                    1 => Vec3::new(s, 0.3 * s, 2.0 * s),
                    _ => Vec3::splat(s),
                };
                let at = Vec3::from(rng.vec(-9.0, 9.0));
                (
                    0,
                    Mat4::from_scale_rotation_translation(scale, rotation, at),
                )
            })
            .collect();
        let scene = procedural::scene(vec![mesh], &placements).unwrap();
        let bvh = Bvh::new(&scene).unwrap();
        assert_eq!(
            bvh.nodes.len(),
            999 + scene.blases[0].nodes.len(),
            "one bottom level and a top level of N - 1 nodes"
        );
        assert_eq!(tlas_node_count(1000), 999);
        assert_eq!(mesh_roots(&scene), vec![999]);
        assert!(bvh.tlas.max_depth <= BVH_TLAS_MAX_DEPTH);
        // 1200 rays: each tests 320 000 triangles brute force (4000 took 35 s of the test
        // command's 8 minutes).
        let hits = assert_agrees_with_brute_force(&scene, &mut rng, 1200);
        assert!(hits > 450, "{hits}");
    }

    /// 10k items along a line, each gap 1.5% wider than the last: a binned SAH split can only
    /// cut off the few items in the far bins, so without the depth guard the tree is a long
    /// chain (depth 84).
    fn pathological() -> Vec<Tri> {
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
    fn depth_stays_within_the_traversal_limits_on_a_pathological_input() {
        let input = pathological();
        assert!(input.iter().flatten().flatten().all(|c| c.is_finite()));
        let mesh = soup_mesh(&input);
        let (unbounded, _) = Blas::build_with_depth(&mesh.positions, &mesh.triangles, u32::MAX);
        assert!(
            unbounded.stats.max_depth > BVH_BLAS_MAX_DEPTH,
            "not pathological: depth {}",
            unbounded.stats.max_depth
        );
        let scene = one_instance(&input);
        assert_well_formed(&scene.blases[0], &scene.meshes[0], BVH_BLAS_MAX_DEPTH);
        // The tightest possible limit holds too: 2500 leaves of 4 need depth ⌈log2 2500⌉ = 12.
        let (tight, order) = Blas::build_with_depth(&mesh.positions, &mesh.triangles, 12);
        let mut reordered = mesh.clone();
        reordered.triangles = order.iter().map(|&i| mesh.triangles[i as usize]).collect();
        assert_well_formed(&tight, &reordered, 12);
        assert_eq!(tight.stats.max_depth, 12);
        // Rays along the line, each starting in the plane of triangle `i`: `i` is hit at t = 0.
        let bvh = Bvh::new(&scene).unwrap();
        let shading = ShadingData::new(&scene).unwrap();
        let mut rng = Rng::new(8);
        for _ in 0..2000 {
            let i = rng.next_u32() % input.len() as u32;
            let x = scene.meshes[0].triangle(i as usize)[0].x;
            let ray = Ray {
                origin: [x, 0.25, 0.25],
                t_min: 0.0,
                direction: [1.0, 0.0, 0.0],
                t_max: f32::INFINITY,
            };
            let hit = bvh.closest_hit(&shading, &ray);
            assert_eq!(
                hit,
                closest_hit_brute_force(bvh.scene(&shading), &shading.texels[..], &ray)
            );
            assert_eq!((hit.primitive, hit.t), (i, 0.0));
        }
        // The same along the top level: instances of one triangle at those positions.
        let tri = soup_mesh(&input[..1]);
        let placements: Vec<(u32, Mat4)> = input
            .iter()
            .map(|t| (0, Mat4::from_translation(Vec3::new(t[0][0], 0.0, 0.0))))
            .collect();
        let bounds: Vec<Bounds> = input
            .iter()
            .map(|t| [[t[0][0], 0.0, 0.0], [t[0][0], 1.0, 1.0]])
            .collect();
        let (_, stats) = build_tlas(&bounds);
        assert!(stats.max_depth <= BVH_TLAS_MAX_DEPTH, "{stats:?}");
        let scene = procedural::scene(vec![tri], &placements[..3000]).unwrap();
        assert!(Bvh::new(&scene).unwrap().tlas.max_depth <= BVH_TLAS_MAX_DEPTH);
    }

    #[test]
    fn nan_degenerate_and_coincident_triangles_do_not_break_the_build() {
        let mut rng = Rng::new(9);
        let mut input = random_soup(&mut rng, 400, 1.0);
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
        let scene = one_instance(&input);
        assert_well_formed(&scene.blases[0], &scene.meshes[0], BVH_BLAS_MAX_DEPTH);
        assert_agrees_with_brute_force(&scene, &mut rng, 3000);

        // Indices past the vertices count as NaN vertices.
        let mut mesh = soup_mesh(&input[..9]);
        mesh.triangles[4] = [0, 1, 1000];
        let (blas, order) = Blas::build(&mesh.positions, &mesh.triangles);
        assert_eq!(order.len(), 9);
        assert_eq!(blas.triangles, 9);

        let all_nan = vec![[[nan; 3]; 3]; 9];
        let scene = one_instance(&all_nan);
        assert!(scene.blases[0].stats.max_depth <= BVH_BLAS_MAX_DEPTH);
        let bvh = Bvh::new(&scene).unwrap();
        let shading = ShadingData::new(&scene).unwrap();
        let ray = Ray {
            origin: [0.0; 3],
            t_min: 0.0,
            direction: [1.0, 0.0, 0.0],
            t_max: f32::INFINITY,
        };
        assert!(!bvh.closest_hit(&shading, &ray).is_hit());

        let same = vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]; 1000];
        let scene = one_instance(&same);
        assert_well_formed(&scene.blases[0], &scene.meshes[0], BVH_BLAS_MAX_DEPTH);
        assert_eq!(
            scene.blases[0].stats.max_depth,
            median_levels(1000, MAX_LEAF_TRIANGLES)
        );
        // Coincident instances, too.
        let (nodes, stats) = build_tlas(&vec![[[0.0; 3], [1.0; 3]]; 1000]);
        assert_eq!((nodes.len(), stats.leaves), (999, 1000));
        assert_eq!(stats.max_depth, median_levels(1000, 1));
    }

    #[test]
    fn empty_input_gives_an_empty_bvh() {
        let (blas, order) = Blas::build(&[], &[]);
        assert!(blas.nodes.is_empty() && order.is_empty());
        assert_eq!(blas.stats, BvhStats::default());
        let (nodes, stats) = build_tlas(&[]);
        assert!(nodes.is_empty());
        assert_eq!(stats, BvhStats::default());
    }

    #[test]
    fn stale_and_oversized_scenes_are_errors() {
        let input = random_soup(&mut Rng::new(11), 100, 1.0);
        let mut scene = one_instance(&input);
        scene.meshes[0].triangles.pop();
        let err = Bvh::new(&scene).unwrap_err();
        assert!(err.to_string().contains("update_derived"), "{err}");
        scene.blases.clear();
        assert!(Bvh::new(&scene).is_err());
        scene.update_derived();
        let bvh = Bvh::new(&scene).unwrap();
        let bytes = bvh.nodes.len() * size_of::<BvhNode>();
        assert!(Bvh::new_with_limit(&scene, bytes).is_ok());
        let err = Bvh::new_with_limit(&scene, bytes - 1).unwrap_err();
        assert!(
            matches!(err, Error::InvalidArgument { name: "nodes", .. }),
            "{err}"
        );
        assert!(err.to_string().contains("storage-buffer limit"), "{err}");
    }

    #[test]
    fn median_levels_counts_levels_below_a_node() {
        assert_eq!(median_levels(0, 4), 0);
        assert_eq!(median_levels(4, 4), 0);
        assert_eq!(median_levels(5, 4), 1);
        assert_eq!(median_levels(8, 4), 1);
        assert_eq!(median_levels(9, 4), 2);
        assert_eq!(median_levels(10_000, 4), 12);
        assert_eq!(median_levels(1 << 24, 1), BVH_TLAS_MAX_DEPTH);
    }

    /// Build time of 100k random triangles; prints it (run with `--release --nocapture` for the
    /// figure that matters) and checks the result is sound.
    #[test]
    fn build_100k_triangles() {
        let mut rng = Rng::new(12);
        let input = random_soup(&mut rng, 100_000, 0.3);
        let mesh = soup_mesh(&input);
        let start = Instant::now();
        let (blas, _) = Blas::build(&mesh.positions, &mesh.triangles);
        let seconds = start.elapsed().as_secs_f64();
        println!(
            "BVH build of 100k triangles: {:.1} ms, {:?}",
            seconds * 1e3,
            blas.stats
        );
        assert!(blas.stats.max_depth <= BVH_BLAS_MAX_DEPTH);
        let scene = one_instance(&input);
        assert_agrees_with_brute_force(&scene, &mut rng, 200);
    }
}

#[cfg(test)]
mod watertight;
