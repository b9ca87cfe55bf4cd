//! Host side of the `trace_rays` kernel: closest hits of a batch of rays, in either tracing
//! variant. Used to check the variants against each other and against the CPU, and to measure
//! their speed.

use crate::error::Result;
use crate::scene::upload::GpuScene;
use crate::vulkan::{Buffer, Context, Kernel, KernelModule, submit_timed};
use gi_shared::abi::WORKGROUP_SIZE;
use gi_shared::ray::{HitRecord, Ray};

crate::bindings! {
    /// TraceRays's set 0 (`kernels::trace_rays::trace_rays`).
    pub(crate) struct RaysAndHits<'a> {
        rays: &'a Buffer,
        hits: &'a Buffer,
    }
}

/// The `trace_rays::trace_rays` pipeline.
pub struct TraceRays {
    kernel: Kernel,
}

/// Hits of one batch and the GPU time the dispatch took (when the device has timestamps).
pub struct TraceResult {
    /// `hits[i]` is the closest hit of ray `i`.
    pub hits: Vec<HitRecord>,
    /// Milliseconds of GPU time.
    pub gpu_ms: Option<f64>,
}

impl TraceRays {
    /// Creates the pipeline.
    pub fn new(ctx: &Context) -> Result<Self> {
        let module = KernelModule::new(ctx)?;
        let kernel = Kernel::new::<RaysAndHits>(ctx, &module, "trace_rays::trace_rays", 0)?;
        Ok(Self { kernel })
    }

    /// Traces `rays` against `scene` (its geometry and, for the software traversal's triangles,
    /// its shading data).
    pub fn run(&self, ctx: &Context, scene: &GpuScene, rays: &[Ray]) -> Result<TraceResult> {
        let ray_buf = Buffer::device_local(ctx, "rays", rays, Default::default())?;
        let hit_buf = Buffer::device_zeroed::<HitRecord>(ctx, "hits", rays.len())?;
        let bindings = RaysAndHits {
            rays: &ray_buf,
            hits: &hit_buf,
        };
        let groups = (rays.len() as u32).div_ceil(WORKGROUP_SIZE);
        let gpu_ms = submit_timed(ctx, "trace_rays", |cmd| {
            self.kernel
                .dispatch_traced(ctx, cmd, scene.sets(), &bindings, &[], [groups, 1, 1])
        })?;
        let hits = hit_buf.read_back::<HitRecord>(ctx)?;
        Ok(TraceResult { hits, gpu_ms })
    }
}
