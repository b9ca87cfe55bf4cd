//! Geometry made in code: closed meshes (a cube, an icosphere), scenes built from them, and rays
//! aimed exactly at their shared vertices and edges, which a watertight tracer never lets
//! through. Used by the tracing tests and the tracing benchmark; and rooms of any triangle and
//! light count for `gi bench`'s scaling sweeps ([`scaling_room`]).

use super::{Camera, Instance, Light, LightKind, Material, Mesh, Scene};
use gi_shared::random::Random;
use gi_shared::ray::Ray;
use glam::{Mat4, Vec3, Vec4};
use std::collections::HashMap;

/// Radius of a ball around the origin that [`cube`] and [`icosphere`] both contain with room to
/// spare: where [`ray_at_shared_feature`] starts its rays from inside.
pub const INTERIOR_RADIUS: f32 = 0.7;

/// The cube `[-1, 1]³` (12 triangles), counter-clockwise seen from outside, with face normals
/// at its (shared) vertices averaged.
pub fn cube() -> Mesh {
    let positions: Vec<Vec3> = (0..8).map(|i| box_corner(i, Vec3::ONE)).collect();
    let triangles = BOX_FACES
        .iter()
        .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
        .collect();
    mesh("cube", positions, triangles)
}

/// Corner `i` of the box `[-h, h]`: `+h` along axis `k` where bit `k` of `i` is set.
fn box_corner(i: u32, h: Vec3) -> Vec3 {
    Vec3::select(glam::BVec3::new(i & 1 != 0, i & 2 != 0, i & 4 != 0), h, -h)
}

/// The faces of a box of [`box_corner`]s: quads counter-clockwise seen from outside, -x, +x, -y,
/// +y, -z, +z.
const BOX_FACES: [[u32; 4]; 6] = [
    [0, 4, 6, 2],
    [1, 3, 7, 5],
    [0, 1, 5, 4],
    [2, 6, 7, 3],
    [0, 2, 3, 1],
    [4, 5, 7, 6],
];

/// Most subdivisions [`icosphere`] makes: 21 million triangles.
pub const MAX_ICOSPHERE_LEVELS: u32 = 10;

/// The icosahedron subdivided `levels` times (at most [`MAX_ICOSPHERE_LEVELS`]; `20·4^levels`
/// triangles) on the unit sphere, counter-clockwise seen from outside; neighbouring triangles
/// share their vertices.
pub fn icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&p| Vec3::from(p).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels.min(MAX_ICOSPHERE_LEVELS) {
        let mut midpoints: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                positions.push((positions[a as usize] + positions[b as usize]).normalize());
                positions.len() as u32 - 1
            })
        };
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let ab = midpoint(a, b, &mut positions);
                let bc = midpoint(b, c, &mut positions);
                let ca = midpoint(c, a, &mut positions);
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    mesh("icosphere", positions, triangles)
}

fn mesh(name: &str, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in &triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a);
        t.iter().for_each(|&i| normals[i as usize] += n);
    }
    Mesh {
        name: name.to_owned(),
        normals: normals.iter().map(|n| n.normalize()).collect(),
        positions,
        uvs: None,
        materials: vec![0; triangles.len()],
        triangles,
    }
}

/// A mesh named `name` of the triangles `soup` (world-space corners), each with its own three
/// vertices and material 0: what BVH tests feed the builder.
pub fn triangle_soup(name: &str, soup: &[[[f32; 3]; 3]]) -> Mesh {
    Mesh {
        name: name.into(),
        positions: soup.iter().flatten().map(|&v| Vec3::from(v)).collect(),
        normals: vec![Vec3::ZERO; 3 * soup.len()],
        uvs: None,
        triangles: (0..soup.len() as u32)
            .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
            .collect(),
        materials: vec![0; soup.len()],
    }
}

/// `mesh` with its positions moved by `transform` (and its normals turned with it), the way
/// [`Scene::world_triangles`] moves an instance's: the same vertex values, for a scene whose
/// instances have the identity transform.
pub fn transformed(mesh: &Mesh, transform: Mat4) -> Mesh {
    let normal = Instance {
        name: String::new(),
        node: 0,
        mesh: 0,
        transform,
    }
    .normal_matrix();
    Mesh {
        positions: mesh
            .positions
            .iter()
            .map(|&p| transform.transform_point3(p))
            .collect(),
        normals: mesh
            .normals
            .iter()
            .map(|&n| (normal * n).normalize_or_zero())
            .collect(),
        ..mesh.clone()
    }
}

/// A scene of `meshes` placed by `instances` (mesh index, object-to-world transform), all with
/// glTF's default material, no lights and no camera. Returns `None` when an instance names a
/// mesh that does not exist, has a singular transform, or a mesh has no triangles.
pub fn scene(meshes: Vec<Mesh>, instances: &[(u32, Mat4)]) -> Option<Scene> {
    let valid = |&(m, t): &(u32, Mat4)| (m as usize) < meshes.len() && t.determinant() != 0.0;
    if instances.is_empty()
        || !instances.iter().all(valid)
        || meshes.iter().any(|m| m.triangles.is_empty())
    {
        return None;
    }
    let instances = instances
        .iter()
        .enumerate()
        .map(|(i, &(mesh, transform))| Instance {
            name: format!("instance {i}"),
            node: i as u32,
            mesh,
            transform,
        })
        .collect();
    Some(Scene::from_parts(
        "<procedural>",
        meshes,
        instances,
        vec![Material::default()],
        Vec::new(),
        Vec::new(),
    ))
}

/// Half extents of [`scaling_room`]'s room, in metres.
pub const ROOM_HALF_EXTENTS: Vec3 = Vec3::new(4.0, 1.5, 4.0);
/// Spheres on [`scaling_room`]'s floor: a 4 × 4 grid.
pub const ROOM_SPHERES: u32 = 16;
/// Total power of [`scaling_room`]'s point lights, shared equally, in W/sr: the image's light
/// stays the same whatever their count.
pub const ROOM_LIGHT_INTENSITY: f32 = 12.0;

/// A closed room (walls facing inward) holding [`ROOM_SPHERES`] icospheres of `sphere_levels`
/// subdivisions (`16 · 20 · 4^levels` triangles plus the room's 12; at most
/// [`MAX_ICOSPHERE_LEVELS`]) and `lights` point lights spread under the ceiling, all of one grey
/// diffuse material, with a camera in a corner looking across: the generated scene of `gi
/// bench`'s triangle-count and light-count sweeps. `None` for 0 lights.
pub fn scaling_room(sphere_levels: u32, lights: u32) -> Option<Scene> {
    if lights == 0 || sphere_levels > MAX_ICOSPHERE_LEVELS {
        return None;
    }
    let h = ROOM_HALF_EXTENTS;
    // Each face its own four vertices (flat normals), counter-clockwise seen from inside.
    let faces = BOX_FACES.map(|[a, b, c, d]| [a, d, c, b]);
    let positions: Vec<Vec3> = faces.iter().flatten().map(|&i| box_corner(i, h)).collect();
    let triangles = (0..6u32)
        .flat_map(|f| [[4 * f, 4 * f + 1, 4 * f + 2], [4 * f, 4 * f + 2, 4 * f + 3]])
        .collect();
    let room = mesh("room", positions, triangles);
    let side = ROOM_SPHERES.isqrt();
    let spacing = 2.0 * h.x / side as f32;
    let radius = 0.3 * spacing;
    let mut instances = vec![(0, Mat4::IDENTITY)];
    for i in 0..ROOM_SPHERES {
        let x = -h.x + spacing * ((i % side) as f32 + 0.5);
        let z = -h.z + spacing * ((i / side) as f32 + 0.5);
        let centre = Vec3::new(x, -h.y + radius, z);
        instances.push((
            1,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(radius),
                glam::Quat::IDENTITY,
                centre,
            ),
        ));
    }
    let mut scene = scene(vec![room, icosphere(sphere_levels)], &instances)?;
    scene.materials = vec![Material {
        name: "grey".into(),
        base_color: Vec4::new(0.6, 0.6, 0.6, 1.0),
        metallic: 0.0,
        double_sided: true,
        ..Material::default()
    }];
    let per_side = lights.isqrt().max(1);
    let rows = lights.div_ceil(per_side);
    scene.lights = (0..lights)
        .map(|i| {
            let u = ((i % per_side) as f32 + 0.5) / per_side as f32;
            let v = ((i / per_side) as f32 + 0.5) / rows as f32;
            Light {
                name: format!("light {i}"),
                kind: LightKind::Point,
                intensity: Vec3::splat(ROOM_LIGHT_INTENSITY / lights as f32),
                position: Vec3::new(
                    (2.0 * u - 1.0) * 0.8 * h.x,
                    0.8 * h.y,
                    (2.0 * v - 1.0) * 0.8 * h.z,
                ),
                direction: Vec3::NEG_Z,
                range: None,
            }
        })
        .collect();
    let eye = Vec3::new(0.9 * h.x, 0.5 * h.y, 0.9 * h.z);
    // Camera to world: x right, y up, looking down -z.
    let forward = (Vec3::new(-0.3 * h.x, -h.y, -0.3 * h.z) - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    scene.cameras = vec![Camera {
        name: "corner".into(),
        yfov: 60f32.to_radians(),
        aspect_ratio: None,
        znear: 0.01,
        zfar: None,
        transform: Mat4::from_cols(
            right.extend(0.0),
            up.extend(0.0),
            (-forward).extend(0.0),
            eye.extend(1.0),
        ),
    }];
    scene.update_derived();
    Some(scene)
}

/// [`scaling_room`] lit by a panel under its ceiling instead of point lights: `emitters`
/// emissive triangles (an even count, at least 2; `cols × rows` quads of two triangles each,
/// `cols` the largest divisor of `emitters / 2` up to its square root) covering 80 % of the
/// ceiling's width and depth, facing down, of one radiance whatever their count, so that the
/// image's light stays the same: what the scaling sweep over emissive triangles renders. The
/// panel gives the power of [`scaling_room`]'s point lights. `None` for an odd count or 0.
pub fn emitter_room(sphere_levels: u32, emitters: u32) -> Option<Scene> {
    if emitters == 0 || !emitters.is_multiple_of(2) {
        return None;
    }
    let mut scene = scaling_room(sphere_levels, 1)?;
    scene.lights.clear();
    let quads = emitters / 2;
    let cols = (1..=quads.isqrt())
        .rev()
        .find(|&c| quads.is_multiple_of(c))?;
    let rows = quads / cols;
    let h = ROOM_HALF_EXTENTS;
    let (x0, z0, y) = (-0.8 * h.x, -0.8 * h.z, 0.95 * h.y);
    let (dx, dz) = (1.6 * h.x / cols as f32, 1.6 * h.z / rows as f32);
    let mut positions = Vec::with_capacity(4 * quads as usize);
    let mut triangles = Vec::with_capacity(emitters as usize);
    for r in 0..rows {
        for c in 0..cols {
            let (x, z) = (x0 + dx * c as f32, z0 + dz * r as f32);
            let v = positions.len() as u32;
            positions.extend([
                Vec3::new(x, y, z),
                Vec3::new(x + dx, y, z),
                Vec3::new(x + dx, y, z + dz),
                Vec3::new(x, y, z + dz),
            ]);
            // Counter-clockwise seen from below: the front faces the floor.
            triangles.extend([[v, v + 1, v + 2], [v, v + 2, v + 3]]);
        }
    }
    let mut panel = mesh("panel", positions, triangles);
    panel.materials.fill(1);
    // Power π L A equal to the point lights' 4π I.
    let area = 1.6 * h.x * 1.6 * h.z;
    scene.materials.push(Material {
        name: "panel".into(),
        base_color: Vec4::new(0.6, 0.6, 0.6, 1.0),
        emissive: Vec3::splat(4.0 * ROOM_LIGHT_INTENSITY / area),
        metallic: 0.0,
        ..Material::default()
    });
    scene.meshes.push(panel);
    scene.instances.push(Instance {
        name: "panel".into(),
        node: scene.instances.len() as u32,
        mesh: scene.meshes.len() as u32 - 1,
        transform: Mat4::IDENTITY,
    });
    scene.update_derived();
    Some(scene)
}

/// `transform` followed by a move of 32 times its scale along (1, 1, 1): a [`cube`] or
/// [`icosphere`] placed by it, and the outside origins of [`ray_at_shared_feature`], then lie
/// away from the coordinate planes, every coordinate of a ray within a factor 2 of its target's.
pub fn clear_of_the_axes(transform: Mat4) -> Mat4 {
    let size = transform.x_axis.truncate().length();
    Mat4::from_translation(Vec3::splat(32.0 * size)) * transform
}

/// A ray aimed exactly at a shared feature of the closed `mesh` ([`cube`] or [`icosphere`])
/// placed by `transform` (a similarity): half the time a vertex, half the time a point of an
/// edge (its midpoint, or a random point away from its ends), each as the scene computes it.
/// Returns the ray and its target, which it reaches at `t = 1`.
///
/// From `inside`, the ray starts at a random point within [`INTERIOR_RADIUS`] of the centre and
/// must hit the mesh. From outside, it comes along the outward direction of the target with a
/// random tilt that stays within the normals of the triangles around it, from 0.2 to 4 sizes
/// away; for its line to pass exactly through the target, place the mesh with
/// [`clear_of_the_axes`] (the direction `target - origin` is then exact, which this checks:
/// `None` otherwise, or for a mesh without triangles).
pub fn ray_at_shared_feature(
    mesh: &Mesh,
    transform: Mat4,
    rng: &mut Random,
    inside: bool,
) -> Option<(Ray, Vec3)> {
    let n = mesh.triangles.len() as u32;
    let tri = mesh.triangles.get((rng.next_u32() % n.max(1)) as usize)?;
    let corner = (rng.next_u32() % 3) as usize;
    let world = |i: u32| {
        mesh.positions
            .get(i as usize)
            .map(|&p| transform.transform_point3(p))
    };
    let (a, b) = (world(tri[corner])?, world(tri[(corner + 1) % 3])?);
    let target = if rng.next_u32().is_multiple_of(2) {
        a
    } else {
        // Not within 1% of an end: a point rounded off its edge there could lie outside both
        // triangles of the edge, yet inside neither of the others around the vertex.
        let s = if rng.next_u32().is_multiple_of(4) {
            0.5
        } else {
            rng.next_in(0.01, 0.99)
        };
        a + (b - a) * s
    };
    let centre = transform.transform_point3(Vec3::ZERO);
    let size = transform.x_axis.truncate().length();
    let origin = if inside {
        let p = loop {
            let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            if p.length() < 1.0 {
                break p * INTERIOR_RADIUS;
            }
        };
        transform.transform_point3(p)
    } else {
        // Both meshes are convex and centred: around any point of their surface, every
        // triangle's normal is within 55° of the outward direction from the centre, so a tilt
        // of less than 35° enters all of them.
        let out = (target - centre).normalize();
        let tilt = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.6 - 0.3;
        let u = (out + tilt - out * tilt.dot(out)).normalize();
        let origin = target + u * (size * rng.next_in(0.2, 4.0));
        let exact = (0..3).all(|k| {
            f64::from(target[k] - origin[k]) == f64::from(target[k]) - f64::from(origin[k])
        });
        if !exact {
            return None;
        }
        origin
    };
    let ray = Ray {
        origin: origin.to_array(),
        t_min: 0.0,
        direction: (target - origin).to_array(),
        t_max: f32::INFINITY,
    };
    Some((ray, target))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both meshes are closed (every edge has exactly two triangles, in opposite directions)
    /// and counter-clockwise seen from outside.
    #[test]
    fn scaling_rooms_hold_the_asked_triangles_and_lights() {
        for (levels, lights) in [(0, 1), (2, 7), (3, 64)] {
            let room = scaling_room(levels, lights).unwrap();
            let spheres = ROOM_SPHERES as usize * 20 * 4usize.pow(levels);
            assert_eq!(room.triangle_count(), 12 + spheres);
            assert_eq!(room.lights.len(), lights as usize);
            let total: f32 = room.lights.iter().map(|l| l.intensity.x).sum();
            assert!((total - ROOM_LIGHT_INTENSITY).abs() < 1e-3);
            // Lights and camera inside the room, the camera looking into it.
            let inside = |p: Vec3| p.abs().cmplt(ROOM_HALF_EXTENTS).all();
            assert!(room.lights.iter().all(|l| inside(l.position)));
            let camera = &room.cameras[0];
            assert!(inside(camera.position()));
            assert!(inside(camera.position() + camera.forward()));
        }
        assert!(scaling_room(1, 0).is_none());
        for emitters in [16, 1000, 10_000] {
            let room = emitter_room(1, emitters).unwrap();
            assert!(room.lights.is_empty());
            assert_eq!(room.emissive_triangles.len(), emitters as usize);
            let power: f32 = room
                .emissive_triangles
                .iter()
                .map(|t| t.emission.x * t.area)
                .sum();
            let points = 4.0 * ROOM_LIGHT_INTENSITY;
            assert!((power - points).abs() < 1e-3 * points, "{power}");
            // Facing the floor.
            let [a, b, c] = room.emissive_triangles[0].vertices;
            assert!((b - a).cross(c - a).y < 0.0);
        }
        assert!(emitter_room(1, 0).is_none() && emitter_room(1, 7).is_none());
        assert!(scaling_room(MAX_ICOSPHERE_LEVELS + 1, 1).is_none());
    }

    #[test]
    fn meshes_are_closed_and_face_outward() {
        for (mesh, count) in [(cube(), 12), (icosphere(2), 320)] {
            assert_eq!(mesh.triangles.len(), count);
            let mut edges: HashMap<(u32, u32), i32> = HashMap::new();
            for t in &mesh.triangles {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    *edges.entry((a.min(b), a.max(b))).or_default() += if a < b { 1 } else { -1 };
                }
                let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                assert!((b - a).cross(c - a).dot(a + b + c) > 0.0);
            }
            assert!(edges.values().all(|&v| v == 0));
            let inradius = mesh
                .triangles
                .iter()
                .map(|t| {
                    let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                    (b - a).cross(c - a).normalize().dot(a)
                })
                .fold(f32::INFINITY, f32::min);
            assert!(inradius > INTERIOR_RADIUS + 0.05, "{inradius}");
        }
        let scene = scene(
            vec![cube(), icosphere(1)],
            &[(0, Mat4::IDENTITY), (1, Mat4::IDENTITY)],
        );
        assert_eq!(scene.map(|s| s.triangle_count()), Some(12 + 80));
        assert!(super::scene(vec![cube()], &[(1, Mat4::IDENTITY)]).is_none());
        assert!(super::scene(vec![cube()], &[(0, Mat4::ZERO)]).is_none());
    }
}
