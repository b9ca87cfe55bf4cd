//! The frame recorder: every command of a frame goes through it, and it places the barriers.
//!
//! A pass declares what it touches once, by what it binds: a kernel's set 0 is its
//! [`Bindings`] struct, checked against the kernel's own SPIR-V when the pipeline is made, and
//! whether the kernel writes each binding comes from that SPIR-V too ([`Kernel::binding_writes`]:
//! buffers it only reads are `NonWritable`). Transfers (fills, updates, copies) and indirect
//! arguments name their buffers. From these uses the recorder tracks, per buffer and image, the
//! last write and the reads since, and before each command records one `vkCmdPipelineBarrier`
//! with a buffer or image barrier for exactly the resources that need one:
//!
//! - read or write after a write (a memory dependency from the writer's stage and access to the
//!   reader's, unless that write was already made visible to them);
//! - write after reads (an execution dependency on the readers' stages).
//!
//! Independent dispatches get no barrier between them and may overlap on a GPU. What the recorder
//! cannot see (earlier frames and scene updates on the queue, the engine's work before and after)
//! gets one global barrier at each end of the frame: [`Recorder::begin`] and [`Recorder::finish`].
//!
//! Each pass is named with the talk's words ([`Recorder::pass`]): the name labels its commands
//! for RenderDoc and Nsight (`VK_EXT_debug_utils`, where the instance has it), times it
//! ([`GpuTimer`]) and, when [`Recorder::log`] asks, lists what it read and wrote: the pass table
//! of `docs/integration.md` is generated from that list.
//!
//! Failure modes: a resource a kernel reaches other than through its set 0 (none does) or a
//! command recorded past the recorder (with `ctx.device` directly) is not tracked; the
//! synchronization validation every GPU test runs under reports either as a hazard.

use crate::error::Result;
use crate::vulkan::{
    Bindings, Buffer, Context, GpuTimer, Groups, Image, Kernel, Resource, SceneSets, SetZero,
};
use ash::vk;
use std::collections::HashMap;
use std::ffi::CString;

type Stages = vk::PipelineStageFlags;
type Accesses = vk::AccessFlags;

/// How a command uses a resource.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Use {
    stage: Stages,
    access: Accesses,
    write: bool,
}

impl Use {
    const SHADER_READ: Self = Self {
        stage: Stages::COMPUTE_SHADER,
        access: Accesses::SHADER_READ,
        write: false,
    };
    const SHADER_WRITE: Self = Self {
        stage: Stages::COMPUTE_SHADER,
        access: Accesses::from_raw(
            Accesses::SHADER_READ.as_raw() | Accesses::SHADER_WRITE.as_raw(),
        ),
        write: true,
    };
    const TRANSFER_READ: Self = Self {
        stage: Stages::TRANSFER,
        access: Accesses::TRANSFER_READ,
        write: false,
    };
    const TRANSFER_WRITE: Self = Self {
        stage: Stages::TRANSFER,
        access: Accesses::TRANSFER_WRITE,
        write: true,
    };
    const INDIRECT_READ: Self = Self {
        stage: Stages::DRAW_INDIRECT,
        access: Accesses::INDIRECT_COMMAND_READ,
        write: false,
    };

    fn merge(self, other: Self) -> Self {
        Self {
            stage: self.stage | other.stage,
            access: self.access | other.access,
            write: self.write || other.write,
        }
    }
}

/// What the recorder knows of one resource.
#[derive(Clone, Copy, Debug, Default)]
struct State {
    /// The last write's stage and access.
    write: Option<(Stages, Accesses)>,
    /// The stages and accesses that write was made visible to.
    visible: (Stages, Accesses),
    /// The stages that read since the last write.
    reads: Stages,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Target {
    Buffer(vk::Buffer),
    Image(vk::Image),
}

/// One resource a command uses, with its name for the pass table.
struct Touch<'n> {
    target: Target,
    name: &'n str,
    how: Use,
}

/// What one pass read and wrote ([`Recorder::log`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PassUses {
    /// The pass's name.
    pub pass: String,
    /// Its commands, in order, each once: the kernels it dispatched, `fill`, `update`, `copy`.
    pub commands: Vec<String>,
    /// The resources it read and did not write, by name, each once.
    pub reads: Vec<String>,
    /// The resources it wrote (or read and wrote), by name, each once.
    pub writes: Vec<String>,
}

/// The name [`PassUses`] gives commands recorded outside any [`Recorder::pass`].
pub const BETWEEN_PASSES: &str = "(between passes)";

/// `uses` as a Markdown table: one row per pass, with its commands, what it read and what it
/// wrote (the pass table of `docs/integration.md`).
pub fn pass_table(uses: &[PassUses]) -> String {
    let code = |items: &[String]| {
        items
            .iter()
            .map(|i| format!("`{i}`"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut table =
        String::from("| # | pass | commands | reads | writes |\n|---|---|---|---|---|\n");
    for (i, u) in uses.iter().enumerate() {
        table += &format!(
            "| {i} | {} | {} | {} | {} |\n",
            u.pass,
            code(&u.commands),
            u.reads.join(", "),
            u.writes.join(", ")
        );
    }
    table
}

/// Counts of what the recorder placed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BarrierCounts {
    /// `vkCmdPipelineBarrier` calls.
    pub barriers: u32,
    /// Buffer memory barriers in them.
    pub buffer_barriers: u32,
    /// Image memory barriers in them.
    pub image_barriers: u32,
}

/// Records a frame's commands into `cmd`, placing the barriers: before each command, a buffer or
/// image barrier for exactly the resources a dependency needs (a read or write after a write, a
/// write after reads), derived from what each command binds and whether its kernel writes it
/// (`docs/integration.md`, "The frame graph").
pub struct Recorder<'a> {
    ctx: &'a Context,
    cmd: vk::CommandBuffer,
    timer: Option<&'a mut GpuTimer>,
    states: HashMap<Target, State>,
    /// Passes open around the command being recorded (0: between passes).
    depth: u32,
    log: Option<Vec<PassUses>>,
    counts: BarrierCounts,
}

impl<'a> Recorder<'a> {
    /// A recorder of `cmd` (recording, outside a render pass), timing each pass into `timer`
    /// (reset here) when given. Nothing is recorded yet: call [`Self::begin`] first when earlier
    /// work on the queue may touch the frame's resources.
    pub fn new(
        ctx: &'a Context,
        cmd: vk::CommandBuffer,
        mut timer: Option<&'a mut GpuTimer>,
    ) -> Self {
        if let Some(t) = timer.as_deref_mut() {
            t.reset(ctx, cmd);
        }
        Self {
            ctx,
            cmd,
            timer,
            states: HashMap::new(),
            depth: 0,
            log: None,
            counts: BarrierCounts::default(),
        }
    }

    /// Keeps the list of what each pass read and wrote ([`Self::uses`]).
    pub fn log(mut self) -> Self {
        self.log = Some(vec![]);
        self
    }

    /// The context.
    pub fn ctx(&self) -> &'a Context {
        self.ctx
    }

    /// Orders everything after it after the compute and transfer work before it on the queue,
    /// which the recorder does not see (earlier frames, scene updates, the engine's writes).
    pub fn begin(&mut self) {
        let all = (
            Stages::COMPUTE_SHADER | Stages::TRANSFER,
            Accesses::SHADER_READ
                | Accesses::SHADER_WRITE
                | Accesses::TRANSFER_READ
                | Accesses::TRANSFER_WRITE,
        );
        self.global_barrier(all, all);
    }

    /// Makes every write recorded so far visible to whatever follows on the queue (later
    /// frames, the engine's commands, host reads after the submission's fence) and returns what
    /// the recorder placed; [`Self::uses`] first if it kept the list.
    pub fn finish(mut self) -> BarrierCounts {
        if self.states.values().any(|s| s.write.is_some()) {
            self.global_barrier(
                (
                    Stages::COMPUTE_SHADER | Stages::TRANSFER,
                    Accesses::SHADER_WRITE | Accesses::TRANSFER_WRITE,
                ),
                (
                    Stages::ALL_COMMANDS | Stages::HOST,
                    Accesses::MEMORY_READ | Accesses::MEMORY_WRITE | Accesses::HOST_READ,
                ),
            );
        }
        self.counts
    }

    /// The barriers placed so far.
    pub fn counts(&self) -> BarrierCounts {
        self.counts
    }

    /// What each pass read and wrote, in order (empty unless [`Self::log`] asked).
    pub fn uses(&self) -> &[PassUses] {
        self.log.as_deref().unwrap_or_default()
    }

    /// Records `body` as the pass `name`: labelled, timed, and logged under that name.
    pub fn pass(&mut self, name: &str, body: impl FnOnce(&mut Self) -> Result<()>) -> Result<()> {
        if let Some(t) = self.timer.as_deref_mut() {
            t.begin(self.ctx, self.cmd, name)?;
        }
        if let Some(labels) = &self.ctx.labels {
            let label = CString::new(name).unwrap_or_default();
            let info = vk::DebugUtilsLabelEXT::default().label_name(&label);
            unsafe { labels.cmd_begin_debug_utils_label(self.cmd, &info) };
        }
        if let Some(log) = &mut self.log {
            log.push(PassUses {
                pass: name.to_string(),
                ..Default::default()
            });
        }
        self.depth += 1;
        let result = body(self);
        self.depth -= 1;
        if let Some(labels) = &self.ctx.labels {
            unsafe { labels.cmd_end_debug_utils_label(self.cmd) };
        }
        if let Some(t) = self.timer.as_deref() {
            t.end(self.ctx, self.cmd);
        }
        result
    }

    /// Dispatches `kernel` over `groups` workgroups with `bindings` as set 0 and `push` as push
    /// constants ([`Kernel::dispatch`]).
    pub fn dispatch<B: Bindings>(
        &mut self,
        kernel: &Kernel,
        bindings: &B,
        push: &[u8],
        groups: [u32; 3],
    ) -> Result<()> {
        self.kernel(kernel, None, bindings, push, Groups::Direct(groups))
    }

    /// [`Self::dispatch`] of a kernel that traces, in `scene` ([`Kernel::dispatch_traced`]).
    pub fn dispatch_traced<B: Bindings>(
        &mut self,
        kernel: &Kernel,
        scene: SceneSets<'_>,
        bindings: &B,
        push: &[u8],
        groups: [u32; 3],
    ) -> Result<()> {
        self.kernel(kernel, Some(scene), bindings, push, Groups::Direct(groups))
    }

    /// Dispatches `kernel` with the workgroup counts at byte `offset` of `args`
    /// ([`Kernel::dispatch_indirect`]).
    pub fn dispatch_indirect<B: Bindings>(
        &mut self,
        kernel: &Kernel,
        bindings: &B,
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) -> Result<()> {
        let groups = Groups::Indirect(args, offset);
        self.kernel(kernel, None, bindings, push, groups)
    }

    /// [`Self::dispatch_indirect`] of a kernel that traces, in `scene`.
    pub fn dispatch_indirect_traced<B: Bindings>(
        &mut self,
        kernel: &Kernel,
        scene: SceneSets<'_>,
        bindings: &B,
        push: &[u8],
        args: &Buffer,
        offset: u64,
    ) -> Result<()> {
        let groups = Groups::Indirect(args, offset);
        self.kernel(kernel, Some(scene), bindings, push, groups)
    }

    /// Fills the whole of `buffer` with the word `word`.
    pub fn fill(&mut self, buffer: &Buffer, word: u32) {
        self.before("fill", &[buffer_touch(buffer, Use::TRANSFER_WRITE)]);
        buffer.record_fill(self.ctx, self.cmd, word);
    }

    /// Writes `bytes` (at most 65 536, a multiple of 4) at byte `offset` (a multiple of 4) of
    /// `buffer` (`vkCmdUpdateBuffer`).
    pub fn update(&mut self, buffer: &Buffer, offset: u64, bytes: &[u8]) {
        self.before("update", &[buffer_touch(buffer, Use::TRANSFER_WRITE)]);
        unsafe {
            self.ctx
                .device
                .cmd_update_buffer(self.cmd, buffer.handle, offset, bytes)
        };
    }

    /// Copies the whole of `src` to the start of `dst` ([`Buffer::record_copy_to`]).
    pub fn copy(&mut self, src: &Buffer, dst: &Buffer) -> Result<()> {
        self.before(
            "copy",
            &[
                buffer_touch(src, Use::TRANSFER_READ),
                buffer_touch(dst, Use::TRANSFER_WRITE),
            ],
        );
        src.record_copy_to(self.ctx, self.cmd, dst)
    }

    /// Copies `src` into an image the recorder does not track (the engine's, in `layout`): `src`
    /// is read by a transfer; the engine orders its own later use of the image.
    pub fn copy_to_image(
        &mut self,
        src: &Buffer,
        image: vk::Image,
        layout: vk::ImageLayout,
        regions: &[vk::BufferImageCopy],
    ) {
        self.before("copy", &[buffer_touch(src, Use::TRANSFER_READ)]);
        unsafe {
            self.ctx
                .device
                .cmd_copy_buffer_to_image(self.cmd, src.handle, image, layout, regions)
        };
    }

    /// Places the barriers a dispatch of `kernel` with `bindings` needs, then records it: its set
    /// 0 is read once, for both.
    fn kernel<B: Bindings>(
        &mut self,
        kernel: &Kernel,
        scene: Option<SceneSets<'_>>,
        bindings: &B,
        push: &[u8],
        groups: Groups<'_>,
    ) -> Result<()> {
        let set0 = SetZero::of(bindings);
        let mut touches: Vec<Touch<'_>> = vec![];
        for (resource, &writes) in set0.resources.iter().zip(kernel.binding_writes()) {
            let how = if writes {
                Use::SHADER_WRITE
            } else {
                Use::SHADER_READ
            };
            match resource {
                Resource::Buffer(b) => touches.push(buffer_touch(b, how)),
                Resource::Image(i) => touches.push(image_touch(i, how)),
                // Sampled images are the engine's (its barrier orders them); the scene's sets
                // are written once, before any frame.
                Resource::SampledImage { .. }
                | Resource::Split(_)
                | Resource::AccelerationStructure(_)
                | Resource::Textures(_) => {}
            }
        }
        if let Groups::Indirect(args, _) = groups {
            touches.push(buffer_touch(args, Use::INDIRECT_READ));
        }
        self.before(&kernel.entry, &touches);
        kernel.record(self.ctx, self.cmd, scene, &set0, push, groups)
    }

    /// Places the barriers `touches` need (merged per resource) and updates the states.
    fn before(&mut self, command: &str, touches: &[Touch<'_>]) {
        let mut merged: Vec<Touch<'_>> = vec![];
        for t in touches {
            match merged.iter_mut().find(|m| m.target == t.target) {
                Some(m) => m.how = m.how.merge(t.how),
                None => merged.push(Touch { ..*t }),
            }
        }
        let (mut src, mut dst) = (Stages::empty(), Stages::empty());
        let mut buffers = vec![];
        let mut images = vec![];
        for t in &merged {
            let state = self.states.entry(t.target).or_default();
            let how = t.how;
            if let Some((stage, access)) = state.write
                && !(state.visible.0.contains(how.stage) && state.visible.1.contains(how.access))
            {
                src |= stage;
                dst |= how.stage;
                match t.target {
                    Target::Buffer(buffer) => buffers.push(
                        vk::BufferMemoryBarrier::default()
                            .src_access_mask(access)
                            .dst_access_mask(how.access)
                            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                            .buffer(buffer)
                            .size(vk::WHOLE_SIZE),
                    ),
                    Target::Image(image) => images.push(
                        vk::ImageMemoryBarrier::default()
                            .src_access_mask(access)
                            .dst_access_mask(how.access)
                            .old_layout(vk::ImageLayout::GENERAL)
                            .new_layout(vk::ImageLayout::GENERAL)
                            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                            .image(image)
                            .subresource_range(
                                vk::ImageSubresourceRange::default()
                                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                                    .level_count(vk::REMAINING_MIP_LEVELS)
                                    .layer_count(vk::REMAINING_ARRAY_LAYERS),
                            ),
                    ),
                }
                state.visible.0 |= how.stage;
                state.visible.1 |= how.access;
            }
            if how.write && !state.reads.is_empty() {
                // Write after read: the readers finish first; no memory to make visible.
                src |= state.reads;
                dst |= how.stage;
            }
            if how.write {
                let written = how.access & (Accesses::SHADER_WRITE | Accesses::TRANSFER_WRITE);
                *state = State {
                    write: Some((how.stage, written)),
                    ..State::default()
                };
            } else {
                state.reads |= how.stage;
            }
        }
        if !src.is_empty() {
            unsafe {
                self.ctx.device.cmd_pipeline_barrier(
                    self.cmd,
                    src,
                    dst,
                    vk::DependencyFlags::empty(),
                    &[],
                    &buffers,
                    &images,
                )
            };
            self.counts.barriers += 1;
            self.counts.buffer_barriers += buffers.len() as u32;
            self.counts.image_barriers += images.len() as u32;
        }
        if let Some(log) = &mut self.log
            && self.depth == 0
            && log.last().is_none_or(|l| l.pass != BETWEEN_PASSES)
        {
            log.push(PassUses {
                pass: BETWEEN_PASSES.into(),
                ..Default::default()
            });
        }
        if let Some(entry) = self.log.as_mut().and_then(|l| l.last_mut()) {
            push_once(&mut entry.commands, command);
            for t in &merged {
                if t.how.write {
                    entry.reads.retain(|r| r != t.name);
                    push_once(&mut entry.writes, t.name);
                } else if !entry.writes.iter().any(|w| w == t.name) {
                    push_once(&mut entry.reads, t.name);
                }
            }
        }
    }

    fn global_barrier(&mut self, src: (Stages, Accesses), dst: (Stages, Accesses)) {
        crate::vulkan::memory_barrier(self.ctx, self.cmd, src, dst);
        self.counts.barriers += 1;
        // Everything before is now visible to every later use.
        self.states.clear();
    }
}

fn push_once(list: &mut Vec<String>, item: &str) {
    if !list.iter().any(|i| i == item) {
        list.push(item.to_string());
    }
}

fn buffer_touch(buffer: &Buffer, how: Use) -> Touch<'_> {
    Touch {
        target: Target::Buffer(buffer.handle),
        name: buffer.name(),
        how,
    }
}

fn image_touch(image: &Image, how: Use) -> Touch<'_> {
    Touch {
        target: Target::Image(image.handle),
        name: image.name(),
        how,
    }
}
