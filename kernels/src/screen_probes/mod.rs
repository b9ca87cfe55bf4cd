//! GI-1.0's screen probes (`gi_shared::screen_probes`), one file per pass with the talk's name.
//! Only PopulateScreenProbes traces; the others are compiled in the software variant alone.

#[cfg(not(feature = "ray-query"))]
use gi_shared::screen_probes::{GiFrameParams, PROBE_SIZE, ProbeRecord};
#[cfg(not(feature = "ray-query"))]
use spirv_std::{glam::UVec3, spirv};

#[cfg(not(feature = "ray-query"))]
pub mod blend;
#[cfg(not(feature = "ray-query"))]
pub mod filter;
#[cfg(not(feature = "ray-query"))]
pub mod interpolate;
#[cfg(not(feature = "ray-query"))]
pub mod patch;
pub mod populate;
#[cfg(not(feature = "ray-query"))]
pub mod probe_mask;
#[cfg(not(feature = "ray-query"))]
pub mod project;
#[cfg(not(feature = "ray-query"))]
pub mod reproject;
#[cfg(not(feature = "ray-query"))]
pub mod sample;
#[cfg(not(feature = "ray-query"))]
pub mod spawn;

/// ProbeAgeView, a debug view: pixel `id.xy` in the colour of its tile's probe age
/// (`ProbeRecord::age_colour`). Set 0: frame (`GiFrameParams`), records (`ProbeRecord`), colours
/// (`[f32; 4]` per pixel). Workgroups of 8 × 8 pixels.
#[cfg(not(feature = "ray-query"))]
#[spirv(compute(threads(8, 8)))]
pub fn probe_age_view(
    #[spirv(global_invocation_id)] id: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] frame: &GiFrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] records: &[ProbeRecord],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] colours: &mut [[f32; 4]],
) {
    let [w, h] = frame.image_size;
    if id.x >= w || id.y >= h {
        return;
    }
    let tile = (id.y / PROBE_SIZE) * frame.probe_grid[0] + id.x / PROBE_SIZE;
    let (pixel, tile) = ((id.y * w + id.x) as usize, tile as usize);
    if pixel < colours.len() && tile < records.len() {
        colours[pixel] = records[tile].age_colour().extend(1.0).to_array();
    }
}
