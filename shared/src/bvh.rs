//! A flat binary BVH over world-space triangles, and its traversal: the same code walks it on the
//! CPU and in the software-traversal kernels.
//!
//! # Layout
//!
//! Two buffers, both `#[repr(C)]` + [`Pod`], only `f32`/`u32`, explicit padding:
//!
//! * [`BvhNode`] (64 bytes): an interior node holding both of its children, each a [`BvhChild`]
//!   (box and reference), so that one node load decides where to go next. Node 0 is the root. A
//!   child with `count > 0` is a leaf of triangles `index .. index + count` (at most
//!   [`BVH_MAX_LEAF_TRIANGLES`]); a child with `count == 0` is the interior node `index`, which
//!   must come after its parent (`index > ` the parent's index). A child slot that holds nothing
//!   (the second child of a root over a single leaf) has the box [`BvhChild::EMPTY`], which no
//!   ray enters.
//! * [`BvhTriangle`] (48 bytes): the three world-space vertices as stored in the mesh (the
//!   watertight test needs the exact vertex values that neighbouring triangles share), the ids
//!   that go into the [`HitRecord`], and [`BVH_TRIANGLE_MIRRORED`].
//!
//! An empty node buffer is an empty scene: every ray misses.
//!
//! The kernels bind the same bytes as [`BvhNodeRows`] and [`BvhTriangleRows`], arrays of 16-byte
//! vectors, and the traversal reads either through [`BvhElement`]: a node is then four vector
//! loads rather than one load per field, which on lavapipe (where every load of a SIMD group is
//! a loop over its invocations) roughly doubled the rays per second.
//!
//! # Traversal
//!
//! One loop, one step per iteration: either one ray/triangle test or one node (both child boxes
//! tested together), so that invocations of a SIMD group stay in step. The closest hit visits
//! the nearer child first and keeps the farther one on a stack with its entry distance; a pop
//! skips an entry beyond the closest hit so far without touching its node. [`any_hit`] does not
//! order children.
//!
//! No recursion and no allocation. The stack holds [`BVH_SHORT_STACK_SIZE`] entries. When it is
//! full, the traversal drops the entry, finishes, and then walks the tree again from the root
//! with a stack of [`BVH_STACK_SIZE`] entries and the closest hit found so far as `t_max`; the
//! builder keeps every leaf at depth `<=` [`BVH_MAX_DEPTH`] (root node = depth 0), so that
//! second walk cannot overflow on a well-formed tree (an interior node at depth `d` sees at most
//! `d` deferred children on the stack and adds one). The second walk only costs time for the rays
//! that need a deeper stack: 1 in 2·10⁶ on the largest benchmark scene (`bathroom.glb`), none on
//! the others.
//!
//! Nothing on this path panics: an out-of-range node or triangle index, a child that does not
//! come after its parent, a leaf of more than [`BVH_MAX_LEAF_TRIANGLES`] triangles, or an
//! overflow of the long stack drops that child (it is treated as a miss), so a malformed BVH
//! gives wrong hits, never a fault or an endless loop.
//!
//! # Ray/triangle test
//!
//! Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection", JCGT 2(1), 2013: the vertices
//! are translated to the ray's origin and sheared so that the ray runs along +z, and three 2D
//! edge functions decide. Each edge function of an edge shared by two triangles is computed from
//! the same vertex values with the operands swapped, so it comes out exactly negated: a ray
//! cannot pass between two triangles that share an edge, nor through a vertex shared by a fan.
//! The paper recomputes an edge function that is exactly 0 in double precision; kernels have no
//! `f64`, so here 0 counts as inside for both triangles of the edge instead, which keeps the test
//! watertight (both may report the hit, and the tie rule below picks one). On the device this
//! relies on the compiler evaluating both products of an edge function alike; one that fused
//! only one of them into an FMA could break the exact negation (lavapipe lets none through:
//! `tests/tests/tracing.rs`).
//!
//! Hits obey `t_min <= t <= t_max`, with `t` in units of the direction's length, like
//! `VK_KHR_ray_query`; `t` is compared against the bounds scaled by the determinant before the
//! division, then checked again after it. Ties: the closest `t` wins; among hits at exactly the
//! same `t` the first one tested wins, and the test order follows the traversal (near child
//! first, the left one on equal entry distances; after a stack overflow, what the first walk
//! found), which a hardware or lavapipe ray query need not share. Ties only happen on shared
//! edges and vertices and on coplanar overlaps.
//!
//! Front faces are counter-clockwise seen from the ray's origin in world space, flipped for
//! triangles flagged [`BVH_TRIANGLE_MIRRORED`]: ray queries decide in object space, and a
//! mirroring instance transform reverses the winding. Barycentrics stay in the mesh's vertex
//! order.

use bytemuck::{Pod, Zeroable};
use glam::{UVec4, Vec3};
use num_traits::Float;

use crate::ray::{HitRecord, Ray};

/// Entries of the long traversal stack: enough for any tree whose leaves are at depth `<=`
/// [`BVH_MAX_DEPTH`].
pub const BVH_STACK_SIZE: usize = 64;

/// Entries of the short stack of the first walk; see the module documentation.
pub const BVH_SHORT_STACK_SIZE: usize = 16;

/// Deepest leaf the traversal supports, root node at depth 0. Builders must respect (and
/// assert) it.
pub const BVH_MAX_DEPTH: u32 = BVH_STACK_SIZE as u32;

/// Most triangles in one leaf: the stack packs a leaf's count into [`STACK_COUNT_BITS`] bits.
pub const BVH_MAX_LEAF_TRIANGLES: u32 = (1 << STACK_COUNT_BITS) - 1;

/// Node and triangle indices must stay below this: the stack packs an index with a count into
/// one `u32` (far above what a 128 MiB buffer holds).
pub const BVH_MAX_INDEX: u32 = 1 << (31 - STACK_COUNT_BITS);

/// [`BvhTriangle::flags`] bit: the triangle belongs to an instance whose transform mirrors
/// (negative determinant), so its front face is the clockwise one in world space.
pub const BVH_TRIANGLE_MIRRORED: u32 = 1;

/// Bits of a stack entry that hold a leaf's triangle count (0 for an interior node).
const STACK_COUNT_BITS: u32 = 4;

/// A stack entry or child reference that is not there.
const NO_CHILD: u32 = u32::MAX;

/// Direction components smaller than this in magnitude count as zero in the box test: their
/// inverse is `±∞` without a division by 0, which Vulkan leaves unspecified on the GPU.
const MIN_DIRECTION: f32 = 1e-30;

/// Widens the far distance of a box test by the worst rounding of the slab computation
/// (`1 + 2·γ(3)`, Ize 2013), so that a triangle lying on its node's bounds is never culled.
const BOX_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// One child of a [`BvhNode`] (32 bytes): its bounds, and either a node or a run of triangles.
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
    /// Interior child: its node index. Leaf: index of its first triangle.
    pub index: u32,
    /// Upper corner of the child's bounds.
    pub max: [f32; 3],
    /// Number of triangles of a leaf; 0 for an interior node.
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

/// A triangle as the traversal reads it (48 bytes, three 16-byte rows).
///
/// | offset | field       |
/// |--------|-------------|
/// | 0      | `v0`        |
/// | 12     | `instance`  |
/// | 16     | `v1`        |
/// | 28     | `primitive` |
/// | 32     | `v2`        |
/// | 44     | `flags`     |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhTriangle {
    /// First vertex, world space.
    pub v0: [f32; 3],
    /// Instance index reported in [`HitRecord::instance`].
    pub instance: u32,
    /// Second vertex, world space.
    pub v1: [f32; 3],
    /// Triangle index within the instance's mesh, reported in [`HitRecord::primitive`].
    pub primitive: u32,
    /// Third vertex, world space.
    pub v2: [f32; 3],
    /// [`BVH_TRIANGLE_MIRRORED`] or 0.
    pub flags: u32,
}

impl BvhTriangle {
    /// The record of the world-space triangle `v` (in the mesh's vertex order) with its ids and
    /// flags.
    pub fn new(v: [[f32; 3]; 3], instance: u32, primitive: u32, flags: u32) -> Self {
        Self {
            v0: v[0],
            instance,
            v1: v[1],
            primitive,
            v2: v[2],
            flags,
        }
    }
}

/// A [`BvhNode`] as the software-traversal kernels bind it: the same 64 bytes as four 16-byte
/// vectors, so that a node is four vector loads on the device rather than one load per field.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhNodeRows {
    /// The node's bytes, 16 at a time.
    pub rows: [UVec4; 4],
}

/// A [`BvhTriangle`] as the software-traversal kernels bind it: three 16-byte vectors.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhTriangleRows {
    /// The triangle's bytes, 16 at a time.
    pub rows: [UVec4; 3],
}

/// An element of a node or triangle buffer that the traversal can read `T` from: the record
/// itself on the CPU, its rows on the device.
pub trait BvhElement<T> {
    /// The record this element holds.
    fn get(&self) -> T;
}

impl BvhElement<BvhNode> for BvhNode {
    #[inline]
    fn get(&self) -> BvhNode {
        *self
    }
}

impl BvhElement<BvhTriangle> for BvhTriangle {
    #[inline]
    fn get(&self) -> BvhTriangle {
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

impl BvhElement<BvhNode> for BvhNodeRows {
    #[inline]
    fn get(&self) -> BvhNode {
        BvhNode {
            left: child_of_rows(self.rows[0], self.rows[1]),
            right: child_of_rows(self.rows[2], self.rows[3]),
        }
    }
}

impl BvhElement<BvhTriangle> for BvhTriangleRows {
    #[inline]
    fn get(&self) -> BvhTriangle {
        let (v0, instance) = split_row(self.rows[0]);
        let (v1, primitive) = split_row(self.rows[1]);
        let (v2, flags) = split_row(self.rows[2]);
        BvhTriangle {
            v0,
            instance,
            v1,
            primitive,
            v2,
            flags,
        }
    }
}

/// A ray/triangle intersection before it becomes a [`HitRecord`]; `t` is `+∞` on a miss. No
/// `bool` fields: rust-gpu would need the `Int8` capability to keep them in memory.
#[derive(Clone, Copy)]
struct TriangleHit {
    t: f32,
    u: f32,
    v: f32,
    front_face: u32,
}

impl TriangleHit {
    /// Makes this hit of `tri` the closest in `best` when it is strictly closer (the first hit
    /// tested keeps an exact tie); returns whether it did.
    #[inline]
    fn record(&self, tri: &BvhTriangle, best: &mut HitRecord) -> bool {
        if self.t < best.t {
            best.t = self.t;
            best.instance = tri.instance;
            best.primitive = tri.primitive;
            best.front_face = self.front_face;
            best.barycentrics = [self.u, self.v];
            true
        } else {
            false
        }
    }
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

    /// The watertight test: the hit of the ray with `tri` for `t` in `[t_min, t_max]`.
    ///
    /// `u`, `v` weigh the second and third vertex. Every comparison is written so that NaN
    /// fails it, so NaN triangles miss.
    #[inline]
    fn intersect(&self, tri: &BvhTriangle, t_max: f32) -> TriangleHit {
        let a = Vec3::from_array(tri.v0) - self.origin;
        let b = Vec3::from_array(tri.v1) - self.origin;
        let c = Vec3::from_array(tri.v2) - self.origin;
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
        let u = cx * by - cy * bx;
        let v = ax * cy - ay * cx;
        let w = bx * ay - by * ax;
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
        let counter_clockwise = if det > 0.0 { 1 } else { 0 };
        out.front_face = counter_clockwise ^ (tri.flags & BVH_TRIANGLE_MIRRORED);
        out
    }
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

/// The stack entry of `child` of node `parent`, or [`NO_CHILD`] when it is malformed: an interior
/// child that does not come after its parent or lies past the end, or a leaf too long or past
/// the end of the triangles.
#[inline]
fn child_entry(child: &BvhChild, parent: u32, nodes: usize, tris: usize) -> u32 {
    let (index, count) = (child.index, child.count);
    let valid = if count == 0 {
        index > parent && (index as usize) < nodes
    } else {
        count <= BVH_MAX_LEAF_TRIANGLES
            && (index as usize) <= tris
            && count as usize <= tris - index as usize
    };
    if valid && index < BVH_MAX_INDEX {
        (index << STACK_COUNT_BITS) | count
    } else {
        NO_CHILD
    }
}

/// One walk of the tree from the root with a stack of `STACK` entries, starting from the hit in
/// `best` (which must lie in `[ray.t_min, t_max]` when it is one). Returns whether an entry was
/// dropped because the stack was full. With `ANY`, stops at the first hit and does not order
/// children.
#[inline]
fn walk<const STACK: usize, const ANY: bool, N: BvhElement<BvhNode>, T: BvhElement<BvhTriangle>>(
    nodes: &[N],
    tris: &[T],
    ray: &TraceRay,
    mut t_max: f32,
    best: &mut HitRecord,
) -> bool {
    // Each entry: the child (see `child_entry`) and its entry distance's bits.
    let mut stack = [[0u32; 2]; STACK];
    let mut sp = 0usize;
    let mut overflow = false;
    // The interior node to visit next (`NO_CHILD`: none), and the triangles still to test.
    let mut node = 0u32;
    let mut tri = 0usize;
    let mut tri_end = 0usize;
    loop {
        // Where to go next, as a stack entry; `NO_CHILD` keeps going with the triangles or pops.
        let mut next = NO_CHILD;
        if tri < tri_end {
            let t = tris[tri].get();
            let h = ray.intersect(&t, t_max);
            if h.record(&t, best) {
                t_max = h.t;
                if ANY {
                    return overflow;
                }
            }
            tri += 1;
        } else if node != NO_CHILD {
            let n = nodes[node as usize].get();
            let left = child_entry(&n.left, node, nodes.len(), tris.len());
            let right = child_entry(&n.right, node, nodes.len(), tris.len());
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
            } else {
                tri = index as usize;
                tri_end = tri + count as usize;
            }
        }
    }
}

/// Both walks of the module documentation: the short stack, then the long one if the short one
/// dropped an entry.
#[inline]
fn traverse<const ANY: bool, N: BvhElement<BvhNode>, T: BvhElement<BvhTriangle>>(
    nodes: &[N],
    tris: &[T],
    ray: &Ray,
) -> HitRecord {
    let mut best = HitRecord::miss();
    if nodes.is_empty() || !ray.is_traceable() {
        return best;
    }
    let prepared = TraceRay::new(ray);
    if walk::<BVH_SHORT_STACK_SIZE, ANY, N, T>(nodes, tris, &prepared, ray.t_max, &mut best)
        && !(ANY && best.is_hit())
    {
        let t_max = if best.is_hit() { best.t } else { ray.t_max };
        walk::<BVH_STACK_SIZE, ANY, N, T>(nodes, tris, &prepared, t_max, &mut best);
    }
    best
}

/// The closest hit of `ray` among `tris` through the BVH `nodes`, or [`HitRecord::miss`].
///
/// A ray that is not [`Ray::is_traceable`] misses (as it must with ray queries too),
/// as does every ray on an empty BVH. See the module documentation for ties.
pub fn closest_hit<N: BvhElement<BvhNode>, T: BvhElement<BvhTriangle>>(
    nodes: &[N],
    tris: &[T],
    ray: &Ray,
) -> HitRecord {
    traverse::<false, N, T>(nodes, tris, ray)
}

/// Whether `ray` hits any triangle with `t_min <= t <= t_max` (shadow rays): stops at the first.
pub fn any_hit<N: BvhElement<BvhNode>, T: BvhElement<BvhTriangle>>(
    nodes: &[N],
    tris: &[T],
    ray: &Ray,
) -> bool {
    traverse::<true, N, T>(nodes, tris, ray).is_hit()
}

/// The closest hit by testing every triangle in order: the reference for the BVH traversal, with
/// the same triangle test, validity rules and tie-break (the first triangle in `tris` wins).
pub fn closest_hit_brute_force(tris: &[BvhTriangle], ray: &Ray) -> HitRecord {
    let mut best = HitRecord::miss();
    if !ray.is_traceable() {
        return best;
    }
    let prepared = TraceRay::new(ray);
    let mut i = 0;
    while i < tris.len() {
        let tri = &tris[i];
        prepared.intersect(tri, ray.t_max).record(tri, &mut best);
        i += 1;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Random;
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

    fn tri(v: [[f32; 3]; 3], instance: u32, primitive: u32) -> BvhTriangle {
        BvhTriangle::new(v, instance, primitive, 0)
    }

    /// Bounds of `tris` as a child (index and count left 0); `f32::min`/`max` skip NaN, unlike
    /// glam's.
    fn bounds(tris: &[BvhTriangle]) -> BvhChild {
        let mut b = BvhChild {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
            ..BvhChild::default()
        };
        for t in tris {
            for v in [t.v0, t.v1, t.v2] {
                for (a, x) in v.into_iter().enumerate() {
                    b.min[a] = b.min[a].min(x);
                    b.max[a] = b.max[a].max(x);
                }
            }
        }
        b
    }

    /// A test-only object-median builder with the production layout (children after their
    /// parent, leaves of up to 2 triangles). The SAH builder lives in the host.
    fn median_bvh(input: &[BvhTriangle]) -> (Vec<BvhNode>, Vec<BvhTriangle>) {
        fn centroid(t: &BvhTriangle, axis: usize) -> f32 {
            t.v0[axis] + t.v1[axis] + t.v2[axis]
        }
        fn build(tris: &mut [BvhTriangle], first: usize, nodes: &mut Vec<BvhNode>) -> BvhChild {
            let mut child = bounds(tris);
            if tris.len() <= 2 {
                child.index = first as u32;
                child.count = tris.len() as u32;
                return child;
            }
            let extent = Vec3::from(child.max) - Vec3::from(child.min);
            let axis = extent.max_position();
            let mid = tris.len() / 2;
            tris.select_nth_unstable_by(mid, |a, b| {
                centroid(a, axis).total_cmp(&centroid(b, axis))
            });
            let me = nodes.len();
            nodes.push(BvhNode::default());
            let (l, r) = tris.split_at_mut(mid);
            let left = build(l, first, nodes);
            let right = build(r, first + mid, nodes);
            nodes[me] = BvhNode { left, right };
            child.index = me as u32;
            child
        }
        let mut tris = input.to_vec();
        if tris.is_empty() {
            return (Vec::new(), tris);
        }
        let mut nodes = Vec::new();
        let root = build(&mut tris, 0, &mut nodes);
        if root.is_leaf() {
            nodes.push(BvhNode {
                left: root,
                right: BvhChild::EMPTY,
            });
        }
        (nodes, tris)
    }

    fn random_soup(rng: &mut Rng, n: usize, extent: f32, size: f32) -> Vec<BvhTriangle> {
        (0..n)
            .map(|i| {
                let c = Vec3::from(rng.vec(-extent, extent));
                let v = [
                    (c + Vec3::from(rng.vec(-size, size))).to_array(),
                    (c + Vec3::from(rng.vec(-size, size))).to_array(),
                    (c + Vec3::from(rng.vec(-size, size))).to_array(),
                ];
                tri(v, (i % 7) as u32, i as u32)
            })
            .collect()
    }

    /// Asserts that the BVH and brute force agree on `ray`: the same record, or an exact tie in
    /// `t` (then the order of testing may pick another triangle).
    fn assert_agree(nodes: &[BvhNode], tris: &[BvhTriangle], ray: &Ray) {
        let bvh = closest_hit(nodes, tris, ray);
        let brute = closest_hit_brute_force(tris, ray);
        assert_eq!(any_hit(nodes, tris, ray), brute.is_hit(), "{ray:?}");
        if bvh.primitive != brute.primitive && bvh.t == brute.t {
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
        assert_eq!(size_of::<BvhTriangle>(), 48);
        assert_eq!(offset_of!(BvhTriangle, v0), 0);
        assert_eq!(offset_of!(BvhTriangle, instance), 12);
        assert_eq!(offset_of!(BvhTriangle, v1), 16);
        assert_eq!(offset_of!(BvhTriangle, primitive), 28);
        assert_eq!(offset_of!(BvhTriangle, v2), 32);
        assert_eq!(offset_of!(BvhTriangle, flags), 44);
        // Packed stack entries never collide with the "no child" marker.
        const {
            assert!((BVH_MAX_INDEX - 1) << STACK_COUNT_BITS | BVH_MAX_LEAF_TRIANGLES < NO_CHILD);
            assert!(BVH_SHORT_STACK_SIZE < BVH_STACK_SIZE);
        }
    }

    /// The rows the kernels bind hold the same records as the buffers the host uploads.
    #[test]
    fn rows_hold_the_records() {
        let mut rng = Rng::new(4);
        let soup = random_soup(&mut rng, 300, 2.0, 0.5);
        let (nodes, mut tris) = median_bvh(&soup);
        tris[7].flags = BVH_TRIANGLE_MIRRORED;
        tris[8].v1[2] = f32::NAN;
        let rows = |words: &[u32]| -> Vec<UVec4> {
            words
                .as_chunks::<4>()
                .0
                .iter()
                .map(|&c| UVec4::from(c))
                .collect()
        };
        for node in &nodes {
            let r = rows(bytemuck::cast_slice(core::slice::from_ref(node)));
            let from_rows = BvhNodeRows {
                rows: [r[0], r[1], r[2], r[3]],
            }
            .get();
            assert_eq!(
                bytemuck::bytes_of(&from_rows),
                bytemuck::bytes_of(node),
                "{node:?}"
            );
        }
        for tri in &tris {
            let r = rows(bytemuck::cast_slice(core::slice::from_ref(tri)));
            let from_rows = BvhTriangleRows {
                rows: [r[0], r[1], r[2]],
            }
            .get();
            assert_eq!(bytemuck::bytes_of(&from_rows), bytemuck::bytes_of(tri));
        }
        assert_eq!(size_of::<BvhNodeRows>(), size_of::<BvhNode>());
        assert_eq!(size_of::<BvhTriangleRows>(), size_of::<BvhTriangle>());
        // The same traversal reads either.
        let node_rows: Vec<BvhNodeRows> = nodes
            .iter()
            .map(|n| {
                let r = rows(bytemuck::cast_slice(core::slice::from_ref(n)));
                BvhNodeRows {
                    rows: [r[0], r[1], r[2], r[3]],
                }
            })
            .collect();
        let tri_rows: Vec<BvhTriangleRows> = tris
            .iter()
            .map(|t| {
                let r = rows(bytemuck::cast_slice(core::slice::from_ref(t)));
                BvhTriangleRows {
                    rows: [r[0], r[1], r[2]],
                }
            })
            .collect();
        for _ in 0..2000 {
            let ray = Ray {
                origin: rng.vec(-4.0, 4.0),
                t_min: 0.0,
                direction: rng.vec(-1.0, 1.0),
                t_max: f32::INFINITY,
            };
            let want = closest_hit(&nodes, &tris, &ray);
            assert_eq!(closest_hit(&node_rows, &tri_rows, &ray), want);
            assert_eq!(any_hit(&node_rows, &tri_rows, &ray), want.is_hit());
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
            let soup = random_soup(&mut rng, n, 2.0, size);
            let (nodes, tris) = median_bvh(&soup);
            for _ in 0..4000 {
                let origin = rng.vec(-4.0, 4.0);
                let target = Vec3::from(rng.vec(-2.0, 2.0));
                // Not normalised: the length scales t.
                let direction = ((target - Vec3::from(origin)) * rng.range(0.1, 3.0)).to_array();
                let t_max = if rng.range(0.0, 1.0) < 0.5 {
                    f32::INFINITY
                } else {
                    rng.range(0.0, 2.0)
                };
                let ray = Ray {
                    origin,
                    t_min: rng.range(0.0, 0.2),
                    direction,
                    t_max,
                };
                assert_agree(&nodes, &tris, &ray);
                hits += usize::from(closest_hit(&nodes, &tris, &ray).is_hit());
            }
        }
        // The rays must actually exercise hits, not just misses.
        assert!(hits > 4000, "{hits}");
    }

    /// A 16 × 16 grid of quads in the plane z = 0: node bounds have zero thickness and share
    /// planes with the rays below.
    fn grid() -> Vec<BvhTriangle> {
        let mut tris = Vec::new();
        for y in 0..16 {
            for x in 0..16 {
                let (x, y) = (x as f32, y as f32);
                let prim = tris.len() as u32;
                tris.push(tri(
                    [[x, y, 0.0], [x + 1.0, y, 0.0], [x + 1.0, y + 1.0, 0.0]],
                    0,
                    prim,
                ));
                tris.push(tri(
                    [[x, y, 0.0], [x + 1.0, y + 1.0, 0.0], [x, y + 1.0, 0.0]],
                    0,
                    prim + 1,
                ));
            }
        }
        tris
    }

    #[test]
    fn axis_aligned_rays_with_zero_components() {
        let (nodes, tris) = median_bvh(&grid());
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
                assert_agree(&nodes, &tris, &ray);
                let hit = closest_hit(&nodes, &tris, &ray);
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
            assert!(!closest_hit(&nodes, &tris, &ray).is_hit(), "{ray:?}");
            assert!(!any_hit(&nodes, &tris, &ray), "{ray:?}");
        }
    }

    #[test]
    fn back_face_and_barycentrics() {
        let (nodes, tris) = median_bvh(&grid());
        let ray = Ray {
            origin: [2.25, 3.75, -2.0],
            t_min: 0.0,
            direction: [0.0, 0.0, 4.0],
            t_max: f32::INFINITY,
        };
        let hit = closest_hit(&nodes, &tris, &ray);
        assert!(hit.is_hit());
        assert_eq!(hit.front_face, 0);
        assert_eq!(hit.t, 0.5);
        let t = tris.iter().find(|t| t.primitive == hit.primitive).unwrap();
        let [u, v] = hit.barycentrics;
        let (v0, v1, v2) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
        let p = v0 + u * (v1 - v0) + v * (v2 - v0);
        let expected = Vec3::from(ray.origin) + hit.t * Vec3::from(ray.direction);
        assert!((p - expected).length() < 1e-6, "{p} {expected}");
        let n = (v1 - v0).cross(v2 - v0);
        assert!(n.dot(Vec3::from(ray.direction)) > 0.0);
    }

    /// A mirrored triangle reports the other face, and the same distance and barycentrics.
    #[test]
    fn mirrored_triangles_flip_the_front_face_only() {
        let v = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        for (flags, front) in [(0, 1), (BVH_TRIANGLE_MIRRORED, 0)] {
            let (nodes, tris) = median_bvh(&[BvhTriangle::new(v, 2, 9, flags)]);
            for (z, dz, face) in [(1.0, -1.0, front), (-1.0, 2.0, 1 - front)] {
                let ray = Ray {
                    origin: [0.25, 0.5, z],
                    t_min: 0.0,
                    direction: [0.0, 0.0, dz],
                    t_max: f32::INFINITY,
                };
                let hit = closest_hit(&nodes, &tris, &ray);
                assert_eq!((hit.instance, hit.primitive), (2, 9));
                assert_eq!(hit.front_face, face, "{flags} {ray:?}");
                assert_eq!(hit.barycentrics, [0.25, 0.5]);
                assert_eq!(hit.t, 1.0 / dz.abs());
            }
        }
    }

    #[test]
    fn t_min_and_t_max_clip_inclusively() {
        // Ten parallel quads at z = 1..=10; the direction has length 2, so quad k is at t = k/2.
        let mut layers = Vec::new();
        for k in 1..=10 {
            let z = k as f32;
            layers.push(tri([[-1.0, -1.0, z], [1.0, -1.0, z], [0.0, 1.0, z]], 3, k));
        }
        let (nodes, tris) = median_bvh(&layers);
        let trace = |t_min: f32, t_max: f32| {
            let ray = Ray {
                origin: [0.0, 0.0, 0.0],
                t_min,
                direction: [0.0, 0.0, 2.0],
                t_max,
            };
            assert_agree(&nodes, &tris, &ray);
            closest_hit(&nodes, &tris, &ray)
        };
        let h = trace(0.0, f32::INFINITY);
        assert_eq!((h.primitive, h.instance, h.t), (1, 3, 0.5));
        let h = trace(1.6, f32::INFINITY);
        assert_eq!((h.primitive, h.t), (4, 2.0));
        assert!(!trace(1.6, 1.9).is_hit());
        let h = trace(2.0, 2.0);
        assert_eq!((h.primitive, h.t), (4, 2.0));
        let h = trace(0.0, 0.5);
        assert_eq!((h.primitive, h.t), (1, 0.5));
        assert!(!trace(5.01, f32::INFINITY).is_hit());
        assert!(!trace(2.0, 1.0).is_hit());
        assert!(!trace(0.0, -1.0).is_hit());
    }

    #[test]
    fn nan_and_infinite_rays_miss() {
        let (nodes, tris) = median_bvh(&grid());
        let good = Ray {
            origin: [0.5, 0.25, 1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        assert!(closest_hit(&nodes, &tris, &good).is_hit());
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
                closest_hit(&nodes, &tris, &ray),
                HitRecord::miss(),
                "{ray:?}"
            );
            assert_eq!(closest_hit_brute_force(&tris, &ray), HitRecord::miss());
            assert!(!any_hit(&nodes, &tris, &ray), "{ray:?}");
        }
    }

    #[test]
    fn nan_triangles_miss_and_do_not_hide_others() {
        let mut soup = grid();
        soup[5].v0[1] = f32::NAN;
        soup[9].v2 = [f32::NAN; 3];
        soup[12].v1[0] = f32::INFINITY;
        let (nodes, tris) = median_bvh(&soup);
        let mut rng = Rng::new(3);
        for _ in 0..2000 {
            let ray = Ray {
                origin: [rng.range(-1.0, 17.0), rng.range(-1.0, 17.0), 1.0],
                t_min: 0.0,
                direction: [rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), -1.0],
                t_max: f32::INFINITY,
            };
            assert_agree(&nodes, &tris, &ray);
            let hit = closest_hit(&nodes, &tris, &ray);
            assert!(![5, 9, 12].contains(&hit.primitive));
        }
    }

    /// Everything contains the ray's path.
    const EVERYWHERE: BvhChild = BvhChild {
        min: [-100.0; 3],
        index: 0,
        max: [100.0; 3],
        count: 0,
    };

    /// A chain of `depth` nodes: node `k`'s left child is node `k + 1` (the last one's a leaf of
    /// triangle `end`), its right child a leaf of triangle `side(k)`. Every box contains the
    /// ray, so with equal entry distances the left child comes first and each level pushes
    /// its right leaf: the chain needs a stack as deep as itself.
    fn chain(depth: usize, end: u32, side: impl Fn(usize) -> u32) -> Vec<BvhNode> {
        (0..depth)
            .map(|k| BvhNode {
                left: if k + 1 == depth {
                    BvhChild {
                        index: end,
                        count: 1,
                        ..EVERYWHERE
                    }
                } else {
                    BvhChild {
                        index: k as u32 + 1,
                        ..EVERYWHERE
                    }
                },
                right: BvhChild {
                    index: side(k),
                    count: 1,
                    ..EVERYWHERE
                },
            })
            .collect()
    }

    #[test]
    fn empty_and_malformed_bvhs_miss() {
        let ray = Ray {
            origin: [0.5, 0.25, 1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        let mut tris = grid();
        let no_nodes: &[BvhNode] = &[];
        let no_tris: &[BvhTriangle] = &[];
        assert!(!closest_hit(no_nodes, &tris, &ray).is_hit());
        assert!(!any_hit(no_nodes, no_tris, &ray));
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
        // A root that is its own child, a child before its parent, children past the end, a
        // leaf past the end of the triangles, an overflowing leaf and one longer than the
        // stack can encode: all terminate and miss. Triangle 0 is the one the ray hits.
        for nodes in [
            vec![node(interior(0), interior(0))],
            vec![
                node(interior(1), BvhChild::EMPTY),
                node(interior(0), interior(1)),
            ],
            vec![node(interior(5), interior(1))],
            vec![node(leaf(600, 1), leaf(511, 2))],
            vec![node(leaf(1, u32::MAX), BvhChild::EMPTY)],
            vec![node(leaf(0, BVH_MAX_LEAF_TRIANGLES + 1), BvhChild::EMPTY)],
        ] {
            assert!(!closest_hit(&nodes, &tris, &ray).is_hit(), "{nodes:?}");
            assert!(!any_hit(&nodes, &tris, &ray));
        }
        // The well-formed counterpart hits.
        let nodes = [node(leaf(0, BVH_MAX_LEAF_TRIANGLES), BvhChild::EMPTY)];
        assert_eq!(closest_hit(&nodes, &tris, &ray).primitive, 0);
        // A chain deeper than both stacks, whose side leaves miss: both walks drop entries
        // without a panic, and the hit at the chain's end is still found.
        tris[511].v0 = [50.0; 3];
        let nodes = chain(3 * BVH_STACK_SIZE, 0, |_| 511);
        let h = closest_hit(&nodes, &tris, &ray);
        assert_eq!((h.primitive, h.t), (0, 1.0));
        assert!(any_hit(&nodes, &tris, &ray));
    }

    /// Hits that only the long stack reaches: the short walk drops them, the second walk finds
    /// them, and keeps a closer hit the first walk found.
    #[test]
    fn the_long_stack_finds_what_the_short_one_dropped() {
        // Triangle k of the stack of layers lies at z = -k, under a ray going down from z = 1.
        let layers: Vec<BvhTriangle> = (0..BVH_STACK_SIZE as u32)
            .map(|k| {
                let z = -(k as f32);
                tri([[-1.0, -1.0, z], [2.0, -1.0, z], [0.0, 2.0, z]], 0, k)
            })
            .collect();
        let mut layers = layers;
        // Layer 0 is not in the tree below.
        layers[0].v0 = [50.0; 3];
        let ray = Ray {
            origin: [0.25, 0.25, 1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        let depth = BVH_SHORT_STACK_SIZE + 20;
        // Side leaf k holds layer `depth - k` (the deeper side leaves hold the nearer layers)
        // and the chain ends on the farthest layer: the short stack drops the nearest ones.
        let nodes = chain(depth, BVH_STACK_SIZE as u32 - 1, |k| (depth - k) as u32);
        let h = closest_hit(&nodes, &layers, &ray);
        let nearest = (depth - (depth - 1)) as u32;
        assert_eq!((h.primitive, h.t), (nearest, 1.0 + nearest as f32));
        assert_eq!(h, closest_hit_brute_force(&layers, &ray));
        assert!(any_hit(&nodes, &layers, &ray));
        // Only the dropped side leaves hit: any_hit needs the second walk too.
        let mut far = layers.clone();
        far[BVH_STACK_SIZE - 1].v0 = [50.0; 3];
        for k in 0..BVH_SHORT_STACK_SIZE {
            far[depth - k].v0 = [50.0; 3];
        }
        let h = closest_hit(&nodes, &far, &ray);
        assert_eq!(h, closest_hit_brute_force(&far, &ray));
        assert!(h.is_hit());
        assert!(any_hit(&nodes, &far, &ray));
    }
}
