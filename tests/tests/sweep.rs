//! `gi sweep`'s tool works (a tiny sweep on lavapipe, not a timing): every point of every group
//! is measured on a static and an orbiting camera, the equal-time comparison and the scaling
//! sweeps run, and every output is written and readable.

use gi_host::bench::plot::PLOT_SIZE;
use gi_host::bench::scaling::{Axis, ScalingConfig};
use gi_host::bench::sweep::Group;
use gi_host::bench::{self, BenchConfig, BenchScene, Motion, Sweeps};
use gi_tests::{
    context, fastest_variant, finish_without_validation_messages, scene_path, variants,
};

#[test]
#[ignore = "long (a whole sweep, 60-80 s): scripts/long-tests.sh runs it, and .ci/run that"]
fn a_tiny_sweep_measures_every_point_and_writes_every_output() {
    // The fastest variant measures; the other, where the device has two, is the variant point.
    let variants = variants();
    let ctx = context(fastest_variant());
    let other = (variants.len() > 1).then(|| context(variants[0]));
    let out = std::env::temp_dir().join(format!("gi-sweep-test-{}", std::process::id()));
    let config = BenchConfig {
        scenes: vec![
            BenchScene::parse(scene_path("cornell-box.gltf").to_str().unwrap()),
            BenchScene::parse("absent/nothing.gltf"),
        ],
        width: 64,
        height: 36,
        frames: 4,
        motion_frames: 3,
        reference_spp: 8,
        sweeps: Sweeps::ALL,
        equal_time_max_spp: 4,
        scaling: Some(ScalingConfig {
            resolutions: vec![(32, 18), (64, 36)],
            sphere_levels: vec![0, 1],
            light_counts: vec![1, 20],
            emitter_counts: vec![2, 40],
            width: 32,
            height: 18,
            base_levels: 0,
            base_lights: 1,
            frames: 2,
        }),
        out: out.clone(),
    };
    let (report, files) = bench::run(&ctx, other.as_ref(), &config).unwrap();

    // Every point twice (static, orbit), each with sane figures.
    let points = bench::sweep::points(
        64,
        36,
        Sweeps::ALL,
        other.as_ref().map(|_| "software".into()),
    );
    assert_eq!(report.points.len(), 2 * points.len());
    for p in &report.points {
        assert!(p.ms_mean.is_finite() && p.ms_mean > 0.0, "{}", p.label);
        assert!(p.ms_p95 >= p.ms_mean * 0.5, "{}", p.label);
        assert!(p.relmse.is_finite() && p.relmse > 0.0, "{}", p.label);
        assert!((0.0..=1.0).contains(&p.flip), "{}", p.label);
        assert!(
            p.gi_mib > 0.0 && p.temporal_change.is_finite(),
            "{}",
            p.label
        );
        let frames = match p.motion {
            Motion::Static => 4,
            Motion::Orbit => 3,
        };
        assert_eq!(
            (p.frames, p.relmse_per_frame.len()),
            (frames, frames as usize)
        );
        assert!(p.passes.iter().any(|q| q.pass == "PopulateScreenProbes"));
    }
    let mib = |label: &str| {
        report
            .points
            .iter()
            .find(|p| p.label == label)
            .unwrap_or_else(|| panic!("no {label}"))
            .gi_mib
    };
    // Memory follows the cache's size; the variant point ran on the other context.
    assert!(mib("buckets=512") > mib("balanced"));
    assert!(mib("buckets=32") < mib("balanced"));
    assert_eq!(
        report
            .points
            .iter()
            .any(|p| p.group == Group::Variant && p.variant == "software"),
        other.is_some()
    );
    assert_eq!(report.skipped.len(), 1, "{:?}", report.skipped);

    let e = &report.equal_time[0];
    let spp: Vec<u32> = e.pt.iter().map(|s| s.spp).collect();
    assert_eq!(spp, [1, 2, 4]);
    assert!(e.pt_ms_per_spp > 0.0 && e.spp_per_gi_frame > 0.0);
    assert!(e.ratio_per_frame.is_finite() && e.ratio_per_frame > 0.0);
    assert!(e.goal_pt_relmse.is_none(), "64 spp not rendered");

    let axes = |a: Axis| report.scaling.iter().filter(|p| p.axis == a).count();
    assert_eq!(
        (
            axes(Axis::Pixels),
            axes(Axis::Triangles),
            axes(Axis::Lights),
            axes(Axis::Emitters)
        ),
        (2, 2, 2, 2)
    );
    let emitters: Vec<usize> = report
        .scaling
        .iter()
        .filter(|p| p.axis == Axis::Emitters)
        .map(|p| p.emitters)
        .collect();
    assert_eq!(emitters, [2, 40]);
    let tris: Vec<usize> = report
        .scaling
        .iter()
        .filter(|p| p.axis == Axis::Triangles)
        .map(|p| p.triangles)
        .collect();
    assert_eq!(tris, [12 + 16 * 20, 12 + 16 * 80]);

    // The files: CSV rows, JSON, tables, plots that decode at their size, references to reuse.
    let read = |name: &str| std::fs::read_to_string(out.join(name)).unwrap();
    assert_eq!(read("results.csv").lines().count(), 1 + report.points.len());
    let json: serde_json::Value = serde_json::from_str(&read("results.json")).unwrap();
    assert_eq!(
        json["points"].as_array().unwrap().len(),
        report.points.len()
    );
    assert!(read("table.md").contains("| cornell-box | **balanced** |"));
    assert!(read("equal-time.md").contains("| cornell-box |"));
    assert_eq!(
        read("scaling.csv").lines().count(),
        1 + report.scaling.len()
    );
    for stem in [
        "error-vs-ms-cornell-box",
        "scaling-pixels",
        "scaling-triangles",
        "scaling-lights",
        "scaling-emitters",
    ] {
        let png = image::open(out.join(format!("{stem}.png"))).unwrap();
        assert_eq!((png.width(), png.height()), PLOT_SIZE);
        assert!(read(&format!("{stem}.svg")).contains("<svg"));
        assert!(files.contains(&out.join(format!("{stem}.png"))));
    }
    assert_eq!(
        std::fs::read_dir(out.join("references")).unwrap().count(),
        2
    );
    // The results read back whole: the outputs can be written again without measuring.
    std::fs::remove_file(out.join("table.md")).unwrap();
    let (again, _) = bench::report::replot(&out).unwrap();
    assert_eq!(again.points.len(), report.points.len());
    assert_eq!(again.equal_time[0].pt.len(), 3);
    assert!(read("table.md").contains("| cornell-box | **balanced** |"));
    std::fs::remove_dir_all(&out).ok();
    if let Some(other) = other {
        finish_without_validation_messages(other);
    }
    finish_without_validation_messages(ctx);
}
