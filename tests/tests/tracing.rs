//! The three tracers agree: the CPU walking the shared BVH, the software-traversal kernel walking
//! the same BVH on the device, and the ray-query kernel against device-built acceleration
//! structures. 100 000 random rays per scene, from inside the scene's bounds in uniformly random
//! directions, on every repository scene, the third-party Blender box, and a scene of mirrored
//! instances (`tests/data/mirrored.gltf`), where both decide the front face in object space.
//!
//! Agreement: the same instance, primitive and front face, and distances within 1e-4 relative.
//! Near the origin the rounding of a hit distance scales with the scene's coordinates, not with
//! the distance, so distances also agree when they differ by less than 1e-6 of the scene's extent.
//! Two tracers may legitimately pick different triangles when a ray hits both at the same
//! distance (a shared edge or vertex, or coplanar faces such as a box's bottom lying on the
//! floor): such ties are counted and accepted when both distances agree; they must stay under 1%
//! of the rays. Both triangle tests are watertight, but they see different coordinates (each
//! implementation rounds the ray's move into object space its own way), so a ray grazing the
//! silhouette of an open surface may still hit in one and miss in the other: such edge misses are
//! counted and must stay below 1 in 10 000 rays. On closed meshes no ray may slip through the
//! software traversal: 10⁶ rays aimed exactly at shared vertices and edges all hit, on the CPU and
//! in the software kernel (lavapipe's ray queries let about 1% of them through; counted, not
//! asserted).

use gi_host::KernelVariant;
use gi_host::scene::Scene;
use gi_host::scene::bvh::Bvh;
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::procedural::{
    self, clear_of_the_axes, cube, icosphere, ray_at_shared_feature, transformed,
};
use gi_host::scene::upload::GpuScene;
use gi_host::trace_rays::TraceRays;
use gi_shared::random::Random;
use gi_shared::ray::{HitRecord, Ray};
use gi_shared::sampling::sample_uniform_sphere;
use gi_tests::{
    computes_like_the_cpu, context, finish_without_validation_messages, scene_path,
    third_party_scene_path, variants,
};
use glam::{Mat4, Quat, Vec3};
use std::path::{Path, PathBuf};

const RAYS: usize = 100_000;
const RELATIVE_T: f32 = 1e-4;
const ABSOLUTE_T_OF_EXTENT: f32 = 1e-6;

fn random_rays(scene: &Scene, seed: u32) -> Vec<Ray> {
    let mut rng = Random::new(seed, 0);
    let (lo, hi) = (scene.bounds.min, scene.bounds.max);
    (0..RAYS)
        .map(|_| {
            let u = glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let origin = lo + (hi - lo) * u;
            let dir = sample_uniform_sphere(rng.next_vec2());
            Ray {
                origin: origin.to_array(),
                t_min: 0.0,
                direction: dir.to_array(),
                t_max: f32::INFINITY,
            }
        })
        .collect()
}

/// `scene` on the device, with its BVH and shading data (lights: its own, no environment).
fn upload(
    ctx: &gi_host::vulkan::Context,
    scene: &Scene,
    bvh: &Bvh,
    shading: &ShadingData,
) -> GpuScene {
    let lights = LightSet::new(scene, None, false);
    GpuScene::upload(ctx, scene, Some(bvh), shading, &lights).unwrap()
}

#[derive(Default, Debug)]
struct Agreement {
    same: usize,
    ties: usize,
    leaks: usize,
    mismatches: Vec<String>,
}

fn compare(name: &str, extent: f32, reference: &[HitRecord], other: &[HitRecord]) -> Agreement {
    let mut a = Agreement::default();
    for (i, (r, o)) in reference.iter().zip(other).enumerate() {
        let t_close = |x: f32, y: f32| {
            (x - y).abs() <= RELATIVE_T * x.abs().max(y.abs()) + ABSOLUTE_T_OF_EXTENT * extent
        };
        match (r.is_hit(), o.is_hit()) {
            (false, false) => a.same += 1,
            (true, true) if (r.instance, r.primitive) == (o.instance, o.primitive) => {
                if t_close(r.t, o.t) && r.front_face == o.front_face {
                    a.same += 1;
                } else {
                    a.mismatches.push(format!("{name} ray {i}: {r:?} vs {o:?}"));
                }
            }
            (true, true) if t_close(r.t, o.t) => a.ties += 1,
            (true, false) | (false, true) => a.leaks += 1,
            _ => a.mismatches.push(format!("{name} ray {i}: {r:?} vs {o:?}")),
        }
    }
    a
}

/// Traces the random rays of `path` on the CPU and in both variants and asserts agreement;
/// returns the scene and the CPU's hits.
fn check_scene(path: PathBuf) -> (Scene, Vec<HitRecord>) {
    let (scene, _warnings) = Scene::load(&path).unwrap();
    check(&path, scene)
}

/// [`check_scene`] for a scene already loaded or built (`path` names it).
fn check(path: &Path, scene: Scene) -> (Scene, Vec<HitRecord>) {
    let file = path.display().to_string();
    let bvh = Bvh::new(&scene).unwrap();
    let shading = ShadingData::new(&scene).unwrap();
    let rays = random_rays(&scene, 17);
    let cpu: Vec<HitRecord> = rays.iter().map(|r| bvh.closest_hit(&shading, r)).collect();
    let hits_on_cpu = cpu.iter().filter(|h| h.is_hit()).count();
    assert!(
        hits_on_cpu > RAYS / 10,
        "{file}: only {hits_on_cpu} rays hit anything"
    );
    for variant in variants() {
        let ctx = context(variant);
        let exact = computes_like_the_cpu(&ctx);
        let gpu_scene = upload(&ctx, &scene, &bvh, &shading);
        let pass = TraceRays::new(&ctx).unwrap();
        let gpu = pass.run(&ctx, &gpu_scene, &rays).unwrap();
        drop(pass);
        drop(gpu_scene);
        finish_without_validation_messages(ctx);
        let extent = (scene.bounds.max - scene.bounds.min).length();
        let a = compare(&format!("{file} {variant}"), extent, &cpu, &gpu.hits);
        let name = path
            .file_name()
            .map_or(file.clone(), |n| n.to_string_lossy().into());
        println!(
            "{name:<40} {variant:<24} same {:>6}, ties {:>3}, edge misses {:>3}, mismatches {}",
            a.same,
            a.ties,
            a.leaks,
            a.mismatches.len()
        );
        assert!(
            a.mismatches.is_empty(),
            "{}",
            a.mismatches[..a.mismatches.len().min(5)].join("\n")
        );
        assert!(a.ties <= RAYS / 100, "{file} {variant}: {} ties", a.ties);
        assert!(
            a.leaks <= RAYS / 10_000,
            "{file} {variant}: {} edge misses",
            a.leaks
        );
        if variant == KernelVariant::Software && exact {
            // Same BVH, same arithmetic: the software kernel must match the CPU exactly on
            // which triangle it reports.
            assert_eq!(
                a.ties + a.leaks,
                0,
                "{file}: software kernel differs from the CPU"
            );
        }
    }
    (scene, cpu)
}

#[test]
fn cornell_box() {
    check_scene(scene_path("cornell-box.gltf"));
}

#[test]
fn indirect_room() {
    check_scene(scene_path("indirect-room.gltf"));
}

#[test]
fn many_lights() {
    check_scene(scene_path("many-lights.gltf"));
}

#[test]
fn textured() {
    check_scene(scene_path("textured.gltf"));
}

#[test]
#[cfg_attr(
    not(third_party_scenes),
    ignore = "../shared/scenes/third-party is absent (a clone without the shared folder)"
)]
fn third_party_blender_export() {
    check_scene(third_party_scene_path(
        "cornell-box-vinc3r/cornellBox-2.80-Eevee-gltf.gltf",
    ));
}

/// Mirrored instances: the agreement above includes the front face, so both variants report
/// the same face as the CPU; and the rays do reach both faces of mirrored instances.
#[test]
fn mirrored_instances() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/mirrored.gltf");
    let (scene, cpu) = check_scene(path);
    let mirrored = scene.instances.iter().filter(|i| i.is_mirrored()).count();
    assert!(mirrored >= 5, "{mirrored} mirrored instances");
    let mut faces = [0usize; 2];
    for h in cpu.iter().filter(|h| h.is_hit()) {
        if scene.instances[h.instance as usize].is_mirrored() {
            faces[h.front_face as usize] += 1;
        }
    }
    println!(
        "hits on mirrored instances: {} back, {} front",
        faces[0], faces[1]
    );
    assert!(faces.iter().all(|&n| n > RAYS / 50), "{faces:?}");
}

/// One mesh placed 400 times, mirrored, scaled (unevenly too) and rotated: the two-level BVH
/// (one bottom level for all) gives exactly what brute force over every instance's triangles
/// gives, on the CPU, and both device variants agree with it as on the other scenes.
#[test]
fn instanced_mesh() {
    let mut rng = Random::new(41, 0);
    let placements: Vec<(u32, Mat4)> = (0..400)
        .map(|i| {
            let axis = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 2.0 - 1.0;
            let turn = Quat::from_axis_angle(axis.normalize_or(Vec3::Z), 6.0 * rng.next_f32());
            let s = rng.next_in(0.05, 0.5);
            let scale = match i % 4 {
                0 => Vec3::new(-s, s, s),
                1 => Vec3::new(s, 0.25 * s, 2.0 * s),
                2 => Vec3::new(s, -s, -s),
                _ => Vec3::splat(s),
            };
            let at = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 8.0 - 4.0;
            (0, Mat4::from_scale_rotation_translation(scale, turn, at))
        })
        .collect();
    let scene = procedural::scene(vec![icosphere(2)], &placements).unwrap();
    let bvh = Bvh::new(&scene).unwrap();
    let shading = ShadingData::new(&scene).unwrap();
    assert_eq!(bvh.nodes.len(), 399 + scene.blases[0].nodes.len());
    let view = bvh.scene(&shading);
    let rays = random_rays(&scene, 43);
    let mut ties = 0;
    for ray in &rays[..RAYS / 10] {
        let got = bvh.closest_hit(&shading, ray);
        let want = gi_shared::bvh::closest_hit_brute_force(view, &shading.texels[..], ray);
        if (got.instance, got.primitive) != (want.instance, want.primitive) && got.t == want.t {
            ties += 1;
        } else {
            assert_eq!(got, want, "{ray:?}");
        }
    }
    assert!(ties <= RAYS / 1000, "{ties} ties");
    let (scene, cpu) = check(Path::new("<400 instances of an icosphere>"), scene);
    let mirrored = cpu
        .iter()
        .filter(|h| h.is_hit() && scene.instances[h.instance as usize].is_mirrored())
        .count();
    assert!(
        mirrored > RAYS / 20,
        "{mirrored} hits on mirrored instances"
    );
}

/// Rays aimed exactly at shared vertices and edges of closed meshes (see
/// [`ray_at_shared_feature`]), 10⁶ per variant: on the CPU and in the software kernel none may
/// miss, and each hits at its target. The placements are baked into the vertices (instances keep
/// the identity), so that ray queries see the very vertex and ray values the software BVH sees;
/// their leaks are the driver's and only counted (lavapipe: about 1%).
#[test]
fn rays_at_shared_vertices_and_edges_never_slip_through_the_software_bvh() {
    const RAYS_PER_GROUP: usize = 50_000;
    let turn = Quat::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 2.1);
    let placements = [
        ("unit", Mat4::IDENTITY),
        (
            "scale 1e-3",
            Mat4::from_scale_rotation_translation(Vec3::splat(1e-3), turn, Vec3::splat(2e-3)),
        ),
        (
            "scale 1e3",
            Mat4::from_scale_rotation_translation(Vec3::splat(1e3), turn, Vec3::ZERO),
        ),
        (
            "mirrored",
            Mat4::from_scale_rotation_translation(Vec3::new(-2.0, 2.0, 2.0), turn, Vec3::ONE),
        ),
        (
            "offset 1e5",
            Mat4::from_scale_rotation_translation(
                Vec3::splat(50.0),
                turn,
                Vec3::new(-1e5, 7e4, 1e5),
            ),
        ),
    ];
    struct Group {
        name: String,
        scene: Scene,
        bvh: Bvh,
        shading: ShadingData,
        rays: Vec<Ray>,
    }
    let mut groups = Vec::new();
    for mesh in [cube(), icosphere(3)] {
        for (name, transform) in placements {
            for inside in [true, false] {
                let placement = if inside {
                    transform
                } else {
                    clear_of_the_axes(transform)
                };
                let scene =
                    procedural::scene(vec![transformed(&mesh, placement)], &[(0, Mat4::IDENTITY)])
                        .unwrap();
                let mut rng = Random::new(groups.len() as u32, 31);
                let rays = (0..RAYS_PER_GROUP)
                    .map(|_| {
                        ray_at_shared_feature(&mesh, placement, &mut rng, inside)
                            .unwrap()
                            .0
                    })
                    .collect();
                groups.push(Group {
                    name: format!("{} {name} inside={inside}", mesh.name),
                    bvh: Bvh::new(&scene).unwrap(),
                    shading: ShadingData::new(&scene).unwrap(),
                    scene,
                    rays,
                });
            }
        }
    }
    // Rays that miss, or that hit away from their target (they slipped through the surface
    // there and hit the far side).
    let leaks = |g: &Group, hits: &[HitRecord]| {
        g.rays
            .iter()
            .zip(hits)
            .filter(|(ray, hit)| {
                let m = Vec3::from(ray.origin).abs().max_element().max(
                    (Vec3::from(ray.origin) + Vec3::from(ray.direction))
                        .abs()
                        .max_element(),
                );
                let tolerance = 1e-4 + 64.0 * m * f32::EPSILON / Vec3::from(ray.direction).length();
                (hit.t - 1.0).abs().is_nan() || (hit.t - 1.0).abs() > tolerance
            })
            .count()
    };
    let mut traced = 0;
    let mut ray_query_leaks = 0;
    for variant in variants() {
        let ctx = context(variant);
        for g in &groups {
            if variant == KernelVariant::Software {
                let cpu: Vec<HitRecord> = g
                    .rays
                    .iter()
                    .map(|r| g.bvh.closest_hit(&g.shading, r))
                    .collect();
                assert_eq!(leaks(g, &cpu), 0, "cpu {}", g.name);
            }
            let gpu_scene = upload(&ctx, &g.scene, &g.bvh, &g.shading);
            let pass = TraceRays::new(&ctx).unwrap();
            let gpu = pass.run(&ctx, &gpu_scene, &g.rays).unwrap();
            drop(pass);
            drop(gpu_scene);
            let n = leaks(g, &gpu.hits);
            println!(
                "{variant:<24} {:<32} {n:>5} of {} rays leak",
                g.name,
                g.rays.len()
            );
            match variant {
                KernelVariant::Software => assert_eq!(n, 0, "{variant} {}", g.name),
                // The driver's test, not ours: lavapipe's lets about 1% of these rays through
                // (its box test is not conservative). More than 5% would mean broken geometry.
                KernelVariant::RayQuery => {
                    assert!(n <= g.rays.len() / 20, "{variant} {}: {n} leaks", g.name);
                    ray_query_leaks += n;
                }
            }
            traced += g.rays.len();
        }
        finish_without_validation_messages(ctx);
    }
    println!(
        "{traced} rays at shared vertices and edges on the device: 0 leaks in software, \
         {ray_query_leaks} with ray queries"
    );
    assert!(traced >= variants().len() * 1_000_000);
}
