//! The three tracers agree: the CPU walking the shared BVH, the software-traversal kernel walking
//! the same BVH on the device, and the ray-query kernel against device-built acceleration
//! structures. 100 000 random rays per scene, from inside the scene's bounds in uniformly random
//! directions.
//!
//! Agreement: the same instance and primitive, and distances within 1e-4 relative. Near the
//! origin the rounding of a hit distance scales with the scene's coordinates, not with the
//! distance, so distances also agree when they differ by less than 1e-6 of the scene's extent
//! (lavapipe's ray queries and Möller–Trumbore differ by up to ~5e-7 there). Two tracers
//! may legitimately pick different triangles when a ray hits both at the same distance (a shared
//! edge or vertex, or coplanar faces such as a box's bottom lying on the floor): such ties are
//! counted and accepted when both distances agree; they must stay under 1% of the rays. A ray that grazes an edge can also slip between two triangles in
//! one tracer and not the other (Möller–Trumbore is not watertight; lavapipe's test is): such
//! leaks are counted and must stay below 1 in 10 000 rays.

use gi_host::KernelVariant;
use gi_host::scene::Scene;
use gi_host::scene::bvh::Bvh;
use gi_host::scene::upload::{SceneGeometry, build_bvh};
use gi_host::trace_rays::TraceRays;
use gi_shared::random::Random;
use gi_shared::ray::{HitRecord, Ray};
use gi_shared::sampling::sample_uniform_sphere;
use gi_tests::{context, finish_without_validation_messages, scene_path};

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

fn check_scene(file: &str) {
    let (scene, _warnings) = Scene::load(scene_path(file)).unwrap();
    let bvh: Bvh = build_bvh(&scene).unwrap();
    let rays = random_rays(&scene, 17);
    let cpu: Vec<HitRecord> = rays.iter().map(|r| bvh.closest_hit(r)).collect();
    let hits_on_cpu = cpu.iter().filter(|h| h.is_hit()).count();
    assert!(
        hits_on_cpu > RAYS / 10,
        "{file}: only {hits_on_cpu} rays hit anything"
    );
    for variant in KernelVariant::ALL {
        let ctx = context(variant);
        let geometry = SceneGeometry::new(&ctx, &scene, Some(&bvh)).unwrap();
        let pass = TraceRays::new(&ctx, &geometry).unwrap();
        let gpu = pass.run(&ctx, &geometry, &rays).unwrap();
        pass.destroy(&ctx);
        geometry.destroy(&ctx);
        finish_without_validation_messages(ctx);
        let extent = (scene.bounds.max - scene.bounds.min).length();
        let a = compare(&format!("{file} {variant}"), extent, &cpu, &gpu.hits);
        println!(
            "{file:<40} {variant:<24} same {:>6}, ties {:>3}, edge leaks {:>3}, mismatches {}",
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
            "{file} {variant}: {} edge leaks",
            a.leaks
        );
        if variant == KernelVariant::Software {
            // Same BVH, same arithmetic: the software kernel must match the CPU exactly on
            // which triangle it reports.
            assert_eq!(
                a.ties + a.leaks,
                0,
                "{file}: software kernel differs from the CPU"
            );
        }
    }
}

#[test]
fn cornell_box() {
    check_scene("cornell-box.gltf");
}

#[test]
fn indirect_room() {
    check_scene("indirect-room.gltf");
}

#[test]
fn many_lights() {
    check_scene("many-lights.gltf");
}

#[test]
fn textured() {
    check_scene("textured.gltf");
}

#[test]
fn third_party_blender_export() {
    check_scene("third-party/cornell-box-vinc3r/cornellBox-2.80-Eevee-gltf.gltf");
}
