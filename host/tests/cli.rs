//! The `gi` program's failure modes: each is one line on stderr and a non-zero exit, never a
//! panic or a backtrace.

use std::process::{Command, Output};

/// The repository's Cornell box.
const CORNELL_BOX: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.gltf");

fn gi(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gi"));
    cmd.args(args).env_remove("GI_DEVICE");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("gi runs")
}

/// The stdout of a run that must succeed (its stderr in the failure message).
fn succeeded(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn single_error_line(out: &Output) -> String {
    assert!(
        !out.status.success(),
        "expected failure, got {:?}",
        out.status
    );
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 1, "expected one line, got:\n{stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

#[test]
fn no_device_is_one_line_pointing_at_set_up() {
    let out = gi(&[], &[("VK_ICD_FILENAMES", "/nonexistent.json")]);
    let err = single_error_line(&out);
    assert!(err.contains("no Vulkan device"), "{err}");
    assert!(err.contains("scripts/setup.sh"), "{err}");
    assert!(err.contains("/nonexistent.json"), "{err}");
}

#[test]
fn no_loader_is_one_line_pointing_at_set_up() {
    let out = gi(&[], &[("GI_VULKAN_LOADER", "/nonexistent/libvulkan.so.1")]);
    let err = single_error_line(&out);
    assert!(err.contains("no Vulkan loader"), "{err}");
    assert!(err.contains("/nonexistent/libvulkan.so.1"), "{err}");
    assert!(err.contains("scripts/setup.sh"), "{err}");
}

#[test]
fn unknown_device_lists_the_devices_there_are() {
    let out = gi(&["--device", "no-such-gpu"], &[]);
    let err = single_error_line(&out);
    assert!(err.contains("no-such-gpu"), "{err}");
    assert!(err.contains("0: "), "{err}");
}

#[test]
fn help_explains_the_options() {
    let out = gi(&["--help"], &[]);
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    for option in [
        "--device",
        "--trace",
        "--validation",
        "ray-query",
        "software",
    ] {
        assert!(text.contains(option), "--help lacks {option}:\n{text}");
    }
}

#[test]
fn compare_reports_metrics_and_writes_a_heat_map() {
    use gi_host::image_io::HdrImage;
    let dir = std::env::temp_dir().join(format!("gi-cli-compare-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (a, b, heat) = (dir.join("a.exr"), dir.join("b.exr"), dir.join("heat.png"));
    let reference = HdrImage::from_pixels(4, 2, vec![[0.5; 3]; 8]).unwrap();
    let mut test = reference.clone();
    test.pixels_mut()[3] = [1.0, 0.0, 0.0];
    reference.write_exr(&a).unwrap();
    test.write_exr(&b).unwrap();
    let out = gi(
        &[
            "compare",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--heat-map",
            heat.to_str().unwrap(),
        ],
        &[],
    );
    succeeded(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("RMSE") && text.contains("FLIP"), "{text}");
    assert!(image::open(&heat).is_ok_and(|i| i.width() == 4 && i.height() == 2));

    let missing = dir.join("missing.exr");
    let out = gi(
        &["compare", a.to_str().unwrap(), missing.to_str().unwrap()],
        &[],
    );
    let err = single_error_line(&out);
    assert!(err.contains("missing.exr"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_writes_an_exr_and_a_png() {
    use gi_host::image_io::HdrImage;
    let dir = std::env::temp_dir().join(format!("gi-cli-render-{}", std::process::id()));
    let out_exr = dir.join("cornell.exr");
    let scene = CORNELL_BOX;
    let out = gi(
        &[
            "--validation",
            "render",
            scene,
            "--width",
            "16",
            "--height",
            "12",
            "--spp",
            "4",
            "--out",
            out_exr.to_str().unwrap(),
        ],
        &[],
    );
    succeeded(&out);
    let image = HdrImage::read(&out_exr).unwrap();
    assert_eq!((image.width(), image.height()), (16, 12));
    assert!(image.pixels().iter().flatten().any(|&c| c > 0.0));
    assert!(image::open(dir.join("cornell.png")).is_ok_and(|i| i.width() == 16));

    // An environment image (here a uniform one) lights what the open side of the scene sees.
    let env = dir.join("white.exr");
    HdrImage::from_pixels(8, 4, vec![[0.5; 3]; 32])
        .unwrap()
        .write_exr(&env)
        .unwrap();
    let lit = dir.join("lit.exr");
    let out = gi(
        &[
            "--validation",
            "render",
            scene,
            "--width",
            "8",
            "--height",
            "8",
            "--spp",
            "2",
            "--environment",
            env.to_str().unwrap(),
            "--camera-position",
            "0,1,10",
            "--camera-target",
            "0,1,0",
            "--fov",
            "60",
            "--out",
            lit.to_str().unwrap(),
        ],
        &[],
    );
    succeeded(&out);
    // The corners look past the box into the environment.
    assert_eq!(HdrImage::read(&lit).unwrap().pixel(0, 0), [0.5; 3]);
    let missing = dir.join("missing.hdr");
    let out = gi(
        &["render", scene, "--environment", missing.to_str().unwrap()],
        &[],
    );
    let err = single_error_line(&out);
    assert!(err.contains("missing.hdr"), "{err}");
    std::fs::remove_dir_all(&dir).ok();

    // Argument errors are clap's (an error line and a pointer to --help).
    let out = gi(&["render", scene, "--sky", "1,2"], &[]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.starts_with("error: ") && err.contains("r,g,b"), "{err}");
}

#[test]
fn presets_choose_the_renderer_and_its_settings() {
    let dir = std::env::temp_dir().join(format!("gi-cli-preset-{}", std::process::id()));
    let scene = CORNELL_BOX;
    let run = |preset: &str| {
        let out_exr = dir.join(format!("{preset}.exr"));
        let out = gi(
            &[
                "--validation",
                "render",
                scene,
                "--width",
                "16",
                "--height",
                "16",
                "--spp",
                "2",
                "--frames",
                "2",
                "--preset",
                preset,
                "--out",
                out_exr.to_str().unwrap(),
            ],
            &[],
        );
        succeeded(&out)
    };
    let fast = run("fast");
    assert!(
        fast.contains("spawn tile 32 px, cache cells 64 px"),
        "{fast}"
    );
    let quality = run("quality");
    assert!(quality.contains("spawn tile 8 px"), "{quality}");
    assert!(quality.contains("probe filter off"), "{quality}");
    let reference = run("reference");
    assert!(!reference.contains("spawn tile"), "{reference}");
    assert!(reference.contains("2 spp"), "{reference}");
    // A preset and a method are one choice, made once.
    let both = gi(
        &["render", scene, "--preset", "fast", "--method", "gi"],
        &[],
    );
    assert!(!both.status.success());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn render_takes_the_cache_cell_size_and_names_an_absurd_one() {
    let dir = std::env::temp_dir().join(format!("gi-cli-cells-{}", std::process::id()));
    let out_exr = dir.join("cells.exr");
    let fine = succeeded(&render_two_small_frames(
        &out_exr,
        &["--cell-size-pixels", "8"],
    ));
    assert!(fine.contains("cache cells 8 px"), "{fine}");
    let err = single_error_line(&render_two_small_frames(
        &out_exr,
        &["--cell-size-pixels", "0"],
    ));
    assert!(err.contains("cell_size_pixels"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// `--cache-tiles` sizes the world cache (the memory table's hash grid values: 85 cells of 8
/// bytes per tile) and names a count that is not a power of two in range.
#[test]
fn render_takes_the_cache_size_and_names_an_absurd_one() {
    let dir = std::env::temp_dir().join(format!("gi-cli-tiles-{}", std::process::id()));
    let out_exr = dir.join("tiles.exr");
    let sized = succeeded(&render_two_small_frames(
        &out_exr,
        &["--cache-tiles", "4096"],
    ));
    assert!(sized.contains("cache tiles 4096,"), "{sized}");
    let values = sized
        .lines()
        .find(|l| l.starts_with("hash grid values "))
        .and_then(|l| l.split_whitespace().nth(4))
        .and_then(|b| b.parse::<u64>().ok());
    assert_eq!(values, Some(4096 * 85 * 8), "{sized}");
    for absurd in ["100", "16", "131072", "0", "many"] {
        // The argument parser's own message: the error line, then a pointer to `--help`.
        let out = render_two_small_frames(&out_exr, &["--cache-tiles", absurd]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{absurd}: accepted");
        let first = err.lines().next().unwrap_or_default();
        assert!(
            first.starts_with("error: ") && first.contains("--cache-tiles"),
            "{absurd}: {err}"
        );
        assert!(!err.contains("panicked"), "{absurd}: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `gi render` of two 16 × 16 `balanced` frames of the Cornell box into `out`, with the
/// validation layer on and `extra` arguments.
fn render_two_small_frames(out: &std::path::Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "--validation",
        "render",
        CORNELL_BOX,
        "--width",
        "16",
        "--height",
        "16",
        "--frames",
        "2",
        "--preset",
        "balanced",
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    gi(&args, &[])
}

/// The presets leave temporal feedback off (README, "Round 14"); `--feedback` turns it on, and
/// then the second frame's secondary hits take the first frame's screen radiance.
#[test]
fn render_leaves_feedback_off_unless_asked() {
    let dir = std::env::temp_dir().join(format!("gi-cli-feedback-{}", std::process::id()));
    let out_exr = dir.join("feedback.exr");
    let run = |extra: &[&str]| succeeded(&render_two_small_frames(&out_exr, extra));
    let fed_back = |out: &str| -> u32 {
        let line = out
            .lines()
            .find(|l| l.starts_with("frame     1:"))
            .unwrap_or_else(|| panic!("no line for frame 1: {out}"));
        line.rsplit("fed back")
            .next()
            .and_then(|n| n.trim().parse().ok())
            .unwrap_or_else(|| panic!("no fed-back count: {line}"))
    };
    let off = run(&[]);
    assert!(off.contains("feedback off"), "{off}");
    assert_eq!(fed_back(&off), 0, "{off}");
    let on = run(&["--feedback"]);
    assert!(on.contains("feedback on"), "{on}");
    assert!(fed_back(&on) > 0, "{on}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn generate_writes_a_scene_that_renders() {
    use gi_host::image_io::HdrImage;
    let dir = std::env::temp_dir().join(format!("gi-cli-generate-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let glb = dir.join("synthetic.glb");
    let out = gi(
        &[
            "generate",
            "--triangles",
            "10k",
            "--unique-meshes",
            "3",
            "--out",
            glb.to_str().unwrap(),
        ],
        &[],
    );
    let stdout = succeeded(&out);
    assert!(stdout.contains("world triangles"), "{stdout}");
    let exr = dir.join("synthetic.exr");
    let out = gi(
        &[
            "--validation",
            "render",
            glb.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "9",
            "--spp",
            "2",
            "--out",
            exr.to_str().unwrap(),
        ],
        &[],
    );
    let stdout = succeeded(&out);
    assert!(stdout.contains("2 emissive triangles"), "{stdout}");
    // The camera sees the lit room: most pixels receive light.
    let image = HdrImage::read(&exr).unwrap();
    let lit = image
        .pixels()
        .iter()
        .filter(|p| p.iter().any(|&c| c > 0.0))
        .count();
    assert!(lit > 16 * 9 / 2, "{lit} of 144 pixels lit");
    std::fs::remove_dir_all(&dir).ok();

    let out = gi(&["generate", "--triangles", "0", "--out", "x.glb"], &[]);
    let err = single_error_line(&out);
    assert!(
        err.contains("triangles") && err.contains("1000 to"),
        "{err}"
    );
    let out = gi(&["generate", "--triangles", "ten", "--out", "x.glb"], &[]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("is not a count"), "{err}");
}

/// `gi memory` prints a row per preset and resolution whose bytes per pixel and totals add up,
/// names a malformed resolution, and a larger frame takes more memory.
#[test]
fn memory_reports_each_preset_and_resolution() {
    let out = succeeded(&gi(
        &[
            "--validation",
            "memory",
            CORNELL_BOX,
            "--preset",
            "fast,quality",
            "--resolution",
            "64x64,128x64",
        ],
        &[],
    ));
    let rows: Vec<Vec<f64>> = out
        .lines()
        .filter(|l| l.starts_with("| Fast") || l.starts_with("| Quality"))
        .map(|l| {
            l.split('|')
                .skip(3)
                .filter_map(|c| c.trim().parse().ok())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 4, "{out}");
    for r in &rows {
        let [per_pixel, tiles, cache, total] = r[..] else {
            panic!("{out}")
        };
        assert!(
            per_pixel > 100.0 && tiles >= 2048.0 && cache > 0.0 && total > cache,
            "{out}"
        );
    }
    // 128 × 64 has twice the pixels of 64 × 64; `quality` traces four times the rays of `fast`.
    assert!(rows[1][3] > rows[0][3] && rows[2][0] > rows[0][0], "{out}");
    let bad = gi(&["memory", CORNELL_BOX, "--resolution", "64by64"], &[]);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("64by64") && err.contains("WIDTHxHEIGHT"),
        "{err}"
    );
}
