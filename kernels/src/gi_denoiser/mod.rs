//! The GI denoiser (`gi_shared::gi_denoiser`): ReprojectGI, FilterBlurMask, FilterGI.

pub mod blur_mask;
pub mod filter_gi;
pub mod reproject_gi;
