//! GI-1.0's screen probes (`gi_shared::screen_probes`), one file per pass with the talk's name.
//! Only PopulateScreenProbes traces; the others are compiled in the software variant alone.

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
