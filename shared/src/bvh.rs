//! A two-level BVH over the scene's instances and meshes, and its traversal: the same code walks
//! it on the CPU and in the software-traversal kernels.
//!
//! # Layout
//!
//! One buffer of [`BvhNode`]s (64 bytes each, `#[repr(C)]` + [`Pod`], only `f32`/`u32`): an
//! interior node holding both of its children, each a [`BvhChild`] (box and reference), so that
//! one node load decides where to go next. It holds two levels:
//!
//! * the top level, rooted at node 0, over the instances in world space: a leaf child
//!   (`count == 1`) is instance `index` ([`GpuInstance`]), its box the world bounds of the
//!   instance's mesh;
//! * one bottom level per mesh ([`GpuMesh`]), rooted at [`GpuMesh::bvh_root`], in the mesh's
//!   object space, shared by every instance of the mesh: a leaf child is the mesh's triangles
//!   `index .. index + count` (at most [`BVH_MAX_LEAF_TRIANGLES`]), indices relative to
//!   [`GpuMesh::first_triangle`], so that the leaf order is the mesh's triangle order and the
//!   index of a triangle is the primitive index a hit reports.
//!
//! In both levels a child with `count == 0` is the interior node `index`, which must come after
//! its parent (`index > ` the parent's index). A child slot that holds nothing (the second child
//! of a root over a single leaf) has the box [`BvhChild::EMPTY`], which no ray enters. An empty
//! node buffer is an empty scene: every ray misses.
//!
//! Triangles are read from the shading data itself ([`GpuTriangle`] indices into the mesh's
//! [`GpuVertex`]es): no copy of the geometry is made for tracing. Neighbouring triangles fetch
//! the exact same vertex values, which the watertight test needs.
//!
//! The kernels bind the nodes as [`BvhNodeRows`], arrays of 16-byte vectors, and the traversal
//! reads either through [`BvhElement`]: a node is then four vector loads rather than one load per
//! field, which on lavapipe (where every load of a SIMD group is a loop over its invocations)
//! roughly doubled the rays per second.
//!
//! # Traversal
//!
//! One loop, one step per iteration: either one ray/triangle test or one node (both child boxes
//! tested together), so that invocations of a SIMD group stay in step. The closest hit visits
//! the nearer child first and keeps the farther one on a stack with its entry distance; a pop
//! skips an entry beyond the closest hit so far without touching its node. [`any_hit`] does not
//! order children.
//!
//! At a top-level leaf the ray moves into the instance's object space
//! ([`GpuInstance::world_to_object`]) and the walk continues at the mesh's root, on the same
//! stack; when the stack is back to the depth it had there, the bottom level is exhausted and the
//! walk goes on with the world-space ray. The object-space direction is not normalised, so `t`
//! keeps the world ray's parametrisation and one `t_max` serves both levels.
//!
//! No recursion and no allocation. The stack holds [`BVH_SHORT_STACK_SIZE`] entries. When it is
//! full, the traversal drops the entry, finishes, and then walks the tree again from the root
//! with a stack of [`BVH_STACK_SIZE`] entries and the closest hit found so far as `t_max`. The
//! builders keep every top-level leaf at depth `<=` [`BVH_TLAS_MAX_DEPTH`] and every
//! bottom-level leaf at depth `<=` [`BVH_BLAS_MAX_DEPTH`] below its root (root node = depth 0),
//! whose sum is [`BVH_MAX_DEPTH`]: an interior node at depth `d` sees at most `d` deferred
//! children on the stack and adds one, so that second walk cannot overflow on a well-formed
//! tree. It only costs time for the rays that need a deeper stack.
//!
//! Nothing on this path panics: an out-of-range node, instance, mesh, triangle or vertex index, a
//! child that does not come after its parent, a top-level leaf of more than one instance, a
//! bottom-level leaf of more than [`BVH_MAX_LEAF_TRIANGLES`] triangles, a mesh root past the end
//! of the nodes, a transform that makes the object-space ray non-finite, or an overflow of the
//! long stack drops that part (it is treated as a miss). Each bottom level is entered once per
//! top-level leaf, and within each level children come after their parents, so a malformed BVH
//! gives wrong hits, never a fault or an endless loop.
//!
//! # Ray/triangle test
//!
//! Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013, in the
//! mesh's object space: the vertices are translated to the ray's origin and sheared so that the
//! ray runs along +z, and three 2D edge functions decide. Each edge function of an edge shared by
//! two triangles of a mesh is computed from the same vertex values, in one canonical order of
//! the edge's two vertices, so it comes out exactly negated: a ray cannot pass between two
//! triangles that share an edge, nor through a vertex shared by a fan. The paper recomputes an
//! edge function that is exactly 0 in double precision; kernels have no `f64`, so here 0 counts
//! as inside for both triangles of the edge instead, which keeps the test watertight (both may
//! report the hit, and the tie rule below picks one). The canonical order keeps the negation
//! exact where a compiler fuses one product of an edge function into an FMA, as NVIDIA's does
//! (`tests/tests/tracing.rs` and `tests/tests/gbuffer.rs` count the rays that slip through).
//!
//! Hits obey `t_min <= t <= t_max`, with `t` in units of the world direction's length, like
//! `VK_KHR_ray_query`; `t` is compared against the bounds scaled by the determinant before the
//! division, then checked again after it. Ties: the closest `t` wins; among hits at exactly the
//! same `t` the first one tested wins, and the test order follows the traversal (near child
//! first, the left one on equal entry distances; after a stack overflow, what the first walk
//! found), which a hardware or lavapipe ray query need not share. Ties only happen on shared
//! edges and vertices and on coplanar overlaps.
//!
//! Front faces are counter-clockwise seen from the ray's origin in the mesh's object space, as
//! ray queries decide them: a mirroring instance transform then shows the clockwise side of its
//! triangles in world space as the front. Barycentrics stay in the mesh's vertex order.
//!
//! # Alpha-tested meshes
//!
//! A triangle of a mesh flagged [`MESH_ALPHA_TESTED`] is only hit where [`alpha_visible`] says
//! its surface is there (base colour alpha at level 0 against its material's cutoff): a hit it
//! rejects neither ends an [`any_hit`] nor shortens the closest hit's `t_max`, so the walk goes
//! on behind it as if the triangle had a hole there. Ray queries do the same with their
//! non-opaque candidates. Unflagged meshes pay one test of the flag per hit.

use bytemuck::{Pod, Zeroable};
use glam::{UVec4, Vec2, Vec3, Vec4};
use num_traits::Float;

use crate::elements::Elements;
use crate::ray::{HitRecord, Ray};
use crate::scene_data::{
    GpuInstance, GpuMesh, GpuTriangle, GpuVertex, MESH_ALPHA_TESTED, SceneSurfaces, alpha_visible,
};
use crate::textures::TextureImages;

/// Entries of the long traversal stack: enough for any tree whose leaves are within the depth
/// limits of both levels.
pub const BVH_STACK_SIZE: usize = 64;

/// Entries of the short stack of the first walk; see the module documentation.
pub const BVH_SHORT_STACK_SIZE: usize = 16;

/// Deepest leaf of the two levels together: a top-level leaf's depth plus a bottom-level leaf's
/// depth below its root.
pub const BVH_MAX_DEPTH: u32 = BVH_STACK_SIZE as u32;

/// Deepest leaf of the top level (over instances), root node at depth 0: room for `2^24`
/// instances even when every split is at the median.
pub const BVH_TLAS_MAX_DEPTH: u32 = 24;

/// Deepest leaf of a mesh's bottom level, its root node at depth 0.
pub const BVH_BLAS_MAX_DEPTH: u32 = BVH_MAX_DEPTH - BVH_TLAS_MAX_DEPTH;

/// Most triangles in one bottom-level leaf: the stack packs a leaf's count into
/// `STACK_COUNT_BITS` (4) bits.
pub const BVH_MAX_LEAF_TRIANGLES: u32 = (1 << STACK_COUNT_BITS) - 1;

/// Node, instance and triangle indices must stay below this: the stack packs an index with a
/// count into one `u32`.
pub const BVH_MAX_INDEX: u32 = 1 << (31 - STACK_COUNT_BITS);

/// Bits of a stack entry that hold a leaf's count (0 for an interior node).
const STACK_COUNT_BITS: u32 = 4;

/// A stack entry, child reference or instance that is not there.
const NO_CHILD: u32 = u32::MAX;

/// Direction components smaller than this in magnitude count as zero in the box test: their
/// inverse is `±∞` without a division by 0, which Vulkan leaves unspecified on the GPU.
const MIN_DIRECTION: f32 = 1e-30;

/// Widens the far distance of a box test by the worst rounding of the slab computation
/// (`1 + 2·γ(3)`, Ize 2013), so that a triangle lying on its node's bounds is never culled.
const BOX_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// One child of a [`BvhNode`] (32 bytes): its bounds, and either a node or a leaf.
///
/// | offset | field   |
/// |--------|---------|
/// | 0      | `min`   |
/// | 12     | `index` |
/// | 16     | `max`   |
/// | 28     | `count` |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhChild {
    /// Lower corner of the child's bounds.
    pub min: [f32; 3],
    /// Interior child: its node index. Top-level leaf: the instance. Bottom-level leaf: its
    /// first triangle within the mesh.
    pub index: u32,
    /// Upper corner of the child's bounds.
    pub max: [f32; 3],
    /// Number of instances (1) or triangles of a leaf; 0 for an interior node.
    pub count: u32,
}

impl BvhChild {
    /// A slot that holds nothing: a box at infinity that no ray enters.
    pub const EMPTY: Self = Self {
        min: [f32::INFINITY; 3],
        index: 0,
        max: [f32::INFINITY; 3],
        count: 0,
    };

    /// Whether the child is a leaf.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count != 0
    }
}

/// One interior node (64 bytes): its two children with their boxes.
///
/// | offset | field   |
/// |--------|---------|
/// | 0      | `left`  |
/// | 32     | `right` |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    /// First child.
    pub left: BvhChild,
    /// Second child.
    pub right: BvhChild,
}

/// A [`BvhNode`] as the software-traversal kernels bind it: the same 64 bytes as four 16-byte
/// vectors, so that a node is four vector loads on the device rather than one load per field.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhNodeRows {
    /// The node's bytes, 16 at a time.
    pub rows: [UVec4; 4],
}

/// An element of a node buffer that the traversal can read a [`BvhNode`] from: the node itself on
/// the CPU, its rows on the device.
pub trait BvhElement {
    /// The node this element holds.
    fn get(&self) -> BvhNode;
}

impl BvhElement for BvhNode {
    #[inline]
    fn get(&self) -> BvhNode {
        *self
    }
}

/// The first three components of a row as floats, and the fourth as it is.
#[inline]
fn split_row(row: UVec4) -> ([f32; 3], u32) {
    (
        [
            f32::from_bits(row.x),
            f32::from_bits(row.y),
            f32::from_bits(row.z),
        ],
        row.w,
    )
}

#[inline]
fn child_of_rows(lo: UVec4, hi: UVec4) -> BvhChild {
    let (min, index) = split_row(lo);
    let (max, count) = split_row(hi);
    BvhChild {
        min,
        index,
        max,
        count,
    }
}

impl BvhElement for BvhNodeRows {
    #[inline]
    fn get(&self) -> BvhNode {
        BvhNode {
            left: child_of_rows(self.rows[0], self.rows[1]),
            right: child_of_rows(self.rows[2], self.rows[3]),
        }
    }
}

/// What the traversal reads: the two-level node buffer, the shading data's geometry (the
/// buffers of `crate::scene_data`), and the materials and texture table that the alpha test of
/// meshes flagged [`MESH_ALPHA_TESTED`] reads.
///
/// The arrays that scale with the triangle count (nodes, vertices, triangles) are read through
/// [`Elements`]: slices on the CPU, split bindings in the kernels (`crate::elements`).
#[derive(Clone, Copy)]
pub struct BvhScene<'a, N, V = &'a [GpuVertex], T = &'a [GpuTriangle]> {
    /// Top level at node 0, then the meshes' bottom levels ([`BvhElement`]s).
    pub nodes: N,
    /// The shading data: the instances and meshes (with their bottom-level roots) and their
    /// vertices and triangles (each mesh's in its bottom level's leaf order) that the walk
    /// intersects, the materials and texture table for the alpha test.
    pub surfaces: SceneSurfaces<'a, V, T>,
}

/// A ray/triangle intersection before it goes into a [`HitRecord`]; `t` is `+∞` on a miss. No
/// `bool` fields: rust-gpu would need the `Int8` capability to keep them in memory.
#[derive(Clone, Copy)]
struct TriangleHit {
    t: f32,
    u: f32,
    v: f32,
    front_face: u32,
}

/// A ray prepared once for the box and triangle tests of a traversal.
#[derive(Clone, Copy)]
struct TraceRay {
    origin: Vec3,
    /// `1/d` per axis; `±∞` where the ray is (nearly) parallel to the axis' slabs.
    inv_dir: Vec3,
    t_min: f32,
    /// The axis along which the direction is largest (`kz` of the paper), and the other two in
    /// the order that keeps the winding (`kx`, `ky`).
    kx: u32,
    ky: u32,
    kz: u32,
    /// Shear constants: `d[kx]/d[kz]`, `d[ky]/d[kz]`, `1/d[kz]`.
    sx: f32,
    sy: f32,
    sz: f32,
}

/// Component `k` (0, 1 or 2) of `v`, without an indexing panic path.
#[inline]
fn component(v: Vec3, k: u32) -> f32 {
    if k == 0 {
        v.x
    } else if k == 1 {
        v.y
    } else {
        v.z
    }
}

/// `m` (three rows of four) applied to `p` extended with `w`.
#[inline]
fn transform(m: &[[f32; 4]; 3], p: Vec3, w: f32) -> Vec3 {
    let h = p.extend(w);
    Vec3::new(
        Vec4::from_array(m[0]).dot(h),
        Vec4::from_array(m[1]).dot(h),
        Vec4::from_array(m[2]).dot(h),
    )
}

/// `ray` in the object space of `inst`: the same `t` reaches the same point, since the direction
/// is transformed as it is (not normalised). Not traceable when the transform is malformed.
///
/// The origin is moved by the instance's translation before the linear part applies: near an
/// instance far from the world's origin that difference is exact, so the object-space origin
/// keeps the precision of the object's own coordinates.
#[inline]
fn object_ray(ray: &Ray, inst: &GpuInstance) -> Ray {
    let m = &inst.world_to_object;
    let o = &inst.object_to_world;
    let translation = Vec3::new(o[0][3], o[1][3], o[2][3]);
    let offset = Vec3::from_array(ray.origin) - translation;
    Ray {
        origin: transform(m, offset, 0.0).to_array(),
        direction: transform(m, Vec3::from_array(ray.direction), 0.0).to_array(),
        ..*ray
    }
}

impl TraceRay {
    /// Prepares a ray that [`Ray::is_traceable`] accepted.
    #[inline]
    fn new(ray: &Ray) -> Self {
        let origin = Vec3::from_array(ray.origin);
        let dir = Vec3::from_array(ray.direction);
        let a = dir.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = if kz == 2 { 0 } else { kz + 1 };
        let mut ky = if kx == 2 { 0 } else { kx + 1 };
        let dz = component(dir, kz);
        // Swapping x and y for a negative z keeps the sheared triangle's winding.
        if dz < 0.0 {
            core::mem::swap(&mut kx, &mut ky);
        }
        Self {
            origin,
            inv_dir: Vec3::new(
                safe_inverse(dir.x),
                safe_inverse(dir.y),
                safe_inverse(dir.z),
            ),
            t_min: ray.t_min,
            kx,
            ky,
            kz,
            sx: component(dir, kx) / dz,
            sy: component(dir, ky) / dz,
            sz: 1.0 / dz,
        }
    }

    /// Entry distance of the ray into `child`'s box clipped to `[t_min, t_max]`, or `+∞` when
    /// it misses.
    ///
    /// The near plane of each slab is picked by the direction's sign rather than as the smaller
    /// distance, so an empty box (`min > max`) misses. A ray parallel to a slab (`inv_dir` is
    /// `±∞`) gets `±∞` from it, or NaN when it runs exactly in one of the slab's planes; the
    /// comparisons are written so that NaN leaves the interval unchanged, which keeps the
    /// boundary inside. NaN bounds (only in a malformed BVH) thus never cull.
    #[inline]
    fn enter(&self, child: &BvhChild, t_max: f32) -> f32 {
        let t0 = (Vec3::from_array(child.min) - self.origin) * self.inv_dir;
        let t1 = (Vec3::from_array(child.max) - self.origin) * self.inv_dir;
        let mut t_enter = self.t_min;
        let mut t_exit = t_max;
        slab(t0.x, t1.x, self.inv_dir.x, &mut t_enter, &mut t_exit);
        slab(t0.y, t1.y, self.inv_dir.y, &mut t_enter, &mut t_exit);
        slab(t0.z, t1.z, self.inv_dir.z, &mut t_enter, &mut t_exit);
        if t_enter <= t_exit * BOX_FAR_SCALE {
            t_enter
        } else {
            f32::INFINITY
        }
    }

    /// The watertight test: the hit of the ray with the triangle `v` for `t` in
    /// `[t_min, t_max]`.
    ///
    /// `u`, `v` weigh the second and third vertex. Every comparison is written so that NaN
    /// fails it, so NaN triangles miss.
    #[inline]
    fn intersect(&self, v: [Vec3; 3], t_max: f32) -> TriangleHit {
        let a = v[0] - self.origin;
        let b = v[1] - self.origin;
        let c = v[2] - self.origin;
        let (a_z, b_z, c_z) = (
            component(a, self.kz),
            component(b, self.kz),
            component(c, self.kz),
        );
        let ax = component(a, self.kx) - self.sx * a_z;
        let ay = component(a, self.ky) - self.sy * a_z;
        let bx = component(b, self.kx) - self.sx * b_z;
        let by = component(b, self.ky) - self.sy * b_z;
        let cx = component(c, self.kx) - self.sx * c_z;
        let cy = component(c, self.ky) - self.sy * c_z;
        // Edge functions; each is the weight of the vertex opposite its edge.
        let (a2, b2, c2) = (Vec2::new(ax, ay), Vec2::new(bx, by), Vec2::new(cx, cy));
        let u = edge_function(c2, b2);
        let v = edge_function(a2, c2);
        let w = edge_function(b2, a2);
        let mut out = TriangleHit {
            t: f32::INFINITY,
            u: 0.0,
            v: 0.0,
            front_face: 0,
        };
        // Mixed signs: outside. Zeros count as inside on both sides of an edge.
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return out;
        }
        let det = u + v + w;
        // The ray is parallel to the plane (or NaN reaches `det`, and the test below fails).
        if det == 0.0 {
            return out;
        }
        let t_scaled = u * (self.sz * a_z) + v * (self.sz * b_z) + w * (self.sz * c_z);
        let (t_signed, det_abs) = if det < 0.0 {
            (-t_scaled, -det)
        } else {
            (t_scaled, det)
        };
        if !(t_signed >= self.t_min * det_abs && t_signed <= t_max * det_abs) {
            return out;
        }
        let t = t_scaled / det;
        // The division may round past a bound the scaled test let through.
        if !(t >= self.t_min && t <= t_max) {
            return out;
        }
        let inv_det = 1.0 / det;
        out.t = t;
        out.u = v * inv_det;
        out.v = w * inv_det;
        out.front_face = if det > 0.0 { 1 } else { 0 };
        out
    }
}

/// The edge function of the directed edge `p → q` in the ray's sheared 2D space, `p × q`,
/// evaluated with the edge's vertices in one canonical order and negated when they come the
/// other way round: the two triangles of a shared edge then run the same arithmetic on the same
/// operands, and their values are exact negatives even where a compiler fuses one product of
/// the difference into an FMA (NVIDIA's does; without this order, 11 rays of a 64 × 48 Cornell
/// box slipped between its triangles on an H200).
#[inline]
fn edge_function(p: Vec2, q: Vec2) -> f32 {
    let swap = q.x < p.x || (q.x == p.x && q.y < p.y);
    let (lo, hi) = if swap { (q, p) } else { (p, q) };
    let e = lo.x * hi.y - lo.y * hi.x;
    if swap { -e } else { e }
}

/// Clips `[t_enter, t_exit]` to one slab, whose planes the ray reaches at `t_lo` (the lower
/// one) and `t_hi`; `inv` is the inverse direction, whose sign says which plane is near.
#[inline]
fn slab(t_lo: f32, t_hi: f32, inv: f32, t_enter: &mut f32, t_exit: &mut f32) {
    let (near, far) = if inv < 0.0 {
        (t_hi, t_lo)
    } else {
        (t_lo, t_hi)
    };
    if near > *t_enter {
        *t_enter = near;
    }
    if far < *t_exit {
        *t_exit = far;
    }
}

/// `1/d`, and `±∞` (with the sign of `d`) for components below [`MIN_DIRECTION`], whose inverse
/// would overflow anyway: no `1/0` on the GPU.
#[inline]
fn safe_inverse(d: f32) -> f32 {
    if Float::abs(d) >= MIN_DIRECTION {
        1.0 / d
    } else if d.is_sign_negative() {
        f32::NEG_INFINITY
    } else {
        f32::INFINITY
    }
}

/// The object-space vertices of triangle `primitive` of `mesh` (which the caller checked is in
/// range); NaN, which misses, for a vertex index out of range.
#[inline]
fn triangle_vertices(
    vertices: impl Elements<Item = GpuVertex>,
    triangles: impl Elements<Item = GpuTriangle>,
    mesh: &GpuMesh,
    primitive: u32,
) -> [Vec3; 3] {
    let [a, b, c] = triangles
        .get(mesh.first_triangle as usize + primitive as usize)
        .indices;
    [
        position(vertices, mesh, a),
        position(vertices, mesh, b),
        position(vertices, mesh, c),
    ]
}

/// The position of vertex `index` of `mesh`; NaN when out of range.
#[inline]
fn position(vertices: impl Elements<Item = GpuVertex>, mesh: &GpuMesh, index: u32) -> Vec3 {
    let i = mesh.first_vertex as usize + index as usize;
    if index < mesh.vertex_count && i < vertices.len() {
        Vec3::from_array(vertices.get(i).position)
    } else {
        Vec3::NAN
    }
}

/// Triangles of `mesh` that exist in `triangles`: its count, clipped to the buffer.
#[inline]
fn triangle_limit(mesh: &GpuMesh, triangles: usize) -> usize {
    let first = mesh.first_triangle as usize;
    if first < triangles {
        (mesh.triangle_count as usize).min(triangles - first)
    } else {
        0
    }
}

/// The stack entry of `child` of node `parent`, or [`NO_CHILD`] when it is malformed: an interior
/// child that does not come after its parent or lies past the end, or a leaf longer than
/// `max_count` or past `items` (instances or the mesh's triangles).
#[inline]
fn child_entry(child: &BvhChild, parent: u32, nodes: usize, items: usize, max_count: u32) -> u32 {
    let (index, count) = (child.index, child.count);
    let valid = if count == 0 {
        index > parent && (index as usize) < nodes
    } else {
        count <= max_count && (index as usize) <= items && count as usize <= items - index as usize
    };
    if valid && index < BVH_MAX_INDEX {
        (index << STACK_COUNT_BITS) | count
    } else {
        NO_CHILD
    }
}

/// One walk of both levels from the root with a stack of `STACK` entries, starting from the hit
/// in `best` (which must lie in `[ray.t_min, t_max]` when it is one). Returns whether an entry
/// was dropped because the stack was full. With `ANY`, stops at the first hit and does not order
/// children.
#[inline]
fn walk<
    const STACK: usize,
    const ANY: bool,
    N: Elements<Item: BvhElement>,
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
>(
    scene: BvhScene<'_, N, V, T>,
    images: &I,
    world_ray: &Ray,
    world: &TraceRay,
    mut t_max: f32,
    best: &mut HitRecord,
) -> bool {
    // Each entry: the child (see `child_entry`) and its entry distance's bits.
    let mut stack = [[0u32; 2]; STACK];
    let mut sp = 0usize;
    let mut overflow = false;
    // The interior node to visit next (`NO_CHILD`: none), and the triangles still to test.
    let mut node = 0u32;
    let mut tri = 0u32;
    let mut tri_end = 0u32;
    // The instance whose bottom level is being walked (`NO_CHILD`: the top level), its mesh, the
    // number of its mesh's triangles that exist, and the stack depth when it was entered.
    let mut instance = NO_CHILD;
    let mut mesh = GpuMesh::EMPTY;
    let mut items = scene.surfaces.instances.len();
    let mut base = 0usize;
    let mut ray = *world;
    loop {
        // Where to go next, as a stack entry; `NO_CHILD` keeps going with the triangles or pops.
        let mut next = NO_CHILD;
        if tri < tri_end {
            let v = triangle_vertices(
                scene.surfaces.vertices,
                scene.surfaces.triangles,
                &mesh,
                tri,
            );
            let h = ray.intersect(v, t_max);
            // Strictly closer: the first hit tested keeps an exact tie.
            if h.t < best.t && surface_there(scene, images, &mesh, instance, tri, &h) {
                *best = HitRecord {
                    t: h.t,
                    instance,
                    primitive: tri,
                    front_face: h.front_face,
                    barycentrics: [h.u, h.v],
                    _pad: [0; 2],
                };
                t_max = h.t;
                if ANY {
                    return overflow;
                }
            }
            tri += 1;
        } else if node != NO_CHILD {
            let n = scene.nodes.get(node as usize).get();
            let nodes = scene.nodes.len();
            let max_count = if instance == NO_CHILD {
                1
            } else {
                BVH_MAX_LEAF_TRIANGLES
            };
            let left = child_entry(&n.left, node, nodes, items, max_count);
            let right = child_entry(&n.right, node, nodes, items, max_count);
            let t_left = if left != NO_CHILD {
                ray.enter(&n.left, t_max)
            } else {
                f32::INFINITY
            };
            let t_right = if right != NO_CHILD {
                ray.enter(&n.right, t_max)
            } else {
                f32::INFINITY
            };
            node = NO_CHILD;
            if t_left < f32::INFINITY && t_right < f32::INFINITY {
                let (near, far, t_far) = if !ANY && t_right < t_left {
                    (right, left, t_left)
                } else {
                    (left, right, t_right)
                };
                next = near;
                if sp < STACK {
                    stack[sp] = [far, t_far.to_bits()];
                    sp += 1;
                } else {
                    overflow = true;
                }
            } else if t_left < f32::INFINITY {
                next = left;
            } else if t_right < f32::INFINITY {
                next = right;
            }
        }
        if next == NO_CHILD && tri >= tri_end && node == NO_CHILD {
            if instance != NO_CHILD && sp <= base {
                // The bottom level is exhausted: back to the world ray and the top level.
                instance = NO_CHILD;
                items = scene.surfaces.instances.len();
                ray = *world;
            }
            if sp == 0 {
                return overflow;
            }
            sp -= 1;
            let [entry, t_bits] = stack[sp];
            // The closest hit may have moved in front of the entry since it was pushed; without
            // ordering (`ANY`) nothing has been hit yet, so every entry is still in reach.
            if ANY || f32::from_bits(t_bits) <= t_max * BOX_FAR_SCALE {
                next = entry;
            }
        }
        if next != NO_CHILD {
            let count = next & BVH_MAX_LEAF_TRIANGLES;
            let index = next >> STACK_COUNT_BITS;
            if count == 0 {
                node = index;
            } else if instance != NO_CHILD {
                tri = index;
                tri_end = index + count;
            } else {
                // A top-level leaf (`child_entry` checked the instance): its mesh's bottom level.
                // By reference: only the fields used are loaded, not the whole 160 bytes.
                let inst = &scene.surfaces.instances[index as usize];
                let m = inst.mesh as usize;
                if m < scene.surfaces.meshes.len()
                    && (scene.surfaces.meshes[m].bvh_root as usize) < scene.nodes.len()
                {
                    let local = object_ray(world_ray, inst);
                    if local.is_traceable() {
                        mesh = scene.surfaces.meshes[m];
                        instance = index;
                        items = triangle_limit(&mesh, scene.surfaces.triangles.len());
                        base = sp;
                        ray = TraceRay::new(&local);
                        node = mesh.bvh_root;
                    }
                }
            }
        }
    }
}

/// Whether the hit `h` on triangle `primitive` of `instance` (whose mesh is `mesh`) counts: always
/// on an unflagged mesh, else where [`alpha_visible`] finds the surface.
#[inline]
fn surface_there<
    N,
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
>(
    scene: BvhScene<'_, N, V, T>,
    images: &I,
    mesh: &GpuMesh,
    instance: u32,
    primitive: u32,
    h: &TriangleHit,
) -> bool {
    mesh.flags & MESH_ALPHA_TESTED == 0
        || alpha_visible(
            scene.surfaces,
            images,
            instance,
            primitive,
            Vec2::new(h.u, h.v),
        )
}

/// Both walks of the module documentation: the short stack, then the long one if the short one
/// dropped an entry.
#[inline]
fn traverse<
    const ANY: bool,
    N: Elements<Item: BvhElement>,
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
>(
    scene: BvhScene<'_, N, V, T>,
    images: &I,
    ray: &Ray,
) -> HitRecord {
    let mut best = HitRecord::miss();
    if scene.nodes.is_empty() || !ray.is_traceable() {
        return best;
    }
    let world = TraceRay::new(ray);
    if walk::<BVH_SHORT_STACK_SIZE, ANY, N, V, T, I>(
        scene, images, ray, &world, ray.t_max, &mut best,
    ) && !(ANY && best.is_hit())
    {
        let t_max = if best.is_hit() { best.t } else { ray.t_max };
        walk::<BVH_STACK_SIZE, ANY, N, V, T, I>(scene, images, ray, &world, t_max, &mut best);
    }
    best
}

/// The closest hit of `ray` in `scene`, or [`HitRecord::miss`]; `images` holds the textures the
/// alpha test of flagged meshes reads (see the module documentation).
///
/// A ray that is not [`Ray::is_traceable`] misses (as it must with ray queries too),
/// as does every ray on an empty BVH. See the module documentation for ties.
pub fn closest_hit<
    N: Elements<Item: BvhElement>,
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
>(
    scene: BvhScene<'_, N, V, T>,
    images: &I,
    ray: &Ray,
) -> HitRecord {
    traverse::<false, N, V, T, I>(scene, images, ray)
}

/// Whether `ray` hits any triangle with `t_min <= t <= t_max` (shadow rays): stops at the first
/// that the alpha test lets through.
pub fn any_hit<
    N: Elements<Item: BvhElement>,
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
>(
    scene: BvhScene<'_, N, V, T>,
    images: &I,
    ray: &Ray,
) -> bool {
    traverse::<true, N, V, T, I>(scene, images, ray).is_hit()
}

/// The closest hit by testing every triangle of every instance in order, without the nodes: the
/// reference for the traversal, with the same transform, triangle test, alpha test, validity
/// rules and tie-break (the first instance, then the first triangle, wins).
pub fn closest_hit_brute_force<
    N: Copy,
    V: Elements<Item = GpuVertex>,
    T: Elements<Item = GpuTriangle>,
    I: TextureImages + ?Sized,
>(
    scene: BvhScene<'_, N, V, T>,
    images: &I,
    ray: &Ray,
) -> HitRecord {
    let mut best = HitRecord::miss();
    if !ray.is_traceable() {
        return best;
    }
    for (instance, inst) in scene.surfaces.instances.iter().enumerate() {
        let Some(mesh) = scene.surfaces.meshes.get(inst.mesh as usize) else {
            continue;
        };
        let local = object_ray(ray, inst);
        if !local.is_traceable() {
            continue;
        }
        let local = TraceRay::new(&local);
        for primitive in 0..triangle_limit(mesh, scene.surfaces.triangles.len()) as u32 {
            let v = triangle_vertices(
                scene.surfaces.vertices,
                scene.surfaces.triangles,
                mesh,
                primitive,
            );
            let h = local.intersect(v, best.t.min(ray.t_max));
            if h.t < best.t && surface_there(scene, images, mesh, instance as u32, primitive, &h) {
                best = HitRecord {
                    t: h.t,
                    instance: instance as u32,
                    primitive,
                    front_face: h.front_face,
                    barycentrics: [h.u, h.v],
                    _pad: [0; 2],
                };
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;
    use crate::scene_data::GpuMaterial;
    use crate::textures::GpuTexture;
    use core::mem::{offset_of, size_of};

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

    type Tri = [[f32; 3]; 3];

    /// Bounds of points as a child (index and count left 0); `f32::min`/`max` skip NaN, unlike
    /// glam's.
    fn bounds(points: impl IntoIterator<Item = [f32; 3]>) -> BvhChild {
        let mut b = BvhChild {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
            ..BvhChild::default()
        };
        for v in points {
            for (a, x) in v.into_iter().enumerate() {
                b.min[a] = b.min[a].min(x);
                b.max[a] = b.max[a].max(x);
            }
        }
        b
    }

    /// A test-only object-median builder with the production layout (children after their
    /// parent, node indices from `first_node`, leaves of up to `leaf` items, the leaf index being
    /// the position in `order`). Returns the nodes and `order` (input item at each position).
    /// The SAH builder lives in the host.
    fn median_tree(items: &[BvhChild], leaf: usize, first_node: u32) -> (Vec<BvhNode>, Vec<u32>) {
        fn centroid(b: &BvhChild, axis: usize) -> f32 {
            b.min[axis] + b.max[axis]
        }
        fn build(
            items: &[BvhChild],
            order: &mut [u32],
            first: usize,
            leaf: usize,
            first_node: u32,
            nodes: &mut Vec<BvhNode>,
        ) -> BvhChild {
            let all = order.iter().map(|&i| &items[i as usize]);
            let mut child = bounds(all.flat_map(|b| [b.min, b.max]));
            if order.len() <= leaf {
                child.index = first as u32;
                child.count = order.len() as u32;
                return child;
            }
            let extent = Vec3::from(child.max) - Vec3::from(child.min);
            let axis = extent.max_position();
            let mid = order.len() / 2;
            order.select_nth_unstable_by(mid, |&a, &b| {
                centroid(&items[a as usize], axis).total_cmp(&centroid(&items[b as usize], axis))
            });
            let me = nodes.len();
            nodes.push(BvhNode::default());
            let (l, r) = order.split_at_mut(mid);
            let left = build(items, l, first, leaf, first_node, nodes);
            let right = build(items, r, first + mid, leaf, first_node, nodes);
            nodes[me] = BvhNode { left, right };
            child.index = first_node + me as u32;
            child
        }
        let mut order: Vec<u32> = (0..items.len() as u32).collect();
        let mut nodes = Vec::new();
        if items.is_empty() {
            return (nodes, order);
        }
        let root = build(items, &mut order, 0, leaf, first_node, &mut nodes);
        if root.is_leaf() {
            nodes.push(BvhNode {
                left: root,
                right: BvhChild::EMPTY,
            });
        }
        (nodes, order)
    }

    /// A scene in the layout the traversal reads.
    #[derive(Clone, Default)]
    struct TestScene {
        nodes: Vec<BvhNode>,
        instances: Vec<GpuInstance>,
        meshes: Vec<GpuMesh>,
        vertices: Vec<GpuVertex>,
        triangles: Vec<GpuTriangle>,
        materials: Vec<GpuMaterial>,
        textures: Vec<GpuTexture>,
        texels: Vec<u32>,
    }

    impl TestScene {
        fn view(&self) -> BvhScene<'_, &[BvhNode]> {
            BvhScene {
                nodes: &self.nodes,
                surfaces: SceneSurfaces {
                    instances: &self.instances,
                    meshes: &self.meshes,
                    vertices: &self.vertices,
                    triangles: &self.triangles,
                    materials: &self.materials,
                    textures: &self.textures,
                },
            }
        }

        /// The object-space vertices of triangle `primitive` of instance `instance`'s mesh.
        fn triangle(&self, instance: u32, primitive: u32) -> [Vec3; 3] {
            let mesh = &self.meshes[self.instances[instance as usize].mesh as usize];
            triangle_vertices(
                self.vertices.as_slice(),
                self.triangles.as_slice(),
                mesh,
                primitive,
            )
        }

        /// The input index of triangle `primitive` (the builder reorders them), kept in its
        /// material.
        fn input_index(&self, primitive: u32) -> u32 {
            self.triangles[primitive as usize].material
        }
    }

    /// The instance of the 3×4 `object_to_world`, its inverse computed in `f64`.
    fn instance(mesh: u32, m: [[f32; 4]; 3]) -> GpuInstance {
        let a = glam::DMat4::from_cols_array_2d(&[
            m[0].map(f64::from),
            m[1].map(f64::from),
            m[2].map(f64::from),
            [0.0, 0.0, 0.0, 1.0],
        ])
        .transpose();
        let inv = a.inverse().transpose().to_cols_array_2d();
        let rows = |r: [f64; 4]| r.map(|x| x as f32);
        GpuInstance {
            object_to_world: m,
            world_to_object: [rows(inv[0]), rows(inv[1]), rows(inv[2])],
            mesh,
            winding: if a.determinant() < 0.0 { -1.0 } else { 1.0 },
            ..GpuInstance::ZERO
        }
    }

    const IDENTITY: [[f32; 4]; 3] = [
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ];

    /// One mesh of the triangles `soup` (each with its own three vertices; material = input
    /// index) placed by `placements`, with median bottom and top levels.
    fn scene(soup: &[Tri], placements: &[[[f32; 4]; 3]]) -> TestScene {
        let items: Vec<BvhChild> = soup.iter().map(|t| bounds(*t)).collect();
        let tlas_nodes = placements.len().saturating_sub(1).max(1) as u32;
        let (blas, order) = median_tree(&items, 2, tlas_nodes);
        let mut s = TestScene::default();
        for (k, &i) in order.iter().enumerate() {
            for v in soup[i as usize] {
                s.vertices.push(GpuVertex {
                    position: v,
                    ..GpuVertex::ZERO
                });
            }
            let k = 3 * k as u32;
            s.triangles.push(GpuTriangle {
                indices: [k, k + 1, k + 2],
                material: i,
            });
        }
        s.meshes.push(GpuMesh {
            first_triangle: 0,
            triangle_count: soup.len() as u32,
            first_vertex: 0,
            vertex_count: s.vertices.len() as u32,
            has_uvs: 0,
            bvh_root: tlas_nodes,
            flags: 0,
            _pad: 0,
        });
        s.instances = placements.iter().map(|&m| instance(0, m)).collect();
        // World bounds of the mesh bounds' corners, widened: the traversal must not cull an
        // instance's box that its transformed triangles touch.
        let b = bounds(soup.iter().flatten().copied());
        let world: Vec<BvhChild> = s
            .instances
            .iter()
            .map(|inst| {
                let corners = (0..8).map(|c| {
                    let p = Vec3::new(
                        if c & 1 == 0 { b.min[0] } else { b.max[0] },
                        if c & 2 == 0 { b.min[1] } else { b.max[1] },
                        if c & 4 == 0 { b.min[2] } else { b.max[2] },
                    );
                    transform(&inst.object_to_world, p, 1.0).to_array()
                });
                let mut w = bounds(corners);
                for a in 0..3 {
                    let pad = 1e-4 * (1.0 + w.max[a].abs().max(w.min[a].abs()));
                    w.min[a] -= pad;
                    w.max[a] += pad;
                }
                w
            })
            .collect();
        let (mut tlas, order) = median_tree(&world, 1, 0);
        for n in &mut tlas {
            for c in [&mut n.left, &mut n.right] {
                if c.is_leaf() {
                    c.index = order[c.index as usize];
                }
            }
        }
        if soup.is_empty() || placements.is_empty() {
            return TestScene::default();
        }
        assert_eq!(tlas.len() as u32, tlas_nodes);
        s.nodes = tlas;
        s.nodes.extend(blas);
        s
    }

    fn random_soup(rng: &mut Rng, n: usize, extent: f32, size: f32) -> Vec<Tri> {
        (0..n)
            .map(|_| {
                let c = Vec3::from(rng.vec(-extent, extent));
                [0; 3].map(|_| (c + Vec3::from(rng.vec(-size, size))).to_array())
            })
            .collect()
    }

    /// Asserts that the BVH and brute force agree on `ray`: the same record, or an exact tie in
    /// `t` (then the order of testing may pick another triangle).
    fn assert_agree(s: &TestScene, ray: &Ray) {
        let bvh = closest_hit(s.view(), &s.texels[..], ray);
        let brute = closest_hit_brute_force(s.view(), &s.texels[..], ray);
        assert_eq!(
            any_hit(s.view(), &s.texels[..], ray),
            brute.is_hit(),
            "{ray:?}"
        );
        if (bvh.instance, bvh.primitive) != (brute.instance, brute.primitive) && bvh.t == brute.t {
            return;
        }
        assert_eq!(bvh, brute, "{ray:?}");
    }

    #[test]
    fn layouts() {
        assert_eq!(size_of::<BvhChild>(), 32);
        assert_eq!(offset_of!(BvhChild, min), 0);
        assert_eq!(offset_of!(BvhChild, index), 12);
        assert_eq!(offset_of!(BvhChild, max), 16);
        assert_eq!(offset_of!(BvhChild, count), 28);
        assert_eq!(size_of::<BvhNode>(), 64);
        assert_eq!(offset_of!(BvhNode, left), 0);
        assert_eq!(offset_of!(BvhNode, right), 32);
        assert_eq!(size_of::<BvhNodeRows>(), size_of::<BvhNode>());
        // Packed stack entries never collide with the "no child" marker.
        const {
            assert!((BVH_MAX_INDEX - 1) << STACK_COUNT_BITS | BVH_MAX_LEAF_TRIANGLES < NO_CHILD);
            assert!(BVH_SHORT_STACK_SIZE < BVH_STACK_SIZE);
            assert!(BVH_TLAS_MAX_DEPTH + BVH_BLAS_MAX_DEPTH <= BVH_STACK_SIZE as u32);
        }
    }

    /// The rows the kernels bind hold the same nodes as the buffer the host uploads, and the
    /// traversal reads either alike.
    #[test]
    fn rows_hold_the_records() {
        let mut rng = Rng::new(4);
        let s = scene(&random_soup(&mut rng, 300, 2.0, 0.5), &[IDENTITY]);
        let node_rows: Vec<BvhNodeRows> = s
            .nodes
            .iter()
            .map(|n| {
                let w: &[u32] = bytemuck::cast_slice(core::slice::from_ref(n));
                let r = |k: usize| UVec4::from_slice(&w[4 * k..]);
                BvhNodeRows {
                    rows: [r(0), r(1), r(2), r(3)],
                }
            })
            .collect();
        for (node, rows) in s.nodes.iter().zip(&node_rows) {
            assert_eq!(bytemuck::bytes_of(&rows.get()), bytemuck::bytes_of(node));
        }
        let v = s.view();
        let rows_scene = BvhScene {
            nodes: &node_rows[..],
            surfaces: v.surfaces,
        };
        let mut hits = 0;
        for _ in 0..2000 {
            let ray = Ray {
                origin: rng.vec(-4.0, 4.0),
                t_min: 0.0,
                direction: rng.vec(-1.0, 1.0),
                t_max: f32::INFINITY,
            };
            let want = closest_hit(s.view(), &s.texels[..], &ray);
            assert_eq!(closest_hit(rows_scene, &s.texels[..], &ray), want);
            assert_eq!(any_hit(rows_scene, &s.texels[..], &ray), want.is_hit());
            hits += usize::from(want.is_hit());
        }
        assert!(hits > 200, "{hits}");
    }

    fn random_ray(rng: &mut Rng) -> Ray {
        let origin = rng.vec(-6.0, 6.0);
        let target = Vec3::from(rng.vec(-3.0, 3.0));
        // Not normalised: the length scales t.
        let direction = ((target - Vec3::from(origin)) * rng.range(0.1, 3.0)).to_array();
        let t_max = if rng.range(0.0, 1.0) < 0.5 {
            f32::INFINITY
        } else {
            rng.range(0.0, 2.0)
        };
        Ray {
            origin,
            t_min: rng.range(0.0, 0.2),
            direction,
            t_max,
        }
    }

    #[test]
    fn bvh_agrees_with_brute_force_on_random_soups() {
        let mut rng = Rng::new(1);
        let mut hits = 0;
        for (n, size) in [
            (1, 1.0),
            (3, 1.0),
            (17, 0.5),
            (200, 0.3),
            (1000, 0.2),
            (1000, 3.0),
        ] {
            let s = scene(&random_soup(&mut rng, n, 2.0, size), &[IDENTITY]);
            for _ in 0..4000 {
                let ray = random_ray(&mut rng);
                assert_agree(&s, &ray);
                hits += usize::from(closest_hit(s.view(), &s.texels[..], &ray).is_hit());
            }
        }
        // The rays must actually exercise hits, not just misses.
        assert!(hits > 4000, "{hits}");
    }

    /// The nodes, vertices and triangles split into chunks as the kernels bind them
    /// (`crate::elements`) give the very same hits as the whole arrays, chunk boundaries inside
    /// meshes and leaves included.
    #[test]
    fn split_arrays_trace_like_whole_ones() {
        use crate::elements::ChunkedSlices;
        use crate::layout::SCENE_BUFFER_CHUNKS;
        let mut rng = Rng::new(9);
        let soup = random_soup(&mut rng, 150, 2.0, 0.4);
        let s = scene(
            &soup,
            &[
                IDENTITY,
                [
                    [0.5, 0.0, 0.0, 1.0],
                    [0.0, 0.5, 0.0, 0.5],
                    [0.0, 0.0, 0.5, 0.0],
                ],
            ],
        );
        for chunk in [64, 128, 256, 1024] {
            let nodes: Vec<&[BvhNode]> = s.nodes.chunks(chunk).collect();
            let vertices: Vec<&[GpuVertex]> = s.vertices.chunks(chunk).collect();
            let triangles: Vec<&[GpuTriangle]> = s.triangles.chunks(chunk).collect();
            assert!(
                vertices.len() <= SCENE_BUFFER_CHUNKS,
                "{} chunks",
                vertices.len()
            );
            if chunk == 64 {
                assert!(nodes.len() > 1 && triangles.len() > 1 && vertices.len() > 1);
            }
            let split = BvhScene {
                nodes: ChunkedSlices::new(&nodes).unwrap(),
                surfaces: SceneSurfaces {
                    instances: &s.instances[..],
                    meshes: &s.meshes[..],
                    vertices: ChunkedSlices::new(&vertices).unwrap(),
                    triangles: ChunkedSlices::new(&triangles).unwrap(),
                    materials: &s.materials[..],
                    textures: &s.textures[..],
                },
            };
            let mut hits = 0;
            for _ in 0..2000 {
                let ray = random_ray(&mut rng);
                let whole = closest_hit(s.view(), &s.texels[..], &ray);
                assert_eq!(closest_hit(split, &s.texels[..], &ray), whole, "{ray:?}");
                assert_eq!(
                    any_hit(split, &s.texels[..], &ray),
                    any_hit(s.view(), &s.texels[..], &ray)
                );
                hits += usize::from(whole.is_hit());
            }
            assert!(hits > 200, "{hits} hits with chunks of {chunk}");
        }
    }

    /// Many placements of one mesh, mirrored, scaled, rotated and sheared ones among them: the
    /// two levels agree with brute force, and the front face is decided in object space.
    #[test]
    fn instanced_meshes_agree_with_brute_force() {
        let mut rng = Rng::new(5);
        let soup = random_soup(&mut rng, 200, 1.0, 0.3);
        let mut placements = Vec::new();
        for i in 0..40 {
            let mut m = [[0.0; 4]; 3];
            for (r, row) in m.iter_mut().enumerate() {
                for (c, x) in row.iter_mut().take(3).enumerate() {
                    *x = if r == c { 1.0 } else { 0.0 } + rng.range(-0.3, 0.3);
                }
                row[3] = rng.range(-3.0, 3.0);
            }
            match i % 4 {
                // Mirrored in x.
                0 => m.iter_mut().for_each(|row| row[0] = -row[0]),
                // Scaled up and down.
                1 => m.iter_mut().flatten().take(3).for_each(|x| *x *= 2.5),
                2 => m
                    .iter_mut()
                    .for_each(|row| row[..3].iter_mut().for_each(|x| *x *= 0.1)),
                _ => {}
            }
            placements.push(m);
        }
        let s = scene(&soup, &placements);
        let mut hits = 0;
        let mut mirrored_front = 0;
        for _ in 0..6000 {
            let ray = random_ray(&mut rng);
            assert_agree(&s, &ray);
            let h = closest_hit(s.view(), &s.texels[..], &ray);
            if h.is_hit() {
                hits += 1;
                // Front face = counter-clockwise in object space = the world-space cross product
                // flipped by a mirroring transform.
                let inst = &s.instances[h.instance as usize];
                let [a, b, c] = s
                    .triangle(h.instance, h.primitive)
                    .map(|p| transform(&inst.object_to_world, p, 1.0));
                let n = (b - a).cross(c - a) * inst.winding;
                let facing = n.dot(Vec3::from(ray.direction)) < 0.0;
                assert_eq!(h.front_face, u32::from(facing), "{ray:?}");
                mirrored_front += usize::from(inst.winding < 0.0 && facing);
                // The reported t reaches the triangle in world space.
                let p = Vec3::from(ray.origin) + h.t * Vec3::from(ray.direction);
                let q = a + h.barycentrics[0] * (b - a) + h.barycentrics[1] * (c - a);
                assert!((p - q).length() < 1e-3 * (1.0 + p.length()), "{p} {q}");
            }
        }
        assert!(
            hits > 1500 && mirrored_front > 50,
            "{hits} {mirrored_front}"
        );
        // One bottom level for all 40 placements, and a top level of 39 nodes.
        assert_eq!(
            s.nodes.len(),
            39 + median_tree(&[BvhChild::default(); 200], 2, 0).0.len()
        );
    }

    /// A 16 × 16 grid of quads in the plane z = 0: node bounds have zero thickness and share
    /// planes with the rays below.
    fn grid() -> Vec<Tri> {
        let mut tris = Vec::new();
        for y in 0..16 {
            for x in 0..16 {
                let (x, y) = (x as f32, y as f32);
                tris.push([[x, y, 0.0], [x + 1.0, y, 0.0], [x + 1.0, y + 1.0, 0.0]]);
                tris.push([[x, y, 0.0], [x + 1.0, y + 1.0, 0.0], [x, y + 1.0, 0.0]]);
            }
        }
        tris
    }

    #[test]
    fn axis_aligned_rays_with_zero_components() {
        let s = scene(&grid(), &[IDENTITY]);
        let mut rng = Rng::new(2);
        for i in 0..2000 {
            // Half the origins sit exactly on grid lines, i.e. on node bounds.
            let mut xy = [rng.range(-1.0, 17.0), rng.range(-1.0, 17.0)];
            if i % 2 == 0 {
                xy[i % 4 / 2] = (rng.next_u32() % 17) as f32;
            }
            for direction in [[0.0, 0.0, -1.0], [0.0, -0.0, -3.0], [-0.0, 0.0, 0.5]] {
                let ray = Ray {
                    origin: [xy[0], xy[1], 1.0],
                    t_min: 0.0,
                    direction,
                    t_max: f32::INFINITY,
                };
                assert_agree(&s, &ray);
                let hit = closest_hit(s.view(), &s.texels[..], &ray);
                let inside = (0.0..=16.0).contains(&xy[0]) && (0.0..=16.0).contains(&xy[1]);
                if direction[2] > 0.0 || !inside {
                    assert!(!hit.is_hit(), "{ray:?}");
                } else {
                    // Watertight: inside the grid, on its lines included, every ray hits.
                    assert!(hit.is_hit(), "{ray:?}");
                    // `t` goes through the shear's `1/d`: within a few ULPs.
                    let t = 1.0 / -direction[2];
                    assert!((hit.t - t).abs() <= 2.0 * f32::EPSILON * t, "{hit:?}");
                    // Counter-clockwise seen from above: the front face.
                    assert_eq!(hit.front_face, 1);
                }
            }
        }
        // Along the grid's own plane and along its lines: parallel to every triangle.
        for (origin, direction) in [
            ([-1.0, 0.5, 0.0], [1.0, 0.0, 0.0]),
            ([-1.0, 3.0, 0.0], [1.0, 0.0, 0.0]),
            ([3.0, -1.0, 0.0], [0.0, 2.0, 0.0]),
            ([-1.0, -1.0, 0.0], [1.0, 1.0, 0.0]),
            ([-1.0, 0.5, 1.0], [1.0, 0.0, 0.0]),
        ] {
            let ray = Ray {
                origin,
                t_min: 0.0,
                direction,
                t_max: f32::INFINITY,
            };
            assert!(
                !closest_hit(s.view(), &s.texels[..], &ray).is_hit(),
                "{ray:?}"
            );
            assert!(!any_hit(s.view(), &s.texels[..], &ray), "{ray:?}");
        }
    }

    #[test]
    fn back_face_and_barycentrics() {
        let s = scene(&grid(), &[IDENTITY]);
        let ray = Ray {
            origin: [2.25, 3.75, -2.0],
            t_min: 0.0,
            direction: [0.0, 0.0, 4.0],
            t_max: f32::INFINITY,
        };
        let hit = closest_hit(s.view(), &s.texels[..], &ray);
        assert!(hit.is_hit());
        assert_eq!(hit.front_face, 0);
        assert_eq!(hit.t, 0.5);
        let [v0, v1, v2] = s.triangle(0, hit.primitive);
        let [u, v] = hit.barycentrics;
        let p = v0 + u * (v1 - v0) + v * (v2 - v0);
        let expected = Vec3::from(ray.origin) + hit.t * Vec3::from(ray.direction);
        assert!((p - expected).length() < 1e-6, "{p} {expected}");
        let n = (v1 - v0).cross(v2 - v0);
        assert!(n.dot(Vec3::from(ray.direction)) > 0.0);
    }

    /// The front face is decided in object space: a mirroring instance's triangle, clockwise
    /// seen from above in world space, still shows its front face upwards, with the same
    /// distance and barycentrics.
    #[test]
    fn mirrored_instances_keep_the_object_space_front_face() {
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        // Mirrored in x, moved by 1 in x: the triangle covers x in [0, 1] again.
        let mirror = [
            [-1.0, 0.0, 0.0, 1.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ];
        for (m, x, winding) in [(IDENTITY, 0.25, 1.0), (mirror, 0.75, -1.0)] {
            let s = scene(&[v], &[m, m]);
            let [a, b, c] = s.triangle(0, 0).map(|p| transform(&m, p, 1.0));
            assert_eq!((b - a).cross(c - a).z, winding);
            for (z, dz, face) in [(1.0, -1.0, 1), (-1.0, 2.0, 0)] {
                let ray = Ray {
                    origin: [x, 0.5, z],
                    t_min: 0.0,
                    direction: [0.0, 0.0, dz],
                    t_max: f32::INFINITY,
                };
                let hit = closest_hit(s.view(), &s.texels[..], &ray);
                assert_eq!(hit.primitive, 0);
                assert_eq!(hit.front_face, face, "{m:?} {ray:?}");
                assert_eq!(hit.barycentrics, [0.25, 0.5]);
                assert_eq!(hit.t, 1.0 / dz.abs());
            }
        }
    }

    #[test]
    fn t_min_and_t_max_clip_inclusively() {
        // Ten parallel quads at z = 1..=10; the direction has length 2, so quad k is at t = k/2.
        let layers: Vec<Tri> = (1..=10)
            .map(|k| {
                let z = k as f32;
                [[-1.0, -1.0, z], [1.0, -1.0, z], [0.0, 1.0, z]]
            })
            .collect();
        let s = scene(&layers, &[IDENTITY]);
        let trace = |t_min: f32, t_max: f32| {
            let ray = Ray {
                origin: [0.0, 0.0, 0.0],
                t_min,
                direction: [0.0, 0.0, 2.0],
                t_max,
            };
            assert_agree(&s, &ray);
            let h = closest_hit(s.view(), &s.texels[..], &ray);
            // The layer's number, or 0 on a miss.
            let layer = if h.is_hit() {
                s.input_index(h.primitive) + 1
            } else {
                0
            };
            (layer, h.t)
        };
        assert_eq!(trace(0.0, f32::INFINITY), (1, 0.5));
        assert_eq!(trace(1.6, f32::INFINITY), (4, 2.0));
        assert_eq!(trace(1.6, 1.9).0, 0);
        assert_eq!(trace(2.0, 2.0), (4, 2.0));
        assert_eq!(trace(0.0, 0.5), (1, 0.5));
        assert_eq!(trace(5.01, f32::INFINITY).0, 0);
        assert_eq!(trace(2.0, 1.0).0, 0);
        assert_eq!(trace(0.0, -1.0).0, 0);
    }

    #[test]
    fn nan_and_infinite_rays_miss() {
        let s = scene(&grid(), &[IDENTITY]);
        let good = Ray {
            origin: [0.5, 0.25, 1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        assert!(closest_hit(s.view(), &s.texels[..], &good).is_hit());
        let nan = f32::NAN;
        for ray in [
            Ray {
                origin: [nan, 0.25, 1.0],
                ..good
            },
            Ray {
                origin: [0.5, 0.25, f32::INFINITY],
                ..good
            },
            Ray {
                direction: [0.0, nan, -1.0],
                ..good
            },
            Ray {
                direction: [0.0, 0.0, f32::NEG_INFINITY],
                ..good
            },
            Ray {
                direction: [0.0; 3],
                ..good
            },
            Ray { t_min: nan, ..good },
            Ray { t_max: nan, ..good },
        ] {
            assert_eq!(
                closest_hit(s.view(), &s.texels[..], &ray),
                HitRecord::miss(),
                "{ray:?}"
            );
            assert_eq!(
                closest_hit_brute_force(s.view(), &s.texels[..], &ray),
                HitRecord::miss()
            );
            assert!(!any_hit(s.view(), &s.texels[..], &ray), "{ray:?}");
        }
    }

    #[test]
    fn nan_triangles_and_bad_indices_miss_and_do_not_hide_others() {
        let mut soup = grid();
        soup[5][0][1] = f32::NAN;
        soup[9][2] = [f32::NAN; 3];
        soup[12][1][0] = f32::INFINITY;
        let mut s = scene(&soup, &[IDENTITY]);
        // Triangle of input 20 gets a vertex index past the mesh's vertices.
        let bad = s.triangles.iter().position(|t| t.material == 20).unwrap();
        s.triangles[bad].indices[1] = 1 << 30;
        let mut rng = Rng::new(3);
        let mut hits = 0;
        for _ in 0..2000 {
            let ray = Ray {
                origin: [rng.range(-1.0, 17.0), rng.range(-1.0, 17.0), 1.0],
                t_min: 0.0,
                direction: [rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), -1.0],
                t_max: f32::INFINITY,
            };
            assert_agree(&s, &ray);
            let hit = closest_hit(s.view(), &s.texels[..], &ray);
            if hit.is_hit() {
                hits += 1;
                assert!(![5, 9, 12, 20].contains(&s.input_index(hit.primitive)));
            }
        }
        assert!(hits > 1000, "{hits}");
    }

    /// Everything contains the ray's path.
    const EVERYWHERE: BvhChild = BvhChild {
        min: [-100.0; 3],
        index: 0,
        max: [100.0; 3],
        count: 0,
    };

    /// A top-level root (node 0) over instance 0, then a chain of `depth` nodes from node 1 (the
    /// mesh's root): node `k`'s left child is node `k + 1` (the last one's a leaf of triangle
    /// `end`), its right child a leaf of triangle `side(k)`. Every box contains the ray, so with
    /// equal entry distances the left child comes first and each level pushes its right leaf:
    /// the chain needs a stack as deep as itself.
    fn chain(depth: usize, end: u32, side: impl Fn(usize) -> u32) -> Vec<BvhNode> {
        let root = BvhNode {
            left: BvhChild {
                index: 0,
                count: 1,
                ..EVERYWHERE
            },
            right: BvhChild::EMPTY,
        };
        let leaf = |index| BvhChild {
            index,
            count: 1,
            ..EVERYWHERE
        };
        let mut nodes = vec![root];
        nodes.extend((0..depth).map(|k| BvhNode {
            left: if k + 1 == depth {
                leaf(end)
            } else {
                BvhChild {
                    index: k as u32 + 2,
                    ..EVERYWHERE
                }
            },
            right: leaf(side(k)),
        }));
        nodes
    }

    /// `tris` as one mesh of one identity instance whose bottom level starts at node 1; the nodes
    /// are left to the test.
    fn bare(tris: &[Tri]) -> TestScene {
        let mut s = scene(tris, &[IDENTITY]);
        s.meshes[0].bvh_root = 1;
        s.nodes.clear();
        s
    }

    #[test]
    fn empty_and_malformed_bvhs_miss() {
        let ray = Ray {
            origin: [0.5, 0.25, 1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        let mut s = bare(&grid());
        // The triangle the ray hits, wherever the builder put it.
        let target = s.triangles.iter().position(|t| t.material == 0).unwrap() as u32;
        let miss = |s: &TestScene| {
            !closest_hit(s.view(), &s.texels[..], &ray).is_hit()
                && !any_hit(s.view(), &s.texels[..], &ray)
        };
        assert!(miss(&s));
        assert!(miss(&TestScene::default()));
        let node = |left: BvhChild, right: BvhChild| BvhNode { left, right };
        let leaf = |index: u32, count: u32| BvhChild {
            index,
            count,
            ..EVERYWHERE
        };
        let interior = |index: u32| BvhChild {
            index,
            ..EVERYWHERE
        };
        let top = node(leaf(0, 1), BvhChild::EMPTY);
        // Bottom levels whose root is its own child, a child before its parent, children past
        // the end, a leaf past the end of the triangles, an overflowing leaf and one longer than
        // the stack can encode; a top level that is its own child, whose leaf names an instance
        // past the end or several instances: all terminate and miss.
        let first = target.saturating_sub(5);
        for nodes in [
            vec![top, node(interior(1), interior(1))],
            vec![
                top,
                node(interior(2), BvhChild::EMPTY),
                node(interior(1), interior(2)),
            ],
            vec![top, node(interior(7), interior(2))],
            vec![top, node(leaf(600, 1), leaf(511, 2))],
            vec![top, node(leaf(1, u32::MAX), BvhChild::EMPTY)],
            vec![
                top,
                node(leaf(first, BVH_MAX_LEAF_TRIANGLES + 1), BvhChild::EMPTY),
            ],
            vec![
                node(interior(0), leaf(1, 1)),
                node(leaf(target, 1), BvhChild::EMPTY),
            ],
            vec![
                node(leaf(0, 2), BvhChild::EMPTY),
                node(leaf(target, 1), BvhChild::EMPTY),
            ],
        ] {
            s.nodes = nodes;
            assert!(miss(&s), "{:?}", s.nodes);
        }
        // The well-formed counterpart hits.
        s.nodes = vec![
            top,
            node(leaf(first, BVH_MAX_LEAF_TRIANGLES), BvhChild::EMPTY),
        ];
        assert_eq!(closest_hit(s.view(), &s.texels[..], &ray).primitive, target);
        // A mesh root, a mesh or a vertex past the end, a singular or NaN transform: misses.
        let good = s.clone();
        let mut broken = Vec::new();
        let mut b = good.clone();
        b.meshes[0].bvh_root = 2;
        broken.push(b);
        let mut b = good.clone();
        b.instances[0].mesh = 1;
        broken.push(b);
        let mut b = good.clone();
        b.meshes[0].first_vertex = 1 << 31;
        broken.push(b);
        let mut b = good.clone();
        b.meshes[0].first_triangle = 1 << 31;
        broken.push(b);
        let mut b = good.clone();
        b.instances[0].world_to_object = [[0.0; 4]; 3];
        broken.push(b);
        let mut b = good.clone();
        b.instances[0].world_to_object[1][1] = f32::NAN;
        broken.push(b);
        for (i, b) in broken.iter().enumerate() {
            assert!(miss(b));
            // Brute force does not use the mesh's root.
            assert_eq!(
                closest_hit_brute_force(b.view(), &b.texels[..], &ray).is_hit(),
                i == 0
            );
        }
        // A chain deeper than both stacks, whose side leaves miss: both walks drop entries
        // without a panic, and the hit at the chain's end is still found.
        let far = s.triangles.iter().position(|t| t.material == 511).unwrap();
        let k = s.triangles[far].indices[0] as usize;
        s.vertices[k].position = [50.0; 3];
        s.nodes = chain(3 * BVH_STACK_SIZE, target, |_| far as u32);
        let h = closest_hit(s.view(), &s.texels[..], &ray);
        assert_eq!((h.primitive, h.t), (target, 1.0));
        assert!(any_hit(s.view(), &s.texels[..], &ray));
    }

    /// Hits that only the long stack reaches: the short walk drops them, the second walk finds
    /// them, and keeps a closer hit the first walk found.
    #[test]
    fn the_long_stack_finds_what_the_short_one_dropped() {
        // Triangle k of the stack of layers lies at z = -k, under a ray going down from z = 1.
        let mut layers: Vec<Tri> = (0..BVH_STACK_SIZE)
            .map(|k| {
                let z = -(k as f32);
                [[-1.0, -1.0, z], [2.0, -1.0, z], [0.0, 2.0, z]]
            })
            .collect();
        // Layer 0 is not in the tree below.
        layers[0][0] = [50.0; 3];
        let ray = Ray {
            origin: [0.25, 0.25, 1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        // Bottom-level leaves name the layer by its input index through this map.
        let mut s = bare(&layers);
        let at = |s: &TestScene, layer: usize| {
            s.triangles
                .iter()
                .position(|t| t.material as usize == layer)
                .unwrap() as u32
        };
        let depth = BVH_SHORT_STACK_SIZE + 20;
        // Side leaf k holds layer `depth - k` (the deeper side leaves hold the nearer layers)
        // and the chain ends on the farthest layer: the short stack drops the nearest ones.
        s.nodes = chain(depth, at(&s, BVH_STACK_SIZE - 1), |k| at(&s, depth - k));
        let h = closest_hit(s.view(), &s.texels[..], &ray);
        let nearest = depth - (depth - 1);
        assert_eq!(
            (s.input_index(h.primitive), h.t),
            (nearest as u32, 1.0 + nearest as f32)
        );
        assert_eq!(h, closest_hit_brute_force(s.view(), &s.texels[..], &ray));
        assert!(any_hit(s.view(), &s.texels[..], &ray));
        // Only the dropped side leaves hit: any_hit needs the second walk too.
        let mut far = s.clone();
        let mut hide = |layer: usize| {
            let k = far.triangles[at(&s, layer) as usize].indices[0] as usize;
            far.vertices[k].position = [50.0; 3];
        };
        hide(BVH_STACK_SIZE - 1);
        for k in 0..BVH_SHORT_STACK_SIZE {
            hide(depth - k);
        }
        let h = closest_hit(far.view(), &far.texels[..], &ray);
        assert_eq!(
            h,
            closest_hit_brute_force(far.view(), &far.texels[..], &ray)
        );
        assert!(h.is_hit());
        assert!(any_hit(far.view(), &far.texels[..], &ray));
    }

    /// A quad at z = 1 (triangles 0 and 1, material 0: masked, UVs = xy over [0, 1]²) whose
    /// 2 × 2 texture has a hole at texel (0, 0), in front of an opaque quad at z = 2.
    fn fence() -> TestScene {
        let quad = |z: f32| -> [Tri; 2] {
            [
                [[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z]],
                [[0.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]],
            ]
        };
        let soup: Vec<Tri> = quad(1.0).into_iter().chain(quad(2.0)).collect();
        let identity = [
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
        ];
        let mut s = scene(&soup, &[identity]);
        for v in &mut s.vertices {
            (v.u, v.v) = (v.position[0], v.position[1]);
        }
        s.meshes[0].has_uvs = 1;
        s.meshes[0].flags = MESH_ALPHA_TESTED;
        // `scene` gives triangle `i` material `i`: the back quad's (2, 3) do not exist, and read
        // as opaque.
        let masked = GpuMaterial {
            base_color_texture: 0,
            alpha_cutoff: 0.5,
            ..GpuMaterial::default()
        };
        s.materials = vec![masked, masked];
        s.textures = vec![GpuTexture {
            offset: 0,
            width: 2,
            height: 2,
            srgb: 0,
            wrap_u: crate::textures::WRAP_CLAMP_TO_EDGE,
            wrap_v: crate::textures::WRAP_CLAMP_TO_EDGE,
            levels: 1,
            _pad: 0,
        }];
        // RGBA8, alpha in the high byte: texel (0, 0) is transparent white.
        s.texels = vec![0x00ff_ffff, 0xffff_ffff, 0xffff_ffff, 0xffff_ffff];
        s
    }

    #[test]
    fn alpha_masked_triangles_are_hit_only_where_the_surface_is() {
        let s = fence();
        let ray = |x: f32, y: f32, t_max: f32| Ray {
            origin: [x, y, 0.0],
            t_min: 0.0,
            direction: [0.0, 0.0, 1.0],
            t_max,
        };
        let material = |h: HitRecord| s.triangles[h.primitive as usize].material;
        // Through the hole: the back quad, and no shadow-ray hit short of it.
        let hole = closest_hit(s.view(), &s.texels[..], &ray(0.2, 0.3, f32::INFINITY));
        assert_eq!(hole.t, 2.0);
        assert!(material(hole) >= 2, "{hole:?}");
        assert!(!any_hit(s.view(), &s.texels[..], &ray(0.2, 0.3, 1.5)));
        assert!(any_hit(s.view(), &s.texels[..], &ray(0.2, 0.3, 2.5)));
        // Through solid texels: the fence.
        for (x, y) in [(0.75, 0.25), (0.25, 0.75), (0.8, 0.7)] {
            let h = closest_hit(s.view(), &s.texels[..], &ray(x, y, f32::INFINITY));
            assert_eq!(h.t, 1.0);
            assert!(material(h) < 2, "{h:?}");
            assert!(any_hit(s.view(), &s.texels[..], &ray(x, y, 1.5)));
        }
        // Brute force applies the same test, over the whole quad. Bilinear alpha is
        // `1 - (1 - wu)(1 - wv)`, each weight `clamp(2 (x - 1/4), 0, 1)`: the hole is where the
        // product exceeds 1/2 (never exactly 1/2 on this grid).
        for i in 0..16 {
            for j in 0..16 {
                let (x, y) = ((i as f32 + 0.5) / 16.0, (j as f32 + 0.5) / 16.0);
                let r = ray(x, y, f32::INFINITY);
                let want = closest_hit_brute_force(s.view(), &s.texels[..], &r);
                assert_eq!(closest_hit(s.view(), &s.texels[..], &r), want, "{r:?}");
                let weight = |c: f32| (2.0 * (c - 0.25)).clamp(0.0, 1.0);
                let through = (1.0 - weight(x)) * (1.0 - weight(y)) > 0.5;
                assert_eq!(want.t, if through { 2.0 } else { 1.0 }, "{r:?}");
            }
        }
        // The mesh flag is what asks for the test: without it the hole is solid.
        let mut opaque = s.clone();
        opaque.meshes[0].flags = 0;
        let h = closest_hit(
            opaque.view(),
            &opaque.texels[..],
            &ray(0.2, 0.3, f32::INFINITY),
        );
        assert_eq!(h.t, 1.0);
        assert!(any_hit(
            opaque.view(),
            &opaque.texels[..],
            &ray(0.2, 0.3, 1.5)
        ));
    }
}
