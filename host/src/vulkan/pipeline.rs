//! Compute pipelines over the kernel modules, and how kernels get their resources.
//!
//! Descriptor sets, the same in both tracing variants:
//!
//! * **set 0**: the kernel's own resources (outputs, parameters, per-frame buffers), pushed with
//!   each dispatch by push descriptors, at most [`MAX_PUSH_BINDINGS`] (the least
//!   `maxPushDescriptors` a device may have). Nothing to allocate or keep alive per dispatch.
//! * **set 1**: the scene's geometry ([`SceneSet::Geometry`]): the top-level acceleration
//!   structure with ray queries, the two-level BVH's nodes in software. A persistent set
//!   allocated once with the geometry (`SceneGeometry`), since it changes only with the scene.
//! * **set 2**: the scene's shading data and lights ([`SceneSet::Shading`]), persistent, owned by
//!   the uploaded scene (`GpuScene`).
//!
//! Only kernels that trace (those `kernels::traces` names) have sets 1 and 2 in their pipeline
//! layout, and are dispatched with [`Kernel::dispatch_traced`]; every other kernel's layout is
//! set 0 alone, so it carries no placeholder layouts. Why this order: the pass's set is the one
//! every kernel has, so it comes first and no layout needs an empty set below it (a pipeline
//! layout lists its sets from 0, and `VK_NULL_HANDLE` is only valid there with
//! `graphicsPipelineLibrary`); the scene's geometry sits at one place in both variants, so no
//! host code shifts binding numbers by variant; and the scene's many shading buffers stay out of
//! the 32 push-descriptor bindings a pass may use.

use super::bindings::{Bindings, DeclaredBinding};
use super::context::{Context, SharedDevice};
use super::image::Image;
use super::memory::{Buffer, memory_barrier};
use super::reflect::{KernelBinding, check_declared, set0_bindings};
use super::split_buffer::SplitBuffer;
use crate::error::{Error, Result, VkContext};
use crate::kernels::KernelVariant;
use ash::vk;
use gi_shared::layout::SCENE_BUFFER_CHUNKS;
use std::collections::HashMap;
use std::ffi::CString;
use std::sync::Arc;

/// The most bindings set 0 may have: the least `maxPushDescriptors` a device may report.
pub const MAX_PUSH_BINDINGS: usize = 32;

/// What a binding holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    /// A storage buffer (`#[spirv(storage_buffer)]`).
    StorageBuffer,
    /// One of the scene's split arrays: an array of [`SCENE_BUFFER_CHUNKS`] storage buffers
    /// (`#[spirv(storage_buffer)]` on a `RuntimeArray<TypedBuffer<[T]>>`), every one written.
    SplitBuffer,
    /// A top-level acceleration structure (ray-query variant only).
    AccelerationStructure,
    /// A storage image in the `GENERAL` layout (`Image!(2D, format = ..., sampled = false)`).
    StorageImage,
    /// A sampled image without a sampler, read by texel fetch (`Image!(2D, type = f32,
    /// sampled)`), in the layout its [`Resource::SampledImage`] names: any depth or colour
    /// format that supports sampling.
    SampledImage,
    /// The scene's textures: an array of this many combined image samplers in
    /// `SHADER_READ_ONLY_OPTIMAL`, partially bound (entries past the scene's textures stay
    /// unwritten and are never read).
    Textures(u32),
}

/// Most textures a scene may have: the length of set 2's texture array, unless the device allows
/// fewer sampled images or samplers per stage or set (`Capabilities::scene_texture_slots`).
pub const MAX_SCENE_TEXTURES: u32 = 1 << 14;

/// A resource bound to a binding, matching its [`BindingKind`].
#[derive(Clone, Copy)]
pub enum Resource<'a> {
    /// A whole storage buffer.
    Buffer(&'a Buffer),
    /// A split array, one whole buffer per slot.
    Split(&'a SplitBuffer),
    /// An acceleration structure handle.
    AccelerationStructure(vk::AccelerationStructureKHR),
    /// The scene's textures, each image view with its sampler (possibly none).
    Textures(&'a [vk::DescriptorImageInfo]),
    /// A whole storage image.
    Image(&'a Image),
    /// A sampled image's view, in `layout` whenever the dispatch runs.
    SampledImage {
        /// The view.
        view: vk::ImageView,
        /// Its layout.
        layout: vk::ImageLayout,
    },
}

/// A kernel's set 0 ready to bind: the declaration it was written with and its resources, in
/// order (read once per dispatch, by the recorder's barriers and by the binding).
pub(crate) struct SetZero<'a> {
    declared: &'static [DeclaredBinding],
    pub(crate) resources: Vec<Resource<'a>>,
}

impl<'a> SetZero<'a> {
    /// `bindings`' declaration and resources.
    pub(crate) fn of<B: Bindings>(bindings: &'a B) -> Self {
        Self {
            declared: B::DECLARED,
            resources: bindings.resources(),
        }
    }
}

/// How many workgroups a dispatch runs: counts known when it is recorded, or read by the GPU
/// from the `VkDispatchIndirectCommand` at a byte offset of an arguments buffer.
#[derive(Clone, Copy)]
pub(crate) enum Groups<'a> {
    /// `[x, y, z]` workgroups.
    Direct([u32; 3]),
    /// The arguments buffer and the byte offset.
    Indirect(&'a Buffer, u64),
}

/// The kernel code of the context's variant: the common module (every kernel, tracing in
/// software) and, with ray queries, the module of the kernels that trace with them. Freed when
/// dropped (pipelines made from it stay valid).
pub struct KernelModule {
    common: vk::ShaderModule,
    common_kernels: HashMap<String, Vec<KernelBinding>>,
    /// The ray-query module; `None` in software, where the common module traces.
    ray_query: Option<(vk::ShaderModule, HashMap<String, Vec<KernelBinding>>)>,
    shared: Arc<SharedDevice>,
}

impl KernelModule {
    /// Loads the modules of the context's variant.
    pub fn new(ctx: &Context) -> Result<Self> {
        let load = |words: &[u32]| -> Result<vk::ShaderModule> {
            let info = vk::ShaderModuleCreateInfo::default().code(words);
            unsafe { ctx.device.create_shader_module(&info, None) }.vk("vkCreateShaderModule")
        };
        let words = crate::kernels::common_spirv_words();
        let mut module = Self {
            common: load(&words)?,
            common_kernels: set0_bindings(&words),
            ray_query: None,
            shared: ctx.shared.clone(),
        };
        if ctx.variant() == KernelVariant::RayQuery {
            let words = KernelVariant::RayQuery.tracing_spirv_words();
            module.ray_query = Some((load(&words)?, set0_bindings(&words)));
        }
        Ok(module)
    }

    /// The module `entry` comes from and its set-0 bindings, if the module has it (else the
    /// module's name): the ray-query module for a kernel that traces in the ray-query variant,
    /// the common module otherwise.
    fn find(
        &self,
        entry: &str,
    ) -> std::result::Result<(vk::ShaderModule, &[KernelBinding]), &'static str> {
        let (module, kernels, name) = match &self.ray_query {
            Some((m, kernels)) if crate::kernels::traces(entry) => (*m, kernels, "ray-query"),
            _ => (self.common, &self.common_kernels, "common"),
        };
        kernels
            .get(entry)
            .map(|b| (module, b.as_slice()))
            .ok_or(name)
    }
}

impl Drop for KernelModule {
    fn drop(&mut self) {
        let device = &self.shared.device;
        unsafe {
            device.destroy_shader_module(self.common, None);
            if let Some((m, _)) = &self.ray_query {
                device.destroy_shader_module(*m, None);
            }
        }
    }
}

/// One compute entry point as a pipeline, freed when dropped.
pub struct Kernel {
    pipeline: vk::Pipeline,
    layout: vk::PipelineLayout,
    set_layout: vk::DescriptorSetLayout,
    /// Set 0: each binding's number and kind, in the order of `declared`.
    slots: Vec<(u32, BindingKind)>,
    /// Set 0: whether the kernel writes each binding, in the order of `declared`.
    writes: Vec<bool>,
    declared: &'static [DeclaredBinding],
    push_constant_bytes: u32,
    traces: bool,
    /// The entry point's name.
    pub entry: String,
    shared: Arc<SharedDevice>,
}

impl Kernel {
    /// Creates the pipeline of `entry`, whose set 0 the host binds as `B` (a [`crate::bindings!`]
    /// struct: the kernel's parameters by name, in order, at most [`MAX_PUSH_BINDINGS`]), with
    /// `push_constant_bytes` of push constants (0 for none). A kernel that traces also gets the
    /// scene's sets 1 and 2. A declaration that is not the kernel's (a binding swapped, missing,
    /// extra or of another kind) is an error naming the kernel and the binding.
    pub fn new<B: Bindings>(
        ctx: &Context,
        module: &KernelModule,
        entry: &str,
        push_constant_bytes: u32,
    ) -> Result<Self> {
        let (module, kernel_bindings) = module
            .find(entry)
            .map_err(|name| Error::NoSuchKernel(entry.to_string(), name))?;
        let bindings = B::DECLARED;
        check_declared(kernel_bindings, bindings).map_err(|why| Error::InvalidArgument {
            name: "kernel bindings",
            why: format!("kernel {entry}: {why}"),
        })?;
        let slots: Vec<(u32, BindingKind)> = kernel_bindings
            .iter()
            .map(|b| (b.binding, b.kind))
            .collect();
        if bindings.len() > MAX_PUSH_BINDINGS {
            return Err(Error::InvalidArgument {
                name: "kernel bindings",
                why: format!(
                    "kernel {entry}: {} bindings in set 0, more than the {MAX_PUSH_BINDINGS} push \
                     descriptors every device has; move long-lived resources to a persistent set",
                    bindings.len()
                ),
            });
        }
        let name = CString::new(entry).map_err(|_| Error::NoSuchKernel(entry.into(), "any"))?;
        let traces = crate::kernels::traces(entry);
        // From here on, dropping `kernel` frees what exists (null handles are no-ops).
        let mut kernel = Self {
            pipeline: vk::Pipeline::null(),
            layout: vk::PipelineLayout::null(),
            set_layout: create_set_layout(&ctx.device, &slots, true)?,
            slots,
            writes: kernel_bindings.iter().map(|b| b.writes).collect(),
            declared: bindings,
            push_constant_bytes,
            traces,
            entry: entry.to_string(),
            shared: ctx.shared.clone(),
        };
        let ranges = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .size(push_constant_bytes)];
        let scene = ctx.scene_set_layouts();
        let all_sets = [kernel.set_layout, scene[0], scene[1]];
        let set_layouts = if traces {
            &all_sets[..]
        } else {
            &all_sets[..1]
        };
        let mut layout_info = vk::PipelineLayoutCreateInfo::default().set_layouts(set_layouts);
        if push_constant_bytes > 0 {
            layout_info = layout_info.push_constant_ranges(&ranges);
        }
        kernel.layout = unsafe { ctx.device.create_pipeline_layout(&layout_info, None) }
            .vk("vkCreatePipelineLayout")?;
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(&name);
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(kernel.layout)];
        kernel.pipeline = unsafe {
            ctx.device
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
        }
        .map_err(|(_, result)| Error::Vulkan {
            call: "vkCreateComputePipelines",
            result,
        })?[0];
        Ok(kernel)
    }

    /// Records a dispatch of `groups` workgroups with `bindings` as set 0 and
    /// `push` as push constants. A kernel that traces needs the scene: [`Kernel::dispatch_traced`].
    pub fn dispatch<B: Bindings>(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bindings: &B,
        push: &[u8],
        groups: [u32; 3],
    ) -> Result<()> {
        let set0 = SetZero::of(bindings);
        self.record(ctx, cmd, None, &set0, push, Groups::Direct(groups))
    }

    /// Records a dispatch of a kernel that traces, in `scene` (bound as sets 1 and up), with
    /// `bindings` as set 0 and `push` as push constants.
    pub fn dispatch_traced<B: Bindings>(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scene: SceneSets<'_>,
        bindings: &B,
        push: &[u8],
        groups: [u32; 3],
    ) -> Result<()> {
        let set0 = SetZero::of(bindings);
        self.record(ctx, cmd, Some(scene), &set0, push, Groups::Direct(groups))
    }

    /// Records a dispatch whose workgroup counts the GPU reads, when the dispatch executes, from
    /// the `VkDispatchIndirectCommand` (`gi_shared::indirect::DispatchIndirect`) at byte `offset`
    /// of `args` (a buffer with `INDIRECT_BUFFER` usage: `frame::indirect_args`). A count of
    /// zero dispatches nothing. Whatever wrote the arguments must be made visible to indirect
    /// reads first (`frame::Recorder::dispatch_indirect` does).
    pub fn dispatch_indirect<B: Bindings>(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        bindings: &B,
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) -> Result<()> {
        let set0 = SetZero::of(bindings);
        self.record(ctx, cmd, None, &set0, push, Groups::Indirect(args, offset))
    }

    /// Records the dispatch of every `dispatch*` method (and of `frame::Recorder`, which reads
    /// `set0` first to place its barriers): checks the workgroup counts or the arguments' place,
    /// binds, dispatches.
    pub(crate) fn record(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scene: Option<SceneSets<'_>>,
        set0: &SetZero<'_>,
        push: &[u8],
        groups: Groups<'_>,
    ) -> Result<()> {
        match groups {
            Groups::Direct(groups) => {
                let max = ctx.capabilities().max_workgroup_count;
                if groups.iter().zip(max).any(|(g, m)| *g > m) || groups.contains(&0) {
                    return Err(self
                        .bad_dispatch(format!("workgroup count {groups:?} outside 1..={max:?}")));
                }
                self.bind(ctx, cmd, scene, set0, push)?;
                unsafe {
                    ctx.device
                        .cmd_dispatch(cmd, groups[0], groups[1], groups[2])
                };
            }
            Groups::Indirect(args, offset) => {
                let size = std::mem::size_of::<gi_shared::indirect::DispatchIndirect>() as u64;
                if !offset.is_multiple_of(4) || offset + size > args.size {
                    return Err(self.bad_dispatch(format!(
                        "indirect arguments at byte {offset} of {:?} ({} bytes)",
                        args.name(),
                        args.size
                    )));
                }
                self.bind(ctx, cmd, scene, set0, push)?;
                unsafe { ctx.device.cmd_dispatch_indirect(cmd, args.handle, offset) };
            }
        }
        Ok(())
    }

    /// Whether the kernel writes each of its set-0 bindings, in the order of its [`Bindings`]
    /// (buffers it only reads are `NonWritable` in its SPIR-V; storage images it writes have an
    /// `OpImageWrite`).
    pub fn binding_writes(&self) -> &[bool] {
        &self.writes
    }

    fn bad_dispatch(&self, why: String) -> Error {
        Error::InvalidArgument {
            name: "dispatch",
            why: format!("kernel {}: {why}", self.entry),
        }
    }

    /// Binds the pipeline and `scene` (which a kernel that traces needs, and no other takes),
    /// pushes `bindings` as set 0 and `push` as push constants.
    fn bind(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        scene: Option<SceneSets<'_>>,
        set0: &SetZero<'_>,
        push: &[u8],
    ) -> Result<()> {
        let bad = |why: String| self.bad_dispatch(why);
        if scene.is_some() != self.traces {
            return Err(bad(if self.traces {
                "it traces: dispatch it with the scene (dispatch_traced)".into()
            } else {
                "it does not trace: it takes no scene".into()
            }));
        }
        if push.len() as u32 != self.push_constant_bytes {
            return Err(bad(format!(
                "{} push-constant bytes, layout has {}",
                push.len(),
                self.push_constant_bytes
            )));
        }
        if set0.declared != self.declared {
            return Err(bad(format!(
                "dispatched with bindings {:?}, declared for another kernel",
                set0.declared.iter().map(|d| d.name).collect::<Vec<_>>()
            )));
        }
        let sets: Vec<vk::DescriptorSet> = scene.iter().flat_map(SceneSets::handles).collect();
        with_writes(&self.slots, &set0.resources, |writes| unsafe {
            ctx.device
                .cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            if !sets.is_empty() {
                ctx.device.cmd_bind_descriptor_sets(
                    cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    self.layout,
                    1,
                    &sets,
                    &[],
                );
            }
            ctx.push_descriptor.cmd_push_descriptor_set(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                writes,
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
        })
        .map_err(bad)
    }
}

impl Drop for Kernel {
    fn drop(&mut self) {
        let device = &self.shared.device;
        unsafe {
            device.destroy_pipeline(self.pipeline, None);
            device.destroy_pipeline_layout(self.layout, None);
            device.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// Makes every shader write before this point visible to later shaders, transfers (copies from
/// it, and fills, updates and copies over it) and host reads (a fence alone does not make device
/// writes visible to the host).
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
            // TRANSFER_WRITE: a transfer overwriting what a kernel wrote (a counter reset by
            // vkCmdUpdateBuffer after the pass that wrote it) is a write-after-write hazard
            // without it (synchronization validation reports it).
            vk::AccessFlags::SHADER_READ
                | vk::AccessFlags::SHADER_WRITE
                | vk::AccessFlags::TRANSFER_READ
                | vk::AccessFlags::TRANSFER_WRITE
                | vk::AccessFlags::HOST_READ,
        ),
    );
}

/// The scene's persistent descriptor sets, above the pass's set 0.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneSet {
    /// Set 1: the geometry that kernels trace against (variant-dependent bindings, see
    /// [`SceneSet::binding_kinds`]; the software traversal's nodes split).
    Geometry,
    /// Set 2: the shading data and lights, [`SHADING_BINDINGS`] bindings: instances, meshes,
    /// vertices, triangles (split), materials, texture table (storage buffers), the textures
    /// ([`BindingKind::Textures`], binding [`TEXTURES_BINDING`]), lights, triangle→light table,
    /// environment texels, environment distribution (storage buffers).
    Shading,
}

/// Bindings in [`SceneSet::Shading`].
pub const SHADING_BINDINGS: usize = 11;

/// The binding of the textures in [`SceneSet::Shading`].
pub const TEXTURES_BINDING: usize = 6;

/// The binding of the vertices in [`SceneSet::Shading`], split ([`BindingKind::SplitBuffer`]).
pub const VERTICES_BINDING: usize = 2;

/// The binding of the triangles in [`SceneSet::Shading`], split ([`BindingKind::SplitBuffer`]).
pub const TRIANGLES_BINDING: usize = 3;

impl SceneSet {
    /// [`SceneSet::binding_kinds`] with their binding numbers.
    pub(crate) fn binding_slots(
        self,
        variant: KernelVariant,
        texture_slots: u32,
    ) -> Vec<(u32, BindingKind)> {
        (0..)
            .zip(self.binding_kinds(variant, texture_slots))
            .collect()
    }

    /// The set's bindings in `variant`, binding `i` the `i`-th.
    pub fn binding_kinds(self, variant: KernelVariant, texture_slots: u32) -> Vec<BindingKind> {
        match (self, variant) {
            (Self::Geometry, KernelVariant::RayQuery) => vec![BindingKind::AccelerationStructure],
            (Self::Geometry, KernelVariant::Software) => vec![BindingKind::SplitBuffer],
            (Self::Shading, _) => {
                let mut kinds = vec![BindingKind::StorageBuffer; SHADING_BINDINGS];
                kinds[VERTICES_BINDING] = BindingKind::SplitBuffer;
                kinds[TRIANGLES_BINDING] = BindingKind::SplitBuffer;
                kinds[TEXTURES_BINDING] = BindingKind::Textures(texture_slots);
                kinds
            }
        }
    }
}

/// A persistent descriptor set of the scene, written once, with the pool it came from; both
/// freed when dropped.
pub struct DescriptorSet {
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    kind: SceneSet,
    shared: Arc<SharedDevice>,
}

impl DescriptorSet {
    /// Allocates set `kind` and points it at `resources` (in the order of
    /// [`SceneSet::binding_kinds`]), which must outlive every dispatch that binds it.
    pub fn new(ctx: &Context, kind: SceneSet, resources: &[Resource<'_>]) -> Result<Self> {
        let kinds = kind.binding_slots(ctx.variant(), ctx.capabilities().scene_texture_slots());
        let mut sizes: Vec<vk::DescriptorPoolSize> = vec![];
        for (_, k) in &kinds {
            let ty = descriptor_type(*k);
            let count = descriptor_count(*k);
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += count,
                None => sizes.push(
                    vk::DescriptorPoolSize::default()
                        .ty(ty)
                        .descriptor_count(count),
                ),
            }
        }
        let info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // From here on, dropping `set` frees the pool.
        let mut set = Self {
            pool: unsafe { ctx.device.create_descriptor_pool(&info, None) }
                .vk("vkCreateDescriptorPool")?,
            set: vk::DescriptorSet::null(),
            kind,
            shared: ctx.shared.clone(),
        };
        let layouts = [ctx.scene_set_layouts()[kind as usize]];
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(set.pool)
            .set_layouts(&layouts);
        set.set = unsafe { ctx.device.allocate_descriptor_sets(&alloc) }
            .vk("vkAllocateDescriptorSets")?[0];
        with_writes(&kinds, resources, |writes| {
            let writes: Vec<_> = writes.iter().map(|w| w.dst_set(set.set)).collect();
            unsafe { ctx.device.update_descriptor_sets(&writes, &[]) };
        })
        .map_err(|why| Error::InvalidArgument {
            name: "descriptor set",
            why: format!("{kind:?}: {why}"),
        })?;
        Ok(set)
    }
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        // Frees the set with it.
        unsafe { self.shared.device.destroy_descriptor_pool(self.pool, None) };
    }
}

/// The scene sets a kernel that traces is dispatched with.
#[derive(Clone, Copy)]
pub struct SceneSets<'a> {
    /// Set 1 ([`SceneSet::Geometry`]).
    pub geometry: &'a DescriptorSet,
    /// Set 2 ([`SceneSet::Shading`]): the software traversal reads its geometry.
    pub shading: &'a DescriptorSet,
}

impl SceneSets<'_> {
    fn handles(&self) -> Vec<vk::DescriptorSet> {
        debug_assert_eq!(self.geometry.kind, SceneSet::Geometry);
        debug_assert_eq!(self.shading.kind, SceneSet::Shading);
        vec![self.geometry.set, self.shading.set]
    }
}

/// A descriptor set layout of `bindings` (number and kind), for push descriptors when `push`.
pub(crate) fn create_set_layout(
    device: &ash::Device,
    bindings: &[(u32, BindingKind)],
    push: bool,
) -> Result<vk::DescriptorSetLayout> {
    let layout_bindings: Vec<_> = bindings
        .iter()
        .map(|(i, kind)| {
            vk::DescriptorSetLayoutBinding::default()
                .binding(*i)
                .descriptor_type(descriptor_type(*kind))
                .descriptor_count(descriptor_count(*kind))
                .stage_flags(vk::ShaderStageFlags::COMPUTE)
        })
        .collect();
    let flags: Vec<_> = bindings
        .iter()
        .map(|(_, kind)| match kind {
            BindingKind::Textures(_) => vk::DescriptorBindingFlags::PARTIALLY_BOUND,
            _ => vk::DescriptorBindingFlags::empty(),
        })
        .collect();
    let mut binding_flags =
        vk::DescriptorSetLayoutBindingFlagsCreateInfo::default().binding_flags(&flags);
    let mut info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings);
    if bindings
        .iter()
        .any(|(_, k)| matches!(k, BindingKind::Textures(_)))
    {
        info = info.push_next(&mut binding_flags);
    }
    if push {
        info = info.flags(vk::DescriptorSetLayoutCreateFlags::PUSH_DESCRIPTOR_KHR);
    }
    unsafe { device.create_descriptor_set_layout(&info, None) }.vk("vkCreateDescriptorSetLayout")
}

/// Calls `f` with the writes that point bindings `kinds` (number and kind) at `resources` (no
/// destination set), or says which resource does not fit.
fn with_writes<R>(
    kinds: &[(u32, BindingKind)],
    resources: &[Resource<'_>],
    f: impl FnOnce(&[vk::WriteDescriptorSet<'_>]) -> R,
) -> std::result::Result<R, String> {
    if resources.len() != kinds.len() {
        return Err(format!(
            "{} resources for {} bindings",
            resources.len(),
            kinds.len()
        ));
    }
    let whole = |b: &Buffer| {
        vk::DescriptorBufferInfo::default()
            .buffer(b.handle)
            .range(vk::WHOLE_SIZE)
    };
    let buffer_infos: Vec<Vec<vk::DescriptorBufferInfo>> = resources
        .iter()
        .map(|r| match r {
            Resource::Buffer(b) => vec![whole(b)],
            Resource::Split(s) => s.slots().map(whole).collect(),
            Resource::AccelerationStructure(_)
            | Resource::Image(_)
            | Resource::Textures(_)
            | Resource::SampledImage { .. } => vec![],
        })
        .collect();
    let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = resources
        .iter()
        .map(|r| match r {
            Resource::Image(image) => [image.descriptor()],
            Resource::SampledImage { view, layout } => [vk::DescriptorImageInfo::default()
                .image_view(*view)
                .image_layout(*layout)],
            Resource::Buffer(_)
            | Resource::Split(_)
            | Resource::AccelerationStructure(_)
            | Resource::Textures(_) => [vk::DescriptorImageInfo::default()],
        })
        .collect();
    let accels: Vec<[vk::AccelerationStructureKHR; 1]> = resources
        .iter()
        .map(|r| match r {
            Resource::AccelerationStructure(a) => [*a],
            Resource::Buffer(_)
            | Resource::Split(_)
            | Resource::Image(_)
            | Resource::Textures(_)
            | Resource::SampledImage { .. } => [vk::AccelerationStructureKHR::null()],
        })
        .collect();
    let mut accel_writes: Vec<vk::WriteDescriptorSetAccelerationStructureKHR<'_>> = accels
        .iter()
        .map(|a| {
            vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(a)
        })
        .collect();
    let mut writes = vec![];
    for (i, (((binding, kind), res), accel_write)) in kinds
        .iter()
        .zip(resources)
        .zip(accel_writes.iter_mut())
        .enumerate()
    {
        let w = vk::WriteDescriptorSet::default()
            .dst_binding(*binding)
            .descriptor_type(descriptor_type(*kind));
        let w = match (kind, res) {
            (BindingKind::StorageBuffer, Resource::Buffer(_))
            | (BindingKind::SplitBuffer, Resource::Split(_)) => w.buffer_info(&buffer_infos[i]),
            (BindingKind::StorageImage, Resource::Image(_))
            | (BindingKind::SampledImage, Resource::SampledImage { .. }) => {
                w.image_info(&image_infos[i])
            }
            // Nothing to write for a scene without textures (a write needs one descriptor).
            (BindingKind::Textures(_), Resource::Textures([])) => continue,
            (BindingKind::Textures(slots), Resource::Textures(infos)) => {
                if infos.len() > *slots as usize {
                    return Err(format!(
                        "{} textures, more than the {slots} the device's texture array holds",
                        infos.len()
                    ));
                }
                w.image_info(infos)
            }
            (BindingKind::AccelerationStructure, Resource::AccelerationStructure(_)) => {
                let mut w = w.push_next(accel_write);
                w.descriptor_count = 1;
                w
            }
            _ => return Err(format!("resource {i} does not match binding {kind:?}")),
        };
        writes.push(w);
    }
    Ok(f(&writes))
}

fn descriptor_type(kind: BindingKind) -> vk::DescriptorType {
    match kind {
        BindingKind::StorageBuffer | BindingKind::SplitBuffer => vk::DescriptorType::STORAGE_BUFFER,
        BindingKind::AccelerationStructure => vk::DescriptorType::ACCELERATION_STRUCTURE_KHR,
        BindingKind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
        BindingKind::SampledImage => vk::DescriptorType::SAMPLED_IMAGE,
        BindingKind::Textures(_) => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
    }
}

fn descriptor_count(kind: BindingKind) -> u32 {
    match kind {
        BindingKind::Textures(slots) => slots,
        BindingKind::SplitBuffer => SCENE_BUFFER_CHUNKS as u32,
        _ => 1,
    }
}
