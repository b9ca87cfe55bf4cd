//! Tracing speed: BVH build time, and rays per second of the CPU traversal, the software-traversal
//! kernel and the ray-query kernel on every scene of `scenes/`, on the default Vulkan device
//! (lavapipe here). Incoherent rays: random origins inside the scene, uniformly random
//! directions. Run with `cargo bench -p gi-host --bench tracing`; figures are ratios within one
//! run, not absolute claims.

use gi_host::KernelVariant;
use gi_host::scene::Scene;
use gi_host::scene::upload::{SceneGeometry, build_bvh};
use gi_host::trace_rays::TraceRays;
use gi_host::vulkan::{Context, ContextOptions};
use gi_host::{Result, TraceMode};
use gi_shared::random::Random;
use gi_shared::ray::Ray;
use gi_shared::sampling::sample_uniform_sphere;
use glam::Vec3;
use std::path::Path;
use std::time::Instant;

const RAYS: usize = 1 << 20;
const SCENES: [&str; 5] = [
    "cornell-box.gltf",
    "indirect-room.gltf",
    "many-lights.gltf",
    "textured.gltf",
    "third-party/cornell-box-vinc3r/cornellBox-2.80-Eevee-gltf.gltf",
];

fn random_rays(scene: &Scene) -> Vec<Ray> {
    let mut rng = Random::new(1, 0);
    let (lo, hi) = (scene.bounds.min, scene.bounds.max);
    (0..RAYS)
        .map(|_| {
            let u = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            Ray {
                origin: (lo + (hi - lo) * u).to_array(),
                t_min: 0.0,
                direction: sample_uniform_sphere(rng.next_vec2()).to_array(),
                t_max: f32::INFINITY,
            }
        })
        .collect()
}

fn mrays(rays: usize, ms: f64) -> f64 {
    rays as f64 / (ms * 1e-3) / 1e6
}

fn main() -> Result<()> {
    let scenes = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let contexts: Vec<Context> = [TraceMode::Software, TraceMode::RayQuery]
        .iter()
        .filter_map(|&trace| {
            Context::new(&ContextOptions {
                trace,
                ..Default::default()
            })
            .inspect_err(|e| println!("skipping {trace:?}: {e}"))
            .ok()
        })
        .collect();
    if let Some(ctx) = contexts.first() {
        println!("device: {}", ctx.capabilities().name);
    }
    println!(
        "{:<28} {:>9} {:>10} {:>11} {:>12} {:>12}",
        "scene", "triangles", "bvh build", "cpu Mray/s", "sw Mray/s", "rq Mray/s"
    );
    for file in SCENES {
        let (scene, _) = Scene::load(scenes.join(file))?;
        let start = Instant::now();
        let bvh = build_bvh(&scene)?;
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let rays = random_rays(&scene);
        let start = Instant::now();
        let hits = rays.iter().filter(|r| bvh.closest_hit(r).is_hit()).count();
        let cpu_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut gpu = [f64::NAN; 2];
        for ctx in &contexts {
            let geometry = SceneGeometry::new(ctx, &scene, Some(&bvh))?;
            let pass = TraceRays::new(ctx, &geometry)?;
            // The first dispatch pays for pipeline compilation and cold caches.
            pass.run(ctx, &geometry, &rays[..RAYS / 16])?;
            let result = pass.run(ctx, &geometry, &rays)?;
            let slot = usize::from(ctx.variant() == KernelVariant::RayQuery);
            gpu[slot] = result.gpu_ms.map_or(f64::NAN, |ms| mrays(RAYS, ms));
            pass.destroy(ctx);
            geometry.destroy(ctx);
        }
        let name = Path::new(file)
            .file_name()
            .map_or(file.into(), |n| n.to_string_lossy());
        println!(
            "{:<28} {:>9} {:>7.2} ms {:>11.2} {:>12.2} {:>12.2}   ({:.0}% of rays hit)",
            name,
            scene.triangle_count(),
            build_ms,
            mrays(RAYS, cpu_ms),
            gpu[0],
            gpu[1],
            100.0 * hits as f64 / RAYS as f64
        );
    }
    Ok(())
}
