//! The integration of `minimal`, small and checked, for CI: 64 × 64, 8 frames of the Cornell
//! box under the validation layer; fails on a validation message, a non-finite pixel or a black
//! image. The `engine_api` test runs the same code and compares its image with
//! `GiRenderer::render_frame`'s.
//!
//! `cargo run --profile dev --example headless`

#[path = "common/integration.rs"]
mod integration;

use gi_host::TraceMode;
use gi_host::engine::Scene;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.gltf");
    let (scene, _warnings) = Scene::load(path)?;
    let rendered = integration::render(&scene, (64, 64), 8, TraceMode::Auto, true)?;
    let pixels = rendered.image.pixels();
    let finite = pixels.iter().flatten().all(|c| c.is_finite());
    let mean =
        pixels.iter().flatten().map(|&c| f64::from(c)).sum::<f64>() / (pixels.len() * 3) as f64;
    println!(
        "64×64, 8 frames: mean {mean:.4}, finite {finite}, {} validation messages",
        rendered.validation_messages.len()
    );
    for message in &rendered.validation_messages {
        eprintln!("validation: {message}");
    }
    if !finite || mean <= 0.0 || !rendered.validation_messages.is_empty() {
        return Err("the headless frame failed its checks".into());
    }
    Ok(())
}
