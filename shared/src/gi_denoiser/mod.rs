//! The GI denoiser (GI-1.0 steps 23–25): the per-pixel irradiance of InterpolateScreenProbes
//! (`crate::screen_probes::interpolate`) accumulated over time and blurred where it has little
//! history.
//!
//! 1. **ReprojectGI** ([`reproject_gi`]): temporal accumulation with a history cap that shrinks
//!    when the lighting changes and toward the image border; writes the blur mask
//!    (`8 − history` pixels).
//! 2. **FilterBlurMask** ([`blur_mask`]): the blur mask dilated and budgeted per 8 × 8 workgroup
//!    into each pixel's blur radius.
//! 3. **FilterGI** ([`filter_gi`]) × 2: the separable bilateral blur over that radius, horizontal
//!    then vertical; its output is the irradiance ResolveGI (`crate::primary_lighting`) composes.
//!
//! It filters lighting only: irradiance, demodulated from the albedo, which ResolveGI multiplies
//! back in from the G-buffer per pixel. Texture detail so never passes through the blur.
//!
//! Every pass is per pixel, `threads(8, 8)`, dispatched `[ceil(W / 8), ceil(H / 8), 1]`, with
//! per-pixel buffers indexed `y × W + x`.

pub mod blur_mask;
pub mod filter_gi;
pub mod reproject_gi;
