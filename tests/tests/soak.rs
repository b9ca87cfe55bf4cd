//! The soak of `gi soak` (issue 13), short: 200 frames at 32×32 of the moving box with the
//! camera, a point light and the box moving, validation (with synchronization checks) on. Every
//! check of the long run must hold: no NaN or infinity in any float buffer of the frame (counted
//! on the GPU every 25 frames), host and device memory flat after the warm-up, cache occupancy
//! bounded, frame time steady, zero validation messages.

use gi_host::KernelVariant;
use gi_host::scene::Scene;
use gi_host::soak::{self, SoakLimits, SoakSettings};
use gi_tests::{context, finish_without_validation_messages, scene_path};

#[test]
fn two_hundred_moving_frames_stay_clean_and_flat() {
    let scene = Scene::load(scene_path("moving-box.gltf")).unwrap().0;
    let settings = SoakSettings {
        frames: 200,
        check_every: 25,
        period: 50,
        width: 32,
        height: 32,
        limits: SoakLimits {
            // 50-frame windows on a CI machine: a few slow frames move the mean by more than in
            // the long run's 500-frame windows.
            frame_time_drift: 0.5,
            ..SoakLimits::default()
        },
        ..SoakSettings::default()
    };
    let ctx = context(KernelVariant::Software);
    let report = soak::run(&ctx, scene, &settings, |_| {}).unwrap();
    print!("{report}");
    let verdicts = report.verdicts(&settings.limits);
    let failed: Vec<_> = verdicts.iter().filter(|v| !v.passed).collect();
    assert!(failed.is_empty(), "{failed:#?}");
    // The checks saw what they claim: 8 checks of every float buffer, a cache in use.
    assert_eq!(report.samples.len(), 8);
    assert!(
        report.samples[0].words_checked > 10_000,
        "{:?}",
        report.samples[0]
    );
    assert!(report.samples.iter().all(|s| s.host_bytes.is_some()));
    let (first, last) = report.occupancy_windows();
    assert!(first > 0 && last > 0, "occupancy {first}, {last}");
    finish_without_validation_messages(ctx);
}
