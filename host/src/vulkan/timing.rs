//! GPU timestamps around recorded work, so that every pass can report its cost in milliseconds.

use super::context::Context;
use crate::error::{Error, Result, VkContext};
use ash::vk;

/// A pool of timestamp pairs; each `begin`/`end` pair measures one labelled span.
pub struct GpuTimer {
    pool: vk::QueryPool,
    labels: Vec<String>,
    capacity: u32,
    period_ns: f64,
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

    /// Frees the query pool.
    pub fn destroy(self, ctx: &Context) {
        unsafe { ctx.device.destroy_query_pool(self.pool, None) };
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
    if let Some(t) = timer {
        t.destroy(ctx);
    }
    submitted.and_then(|r| r).map(|()| ms)
}
