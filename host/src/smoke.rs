//! The smoke dispatch: proves the whole chain (SPIR-V from rust-gpu, pipeline, binding, dispatch,
//! read-back) on a device by hashing indices on the GPU and comparing with the CPU.

use crate::error::{Error, Result};
use crate::vulkan::{Buffer, Context, Kernel, KernelModule, submit_timed};
use gi_shared::abi::WORKGROUP_SIZE;

crate::bindings! {
    /// The smoke kernel's set 0 (`kernels::smoke::smoke`).
    pub(crate) struct Smoke<'a> {
        out: &'a Buffer,
    }
}

/// What a smoke dispatch did.
#[derive(Clone, Debug)]
pub struct SmokeReport {
    /// Invocations run.
    pub invocations: u32,
    /// Invocations whose output differed from the CPU.
    pub mismatches: u32,
    /// GPU time of the dispatch, when the device has timestamps.
    pub gpu_ms: Option<f64>,
}

/// Runs the `smoke` kernel over `invocations` indices and checks every result against the CPU.
pub fn run(ctx: &Context, invocations: u32) -> Result<SmokeReport> {
    if invocations == 0 {
        return Err(Error::InvalidArgument {
            name: "invocations",
            why: "must be at least 1".into(),
        });
    }
    let module = KernelModule::new(ctx)?;
    let kernel = Kernel::new::<Smoke>(ctx, &module, "smoke::smoke", 0)?;
    let out = Buffer::device_zeroed::<u32>(ctx, "smoke output", invocations as usize)?;
    let gpu_ms = submit_timed(ctx, "smoke", |cmd| {
        kernel.dispatch(
            ctx,
            cmd,
            &Smoke { out: &out },
            &[],
            [invocations.div_ceil(WORKGROUP_SIZE), 1, 1],
        )
    })?;
    let values = out.read_back::<u32>(ctx)?;
    let mismatches = values
        .iter()
        .enumerate()
        .filter(|(i, v)| **v != gi_shared::hash::pcg(*i as u32))
        .count() as u32;
    Ok(SmokeReport {
        invocations,
        mismatches,
        gpu_ms,
    })
}
