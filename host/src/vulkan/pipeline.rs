//! Compute pipelines over the kernel modules, with resources bound by push descriptors so that no
//! descriptor set has to outlive its dispatch.

use super::context::Context;
use super::image::Image;
use super::memory::{Buffer, memory_barrier};
use crate::error::{Error, Result, VkContext};
use crate::kernels::KernelVariant;
use ash::vk;
use std::ffi::CString;

/// What a binding of set 0 holds, in binding order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    /// A storage buffer (`#[spirv(storage_buffer)]`).
    StorageBuffer,
    /// A top-level acceleration structure (ray-query variant only).
    AccelerationStructure,
    /// A storage image in the `GENERAL` layout (`Image!(2D, format = ..., sampled = false)`).
    StorageImage,
}

/// A resource bound at dispatch time, matching a [`BindingKind`].
#[derive(Clone, Copy)]
pub enum Resource<'a> {
    /// A whole storage buffer.
    Buffer(&'a Buffer),
    /// An acceleration structure handle.
    AccelerationStructure(vk::AccelerationStructureKHR),
    /// A whole storage image.
    Image(&'a Image),
}

/// The shader module of the context's kernel variant.
pub struct KernelModule {
    module: vk::ShaderModule,
    entries: Vec<String>,
    variant: KernelVariant,
}

impl KernelModule {
    /// Loads the context's kernel variant.
    pub fn new(ctx: &Context) -> Result<Self> {
        let variant = ctx.variant();
        let words = variant.spirv_words();
        let info = vk::ShaderModuleCreateInfo::default().code(&words);
        let module =
            unsafe { ctx.device.create_shader_module(&info, None) }.vk("vkCreateShaderModule")?;
        Ok(Self {
            module,
            entries: crate::kernels::entry_points(&words),
            variant,
        })
    }

    /// Frees the module (pipelines made from it stay valid).
    pub fn destroy(self, ctx: &Context) {
        unsafe { ctx.device.destroy_shader_module(self.module, None) };
    }
}

/// One compute entry point as a pipeline.
pub struct Kernel {
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    bindings: Vec<BindingKind>,
    push_constant_bytes: u32,
    /// The entry point's name.
    pub entry: String,
}

impl Kernel {
    /// Creates the pipeline of `entry`, with set 0 laid out as `bindings` and `push_constant_bytes`
    /// of push constants (0 for none).
    pub fn new(
        ctx: &Context,
        module: &KernelModule,
        entry: &str,
        bindings: &[BindingKind],
        push_constant_bytes: u32,
    ) -> Result<Self> {
        if !module.entries.iter().any(|e| e == entry) {
            return Err(Error::NoSuchKernel(
                entry.to_string(),
                match module.variant {
                    KernelVariant::RayQuery => "ray-query",
                    KernelVariant::Software => "software",
                },
            ));
        }
        let layout_bindings: Vec<_> = bindings
            .iter()
            .enumerate()
            .map(|(i, kind)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(descriptor_type(*kind))
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let set_info = vk::DescriptorSetLayoutCreateInfo::default()
            .flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR)
            .bindings(&layout_bindings);
        let set_layout = unsafe { ctx.device.create_descriptor_set_layout(&set_info, None) }
            .vk("vkCreateDescriptorSetLayout")?;
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .size(push_constant_bytes)];
        let set_layouts = [set_layout];
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        if push_constant_bytes > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        let layout = match unsafe { ctx.device.create_pipeline_layout(&layout_info, None) } {
            Ok(l) => l,
            Err(result) => {
                unsafe { ctx.device.destroy_descriptor_set_layout(set_layout, None) };
                return Err(Error::Vulkan {
                    call: "vkCreatePipelineLayout",
                    result,
                });
            }
        };
        let name = CString::new(entry).map_err(|_| Error::NoSuchKernel(entry.into(), "any"))?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module.module)
            .name(&name);
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout)];
        let pipeline = match unsafe {
            ctx.device
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
        } {
            Ok(p) => p[0],
            Err((_, result)) => {
                unsafe {
                    ctx.device.destroy_pipeline_layout(layout, None);
                    ctx.device.destroy_descriptor_set_layout(set_layout, None);
                }
                return Err(Error::Vulkan {
                    call: "vkCreateComputePipelines",
                    result,
                });
            }
        };
        Ok(Self {
            pipeline,
            layout,
            set_layout,
            bindings: bindings.to_vec(),
            push_constant_bytes,
            entry: entry.to_string(),
        })
    }

    /// Records a dispatch of `groups` workgroups with `resources` bound in order and `push` as
    /// push constants.
    pub fn dispatch(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        resources: &[Resource<'_>],
        push: &[u8],
        groups: [u32; 3],
    ) -> Result<()> {
        let bad = |why: String| Error::InvalidArgument {
            name: "dispatch",
            why: format!("kernel {}: {why}", self.entry),
        };
        if resources.len() != self.bindings.len() {
            return Err(bad(format!(
                "{} resources for {} bindings",
                resources.len(),
                self.bindings.len()
            )));
        }
        if push.len() as u32 != self.push_constant_bytes {
            return Err(bad(format!(
                "{} push-constant bytes, layout has {}",
                push.len(),
                self.push_constant_bytes
            )));
        }
        let max = ctx.capabilities().max_workgroup_count;
        if groups.iter().zip(max).any(|(g, m)| *g > m) || groups.contains(&0) {
            return Err(bad(format!(
                "workgroup count {groups:?} outside 1..={max:?}"
            )));
        }
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = resources
            .iter()
            .map(|r| match r {
                Resource::Buffer(b) => [vk::DescriptorBufferInfo::default()
                    .buffer(b.handle)
                    .range(vk::WHOLE_SIZE)],
                Resource::AccelerationStructure(_) | Resource::Image(_) => {
                    [vk::DescriptorBufferInfo::default()]
                }
            })
            .collect();
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = resources
            .iter()
            .map(|r| match r {
                Resource::Image(image) => [image.descriptor()],
                Resource::Buffer(_) | Resource::AccelerationStructure(_) => {
                    [vk::DescriptorImageInfo::default()]
                }
            })
            .collect();
        let accels: Vec<[vk::AccelerationStructureKHR; 1]> = resources
            .iter()
            .map(|r| match r {
                Resource::AccelerationStructure(a) => [*a],
                Resource::Buffer(_) | Resource::Image(_) => [vk::AccelerationStructureKHR::null()],
            })
            .collect();
        let mut accel_writes: Vec<vk::WriteDescriptorSetAccelerationStructureKHR<'_>> = accels
            .iter()
            .map(|a| {
                vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(a)
            })
            .collect();
        let mut writes = vec![];
        for (i, ((kind, res), accel_write)) in self
            .bindings
            .iter()
            .zip(resources)
            .zip(accel_writes.iter_mut())
            .enumerate()
        {
            let w = vk::WriteDescriptorSet::default()
                .dst_binding(i as u32)
                .descriptor_type(descriptor_type(*kind));
            let w = match (kind, res) {
                (BindingKind::StorageBuffer, Resource::Buffer(_)) => {
                    w.buffer_info(&buffer_infos[i])
                }
                (BindingKind::StorageImage, Resource::Image(_)) => w.image_info(&image_infos[i]),
                (BindingKind::AccelerationStructure, Resource::AccelerationStructure(_)) => {
                    let mut w = w.push_next(accel_write);
                    w.descriptor_count = 1;
                    w
                }
                _ => return Err(bad(format!("resource {i} does not match binding {kind:?}"))),
            };
            writes.push(w);
        }
        unsafe {
            ctx.device
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            ctx.push_descriptor.cmd_push_descriptor_set(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &writes,
            );
            if !push.is_empty() {
                ctx.device.cmd_push_constants(
                    cmd,
                    self.layout,
                    vk::ShaderStageFlags::COMPUTE,
                    0,
                    push,
                );
            }
            ctx.device
                .cmd_dispatch(cmd, groups[0], groups[1], groups[2]);
        }
        Ok(())
    }

    /// Frees the pipeline and its layouts.
    pub fn destroy(self, ctx: &Context) {
        unsafe {
            ctx.device.destroy_pipeline(self.pipeline, None);
            ctx.device.destroy_pipeline_layout(self.layout, None);
            ctx.device
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// Makes every shader write before this point visible to later shaders, transfers and host reads
/// (a fence alone does not make device writes visible to the host).
pub fn compute_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    memory_barrier(
        ctx,
        cmd,
        (
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::AccessFlags::SHADER_WRITE,
        ),
        (
            vk::PipelineStageFlags::COMPUTE_SHADER
                | vk::PipelineStageFlags::TRANSFER
                | vk::PipelineStageFlags::HOST,
            vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE
                | vk::AccessFlags::TRANSFER_READ
                | vk::AccessFlags::HOST_READ,
        ),
    );
}

fn descriptor_type(kind: BindingKind) -> vk::DescriptorType {
    match kind {
        BindingKind::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
        BindingKind::AccelerationStructure => vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
        BindingKind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
    }
}
