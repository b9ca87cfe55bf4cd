//! What the GI passes take besides their resources, shared by every pass and both frames: the
//! push constants' size ([`PUSH_BYTES`]), the pixel passes' workgroups (`pixel_groups`), the
//! view's options ([`ViewOptions`]), the scene's lights as the cache's lighting sees them
//! ([`SceneLighting`], with [`environment_irradiance`]) and the camera's check against the frame
//! ([`check_image_size`]).

use crate::error::{Error, Result};
use crate::gbuffer::GBufferImages;
use crate::scene::lights::LightSet;
use crate::vulkan::Buffer;
use gi_shared::camera::CameraParams;
use gi_shared::color::luminance;
use gi_shared::scene_data::NONE;
use gi_shared::world_cache::CachePassParams;
use glam::Vec3;

/// Bytes of the push constants every cache pass takes.
pub const PUSH_BYTES: u32 = std::mem::size_of::<CachePassParams>() as u32;

/// Workgroups of 8 × 8 pixels over the G-buffer.
pub(crate) fn pixel_groups(gbuffer: &GBufferImages) -> [u32; 3] {
    [gbuffer.width().div_ceil(8), gbuffer.height().div_ceil(8), 1]
}

/// What the view shows besides the settings: the sky and the emitters, like `gi render`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewOptions {
    /// Constant sky radiance where there is no environment image.
    pub sky: Vec3,
    /// Factor on every surface's emission.
    pub emissive_multiplier: f32,
    /// Seed of the random streams.
    pub seed: u32,
}

impl ViewOptions {
    /// Checks the options, naming the first that is out of range.
    pub fn validate(&self) -> Result<()> {
        if !(self.emissive_multiplier.is_finite() && self.emissive_multiplier >= 0.0) {
            return Err(Error::InvalidArgument {
                name: "emissive_multiplier",
                why: format!("{}: must be finite and ≥ 0", self.emissive_multiplier),
            });
        }
        if !(self.sky.is_finite() && self.sky.min_element() >= 0.0) {
            return Err(Error::InvalidArgument {
                name: "sky",
                why: format!("{}: each channel must be finite and ≥ 0", self.sky),
            });
        }
        Ok(())
    }
}

/// What the screen-space passes read of the view: the camera buffer (`CameraParams`) and the
/// G-buffer.
#[derive(Clone, Copy)]
pub struct PrimaryView<'a> {
    /// The camera buffer.
    pub camera: &'a Buffer,
    /// The G-buffer images.
    pub gbuffer: &'a GBufferImages,
}

/// An error unless `camera` renders `width × height` images.
pub fn check_image_size(camera: &CameraParams, width: u32, height: u32) -> Result<()> {
    if camera.image_size == [width, height] {
        Ok(())
    } else {
        Err(Error::InvalidArgument {
            name: "camera",
            why: format!(
                "image size {:?} differs from the frame's {width}x{height}",
                camera.image_size
            ),
        })
    }
}

impl Default for ViewOptions {
    /// No sky, emission as in the file, seed 0.
    fn default() -> Self {
        Self {
            sky: Vec3::ZERO,
            emissive_multiplier: 1.0,
            seed: 0,
        }
    }
}

/// What the cache's lighting needs to know about the scene's lights.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneLighting {
    /// Lights in the light buffer.
    pub light_count: u32,
    /// Punctual lights at its front.
    pub punctual_count: u32,
    /// The environment is importance-sampled: the last light.
    pub environment_light: bool,
    /// The environment image's size (zero for none).
    pub environment_size: [u32; 2],
    /// The light grid's weight of the environment.
    pub environment_irradiance: f32,
}

impl SceneLighting {
    /// Of `lights`.
    pub fn new(lights: &LightSet) -> Self {
        let (environment_size, environment_irradiance) = match &lights.environment {
            Some(e) => (e.size(), environment_irradiance(e.size(), e.texels())),
            None => ([0, 0], 0.0),
        };
        Self {
            light_count: lights.lights.len() as u32,
            punctual_count: lights
                .lights
                .iter()
                .take_while(|l| l.kind < gi_shared::lights::LIGHT_TRIANGLE)
                .count() as u32,
            environment_light: lights.environment_light != NONE,
            environment_size,
            environment_irradiance,
        }
    }
}

/// `¼ ∫ luminance(L) dω` over the sphere of an equirectangular `size` image: the irradiance a
/// uniform sky of the same mean gives a surface, the light grid's weight of the environment.
pub fn environment_irradiance(size: [u32; 2], texels: &[[f32; 4]]) -> f32 {
    let [w, h] = size;
    if w == 0 || h == 0 {
        return 0.0;
    }
    let mut sum = 0.0f64;
    for y in 0..h {
        let theta = (f64::from(y) + 0.5) / f64::from(h) * std::f64::consts::PI;
        let solid_angle = (2.0 * std::f64::consts::PI / f64::from(w))
            * (std::f64::consts::PI / f64::from(h))
            * theta.sin();
        for x in 0..w {
            if let Some(t) = texels.get((y * w + x) as usize) {
                let l = f64::from(luminance(Vec3::new(t[0], t[1], t[2])));
                if l.is_finite() && l > 0.0 {
                    sum += l * solid_angle;
                }
            }
        }
    }
    (0.25 * sum) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_uniform_environment_gives_pi_l() {
        let texels = vec![[2.0f32, 2.0, 2.0, 0.0]; 64 * 32];
        let e = environment_irradiance([64, 32], &texels);
        assert!((e - std::f32::consts::PI * 2.0).abs() < 0.01, "{e}");
        assert_eq!(environment_irradiance([0, 0], &[]), 0.0);
    }
}
