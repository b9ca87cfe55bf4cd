//! The scene's lights in the layout of `gi_shared::lights`: punctual lights first, then emissive
//! triangles, in one buffer (the path tracer selects among them uniformly).
//!
//! Only what the scene has is uploaded: a scene without lights binds a one-light placeholder (a
//! Vulkan buffer cannot be empty) and passes a light count of 0.

use super::{LightKind, Scene};
use crate::error::Result;
use crate::vulkan::{Buffer, Context, Resource};
use ash::vk;
use gi_shared::lights::GpuLight;

/// Every light of `scene`: punctual lights in file order, then the emissive triangles.
pub fn gpu_lights(scene: &Scene) -> Vec<GpuLight> {
    let punctual = scene.lights.iter().map(|l| match l.kind {
        LightKind::Point => GpuLight::point(l.position, l.intensity),
        LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => GpuLight::spot(
            l.position,
            l.direction,
            l.intensity,
            inner_cone_angle,
            outer_cone_angle,
        ),
        LightKind::Directional => GpuLight::directional(l.direction, l.intensity),
    });
    let triangles = scene
        .emissive_triangles
        .iter()
        .map(|t| GpuLight::triangle(t.instance, t.primitive, t.vertices, t.emission));
    punctual.chain(triangles).collect()
}

/// The lights in a storage buffer.
pub struct GpuLights {
    buffer: Buffer,
    count: u32,
}

impl GpuLights {
    /// Uploads `lights` (from [`gpu_lights`]), or a placeholder when there are none.
    pub fn new(ctx: &Context, lights: &[GpuLight]) -> Result<Self> {
        let usage = vk::BufferUsageFlags::empty();
        let buffer = if lights.is_empty() {
            Buffer::from_slice(ctx, "lights placeholder", &[GpuLight::ZERO], usage)?
        } else {
            Buffer::from_slice(ctx, "lights", lights, usage)?
        };
        Ok(Self {
            buffer,
            count: lights.len() as u32,
        })
    }

    /// Number of lights (0 with the placeholder).
    pub fn count(&self) -> u32 {
        self.count
    }

    /// The buffer, for one storage-buffer binding.
    pub fn resource(&self) -> Resource<'_> {
        Resource::Buffer(&self.buffer)
    }

    /// Frees the buffer.
    pub fn destroy(self, ctx: &Context) {
        self.buffer.destroy(ctx);
    }
}
