//! The frame machinery of GI-1.0's passes, which are all "append, scan, dispatch what exists":
//! append lists fill counters on the GPU (`gi_shared::append_list` over the kernels' device
//! atomics), [`Scan`] turns counts into offsets and a total, and [`DispatchFromCounter`] turns a
//! counter into an indirect dispatch, so the host never reads a count back.
//! [`crate::vulkan::FrameTimings`] and [`MemoryTable`] report what each pass costs in time and
//! memory.
//!
//! A pass over a GPU-built list, step by step:
//!
//! 1. **Append.** The producing kernel wraps its counter buffer in `DeviceWords` (kernels'
//!    `atomics`) and calls `gi_shared::append_list::append(&mut counters, i, capacity)`; `Some(slot)`
//!    is where its item goes. Clear the counters with [`Recorder::fill`] at the start of the
//!    frame; the [`Recorder`] orders the producer after the fill and its readers after it.
//! 2. **Scan** (when items fan out into variable-sized ranges): [`Scan::record`] turns per-item
//!    counts into offsets in place and writes their total into a counter word, which step 3
//!    reads like any other counter.
//! 3. **Dispatch what exists.** [`DispatchFromCounter::record`] writes the
//!    `DispatchIndirect` for `min(counter, capacity)` items into an [`indirect_args`] buffer and
//!    [`Recorder::dispatch_indirect`]`(.., &args, indirect_offset(index))` then runs
//!    one invocation per item, rounded up to a workgroup. The consumer clamps the counter with
//!    `gi_shared::append_list::clamped_count` and returns for invocations past it.
//!
//! `tests/tests/frame_machinery.rs` does all of it in one submission.
//!
//! [`FiniteCheck`] counts the NaN and infinite floats of any buffers on the GPU (which words are
//! floats: [`FloatWords`]), so a test can check a frame's buffers without reading them back.

mod finite_check;
mod frame_timer;
mod indirect;
mod memory_table;
mod recorder;
mod scan;

pub use finite_check::{FiniteCheck, FloatWords};
pub use frame_timer::FrameTimer;
pub use indirect::{DispatchFromCounter, indirect_args, indirect_offset};
pub use memory_table::{MemoryRow, MemoryTable};
pub use recorder::{BETWEEN_PASSES, BarrierCounts, PassUses, Recorder, pass_table};
pub use scan::Scan;
