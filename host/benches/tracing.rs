//! Tracing speed: BVH build time, the bytes per triangle of the geometry the software traversal
//! reads (BVH nodes and the shading data's instances, meshes, vertices and triangles), and rays
//! per second of the CPU traversal (all cores), the
//! software-traversal kernel and the ray-query kernel, with the software ÷ ray-query ratio, on
//! the default Vulkan device (lavapipe here). Scenes: every `scenes/*.gltf`, the third-party
//! scenes of `../shared/scenes/third-party/` (skipped with a message where that folder is
//! absent), and a generated scene of instanced icospheres (over 250k triangles); then the build
//! time of a million triangles.
//!
//! Coherent rays: the primary rays of the scene's camera (`gi_host::gbuffer::scene_camera`),
//! 1024 × 1024 in row order. Incoherent rays: random origins inside the scene's bounds,
//! uniformly random directions. Run with
//! `cargo bench --profile dev -p gi-host --bench tracing [-- WORD...]` (only the scenes whose
//! name contains a word; `"1M build"` names the build-time line; a word that is the path of a
//! scene file benches that file, e.g. one from `gi generate`); figures are ratios within one run,
//! not absolute claims. With `GI_BENCH_MAX_BINDING_BYTES=N` in the environment the kernels read
//! the vertices, triangles and BVH nodes split into storage bindings of at most `N` bytes
//! (`GpuScene::upload_with_binding_limit`): the cost of the splitting.

use gi_host::KernelVariant;
use gi_host::gbuffer::scene_camera;
use gi_host::scene::Scene;
use gi_host::scene::bvh::{Blas, Bvh};
use gi_host::scene::gpu_data::ShadingData;
use gi_host::scene::lights::LightSet;
use gi_host::scene::procedural::{icosphere, scene, transformed};
use gi_host::scene::upload::GpuScene;
use gi_host::trace_rays::TraceRays;
use gi_host::vulkan::{Context, ContextOptions};
use gi_host::{Error, Result, TraceMode};
use gi_shared::camera::primary_ray;
use gi_shared::random::Random;
use gi_shared::ray::Ray;
use gi_shared::sampling::sample_uniform_sphere;
use glam::{Mat4, Quat, UVec2, Vec2, Vec3};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Side of the camera image: `SIDE²` coherent rays, as many incoherent ones.
const SIDE: u32 = 1024;
const RAYS: usize = (SIDE * SIDE) as usize;
/// Icosphere instances of the generated scene, and of the build-time test.
const GENERATED_INSTANCES: usize = 64;
const BUILD_INSTANCES: usize = 200;
/// Subdivisions of their icospheres (5120 triangles each).
const ICOSPHERE_LEVELS: u32 = 4;

fn incoherent_rays(scene: &Scene) -> Vec<Ray> {
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

fn coherent_rays(scene: &Scene) -> Vec<Ray> {
    let camera = scene_camera(scene, SIDE, SIDE);
    (0..RAYS as u32)
        .map(|i| primary_ray(&camera, UVec2::new(i % SIDE, i / SIDE), Vec2::ZERO))
        .collect()
}

/// `count` icospheres of random size and orientation in a box of side `count^(1/3) · 4`.
fn icospheres(count: usize, seed: u32) -> Result<Scene> {
    let mut rng = Random::new(seed, 0);
    let side = (count as f32).cbrt() * 4.0;
    let instances: Vec<(u32, Mat4)> = (0..count)
        .map(|_| {
            let position = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * side;
            let axis = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5;
            let rotation =
                Quat::from_axis_angle(axis.normalize(), rng.next_in(0.0, std::f32::consts::TAU));
            let scale = Vec3::new(
                rng.next_in(0.5, 2.0),
                rng.next_in(0.5, 2.0),
                rng.next_in(0.5, 2.0),
            );
            (
                0,
                Mat4::from_scale_rotation_translation(scale, rotation, position),
            )
        })
        .collect();
    scene(vec![icosphere(ICOSPHERE_LEVELS)], &instances).ok_or(Error::InvalidArgument {
        name: "icospheres",
        why: "no scene from the generated instances".into(),
    })
}

fn mrays(rays: usize, ms: f64) -> f64 {
    rays as f64 / (ms * 1e-3) / 1e6
}

/// Mrays/s of the CPU (all cores) on `rays`, and the fraction that hit.
fn cpu_speed(bvh: &Bvh, shading: &ShadingData, rays: &[Ray]) -> (f64, f64) {
    let start = Instant::now();
    let hits = rays
        .par_iter()
        .filter(|r| bvh.closest_hit(shading, r).is_hit())
        .count();
    let ms = start.elapsed().as_secs_f64() * 1e3;
    (mrays(rays.len(), ms), hits as f64 / rays.len() as f64)
}

/// The storage-binding limit of the scene's split arrays: `GI_BENCH_MAX_BINDING_BYTES`, or the
/// device's own.
fn max_binding_bytes() -> u64 {
    std::env::var("GI_BENCH_MAX_BINDING_BYTES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(u64::MAX)
}

/// Timed dispatches per context and ray set; the best counts. The contexts take turns, so that a
/// burst of load on the machine does not favour one of them.
const REPEATS: usize = 4;

/// Mrays/s of each context's kernel on each ray set (`[context][set]`), after one dispatch per
/// context that pays for pipeline compilation and cold caches.
fn gpu_speeds(
    contexts: &[Context],
    scene: &Scene,
    bvh: &Bvh,
    shading: &ShadingData,
    sets: [&[Ray]; 2],
) -> Result<Vec<[f64; 2]>> {
    let lights = LightSet::new(scene, None, false);
    let passes = contexts
        .iter()
        .map(|ctx| {
            Ok((
                GpuScene::upload_with_binding_limit(
                    ctx,
                    scene,
                    Some(bvh),
                    shading,
                    &lights,
                    max_binding_bytes(),
                )?,
                TraceRays::new(ctx)?,
            ))
        })
        .collect::<Result<Vec<_>>>()?;
    for (ctx, (geometry, pass)) in contexts.iter().zip(passes.iter()) {
        pass.run(ctx, geometry, &sets[0][..RAYS / 16])?;
    }
    let mut speeds = vec![[f64::NAN; 2]; contexts.len()];
    for _ in 0..REPEATS {
        for (k, (ctx, (geometry, pass))) in contexts.iter().zip(passes.iter()).enumerate() {
            for (speed, rays) in speeds[k].iter_mut().zip(sets) {
                let ms = pass.run(ctx, geometry, rays)?.gpu_ms;
                // NaN without timestamps; otherwise the fastest run counts.
                let s = ms.map_or(f64::NAN, |ms| mrays(rays.len(), ms));
                if speed.is_nan() || s > *speed {
                    *speed = s;
                }
            }
        }
    }
    Ok(speeds)
}

/// Milliseconds to build every mesh's bottom level (what `Scene::update_derived` does at load),
/// and then the top level with the node buffer ([`Bvh::new`]).
fn build_ms(scene: &Scene) -> Result<(f64, f64, Bvh)> {
    let start = Instant::now();
    let blases: Vec<_> = scene
        .meshes
        .par_iter()
        .map(|m| Blas::build(&m.positions, &m.triangles))
        .collect();
    let blas_ms = start.elapsed().as_secs_f64() * 1e3;
    drop(blases);
    let start = Instant::now();
    let bvh = Bvh::new(scene)?;
    Ok((blas_ms, start.elapsed().as_secs_f64() * 1e3, bvh))
}

/// Bytes per world-space triangle of what the software traversal reads.
fn bytes_per_triangle(scene: &Scene, bvh: &Bvh, shading: &ShadingData) -> f64 {
    let bytes = std::mem::size_of_val(&bvh.nodes[..])
        + std::mem::size_of_val(&shading.instances[..])
        + std::mem::size_of_val(&shading.meshes[..])
        + std::mem::size_of_val(&shading.vertices[..])
        + std::mem::size_of_val(&shading.triangles[..]);
    bytes as f64 / scene.triangle_count() as f64
}

fn bench(contexts: &[Context], name: &str, scene: &Scene) -> Result<()> {
    let (blas_ms, tlas_ms, bvh) = build_ms(scene)?;
    let shading = ShadingData::new(scene)?;
    let bytes = bytes_per_triangle(scene, &bvh, &shading);
    let coherent = coherent_rays(scene);
    let incoherent = incoherent_rays(scene);
    let cpu = [
        cpu_speed(&bvh, &shading, &coherent),
        cpu_speed(&bvh, &shading, &incoherent),
    ];
    // [variant][coherent, incoherent]
    let mut gpu = [[f64::NAN; 2]; 2];
    let speeds = gpu_speeds(contexts, scene, &bvh, &shading, [&coherent, &incoherent])?;
    for (ctx, speed) in contexts.iter().zip(speeds) {
        gpu[usize::from(ctx.variant() == KernelVariant::RayQuery)] = speed;
    }
    let mut line = format!(
        "{name:<26} {:>9} {:>9.1} {:>6.1} {:>5.1}",
        scene.triangle_count(),
        blas_ms,
        tlas_ms,
        bytes
    );
    for k in 0..2 {
        line += &format!(
            " | {:>7.2} {:>7.2} {:>7.2} {:>5.2} {:>4.0}%",
            cpu[k].0,
            gpu[0][k],
            gpu[1][k],
            gpu[0][k] / gpu[1][k],
            100.0 * cpu[k].1
        );
    }
    println!("{line}");
    Ok(())
}

fn main() -> std::result::Result<(), Box<dyn std::error::Error>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
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
        "CPU: {} threads; Mrays/s; sw/rq = software kernel ÷ ray-query kernel; hit = rays that \
         hit",
        rayon::current_num_threads()
    );
    println!(
        "{:<26} {:>9} {:>9} {:>6} {:>5} | {:^36} | {:^36}",
        "", "", "", "", "", "coherent (camera)", "incoherent (random)"
    );
    println!(
        "{:<26} {:>9} {:>9} {:>6} {:>5} | {:>7} {:>7} {:>7} {:>5} {:>5} | {:>7} {:>7} {:>7} {:>5} {:>5}",
        "scene",
        "triangles",
        "blas ms",
        "tlas ms",
        "B/tri",
        "cpu",
        "sw",
        "rq",
        "sw/rq",
        "hit",
        "cpu",
        "sw",
        "rq",
        "sw/rq",
        "hit"
    );

    let mut files: Vec<PathBuf> = std::fs::read_dir(root.join("scenes"))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "gltf"))
        .collect();
    files.sort();
    let third_party = root.join("../shared/scenes/third-party");
    if third_party.is_dir() {
        files.push(third_party.join("cornell-box-vinc3r/cornellBox-2.80-Eevee-gltf.gltf"));
        for name in ["living-room", "staircase", "bathroom"] {
            files.push(third_party.join(format!("bitterli/{name}/{name}.glb")));
        }
    } else {
        println!(
            "skipping the third-party scenes: {} is absent",
            third_party.display()
        );
    }
    // `cargo bench ... -- WORD...` keeps the scenes whose name contains one of the words.
    let words: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    let wanted = |name: &str| words.is_empty() || words.iter().any(|w| name.contains(w.as_str()));
    for file in &files {
        let name = file.file_name().map_or_else(
            || file.display().to_string(),
            |n| n.to_string_lossy().into(),
        );
        if !wanted(&name) {
            continue;
        }
        match Scene::load(file) {
            Ok((scene, _)) => bench(&contexts, &name, &scene)?,
            Err(e) => println!("{name:<26} skipped: {e}"),
        }
    }
    // A word naming a scene file benches that file too (e.g. a `gi generate` scene).
    for path in words
        .iter()
        .map(std::path::Path::new)
        .filter(|p| p.is_file())
    {
        match Scene::load(path) {
            Ok((scene, _)) => bench(&contexts, &path.display().to_string(), &scene)?,
            Err(e) => println!("{} skipped: {e}", path.display()),
        }
    }
    if wanted("generated icospheres") {
        let generated = icospheres(GENERATED_INSTANCES, 2)?;
        assert!(generated.triangle_count() >= 250_000);
        bench(&contexts, "generated icospheres", &generated)?;
    }
    if !wanted("1M build") {
        return Ok(());
    }

    // Distinct meshes, so that the bottom levels are a million triangles' worth: the placed
    // icospheres baked into their own meshes.
    let placed = icospheres(BUILD_INSTANCES, 3)?;
    let meshes = placed
        .instances
        .iter()
        .map(|i| transformed(&placed.meshes[0], i.transform))
        .collect();
    let identity: Vec<(u32, Mat4)> = (0..BUILD_INSTANCES as u32)
        .map(|i| (i, Mat4::IDENTITY))
        .collect();
    let big = scene(meshes, &identity).ok_or(Error::InvalidArgument {
        name: "meshes",
        why: "no scene from the baked icospheres".into(),
    })?;
    let (blas_ms, tlas_ms, bvh) = build_ms(&big)?;
    let nodes: usize = big.blases.iter().map(|b| b.nodes.len()).sum();
    println!(
        "BVH build of {} triangles in {} meshes on {} threads: {blas_ms:.0} ms for the bottom \
         levels ({nodes} nodes, depth <= {}), {tlas_ms:.1} ms for the top level and the node buffer \
         ({} nodes)",
        big.triangle_count(),
        big.meshes.len(),
        rayon::current_num_threads(),
        big.blases
            .iter()
            .map(|b| b.stats.max_depth)
            .max()
            .unwrap_or(0),
        bvh.nodes.len()
    );
    Ok(())
}
