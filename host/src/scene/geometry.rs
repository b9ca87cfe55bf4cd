//! Triangle lists from glTF primitives: strips and fans unrolled, bad triangles dropped, unused
//! vertices removed, normals checked or computed.

use glam::{Vec2, Vec3};
use gltf::json::mesh::Mode;

/// The vertices and triangles of one glTF primitive, as read.
pub(super) struct RawPrimitive {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub uvs: Option<Vec<Vec2>>,
    /// Indices into the vertex arrays, all in range.
    pub triangles: Vec<[u32; 3]>,
}

/// A primitive ready for a [`Mesh`](super::Mesh): every vertex used, every triangle finite and
/// with an area, a unit normal per vertex.
pub(super) struct CleanPrimitive {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Option<Vec<Vec2>>,
    pub triangles: Vec<[u32; 3]>,
}

/// What [`clean`] had to drop or repair.
#[derive(Debug, Default, PartialEq, Eq)]
pub(super) struct Repairs {
    /// Triangles dropped for a NaN or infinite vertex position.
    pub non_finite: usize,
    /// Triangles dropped for a zero area.
    pub degenerate: usize,
    /// Vertices whose normal from the file was not finite or zero, replaced by a computed one.
    pub bad_normals: usize,
    /// Vertices whose UV was not finite, replaced by zero.
    pub bad_uvs: usize,
}

/// Unrolls `indices` of a triangle primitive of `mode` into triangles, keeping the winding of the
/// first one as glTF (and Vulkan) define strips and fans. Returns the triangles and how many
/// trailing indices of a triangle list make no whole triangle. Non-triangle modes give nothing.
pub(super) fn triangulate(mode: Mode, indices: &[u32]) -> (Vec<[u32; 3]>, usize) {
    match mode {
        Mode::Triangles => {
            let (triangles, rest) = indices.as_chunks::<3>();
            (triangles.to_vec(), rest.len())
        }
        Mode::TriangleStrip => (
            indices
                .windows(3)
                .enumerate()
                .map(|(i, w)| {
                    if i % 2 == 0 {
                        [w[0], w[1], w[2]]
                    } else {
                        [w[1], w[0], w[2]]
                    }
                })
                .collect(),
            0,
        ),
        Mode::TriangleFan => (
            indices
                .get(1..)
                .unwrap_or_default()
                .windows(2)
                .map(|w| [w[0], w[1], indices[0]])
                .collect(),
            0,
        ),
        Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip => (Vec::new(), 0),
    }
}

/// Twice the area, as a vector along the counter-clockwise normal.
fn area_vector(p: [Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(p[2] - p[0])
}

/// Whether a triangle has no area at `f32` precision: the sine of its angles, scaled by the ratio
/// of its edges, is below the rounding of its coordinates (repeated and collinear vertices
/// included).
fn is_degenerate(p: [Vec3; 3]) -> bool {
    let longest = (p[1] - p[0])
        .length_squared()
        .max((p[2] - p[1]).length_squared())
        .max((p[0] - p[2]).length_squared());
    let area = area_vector(p).length();
    // NaN (from coordinates so large that their products overflow) counts as degenerate too.
    area.is_nan() || area <= f32::EPSILON * longest
}

/// Drops triangles with a non-finite vertex or no area, removes the vertices no triangle uses,
/// and gives each vertex a unit normal: the file's where it is finite and non-zero, otherwise the
/// area-weighted mean of the normals of the triangles around it.
pub(super) fn clean(raw: RawPrimitive) -> (CleanPrimitive, Repairs) {
    let mut repairs = Repairs::default();
    let finite: Vec<bool> = raw.positions.iter().map(|p| p.is_finite()).collect();
    let triangles: Vec<[u32; 3]> = raw
        .triangles
        .into_iter()
        .filter(|t| {
            if !t.iter().all(|&v| finite[v as usize]) {
                repairs.non_finite += 1;
                false
            } else if is_degenerate(t.map(|v| raw.positions[v as usize])) {
                repairs.degenerate += 1;
                false
            } else {
                true
            }
        })
        .collect();

    // Old vertex index -> new one, in order of first use.
    let mut remap = vec![u32::MAX; raw.positions.len()];
    let mut used = Vec::new();
    let triangles: Vec<[u32; 3]> = triangles
        .iter()
        .map(|t| {
            t.map(|v| {
                if remap[v as usize] == u32::MAX {
                    remap[v as usize] = used.len() as u32;
                    used.push(v as usize);
                }
                remap[v as usize]
            })
        })
        .collect();
    let positions: Vec<Vec3> = used.iter().map(|&v| raw.positions[v]).collect();

    let given: Option<Vec<Vec3>> = raw.normals.map(|normals| {
        used.iter()
            .map(|&v| {
                let n = normals[v];
                let unit = n.normalize_or_zero();
                if unit == Vec3::ZERO || !n.is_finite() {
                    repairs.bad_normals += 1;
                    Vec3::ZERO
                } else {
                    unit
                }
            })
            .collect()
    });
    let normals = match given {
        Some(given) if repairs.bad_normals == 0 => given,
        Some(given) => {
            let computed = vertex_normals(&positions, &triangles);
            given
                .into_iter()
                .zip(computed)
                .map(|(g, c)| if g == Vec3::ZERO { c } else { g })
                .collect()
        }
        // glTF: without NORMAL, normals are flat. A zero vertex normal makes the shading normal
        // fall back to the triangle's geometric normal (`gi_shared::scene_data::fetch_surface`),
        // which is flat shading without unsharing the vertices.
        None => vec![Vec3::ZERO; positions.len()],
    };

    let uvs = raw.uvs.map(|uvs| {
        used.iter()
            .map(|&v| {
                let uv = uvs[v];
                if uv.is_finite() {
                    uv
                } else {
                    repairs.bad_uvs += 1;
                    Vec2::ZERO
                }
            })
            .collect()
    });

    let clean = CleanPrimitive {
        positions,
        normals,
        uvs,
        triangles,
    };
    (clean, repairs)
}

/// Area-weighted vertex normals. A vertex whose weighted sum cancels out (a fold of two opposite
/// faces) takes the normal of the first triangle that uses it.
pub(super) fn vertex_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; positions.len()];
    let mut first = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        // The cross product's length is twice the area: the weight, for free.
        let a = area_vector(t.map(|v| positions[v as usize]));
        for &v in t {
            sums[v as usize] += a;
            if first[v as usize] == Vec3::ZERO {
                first[v as usize] = a.normalize_or_zero();
            }
        }
    }
    sums.into_iter()
        .zip(first)
        .map(|(sum, first)| {
            let n = sum.normalize_or_zero();
            if n == Vec3::ZERO { first } else { n }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_the_winding() {
        let (strip, _) = triangulate(Mode::TriangleStrip, &[0, 1, 2, 3, 4]);
        assert_eq!(strip, vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]);
        let (fan, _) = triangulate(Mode::TriangleFan, &[0, 1, 2, 3]);
        assert_eq!(fan, vec![[1, 2, 0], [2, 3, 0]]);
        let (list, rest) = triangulate(Mode::Triangles, &[0, 1, 2, 3, 4]);
        assert_eq!((list, rest), (vec![[0, 1, 2]], 2));
        assert!(triangulate(Mode::TriangleFan, &[]).0.is_empty());
        assert!(triangulate(Mode::Lines, &[0, 1, 2]).0.is_empty());
    }

    #[test]
    fn normals_are_area_weighted() {
        // A vertex shared by a large triangle facing +Z and a small one facing +X.
        let positions = [
            Vec3::ZERO,
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let normals = vertex_normals(&positions, &[[0, 1, 2], [0, 3, 4]]);
        let expected = Vec3::new(1.0, 0.0, 16.0).normalize();
        assert!(normals[0].abs_diff_eq(expected, 1e-6), "{:?}", normals[0]);
        assert!(normals[1].abs_diff_eq(Vec3::Z, 1e-6));
        assert!(normals[3].abs_diff_eq(Vec3::X, 1e-6));
    }

    #[test]
    fn clean_drops_bad_triangles_and_unused_vertices() {
        let raw = RawPrimitive {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::new(f32::NAN, 0.0, 0.0),
                Vec3::new(2.0, 0.0, 0.0), // collinear with 0 and 1
                Vec3::new(5.0, 5.0, 5.0), // unused
            ],
            normals: Some(vec![
                Vec3::Z,
                Vec3::ZERO,
                Vec3::new(0.0, 0.0, 2.0),
                Vec3::Z,
                Vec3::Z,
                Vec3::Z,
            ]),
            uvs: Some(vec![
                Vec2::ZERO,
                Vec2::new(f32::INFINITY, 0.0),
                Vec2::ONE,
                Vec2::ZERO,
                Vec2::ZERO,
                Vec2::ZERO,
            ]),
            triangles: vec![[0, 1, 2], [0, 1, 3], [0, 1, 4], [2, 2, 0]],
        };
        let (clean, repairs) = clean(raw);
        assert_eq!(
            repairs,
            Repairs {
                non_finite: 1,
                degenerate: 2,
                bad_normals: 1,
                bad_uvs: 1
            }
        );
        assert_eq!(clean.triangles, vec![[0, 1, 2]]);
        assert_eq!(clean.positions, vec![Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(clean.normals, vec![Vec3::Z; 3]);
        assert_eq!(clean.uvs, Some(vec![Vec2::ZERO, Vec2::ZERO, Vec2::ONE]));
    }
}
