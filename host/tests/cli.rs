//! The `gi` program's failure modes: each is one line on stderr and a non-zero exit, never a
//! panic or a backtrace.

use std::process::{Command, Output};

fn gi(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_gi"));
    cmd.args(args).env_remove("GI_DEVICE");
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("gi runs")
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
