//! The minimal integration: an engine that creates its own Vulkan instance, device, queue,
//! output image and command buffer, records our GI passes into that command buffer (G-buffer
//! traced by our pass), and writes the image as a PNG.
//!
//! `cargo run --profile dev --example minimal -- [scene.gltf] [out.png] [side] [frames]`
//! (defaults: `scenes/cornell-box.gltf`, `minimal.png`, 256, 32).

#[path = "common/integration.rs"]
mod integration;

use gi_host::TraceMode;
use gi_host::engine::Scene;
use gi_host::image_io::ToneMap;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let arg = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.to_owned());
    let default_scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.gltf");
    let scene_path = arg(0, default_scene);
    let out = arg(1, "minimal.png");
    let side: u32 = arg(2, "256").parse()?;
    let frames: u32 = arg(3, "32").parse()?;
    let validation = std::env::var_os("GI_VALIDATION").is_some();

    let (scene, _warnings) = Scene::load(&scene_path)?;
    let rendered = integration::render(&scene, (side, side), frames, TraceMode::Auto, validation)?;
    for message in &rendered.validation_messages {
        eprintln!("validation: {message}");
    }
    rendered.image.write_png(&out, &ToneMap::default())?;
    println!("{out}: {side}×{side}, {frames} frames of {scene_path}");
    Ok(())
}
