//! The path-traced references: one per scene and camera path, at the camera of the path's last
//! frame, kept in `OUT/references/` and reused by later runs with the same scene, camera path,
//! frame count, resolution and sample count.

use super::{BenchConfig, BenchScene, LoadedScene, Motion};
use crate::error::Result;
use crate::image_io::HdrImage;
use crate::path_tracer::{PathTracerPass, PathTracerSettings};
use std::path::PathBuf;

/// Seed of the references' random streams; the equal-time comparison's path tracer uses others.
pub const REFERENCE_SEED: u32 = 0x5eed;

/// Where the reference of `bench` seen along `motion` for `frames` frames is kept.
pub fn reference_path(
    config: &BenchConfig,
    bench: &BenchScene,
    motion: Motion,
    frames: u32,
) -> PathBuf {
    let last = match motion {
        Motion::Static => String::new(),
        Motion::Orbit => format!("-frame{}", frames - 1),
    };
    config.out.join("references").join(format!(
        "{}-{}{last}-{}x{}-{}spp-centre-filtered.exr",
        bench.name,
        motion.name(),
        config.width,
        config.height,
        config.reference_spp
    ))
}

/// The reference of `bench` along `motion` after `frames` frames: read from
/// [`reference_path`], else path traced and written there. Warns when it is black: the camera
/// path sees no light, and errors against it mean nothing.
pub fn reference(
    ctx: &crate::vulkan::Context,
    scene: &LoadedScene,
    bench: &BenchScene,
    motion: Motion,
    frames: u32,
    config: &BenchConfig,
) -> Result<HdrImage> {
    let path = reference_path(config, bench, motion, frames);
    let image = match HdrImage::read(&path) {
        Ok(image) if image.width() == config.width && image.height() == config.height => {
            println!("reference:          {} (reused)", path.display());
            image
        }
        _ => render(ctx, scene, motion, frames, config, &path)?,
    };
    if image.pixels().iter().all(|p| p.iter().all(|&c| c <= 0.0)) {
        println!(
            "warning:            {}: the reference is black (the camera sees no light)",
            path.display()
        );
    }
    Ok(image)
}

fn render(
    ctx: &crate::vulkan::Context,
    scene: &LoadedScene,
    motion: Motion,
    frames: u32,
    config: &BenchConfig,
    path: &std::path::Path,
) -> Result<HdrImage> {
    let camera = scene.camera_at(motion, frames - 1, config.width, config.height);
    // The GI frame's primary visibility (pixel centres): errors measure lighting, not edges.
    let settings = PathTracerSettings {
        samples: config.reference_spp,
        seed: REFERENCE_SEED,
        pixel_centre: true,
        ..PathTracerSettings::default()
    };
    let render =
        PathTracerPass::new(ctx)?.render(ctx, &scene.gpu, &camera, &settings, |_, _| {})?;
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|e| crate::error::Error::Output {
            path: dir.to_owned(),
            why: e.to_string(),
        })?;
    }
    render.image.write_exr(path)?;
    println!(
        "reference:          {} ({} spp, {:.1} s GPU)",
        path.display(),
        config.reference_spp,
        render.gpu_ms.unwrap_or(f64::NAN) / 1e3
    );
    Ok(render.image)
}
