//! The bench's outputs: `results.csv` (one row per point, scene and camera path),
//! `results.json` (everything, per-pass times and convergence curves included), `table.md` (one
//! row per point and scene: static and orbit side by side), `equal-time.md`, `scaling.csv`, and
//! the plots ([`super::plot`]).

use super::measure::{PassMs, RunResult};
use super::sweep::{Group, SweepPoint};
use super::{BenchReport, Motion};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// One point of one scene along one camera path.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PointRecord {
    /// The scene.
    pub scene: String,
    /// Its triangles.
    pub triangles: usize,
    /// What the point varies.
    pub group: Group,
    /// `fast`, `spawn_rate=1/16`, ...
    pub label: String,
    /// The knob.
    pub knob: String,
    /// Its value.
    pub value: String,
    /// Rendered width.
    pub width: u32,
    /// Rendered height.
    pub height: u32,
    /// The tracing variant.
    pub variant: String,
    /// The camera path.
    pub motion: Motion,
    /// Frames rendered.
    pub frames: u32,
    /// GPU ms per frame, mean.
    pub ms_mean: f64,
    /// GPU ms per frame, 95th percentile.
    pub ms_p95: f64,
    /// The GI frame's device memory in MiB.
    pub gi_mib: f64,
    /// relMSE against the reference.
    pub relmse: f64,
    /// LDR-FLIP against the reference.
    pub flip: f64,
    /// Mean over the reference's, minus one.
    pub mean_bias: f64,
    /// Frame-to-frame change.
    pub temporal_change: f64,
    /// GPU ms per pass.
    pub passes: Vec<PassMs>,
    /// relMSE after each frame.
    pub relmse_per_frame: Vec<f64>,
}

impl PointRecord {
    /// The record of `result`.
    pub fn new(
        scene: &str,
        triangles: usize,
        point: &SweepPoint,
        variant: String,
        motion: Motion,
        frames: u32,
        result: RunResult,
    ) -> Self {
        Self {
            scene: scene.to_owned(),
            triangles,
            group: point.group,
            label: point.label(),
            knob: point.knob.to_owned(),
            value: point.value.clone(),
            width: point.width,
            height: point.height,
            variant,
            motion,
            frames,
            ms_mean: result.ms_mean,
            ms_p95: result.ms_p95,
            gi_mib: result.gi_bytes as f64 / f64::from(1 << 20),
            relmse: result.relmse,
            flip: result.flip,
            mean_bias: result.mean_bias,
            temporal_change: result.temporal_change,
            passes: result.passes,
            relmse_per_frame: result.relmse_per_frame,
        }
    }
}

/// A CSV row: the record without its lists.
#[derive(Serialize)]
struct CsvRow<'a> {
    scene: &'a str,
    triangles: usize,
    group: Group,
    label: &'a str,
    width: u32,
    height: u32,
    variant: &'a str,
    motion: Motion,
    frames: u32,
    ms_mean: f64,
    ms_p95: f64,
    gi_mib: f64,
    relmse: f64,
    flip: f64,
    mean_bias: f64,
    temporal_change: f64,
}

fn output_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Output {
        path: path.to_owned(),
        why: e.to_string(),
    }
}

/// Writes `text` to `path`.
pub(crate) fn write_text(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|e| output_error(path, e))
}

fn write_csv<T: Serialize>(path: &Path, rows: impl IntoIterator<Item = T>) -> Result<()> {
    let mut w = csv::Writer::from_path(path).map_err(|e| output_error(path, e))?;
    for row in rows {
        w.serialize(row).map_err(|e| output_error(path, e))?;
    }
    w.flush().map_err(|e| output_error(path, e))
}

/// Writes every output of `report` into `dir`; returns the files written.
pub fn write_all(report: &BenchReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let csv_path = dir.join("results.csv");
    write_csv(
        &csv_path,
        report.points.iter().map(|p| CsvRow {
            scene: &p.scene,
            triangles: p.triangles,
            group: p.group,
            label: &p.label,
            width: p.width,
            height: p.height,
            variant: &p.variant,
            motion: p.motion,
            frames: p.frames,
            ms_mean: p.ms_mean,
            ms_p95: p.ms_p95,
            gi_mib: p.gi_mib,
            relmse: p.relmse,
            flip: p.flip,
            mean_bias: p.mean_bias,
            temporal_change: p.temporal_change,
        }),
    )?;
    files.push(csv_path);
    let json_path = dir.join("results.json");
    let json = serde_json::to_string_pretty(report).map_err(|e| output_error(&json_path, e))?;
    write_text(&json_path, &json)?;
    files.push(json_path);
    let table_path = dir.join("table.md");
    write_text(&table_path, &markdown_table(report))?;
    files.push(table_path);
    if !report.equal_time.is_empty() {
        let path = dir.join("equal-time.md");
        write_text(&path, &equal_time_table(report))?;
        files.push(path);
    }
    if !report.scaling.is_empty() {
        let path = dir.join("scaling.csv");
        write_csv(&path, &report.scaling)?;
        files.push(path);
    }
    files.extend(super::plot::write_plots(report, dir)?);
    Ok(files)
}

/// Reads `dir/results.json` (written by [`write_all`]) and writes every output again from it:
/// new tables and plots without measuring again.
pub fn replot(dir: &Path) -> Result<(BenchReport, Vec<PathBuf>)> {
    let path = dir.join("results.json");
    let text = std::fs::read_to_string(&path).map_err(|e| output_error(&path, e))?;
    let report: BenchReport = serde_json::from_str(&text)
        .map_err(|e| output_error(&path, format!("not a sweep's results: {e}")))?;
    let files = write_all(&report, dir)?;
    Ok((report, files))
}

/// One row per scene and point: cost, then the error static and under motion.
pub fn markdown_table(report: &BenchReport) -> String {
    let mut s = format!(
        "{} ({}, {}), {}x{}\n\n| scene | setting | ms/frame | p95 ms | GI MiB | relMSE | FLIP | mean | change | relMSE moving | FLIP moving | change moving |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
        report.device, report.driver, report.variant, report.width, report.height
    );
    for p in report.points.iter().filter(|p| p.motion == Motion::Static) {
        let moving = report
            .points
            .iter()
            .find(|m| m.motion == Motion::Orbit && m.scene == p.scene && m.label == p.label);
        let label = if p.group == Group::Preset {
            format!("**{}**", p.label)
        } else {
            p.label.clone()
        };
        let _ = write!(
            s,
            "| {} | {label} | {:.2} | {:.2} | {:.1} | {:.4} | {:.3} | {:+.1}% | {:.4} |",
            p.scene,
            p.ms_mean,
            p.ms_p95,
            p.gi_mib,
            p.relmse,
            p.flip,
            100.0 * p.mean_bias,
            p.temporal_change
        );
        let _ = match moving {
            Some(m) => writeln!(
                s,
                " {:.4} | {:.3} | {:.4} |",
                m.relmse, m.flip, m.temporal_change
            ),
            None => writeln!(s, " - | - | - |"),
        };
    }
    s
}

/// The equal-time comparison per scene.
pub fn equal_time_table(report: &BenchReport) -> String {
    let mut s = String::from(
        "| scene | GI ms/frame | PT ms/spp | PT spp in one GI frame | their relMSE | GI relMSE after N frames | PT spp for it | PT ms for it | ÷ one GI frame | ÷ GI's N frames | 64 spp relMSE | GI frames to it | speed-up (goal 20) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for e in &report.equal_time {
        let opt = |v: Option<f64>, digits: usize| {
            v.map_or_else(|| "-".to_owned(), |v| format!("{v:.digits$}"))
        };
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.2} | {:.2} | {:.4} | {:.4} (N = {}) | {:.1}{} | {:.0} | {:.1} | {:.2} | {} | {} | {} |",
            e.scene,
            e.gi_ms,
            e.pt_ms_per_spp,
            e.spp_per_gi_frame,
            e.pt_relmse_at_gi_frame_time,
            e.gi_relmse,
            e.gi_frames,
            e.pt_spp_for_gi_error,
            if e.extrapolated { " (extrap.)" } else { "" },
            e.pt_ms_for_gi_error,
            e.ratio_per_frame,
            e.ratio_whole_run,
            opt(e.goal_pt_relmse, 4),
            e.goal_gi_frames
                .map_or_else(|| format!("> {}", e.gi_frames), |f| f.to_string()),
            opt(e.goal_speedup, 1),
        );
    }
    s
}
