//! Response to a change of light (lag), `balanced`: the Cornell box's ceiling light switched off,
//! switched on and moved, with the world cache kept across the change
//! (`gi_host::bench::light_change`; `gi lag` prints the same figures for every preset).

use gi_host::KernelVariant;
use gi_host::bench::light_change::{Frames, LightChange, measure};
use gi_host::gbuffer::scene_camera;
use gi_host::gi::Preset;
use gi_tests::{context, finish_without_validation_messages, load_scene};

const WIDTH: u32 = 64;
const HEIGHT: u32 = 64;
const FRAMES: Frames = Frames {
    warm_up: 64,
    steady: 16,
    after: 16,
};
/// The frame after the change whose share of the change still missing is bounded.
const CHECKED_FRAME: u32 = 15;
/// Random streams the share is the mean of: one stream's figure is one noisy realisation (the
/// light switched on read 0.032 on stream 0 and 0.088 as the mean of four, same code).
const SEEDS: u32 = 2;

/// Asserts that the share of `change` still missing [`CHECKED_FRAME`] frames after it is below
/// `bound`.
fn assert_missing_below(change: LightChange, bound: f64) {
    let scene = load_scene("cornell-box.gltf");
    let ctx = context(KernelVariant::Software);
    let camera = scene_camera(&scene, WIDTH, HEIGHT);
    let settings = Preset::Balanced.settings(WIDTH, HEIGHT);
    let response = measure(&ctx, &scene, change, &camera, settings, FRAMES, SEEDS).unwrap();
    finish_without_validation_messages(ctx);
    let shares: Vec<String> = response
        .remaining
        .iter()
        .map(|r| format!("{r:.3}"))
        .collect();
    println!(
        "{}: share missing per frame {}",
        change.name(),
        shares.join(" ")
    );
    let missing = response.after(CHECKED_FRAME).unwrap();
    assert!(
        missing < bound,
        "{}: {missing:.3} of the change missing after {CHECKED_FRAME} frames",
        change.name()
    );
}

// Bounds: the share measured (in the comment) × about 1.3, so that a lag a third as long again
// fails. Lavapipe, software traversal; `gi lag` gives the figures at 128 × 72 in the README.

#[test]
fn a_light_switched_off_leaves_little_light_after_15_frames() {
    // Measured: 0.029, the mean of 2 streams, since round 22 (a sudden image trend lowers the
    // denoiser's floor of 16 frames toward 4); 0.043 from round 16 (emitter sampling and a
    // one-tile jitter in the presets) under a bound of 0.06; 0.044 before it (also with temporal
    // feedback, before round 14; stream 0 alone: 0.047 before the cache's fading history, 0.058
    // before issue 22's round 5, 0.069 before the cache's adaptive blend). The goal is
    // 0.05, met here and at 128 × 72 since round 22: README "Response to change".
    assert_missing_below(LightChange::Off, 0.04);
}

#[test]
fn a_light_switched_on_is_mostly_there_after_15_frames() {
    // Measured: 0.036, the mean of 2 streams, since round 16: the emitter's direct light, sampled
    // at the primary hit, arrives in the frame it is switched on. Before it 0.078 under a bound of
    // 0.10 (0.081 with temporal feedback, before round 14, whose bound of 0.05 held stream 0
    // alone, 0.032; stream 1 read 0.13). Stream 0 alone: 0.038 before the fading history, 0.084
    // before round 5, 0.098 before the adaptive blend.
    assert_missing_below(LightChange::On, 0.05);
}

#[test]
fn a_moved_light_is_mostly_followed_after_15_frames() {
    // Measured: 0.015, the mean of 2 streams, since round 16 (the emitter sampled at the primary
    // hit); before it 0.088 under a bound of 0.10 (0.112 with temporal feedback, before round 14).
    // Stream 0 alone: 0.093 (0.078 before the fading history, whose cells read their own recent samples
    // where they used to read coarser mips; 0.086 before round 5, 0.088 before the adaptive
    // blend; 0.061 with the
    // denoiser's linear weights alone: the probes' unbiased guided cells follow a moved light
    // with more noise, README "Response to change").
    assert_missing_below(LightChange::Move, 0.03);
}
