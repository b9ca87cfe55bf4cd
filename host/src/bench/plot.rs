//! The bench's plots, each as PNG and SVG: per scene, relMSE against GPU ms per frame (one point
//! per setting, presets labelled in bold, the static camera left and the orbit right); and the
//! four scaling sweeps (ms against pixels, triangles, lights, emissive triangles, total and tracing).
//!
//! Text is drawn with DejaVu Sans, embedded (the `dejavu` crate), so a machine without fonts
//! draws the same PNG.

use super::report::PointRecord;
use super::scaling::{Axis, ScalingPoint};
use super::sweep::Group;
use super::{BenchReport, Motion};
use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// Size of every plot in pixels (the SVG's too).
pub const PLOT_SIZE: (u32, u32) = (1400, 700);

const FONT: &str = "sans-serif";

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The embedded font is valid TrueType: registering it cannot fail.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
        let _ = plotters::style::register_font(FONT, FontStyle::Bold, dejavu::sans::bold());
    });
}

type Drawn = std::result::Result<(), String>;

/// A plot that draws on any backend.
trait Plot {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn;
}

struct ErrorPlot<'a> {
    title: String,
    points: Vec<&'a PointRecord>,
}

impl Plot for ErrorPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn {
        error_vs_ms(root, &self.title, &self.points)
    }
}

struct ScalingPlot<'a> {
    title: String,
    axis: Axis,
    points: Vec<&'a ScalingPoint>,
}

impl Plot for ScalingPlot<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Drawn {
        scaling(root, &self.title, self.axis, &self.points)
    }
}

/// Draws `plot` into `stem.png` and `stem.svg` in `dir`.
fn write_both(dir: &Path, stem: &str, plot: &impl Plot) -> Result<Vec<PathBuf>> {
    register_font();
    let (w, h) = PLOT_SIZE;
    let png = dir.join(format!("{stem}.png"));
    let svg = dir.join(format!("{stem}.svg"));
    let fail = |path: &Path, why: String| Error::Output {
        path: path.to_owned(),
        why,
    };
    let mut pixels = vec![0u8; w as usize * h as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (w, h)).into_drawing_area();
        plot.draw(&root).map_err(|e| fail(&png, e))?;
        root.present().map_err(|e| fail(&png, e.to_string()))?;
    }
    image::RgbImage::from_raw(w, h, pixels)
        .ok_or_else(|| fail(&png, "plot buffer of the wrong size".into()))?
        .save(&png)
        .map_err(|e| fail(&png, e.to_string()))?;
    {
        let root = SVGBackend::new(&svg, (w, h)).into_drawing_area();
        plot.draw(&root).map_err(|e| fail(&svg, e))?;
        root.present().map_err(|e| fail(&svg, e.to_string()))?;
    }
    Ok(vec![png, svg])
}

/// Writes every plot of `report` into `dir`; returns the files.
pub fn write_plots(report: &BenchReport, dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    let mut scenes: Vec<&str> = report.points.iter().map(|p| p.scene.as_str()).collect();
    scenes.dedup();
    for scene in scenes {
        let points: Vec<&PointRecord> = report.points.iter().filter(|p| p.scene == scene).collect();
        let title = format!(
            "{scene}: relMSE against GPU ms per frame ({}, {}x{})",
            report.device, report.width, report.height
        );
        files.extend(write_both(
            dir,
            &format!("error-vs-ms-{scene}"),
            &ErrorPlot { title, points },
        )?);
    }
    for axis in [Axis::Pixels, Axis::Triangles, Axis::Lights, Axis::Emitters] {
        let points: Vec<&ScalingPoint> = report.scaling.iter().filter(|p| p.axis == axis).collect();
        if points.is_empty() {
            continue;
        }
        let title = format!(
            "GPU ms per frame against {} ({})",
            axis.name(),
            report.device
        );
        files.extend(write_both(
            dir,
            &format!("scaling-{}", axis.name()),
            &ScalingPlot {
                title,
                axis,
                points,
            },
        )?);
    }
    Ok(files)
}

/// An axis label without binary-fraction noise (`0.7`, not `0.7000000000000001`).
fn tick(v: &f64) -> String {
    format!("{}", (v * 1e6).round() / 1e6)
}

fn colour(group: Group) -> RGBColor {
    match group {
        Group::Preset => RGBColor(200, 30, 30),
        Group::Knob => RGBColor(40, 90, 200),
        Group::Resolution => RGBColor(30, 150, 60),
        Group::Variant => RGBColor(140, 60, 170),
    }
}

/// `[lo, hi]` widened by a margin on a log scale (positive values only).
fn log_range(values: impl Iterator<Item = f64>) -> std::ops::Range<f64> {
    let (lo, hi) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::MAX, f64::MIN), |(lo, hi), v| (lo.min(v), hi.max(v)));
    if lo > hi {
        return 1e-3..1.0;
    }
    lo / 1.5..hi * 1.5
}

fn error_vs_ms<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    points: &[&PointRecord],
) -> Drawn {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let root = root.titled(title, (FONT, 22).into_font()).map_err(e)?;
    let panels = root.split_evenly((1, 2));
    let x = log_range(points.iter().map(|p| p.ms_mean));
    let y = log_range(points.iter().map(|p| p.relmse));
    for (panel, motion) in panels.iter().zip([Motion::Static, Motion::Orbit]) {
        let mine: Vec<&&PointRecord> = points.iter().filter(|p| p.motion == motion).collect();
        let mut chart = ChartBuilder::on(panel)
            .caption(
                match motion {
                    Motion::Static => "static camera (converged)",
                    Motion::Orbit => "orbiting camera (under motion)",
                },
                (FONT, 18),
            )
            .margin(15)
            .x_label_area_size(45)
            .y_label_area_size(70)
            .build_cartesian_2d(x.clone().log_scale(), y.clone().log_scale())
            .map_err(e)?;
        chart
            .configure_mesh()
            .x_desc("GPU ms per frame")
            .y_desc("relMSE against the path tracer")
            .x_label_formatter(&tick)
            .y_label_formatter(&tick)
            .label_style((FONT, 13))
            .draw()
            .map_err(e)?;
        chart
            .draw_series(mine.iter().map(|p| {
                let (size, style) = if p.group == Group::Preset {
                    (
                        7,
                        (FONT, 15, FontStyle::Bold)
                            .into_font()
                            .color(&colour(p.group)),
                    )
                } else {
                    (4, (FONT, 11).into_font().color(&BLACK))
                };
                EmptyElement::at((p.ms_mean, p.relmse))
                    + Circle::new((0, 0), size, colour(p.group).filled())
                    + Text::new(p.label.clone(), (size + 3, -6), style)
            }))
            .map_err(e)?;
    }
    Ok(())
}

fn scaling<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    axis: Axis,
    points: &[&ScalingPoint],
) -> Drawn {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(e)?;
    let x = log_range(points.iter().map(|p| p.x));
    let y = log_range(points.iter().flat_map(|p| [p.ms, p.tracing_ms]));
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 22))
        .margin(20)
        .x_label_area_size(50)
        .y_label_area_size(70)
        .build_cartesian_2d(x.log_scale(), y.log_scale())
        .map_err(e)?;
    chart
        .configure_mesh()
        .x_desc(match axis {
            Axis::Pixels => "pixels",
            Axis::Triangles => "triangles",
            Axis::Lights => "punctual lights",
            Axis::Emitters => "emissive triangles",
        })
        .y_desc("GPU ms per frame")
        .x_label_formatter(&tick)
        .y_label_formatter(&tick)
        .label_style((FONT, 14))
        .draw()
        .map_err(e)?;
    let series = [
        ("whole frame", RGBColor(200, 30, 30), false),
        ("tracing passes", RGBColor(40, 90, 200), true),
    ];
    for (name, c, tracing) in series {
        let value = move |p: &ScalingPoint| if tracing { p.tracing_ms } else { p.ms };
        chart
            .draw_series(LineSeries::new(
                points.iter().map(|p| (p.x, value(p))),
                c.stroke_width(2),
            ))
            .map_err(e)?
            .label(name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2)));
        chart
            .draw_series(
                points
                    .iter()
                    .map(|p| Circle::new((p.x, value(p)), 4, c.filled())),
            )
            .map_err(e)?;
    }
    chart
        .configure_series_labels()
        .label_font((FONT, 14))
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(e)?;
    Ok(())
}
