//! GPU timestamps around recorded work, so that every pass can report its cost in milliseconds:
//! [`GpuTimer`] measures labelled spans of one submission, [`FrameTimings`] collects them frame
//! after frame into a table per pass (this frame and the running average).

use super::context::{Context, SharedDevice};
use crate::error::{Error, Result, VkContext};
use ash::vk;
use std::fmt;
use std::sync::Arc;

/// A pool of timestamp pairs; each `begin`/`end` pair measures one labelled span. Freed when
/// dropped.
pub struct GpuTimer {
    pool: vk::QueryPool,
    labels: Vec<String>,
    capacity: u32,
    period_ns: f64,
    shared: Arc<SharedDevice>,
}

impl GpuTimer {
    /// A timer for at most `spans` spans per submission. Errors on devices whose compute queue
    /// has no timestamps.
    pub fn new(ctx: &Context, spans: u32) -> Result<Self> {
        let caps = ctx.capabilities();
        if !caps.compute_timestamps {
            return Err(Error::MissingFeature {
                device: caps.name.clone(),
                feature: "timestamp queries on the compute queue".into(),
                needed_for: "GPU timings".into(),
            });
        }
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(spans * 2);
        let pool = unsafe { ctx.device.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        Ok(Self {
            pool,
            labels: vec![],
            capacity: spans,
            period_ns: f64::from(caps.timestamp_period_ns),
            shared: ctx.shared.clone(),
        })
    }

    /// Resets the pool; record this before the first span of a submission.
    pub fn reset(&mut self, ctx: &Context, cmd: vk::CommandBuffer) {
        self.labels.clear();
        unsafe {
            ctx.device
                .cmd_reset_query_pool(cmd, self.pool, 0, self.capacity * 2)
        };
    }

    /// Opens a span named `label`.
    pub fn begin(&mut self, ctx: &Context, cmd: vk::CommandBuffer, label: &str) -> Result<()> {
        let i = self.labels.len() as u32;
        if i >= self.capacity {
            return Err(Error::InvalidArgument {
                name: "GpuTimer::begin",
                why: format!("more than {} spans in one submission", self.capacity),
            });
        }
        self.labels.push(label.to_string());
        unsafe {
            ctx.device.cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::TOP_OF_PIPE,
                self.pool,
                2 * i,
            )
        };
        Ok(())
    }

    /// Closes the span opened last.
    pub fn end(&self, ctx: &Context, cmd: vk::CommandBuffer) {
        let i = self.labels.len().saturating_sub(1) as u32;
        unsafe {
            ctx.device.cmd_write_timestamp(
                cmd,
                vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                self.pool,
                2 * i + 1,
            )
        };
    }

    /// After the submission finished: each span's label and duration in milliseconds.
    pub fn results(&self, ctx: &Context) -> Result<Vec<(String, f64)>> {
        let mut ticks = vec![0u64; self.labels.len() * 2];
        if ticks.is_empty() {
            return Ok(vec![]);
        }
        unsafe {
            ctx.device.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        Ok(self
            .labels
            .iter()
            .zip(ticks.as_chunks::<2>().0)
            .map(|(l, t)| {
                let ms = t[1].wrapping_sub(t[0]) as f64 * self.period_ns * 1e-6;
                (l.clone(), ms)
            })
            .collect())
    }
}

impl Drop for GpuTimer {
    fn drop(&mut self) {
        unsafe { self.shared.device.destroy_query_pool(self.pool, None) };
    }
}

/// One pass of [`FrameTimings`].
#[derive(Clone, Debug, PartialEq)]
pub struct PassTiming {
    /// The pass's name (the talk's: `PurgeRadianceCache`, `UpdateRadianceCache`, ...).
    pub name: String,
    /// Its time in the last frame, in milliseconds (0 when it did not run then).
    pub last_ms: f64,
    /// Its time summed over every frame that ran it.
    pub total_ms: f64,
    /// The frames that ran it.
    pub frames: u32,
}

impl PassTiming {
    /// Its average over the frames that ran it.
    pub fn average_ms(&self) -> f64 {
        if self.frames == 0 {
            0.0
        } else {
            self.total_ms / f64::from(self.frames)
        }
    }
}

/// GPU time per pass, frame after frame: the last frame's table and a running average per pass
/// name. Feed it [`GpuTimer::results`] once per frame; print it with `{}`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameTimings {
    passes: Vec<PassTiming>,
    frames: u32,
    last_total_ms: f64,
    total_ms: f64,
}

impl FrameTimings {
    /// No frames yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one frame's spans (label, milliseconds). A name seen twice in a frame counts once,
    /// with its times summed. Passes keep the order in which they were first seen.
    pub fn add_frame(&mut self, spans: &[(String, f64)]) {
        for p in &mut self.passes {
            p.last_ms = 0.0;
        }
        let mut ran = vec![false; self.passes.len()];
        for (name, ms) in spans {
            let i = match self.passes.iter().position(|p| &p.name == name) {
                Some(i) => i,
                None => {
                    self.passes.push(PassTiming {
                        name: name.clone(),
                        last_ms: 0.0,
                        total_ms: 0.0,
                        frames: 0,
                    });
                    ran.push(false);
                    self.passes.len() - 1
                }
            };
            let p = &mut self.passes[i];
            p.last_ms += ms;
            p.total_ms += ms;
            if !ran[i] {
                ran[i] = true;
                p.frames += 1;
            }
        }
        self.frames += 1;
        self.last_total_ms = spans.iter().map(|(_, ms)| ms).sum();
        self.total_ms += self.last_total_ms;
    }

    /// The frames added so far.
    pub fn frames(&self) -> u32 {
        self.frames
    }

    /// Every pass seen, in first-seen order.
    pub fn passes(&self) -> &[PassTiming] {
        &self.passes
    }

    /// The pass named `name`, if seen.
    pub fn pass(&self, name: &str) -> Option<&PassTiming> {
        self.passes.iter().find(|p| p.name == name)
    }

    /// The last frame's total, in milliseconds.
    pub fn last_total_ms(&self) -> f64 {
        self.last_total_ms
    }

    /// The average total per frame, in milliseconds.
    pub fn average_total_ms(&self) -> f64 {
        if self.frames == 0 {
            0.0
        } else {
            self.total_ms / f64::from(self.frames)
        }
    }
}

impl fmt::Display for FrameTimings {
    /// One line per pass (last frame's ms, average ms over the frames that ran it), then the
    /// total per frame.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let width = self
            .passes
            .iter()
            .map(|p| p.name.chars().count())
            .chain(["pass".len(), "total".len()])
            .max()
            .unwrap_or(0);
        writeln!(
            f,
            "{:<width$}  {:>10}  {:>10}",
            "pass",
            "last ms",
            format!("avg of {}", self.frames)
        )?;
        for p in &self.passes {
            writeln!(
                f,
                "{:<width$}  {:>10.3}  {:>10.3}",
                p.name,
                p.last_ms,
                p.average_ms()
            )?;
        }
        write!(
            f,
            "{:<width$}  {:>10.3}  {:>10.3}",
            "total",
            self.last_total_ms,
            self.average_total_ms()
        )
    }
}

/// Submits the commands `record` writes, followed by [`super::compute_barrier`], and waits.
/// Returns their GPU time in milliseconds when the device has compute timestamps.
pub fn submit_timed(
    ctx: &Context,
    label: &str,
    record: impl FnOnce(vk::CommandBuffer) -> Result<()>,
) -> Result<Option<f64>> {
    let mut timer = GpuTimer::new(ctx, 1).ok();
    let submitted = ctx.submit(|cmd| -> Result<()> {
        if let Some(t) = timer.as_mut() {
            t.reset(ctx, cmd);
            t.begin(ctx, cmd, label)?;
        }
        record(cmd)?;
        if let Some(t) = timer.as_ref() {
            t.end(ctx, cmd);
        }
        super::compute_barrier(ctx, cmd);
        Ok(())
    });
    let ms = match (&submitted, &timer) {
        (Ok(Ok(())), Some(t)) => t.results(ctx)?.first().map(|(_, ms)| *ms),
        _ => None,
    };
    submitted.and_then(|r| r).map(|()| ms)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(spans: &[(&str, f64)]) -> Vec<(String, f64)> {
        spans.iter().map(|(n, ms)| (n.to_string(), *ms)).collect()
    }

    #[test]
    fn passes_average_over_the_frames_that_ran_them() {
        let mut t = FrameTimings::new();
        t.add_frame(&frame(&[
            ("PurgeRadianceCache", 1.0),
            ("UpdateRadianceCache", 4.0),
        ]));
        t.add_frame(&frame(&[
            ("PurgeRadianceCache", 3.0),
            ("UpdateRadianceCache", 1.0),
            ("UpdateRadianceCache", 1.0),
            ("ResolveGI", 2.0),
        ]));
        assert_eq!(t.frames(), 2);
        let purge = t.pass("PurgeRadianceCache").unwrap();
        assert_eq!((purge.last_ms, purge.average_ms()), (3.0, 2.0));
        // Two spans of one name in a frame add up, and count as one frame.
        let update = t.pass("UpdateRadianceCache").unwrap();
        assert_eq!(
            (update.last_ms, update.frames, update.average_ms()),
            (2.0, 2, 3.0)
        );
        let resolve = t.pass("ResolveGI").unwrap();
        assert_eq!((resolve.frames, resolve.average_ms()), (1, 2.0));
        assert_eq!(t.last_total_ms(), 7.0);
        assert_eq!(t.average_total_ms(), 6.0);
        // A pass that skipped the last frame shows 0 there and keeps its average.
        t.add_frame(&frame(&[("PurgeRadianceCache", 2.0)]));
        let resolve = t.pass("ResolveGI").unwrap();
        assert_eq!((resolve.last_ms, resolve.average_ms()), (0.0, 2.0));
        assert_eq!(t.average_total_ms(), 14.0 / 3.0);
    }

    #[test]
    fn the_table_lists_passes_in_order_with_a_total() {
        let mut t = FrameTimings::new();
        t.add_frame(&frame(&[
            ("PurgeRadianceCache", 0.25),
            ("UpdateRadianceCache", 1.5),
        ]));
        t.add_frame(&frame(&[
            ("PurgeRadianceCache", 0.75),
            ("UpdateRadianceCache", 0.5),
        ]));
        let text = t.to_string();
        let rows: Vec<Vec<&str>> = text
            .lines()
            .map(|l| l.split_whitespace().collect())
            .collect();
        assert_eq!(
            rows,
            [
                vec!["pass", "last", "ms", "avg", "of", "2"],
                vec!["PurgeRadianceCache", "0.750", "0.500"],
                vec!["UpdateRadianceCache", "0.500", "1.000"],
                vec!["total", "1.250", "1.500"],
            ],
            "{text}"
        );
        let lines: Vec<&str> = text.lines().collect();
        assert!(
            lines
                .iter()
                .all(|l| l.chars().count() == lines[0].chars().count()),
            "{text}"
        );
        assert_eq!(
            FrameTimings::new().to_string().lines().count(),
            2,
            "an empty table has a header and a total"
        );
    }
}
