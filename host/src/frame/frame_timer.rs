//! A frame recorded, submitted and timed: the GI frame and the cache view share it.

use super::{BarrierCounts, PassUses, Recorder};
use crate::error::Result;
use crate::vulkan::{Context, FrameTimings, GpuTimer};

/// Records frames through a [`Recorder`], submits each and waits, and keeps the running table of
/// their passes' GPU times (and, when asked, what each pass read and wrote).
#[derive(Default)]
pub struct FrameTimer {
    timer: Option<GpuTimer>,
    timings: FrameTimings,
    log: bool,
    uses: Vec<PassUses>,
    barriers: BarrierCounts,
}

impl FrameTimer {
    /// Room for `passes` timed passes a frame; frames go untimed on a device without timestamps.
    pub fn new(ctx: &Context, passes: u32) -> Self {
        Self {
            timer: GpuTimer::new(ctx, passes).ok(),
            ..Self::default()
        }
    }

    /// GPU time per pass, per frame and averaged.
    pub fn timings(&self) -> &FrameTimings {
        &self.timings
    }

    /// Keeps, from the next frame on, what each pass read and wrote ([`Self::pass_uses`]).
    pub fn log_passes(&mut self, on: bool) {
        self.log = on;
    }

    /// What each pass of the last frame read and wrote (empty unless [`Self::log_passes`]).
    pub fn pass_uses(&self) -> &[PassUses] {
        &self.uses
    }

    /// The barriers the recorder placed in the last frame.
    pub fn barrier_counts(&self) -> BarrierCounts {
        self.barriers
    }

    /// Records `body` into a command buffer of the context through a recorder (opened with
    /// [`Recorder::begin`], closed with [`Recorder::finish`]), submits it, waits, and adds the
    /// frame's pass times to the table.
    pub fn submit(
        &mut self,
        ctx: &Context,
        body: impl FnOnce(&mut Recorder<'_>) -> Result<()>,
    ) -> Result<()> {
        let log = self.log;
        let mut timer = self.timer.take();
        let recorded = ctx.submit(|cmd| {
            let mut rec = Recorder::new(ctx, cmd, timer.as_mut());
            if log {
                rec = rec.log();
            }
            rec.begin();
            body(&mut rec)?;
            let uses = rec.uses().to_vec();
            Ok::<_, crate::Error>((uses, rec.finish()))
        });
        let spans = match (&recorded, &timer) {
            (Ok(Ok(_)), Some(t)) => Some(t.results(ctx)),
            _ => None,
        };
        self.timer = timer;
        (self.uses, self.barriers) = recorded??;
        if let Some(spans) = spans {
            self.timings.add_frame(&spans?);
        }
        Ok(())
    }
}
