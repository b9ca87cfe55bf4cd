//! `gi cache-view` end to end (small: lavapipe is slow): its output, files and tables, and its
//! refusals of bad settings, each naming the setting in one line.

use std::path::PathBuf;
use std::process::{Command, Output};

fn gi(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_gi"))
        .args(args)
        .env_remove("GI_DEVICE")
        .output()
        .expect("gi runs")
}

fn cornell_box() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes/cornell-box.gltf")
        .display()
        .to_string()
}

#[test]
fn cache_view_renders_and_reports() {
    let dir = std::env::temp_dir().join(format!("gi-cache-view-cli-{}", std::process::id()));
    let out = dir.join("view.exr");
    let views = dir.join("debug");
    let scene = cornell_box();
    let args = [
        "--validation",
        "cache-view",
        scene.as_str(),
        "--width",
        "32",
        "--height",
        "24",
        "--frames",
        "3",
        "--out",
        out.to_str().unwrap(),
        "--debug-views",
        views.to_str().unwrap(),
    ];
    let run = gi(&args);
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stdout}\n{stderr}");
    // One occupancy line per frame.
    for f in 0..3 {
        let line = stdout
            .lines()
            .find(|l| l.starts_with(&format!("frame {f:>5}:")))
            .unwrap_or_else(|| panic!("no line for frame {f}:\n{stdout}"));
        for field in ["live tiles", "inserted", "failed inserts", "evicted"] {
            assert!(line.contains(field), "{line}");
        }
    }
    // The timing table under the talk's pass names, and the memory table.
    for pass in [
        "PurgeRadianceCache",
        "GBuffer",
        "TraceCacheRays",
        "InsertRadianceCache",
        "UpdateLightGrid",
        "GenerateReservoirs",
        "PopulateRadianceCache",
        "UpdateRadianceCache",
        "ResolveRadianceCache",
        "CacheViewComposite",
    ] {
        assert!(stdout.contains(pass), "{pass} missing:\n{stdout}");
    }
    for resource in [
        "hash grid values",
        "hash grid accumulators",
        "cache queries",
    ] {
        assert!(stdout.contains(resource), "{resource} missing:\n{stdout}");
    }
    assert!(out.is_file() && out.with_extension("png").is_file());
    for view in [
        "cells_by_hash",
        "lod",
        "sample_count",
        "cached_radiance",
        "evicted",
    ] {
        let png = views.join(format!("{view}.png"));
        assert_eq!(image::image_dimensions(&png).unwrap(), (32, 24), "{view}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_settings_are_one_line_naming_the_setting() {
    let scene = cornell_box();
    for (extra, setting) in [
        (&["--buckets-log2", "0"][..], "buckets_log2"),
        (&["--buckets-log2", "40"][..], "buckets_log2"),
        (&["--width", "8000"][..], "resolution"),
        (&["--cell-size-pixels", "0"][..], "cell_size_pixels"),
        (&["--min-cell-size", "-1"][..], "min_cell_size"),
    ] {
        let mut args = vec!["cache-view", scene.as_str(), "--frames", "1"];
        args.extend_from_slice(extra);
        let run = gi(&args);
        assert!(!run.status.success(), "{extra:?} accepted");
        let stderr = String::from_utf8_lossy(&run.stderr);
        let lines: Vec<&str> = stderr.lines().collect();
        assert_eq!(lines.len(), 1, "{extra:?}:\n{stderr}");
        assert!(lines[0].starts_with("error: "), "{stderr}");
        assert!(lines[0].contains(setting), "{extra:?}: {stderr}");
    }
    // Zero frames never reach the device: the argument parser names the option.
    let run = gi(&["cache-view", scene.as_str(), "--frames", "0"]);
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("--frames"));
}
