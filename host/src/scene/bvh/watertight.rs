//! The traversal on closed meshes built by the production SAH builder: rays aimed exactly at
//! shared vertices and edges never slip through (at any scale and offset), and an independent
//! `f64` ray/triangle oracle agrees with it wherever its answer is not ambiguous.

use super::*;
use crate::scene::gpu_data::ShadingData;
use crate::scene::procedural::{self, clear_of_the_axes, cube, icosphere, ray_at_shared_feature};
use gi_shared::random::Random;
use glam::{Mat4, Quat, Vec3};

fn sub64(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot64(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross64(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Similarity transforms from tiny to huge, near and far from the origin, one of them mirroring.
fn transforms(seed: u32) -> Vec<(&'static str, Mat4)> {
    let mut rng = Random::new(seed, 0);
    let mut t = |name, scale: Vec3, offset: [f32; 3]| {
        let axis = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
        let rotation =
            Quat::from_axis_angle(axis.normalize(), rng.next_in(0.0, std::f32::consts::TAU));
        let m = Mat4::from_scale_rotation_translation(scale, rotation, Vec3::from(offset));
        (name, m)
    };
    vec![
        ("unit", Mat4::IDENTITY),
        t("rotated", Vec3::ONE, [0.3, -0.2, 0.1]),
        t("scale 1e-3", Vec3::splat(1e-3), [2e-3, 0.0, -1e-3]),
        t(
            "scale 1e-5 at 0.01",
            Vec3::splat(1e-5),
            [0.01, -0.02, 0.005],
        ),
        t("scale 1e3", Vec3::splat(1e3), [-500.0, 250.0, 40.0]),
        t("mirrored", Vec3::new(-2.0, 2.0, 2.0), [1.0, 2.0, 3.0]),
        t("offset 1e4", Vec3::splat(3.0), [1e4, -2e4, 5e3]),
        t("offset 1e5", Vec3::splat(50.0), [-1e5, 7e4, 1e5]),
    ]
}

/// 10⁶ rays aimed exactly at shared vertices and edges of a closed cube and icosphere (1280
/// triangles), from inside and outside, under every transform of [`transforms`], through the
/// scene's BVH as the renderer builds it: every one hits, at its target.
#[test]
fn rays_at_shared_vertices_and_edges_never_slip_through() {
    const RAYS_PER_GROUP: usize = 1 << 15;
    let mut total = 0;
    for mesh in [cube(), icosphere(3)] {
        for (k, (name, transform)) in transforms(21).into_iter().enumerate() {
            for inside in [true, false] {
                let placement = if inside {
                    transform
                } else {
                    clear_of_the_axes(transform)
                };
                let scene = procedural::scene(vec![mesh.clone()], &[(0, placement)]).unwrap();
                let bvh = Bvh::new(&scene).unwrap();
                let shading = ShadingData::new(&scene).unwrap();
                let seed = (k * 2 + usize::from(inside)) as u32 + 100 * mesh.triangles.len() as u32;
                let results: Vec<(Ray, HitRecord, f32)> = (0..RAYS_PER_GROUP)
                    .into_par_iter()
                    .map(|i| {
                        let mut rng = Random::new(seed, i as u32);
                        let (ray, target) =
                            ray_at_shared_feature(&mesh, placement, &mut rng, inside).unwrap();
                        // How far the hit may be from the target: the rounding of the
                        // coordinates, relative to the ray's length.
                        let m = Vec3::from(ray.origin)
                            .abs()
                            .max_element()
                            .max(target.abs().max_element());
                        let tolerance =
                            1e-4 + 64.0 * m * f32::EPSILON / Vec3::from(ray.direction).length();
                        (ray, bvh.closest_hit(&shading, &ray), tolerance)
                    })
                    .collect();
                let misses: Vec<&Ray> = results
                    .iter()
                    .filter(|(_, h, _)| !h.is_hit())
                    .map(|(r, _, _)| r)
                    .collect();
                let mesh_name = &mesh.name;
                assert!(
                    misses.is_empty(),
                    "{mesh_name} {name} inside={inside}: {} of {RAYS_PER_GROUP} rays slip through, \
                     e.g. {:?}",
                    misses.len(),
                    &misses[..misses.len().min(3)]
                );
                let worst = results
                    .iter()
                    .map(|(_, h, tol)| (h.t - 1.0).abs() / tol)
                    .fold(0.0f32, f32::max);
                assert!(
                    worst <= 1.0,
                    "{mesh_name} {name} inside={inside}: a hit is {worst} tolerances away from \
                     the target"
                );
                total += results.len();
            }
        }
    }
    println!("watertight: {total} rays at shared vertices and edges, 0 misses");
    assert!(total >= 1_000_000);
}

/// The `f64` oracle: Möller–Trumbore on the ray `o + t·d` and the `f32` triangle widened to
/// `f64`, written independently of the traversal. Returns `(t, u, v)` of the ray against the triangle's plane
/// (NaN when parallel), whatever the sign of the barycentrics.
fn oracle(o: [f64; 3], d: [f64; 3], tri: &[[f32; 3]; 3]) -> (f64, f64, f64) {
    let [a, b, c] = tri.map(|v| v.map(f64::from));
    let e1 = sub64(b, a);
    let e2 = sub64(c, a);
    let p = cross64(d, e2);
    let det = dot64(e1, p);
    if det == 0.0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let s = sub64(o, a);
    let u = dot64(s, p) / det;
    let q = cross64(s, e1);
    let v = dot64(d, q) / det;
    let t = dot64(e2, q) / det;
    (t, u, v)
}

/// Relative barycentric margin below which the oracle's answer counts as ambiguous.
const MARGIN: f64 = 1e-5;
/// Relative distance within which two hits count as ambiguous.
const T_GAP: f64 = 1e-4;
/// Largest difference between the traversal's distance and the oracle's: relative, plus
/// [`T_ULPS`] units of the largest vertex coordinate relative to the origin, in ray lengths and
/// divided by the cosine of the angle of incidence (the conditioning of `t`).
const T_RELATIVE: f64 = 1e-5;
/// See [`T_RELATIVE`].
const T_ULPS: f32 = 16.0;

/// What the oracle says about a ray: the closest clear hit, a clear miss, or ambiguous (a hit or
/// near-hit within [`MARGIN`] of an edge, or two hits within [`T_GAP`]).
enum Verdict {
    Hit { primitive: usize, t: f64 },
    Miss,
    Ambiguous,
}

fn verdict(origin: [f64; 3], direction: [f64; 3], tris: &[[[f32; 3]; 3]]) -> Verdict {
    let mut hits: Vec<(f64, usize)> = Vec::new();
    for (i, tri) in tris.iter().enumerate() {
        let (t, u, v) = oracle(origin, direction, tri);
        if t.is_nan() || t < 0.0 {
            // Parallel, or behind the origin (no test ray starts on a surface).
            continue;
        }
        let w = 1.0 - u - v;
        let inside = u.min(v).min(w);
        if inside.abs() <= MARGIN {
            return Verdict::Ambiguous;
        }
        if inside > 0.0 {
            hits.push((t, i));
        }
    }
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    match hits[..] {
        [] => Verdict::Miss,
        [(t, primitive)] => Verdict::Hit { primitive, t },
        [(t, primitive), (t2, _), ..] if t2 - t > T_GAP * t2 => Verdict::Hit { primitive, t },
        _ => Verdict::Ambiguous,
    }
}

/// The BVH against the `f64` oracle with brute force over all triangles, on random rays (half
/// aimed at random points of random triangles) through the placed meshes and a random soup: the
/// same primitive and the same distance within [`T_RELATIVE`] (and [`T_ULPS`]) on every ray whose
/// answer is not ambiguous. The oracle works in the mesh's object space, with the world ray moved
/// there in `f64`, as instancing requires: rounding the placed triangles to world-space `f32`
/// would move them by more than the margins far from the origin.
#[test]
fn the_bvh_agrees_with_an_f64_oracle() {
    const RAYS_PER_SCENE: usize = 20_000;
    let mut scenes: Vec<(String, crate::scene::Scene)> = Vec::new();
    for mesh in [cube(), icosphere(2)] {
        for (name, transform) in transforms(22) {
            let scene = procedural::scene(vec![mesh.clone()], &[(0, transform)]).unwrap();
            scenes.push((format!("{} {name}", mesh.name), scene));
        }
    }
    let mut rng = Random::new(23, 0);
    let soup: Vec<[[f32; 3]; 3]> = (0..1000)
        .map(|_| {
            let c = Vec3::new(
                rng.next_in(-1.0, 1.0),
                rng.next_in(-1.0, 1.0),
                rng.next_in(-1.0, 1.0),
            );
            [0; 3].map(|_| {
                (c + Vec3::new(
                    rng.next_in(-0.2, 0.2),
                    rng.next_in(-0.2, 0.2),
                    rng.next_in(-0.2, 0.2),
                ))
                .to_array()
            })
        })
        .collect();
    let soup = procedural::triangle_soup("random soup", &soup);
    let soup = procedural::scene(vec![soup], &[(0, Mat4::IDENTITY)]).unwrap();
    scenes.push(("random soup".into(), soup));

    let (mut checked, mut ambiguous, mut hits) = (0, 0, 0);
    for (s, (name, scene)) in scenes.iter().enumerate() {
        let transform = &scene.instances[0].transform;
        let inverse = transform.as_dmat4().inverse();
        let mesh = &scene.meshes[0];
        // Object space, in the leaf order the BVH reports primitives in.
        let object: Vec<[[f32; 3]; 3]> = (0..mesh.triangles.len())
            .map(|i| mesh.triangle(i).map(|v| v.to_array()))
            .collect();
        let tris: Vec<[[f32; 3]; 3]> = scene
            .world_triangles()
            .map(|t| t.vertices.map(|v| v.to_array()))
            .collect();
        let tris = &tris;
        let bvh = Bvh::new(scene).unwrap();
        let shading = ShadingData::new(scene).unwrap();
        let outcomes: Vec<Option<(bool, String)>> = (0..RAYS_PER_SCENE)
            .into_par_iter()
            .map(|i| {
                let mut rng = Random::new(24 + s as u32, i as u32);
                let mut point = || {
                    transform.transform_point3(Vec3::new(
                        rng.next_in(-2.0, 2.0),
                        rng.next_in(-2.0, 2.0),
                        rng.next_in(-2.0, 2.0),
                    ))
                };
                let origin = point();
                let target = if i % 2 == 0 {
                    point()
                } else {
                    let t = tris[i / 2 % tris.len()].map(Vec3::from);
                    let (u, v) = (rng.next_f32(), rng.next_f32());
                    let (u, v) = if u + v > 1.0 {
                        (1.0 - u, 1.0 - v)
                    } else {
                        (u, v)
                    };
                    t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v
                };
                let ray = Ray {
                    origin: origin.to_array(),
                    t_min: 0.0,
                    direction: (target - origin).to_array(),
                    t_max: f32::INFINITY,
                };
                let got = bvh.closest_hit(&shading, &ray);
                let o = inverse.transform_point3(Vec3::from(ray.origin).as_dvec3());
                let d = inverse.transform_vector3(Vec3::from(ray.direction).as_dvec3());
                match verdict(o.to_array(), d.to_array(), &object) {
                    Verdict::Ambiguous => None,
                    Verdict::Miss => Some((
                        false,
                        if got.is_hit() {
                            format!("{name}: {ray:?} hits {got:?}, the oracle misses")
                        } else {
                            String::new()
                        },
                    )),
                    Verdict::Hit { primitive, t } => {
                        // The vertices relative to the origin carry their own rounding: it
                        // dominates when the hit is close to the origin.
                        let o = Vec3::from(ray.origin);
                        let reach = tris[primitive]
                            .iter()
                            .map(|&v| (Vec3::from(v) - o).abs().max_element())
                            .fold(0.0f32, f32::max);
                        // ... and a ray at a grazing angle turns it into a larger error in t.
                        let [a, b, c] = tris[primitive].map(|v| v.map(f64::from));
                        let n = cross64(sub64(b, a), sub64(c, a));
                        let d = ray.direction.map(f64::from);
                        let cos = dot64(n, d).abs() / (dot64(n, n) * dot64(d, d)).sqrt();
                        let bound = T_RELATIVE * t
                            + f64::from(T_ULPS * f32::EPSILON * reach) / (dot64(d, d).sqrt() * cos);
                        let ok = got.primitive as usize == primitive
                            && (f64::from(got.t) - t).abs() <= bound;
                        Some((
                            true,
                            if ok {
                                String::new()
                            } else {
                                format!(
                                    "{name}: {ray:?} gives {got:?}, the oracle {primitive} at {t}"
                                )
                            },
                        ))
                    }
                }
            })
            .collect();
        let failures: Vec<&String> = outcomes
            .iter()
            .flatten()
            .filter(|(_, f)| !f.is_empty())
            .map(|(_, f)| f)
            .collect();
        assert!(
            failures.is_empty(),
            "{} disagreements:\n{}",
            failures.len(),
            failures[..failures.len().min(5)]
                .iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join("\n")
        );
        checked += outcomes.iter().flatten().count();
        hits += outcomes.iter().flatten().filter(|(hit, _)| *hit).count();
        ambiguous += outcomes.iter().filter(|o| o.is_none()).count();
    }
    let total = scenes.len() * RAYS_PER_SCENE;
    println!(
        "f64 oracle: {total} rays, {checked} checked ({hits} hits), {ambiguous} ambiguous ({:.3}%), 0 disagreements",
        100.0 * ambiguous as f64 / total as f64
    );
    // The check must have teeth: most rays are decided, a good share of them hits.
    assert!(ambiguous * 100 < total, "{ambiguous} ambiguous rays");
    assert!(hits * 4 > total, "{hits} hits");
}
