//! A flat binary BVH over world-space triangles, and its traversal: the same code walks it on the
//! CPU and in the software-traversal kernels.
//!
//! # Layout
//!
//! Two buffers, both `#[repr(C)]` + [`Pod`], only `f32`/`u32`, explicit padding:
//!
//! * [`BvhNode`] (32 bytes). Node 0 is the root. A node with `count == 0` is interior: its two
//!   children are the adjacent nodes `index` and `index + 1`, and `index` is greater than the
//!   node's own index (children are stored after their parent). A node with `count > 0` is a leaf
//!   holding triangles `index .. index + count`.
//! * [`BvhTriangle`] (48 bytes): `v0`, `e1 = v1 - v0`, `e2 = v2 - v0` in world space, and the ids
//!   that go into the [`HitRecord`].
//!
//! An empty node buffer is an empty scene: every ray misses.
//!
//! # Traversal
//!
//! No recursion and no allocation: a fixed stack of [`BVH_STACK_SIZE`] node indices. The builder
//! must keep every leaf at depth `<=` [`BVH_MAX_DEPTH`] (root = depth 0), which bounds the stack
//! (an interior node at depth `d` leaves at most `d + 1` deferred siblings on it).
//!
//! Nothing on this path panics: an out-of-range node or triangle index, a child index that does
//! not come after its parent, or a stack overflow drops that node (it is treated as a miss), so a
//! malformed BVH gives wrong hits, never a fault or an endless loop.
//!
//! Hits obey `t_min <= t <= t_max`, with `t` in units of the direction's length, like
//! `VK_KHR_ray_query`. Ties: the closest `t` wins; among hits at exactly the same `t` the first one
//! tested wins, and the test order follows the traversal (near child first), which a hardware or
//! lavapipe ray query need not share. Ties only happen on shared edges and coplanar overlaps.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use num_traits::Float;

use crate::ray::{HitRecord, Ray};

/// Entries of the traversal stack.
pub const BVH_STACK_SIZE: usize = 64;

/// Deepest leaf the traversal supports, root at depth 0. Builders must respect (and assert) it.
pub const BVH_MAX_DEPTH: u32 = BVH_STACK_SIZE as u32;

/// Direction components smaller than this in magnitude count as zero in the box test: the ray is
/// parallel to that slab, and the test checks the origin against it instead of dividing, so no
/// `1/0` or `0 · ∞` arises (Vulkan leaves both unspecified on the GPU).
const MIN_DIRECTION: f32 = 1e-30;

/// Widens the far distance of a box test by the worst rounding of the slab computation
/// (`1 + 2·γ(3)`, Ize 2013), so that a triangle lying on its node's bounds is never culled.
const BOX_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// One BVH node (32 bytes): bounds, and either two children or a run of triangles.
///
/// | offset | field     |
/// |--------|-----------|
/// | 0      | `min`     |
/// | 12     | `index`   |
/// | 16     | `max`     |
/// | 28     | `count`   |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    /// Lower corner of the bounds.
    pub min: [f32; 3],
    /// Interior node: index of the first child (the second is `index + 1`). Leaf: index of the
    /// first triangle.
    pub index: u32,
    /// Upper corner of the bounds.
    pub max: [f32; 3],
    /// Number of triangles of a leaf; 0 for an interior node.
    pub count: u32,
}

impl BvhNode {
    /// Whether the node is a leaf.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count != 0
    }
}

/// A triangle as the traversal reads it (48 bytes, three 16-byte rows).
///
/// | offset | field       |
/// |--------|-------------|
/// | 0      | `v0`        |
/// | 12     | `instance`  |
/// | 16     | `e1`        |
/// | 28     | `primitive` |
/// | 32     | `e2`        |
/// | 44     | `_pad`      |
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhTriangle {
    /// First vertex, world space.
    pub v0: [f32; 3],
    /// Instance index reported in [`HitRecord::instance`].
    pub instance: u32,
    /// Second vertex minus the first.
    pub e1: [f32; 3],
    /// Triangle index within the instance's mesh, reported in [`HitRecord::primitive`].
    pub primitive: u32,
    /// Third vertex minus the first.
    pub e2: [f32; 3],
    /// Explicit padding to 48 bytes.
    pub _pad: u32,
}

impl BvhTriangle {
    /// The record of the world-space triangle `v` with its ids.
    pub fn new(v: [[f32; 3]; 3], instance: u32, primitive: u32) -> Self {
        let v0 = Vec3::from_array(v[0]);
        Self {
            v0: v[0],
            instance,
            e1: (Vec3::from_array(v[1]) - v0).to_array(),
            primitive,
            e2: (Vec3::from_array(v[2]) - v0).to_array(),
            _pad: 0,
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

/// Möller–Trumbore: the hit of `(origin, dir)` with `tri` for `t` in `[t_min, t_max]`.
///
/// `u`, `v` weigh the second and third vertex. The front face is the counter-clockwise one seen
/// from the origin: `dot(cross(e1, e2), dir) < 0`, which is `det > 0` here. Every comparison is
/// written so that NaN fails it, so NaN rays and triangles miss.
#[inline]
#[allow(
    clippy::manual_range_contains,
    reason = "`RangeInclusive` holds a `bool`, which rust-gpu keeps in memory only with `Int8`"
)]
fn intersect(tri: &BvhTriangle, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> TriangleHit {
    let e1 = Vec3::from_array(tri.e1);
    let e2 = Vec3::from_array(tri.e2);
    let p = dir.cross(e2);
    let det = e1.dot(p);
    let mut out = TriangleHit {
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
        front_face: if det > 0.0 { 1 } else { 0 },
    };
    // A ray parallel to the plane (det == 0) misses; so does a NaN det.
    if !(det != 0.0) {
        return out;
    }
    let inv_det = 1.0 / det;
    let s = origin - Vec3::from_array(tri.v0);
    let u = s.dot(p) * inv_det;
    if !(u >= 0.0 && u <= 1.0) {
        return out;
    }
    let q = s.cross(e1);
    let v = dir.dot(q) * inv_det;
    if !(v >= 0.0 && u + v <= 1.0) {
        return out;
    }
    let t = e2.dot(q) * inv_det;
    if !(t >= t_min && t <= t_max) {
        return out;
    }
    out.t = t;
    out.u = u;
    out.v = v;
    out
}

/// A ray prepared for box tests.
#[derive(Clone, Copy)]
struct BoxRay {
    origin: Vec3,
    /// `1/d` per axis, with the sign of `d`; 0 where the ray is parallel to the axis' slabs.
    inv_dir: Vec3,
}

impl BoxRay {
    #[inline]
    fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            inv_dir: Vec3::new(
                safe_inverse(dir.x),
                safe_inverse(dir.y),
                safe_inverse(dir.z),
            ),
        }
    }

    /// Entry distance of the ray into `node`'s box clipped to `[t_min, t_max]`, or `+∞` when it
    /// misses.
    #[inline]
    fn enter(&self, node: &BvhNode, t_min: f32, t_max: f32) -> f32 {
        let mut t_enter = t_min;
        let mut t_exit = t_max;
        slab(
            node.min[0],
            node.max[0],
            self.origin.x,
            self.inv_dir.x,
            &mut t_enter,
            &mut t_exit,
        );
        slab(
            node.min[1],
            node.max[1],
            self.origin.y,
            self.inv_dir.y,
            &mut t_enter,
            &mut t_exit,
        );
        slab(
            node.min[2],
            node.max[2],
            self.origin.z,
            self.inv_dir.z,
            &mut t_enter,
            &mut t_exit,
        );
        if t_enter <= t_exit * BOX_FAR_SCALE {
            t_enter
        } else {
            f32::INFINITY
        }
    }
}

/// Clips `[t_enter, t_exit]` to the slab `lo..=hi` of one axis.
///
/// The near plane is picked by the direction's sign rather than as the smaller distance, so an
/// empty box (`lo > hi`) misses. A ray parallel to the slab (`inv == 0`) is inside it for all `t`
/// or for none, boundary included.
#[inline]
fn slab(lo: f32, hi: f32, o: f32, inv: f32, t_enter: &mut f32, t_exit: &mut f32) {
    if inv == 0.0 {
        if !(lo <= o && o <= hi) {
            *t_enter = f32::INFINITY;
        }
        return;
    }
    let t_lo = (lo - o) * inv;
    let t_hi = (hi - o) * inv;
    let (near, far) = if inv < 0.0 {
        (t_hi, t_lo)
    } else {
        (t_lo, t_hi)
    };
    // Written so that a NaN distance (from NaN bounds) leaves the interval unchanged.
    if near > *t_enter {
        *t_enter = near;
    }
    if far < *t_exit {
        *t_exit = far;
    }
}

#[inline]
fn safe_inverse(d: f32) -> f32 {
    if Float::abs(d) >= MIN_DIRECTION {
        1.0 / d
    } else {
        0.0
    }
}

/// Walks the BVH; with `any` set, stops at the first hit in `[t_min, t_max]`.
#[inline]
fn traverse(nodes: &[BvhNode], tris: &[BvhTriangle], ray: &Ray, any: bool) -> HitRecord {
    let mut best = HitRecord::miss();
    if nodes.is_empty() || !ray.is_traceable() {
        return best;
    }
    let origin = Vec3::from_array(ray.origin);
    let dir = Vec3::from_array(ray.direction);
    let box_ray = BoxRay::new(origin, dir);
    let t_min = ray.t_min;
    // Upper bound for further hits: `t_max`, then the closest hit so far.
    let mut t_max = ray.t_max;

    let mut stack = [0u32; BVH_STACK_SIZE];
    let mut sp = 0usize;
    let mut current = 0usize;
    let mut running = box_ray.enter(&nodes[0], t_min, t_max) < f32::INFINITY;
    while running {
        let node = nodes[current];
        // Where to go next; `usize::MAX` means pop.
        let mut next = usize::MAX;
        if node.is_leaf() {
            let first = node.index as usize;
            let count = node.count as usize;
            if first <= tris.len() && count <= tris.len() - first {
                let mut i = first;
                while i < first + count {
                    let tri = &tris[i];
                    let h = intersect(tri, origin, dir, t_min, t_max);
                    // Strictly closer only: the first hit tested keeps an exact tie.
                    if h.t < best.t {
                        best.t = h.t;
                        best.instance = tri.instance;
                        best.primitive = tri.primitive;
                        best.front_face = h.front_face;
                        best.barycentrics = [h.u, h.v];
                        t_max = h.t;
                        if any {
                            return best;
                        }
                    }
                    i += 1;
                }
            }
        } else {
            let left = node.index as usize;
            if left > current && left < nodes.len() - 1 {
                let right = left + 1;
                let tl = box_ray.enter(&nodes[left], t_min, t_max);
                let tr = box_ray.enter(&nodes[right], t_min, t_max);
                let hit_l = tl < f32::INFINITY;
                let hit_r = tr < f32::INFINITY;
                if hit_l && hit_r {
                    let (near, far) = if tr < tl {
                        (right, left)
                    } else {
                        (left, right)
                    };
                    next = near;
                    // A full stack (malformed BVH, too deep) drops the far child.
                    if sp < BVH_STACK_SIZE {
                        stack[sp] = far as u32;
                        sp += 1;
                    }
                } else if hit_l {
                    next = left;
                } else if hit_r {
                    next = right;
                }
            }
        }
        if next == usize::MAX {
            // Pop until a node the (possibly shrunk) interval still reaches. The stack only holds
            // valid indices, checked when they were pushed.
            running = false;
            while sp > 0 {
                sp -= 1;
                let candidate = stack[sp] as usize;
                if box_ray.enter(&nodes[candidate], t_min, t_max) < f32::INFINITY {
                    next = candidate;
                    running = true;
                    break;
                }
            }
        }
        current = next;
    }
    best
}

/// The closest hit of `ray` among `tris` through the BVH `nodes`, or [`HitRecord::miss`].
///
/// A ray that is not [`Ray::is_traceable`] misses (as it must with ray queries too),
/// as does every ray on an empty BVH. See the module documentation for ties.
pub fn closest_hit(nodes: &[BvhNode], tris: &[BvhTriangle], ray: &Ray) -> HitRecord {
    traverse(nodes, tris, ray, false)
}

/// Whether `ray` hits any triangle with `t_min <= t <= t_max` (shadow rays): stops at the first.
pub fn any_hit(nodes: &[BvhNode], tris: &[BvhTriangle], ray: &Ray) -> bool {
    traverse(nodes, tris, ray, true).is_hit()
}

/// The closest hit by testing every triangle in order: the reference for the BVH traversal, with
/// the same triangle test, validity rules and tie-break (the first triangle in `tris` wins).
pub fn closest_hit_brute_force(tris: &[BvhTriangle], ray: &Ray) -> HitRecord {
    let mut best = HitRecord::miss();
    if !ray.is_traceable() {
        return best;
    }
    let origin = Vec3::from_array(ray.origin);
    let dir = Vec3::from_array(ray.direction);
    let mut i = 0;
    while i < tris.len() {
        let tri = &tris[i];
        let h = intersect(tri, origin, dir, ray.t_min, ray.t_max);
        if h.t < best.t {
            best.t = h.t;
            best.instance = tri.instance;
            best.primitive = tri.primitive;
            best.front_face = h.front_face;
            best.barycentrics = [h.u, h.v];
        }
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

    /// A test-only object-median builder with the production layout (children adjacent and
    /// after their parent, leaves of up to 2 triangles). The SAH builder lives in the host.
    fn median_bvh(input: &[BvhTriangle]) -> (Vec<BvhNode>, Vec<BvhTriangle>) {
        fn bounds(tris: &[BvhTriangle]) -> ([f32; 3], [f32; 3]) {
            // `f32::min`/`max` skip NaN, unlike glam's.
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for t in tris {
                let v0 = Vec3::from_array(t.v0);
                for v in [v0, v0 + Vec3::from(t.e1), v0 + Vec3::from(t.e2)] {
                    for a in 0..3 {
                        lo[a] = lo[a].min(v[a]);
                        hi[a] = hi[a].max(v[a]);
                    }
                }
            }
            (lo, hi)
        }
        fn centroid(t: &BvhTriangle, axis: usize) -> f32 {
            3.0 * t.v0[axis] + t.e1[axis] + t.e2[axis]
        }
        let mut tris = input.to_vec();
        if tris.is_empty() {
            return (Vec::new(), tris);
        }
        let mut nodes = vec![BvhNode::default()];
        let mut work = vec![(0usize, 0usize, tris.len())];
        while let Some((node, start, end)) = work.pop() {
            let (min, max) = bounds(&tris[start..end]);
            nodes[node].min = min;
            nodes[node].max = max;
            if end - start <= 2 {
                nodes[node].index = start as u32;
                nodes[node].count = (end - start) as u32;
                continue;
            }
            let extent = Vec3::from(max) - Vec3::from(min);
            let axis = extent.max_position();
            let mid = (start + end) / 2;
            tris[start..end].select_nth_unstable_by(mid - start, |a, b| {
                centroid(a, axis).total_cmp(&centroid(b, axis))
            });
            let left = nodes.len();
            nodes.push(BvhNode::default());
            nodes.push(BvhNode::default());
            nodes[node].index = left as u32;
            work.push((left, start, mid));
            work.push((left + 1, mid, end));
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
                BvhTriangle::new(v, (i % 7) as u32, i as u32)
            })
            .collect()
    }

    /// Asserts that the BVH and brute force agree on `ray`: the same record, or an exact tie in
    /// `t` (then the order of testing may pick another triangle).
    fn assert_agree(nodes: &[BvhNode], tris: &[BvhTriangle], ray: &Ray) {
        let bvh = closest_hit(nodes, tris, ray);
        let brute = closest_hit_brute_force(tris, ray);
        if bvh.primitive != brute.primitive && bvh.t == brute.t {
            return;
        }
        assert_eq!(bvh, brute, "{ray:?}");
        assert_eq!(any_hit(nodes, tris, ray), brute.is_hit(), "{ray:?}");
    }

    #[test]
    fn layouts() {
        assert_eq!(size_of::<BvhNode>(), 32);
        assert_eq!(offset_of!(BvhNode, min), 0);
        assert_eq!(offset_of!(BvhNode, index), 12);
        assert_eq!(offset_of!(BvhNode, max), 16);
        assert_eq!(offset_of!(BvhNode, count), 28);
        assert_eq!(size_of::<BvhTriangle>(), 48);
        assert_eq!(offset_of!(BvhTriangle, v0), 0);
        assert_eq!(offset_of!(BvhTriangle, instance), 12);
        assert_eq!(offset_of!(BvhTriangle, e1), 16);
        assert_eq!(offset_of!(BvhTriangle, primitive), 28);
        assert_eq!(offset_of!(BvhTriangle, e2), 32);
        assert_eq!(offset_of!(BvhTriangle, _pad), 44);
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
                tris.push(BvhTriangle::new(
                    [[x, y, 0.0], [x + 1.0, y, 0.0], [x + 1.0, y + 1.0, 0.0]],
                    0,
                    prim,
                ));
                tris.push(BvhTriangle::new(
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
                // The grid's outer edges count as inside: hits there are allowed, not required.
                let inside = (0.0..=16.0).contains(&xy[0]) && (0.0..=16.0).contains(&xy[1]);
                let interior = xy[0].fract() != 0.0 && xy[1].fract() != 0.0;
                if direction[2] > 0.0 || !inside {
                    assert!(!hit.is_hit(), "{ray:?}");
                } else if interior && xy[0].fract() != xy[1].fract() {
                    assert!(hit.is_hit(), "{ray:?}");
                    assert_eq!(hit.t, 1.0 / -direction[2]);
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
        let tri = tris.iter().find(|t| t.primitive == hit.primitive).unwrap();
        let [u, v] = hit.barycentrics;
        let p = Vec3::from(tri.v0) + u * Vec3::from(tri.e1) + v * Vec3::from(tri.e2);
        let expected = Vec3::from(ray.origin) + hit.t * Vec3::from(ray.direction);
        assert!((p - expected).length() < 1e-6, "{p} {expected}");
        let n = Vec3::from(tri.e1).cross(Vec3::from(tri.e2));
        assert!(n.dot(Vec3::from(ray.direction)) > 0.0);
    }

    #[test]
    fn t_min_and_t_max_clip_inclusively() {
        // Ten parallel quads at z = 1..=10; the direction has length 2, so quad k is at t = k/2.
        let mut layers = Vec::new();
        for k in 1..=10 {
            let z = k as f32;
            layers.push(BvhTriangle::new(
                [[-1.0, -1.0, z], [1.0, -1.0, z], [0.0, 1.0, z]],
                3,
                k,
            ));
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
        soup[9].e2 = [f32::NAN; 3];
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
            assert!(hit.primitive != 5 && hit.primitive != 9);
        }
    }

    #[test]
    fn empty_and_malformed_bvhs_miss() {
        let ray = Ray {
            origin: [0.5, 0.25, 1.0],
            t_min: 0.0,
            direction: [0.0, 0.0, -1.0],
            t_max: f32::INFINITY,
        };
        let tris = grid();
        assert!(!closest_hit(&[], &tris, &ray).is_hit());
        assert!(!any_hit(&[], &[], &ray));
        let everything = BvhNode {
            min: [-100.0; 3],
            index: 0,
            max: [100.0; 3],
            count: 0,
        };
        // A root that is its own child, children past the end, a leaf past the end of the
        // triangles, and an overflowing leaf: all terminate and miss.
        for nodes in [
            vec![everything],
            vec![
                BvhNode {
                    index: 1,
                    ..everything
                },
                everything,
            ],
            vec![BvhNode {
                index: 5,
                ..everything
            }],
            vec![BvhNode {
                index: 600,
                count: 1,
                ..everything
            }],
            vec![BvhNode {
                index: 1,
                count: u32::MAX,
                ..everything
            }],
        ] {
            assert!(!closest_hit(&nodes, &tris, &ray).is_hit(), "{nodes:?}");
            assert!(!any_hit(&nodes, &tris, &ray));
        }
        // A chain deeper than the stack: every level's first child is the next level and its
        // second a leaf whose triangle misses, so each level pushes one entry. The overflow drops
        // entries without a panic, and the hit at the chain's end is still found.
        let miss_leaf = BvhNode {
            index: 511,
            count: 1,
            ..everything
        };
        let hit_leaf = BvhNode {
            index: 0,
            count: 1,
            ..everything
        };
        let depth = 3 * BVH_STACK_SIZE;
        let mut chain = vec![BvhNode {
            index: 1,
            ..everything
        }];
        for level in 0..depth {
            let next = BvhNode {
                index: chain.len() as u32 + 2,
                ..everything
            };
            chain.push(if level + 1 == depth { hit_leaf } else { next });
            chain.push(miss_leaf);
        }
        let mut tris = tris;
        tris[511].v0 = [50.0; 3];
        let h = closest_hit(&chain, &tris, &ray);
        assert_eq!((h.primitive, h.t), (0, 1.0));
    }
}
