//! Host side of the `finite_check::count_non_finite` kernel (`gi_shared::finite_check`): counts
//! the NaN and infinite `f32` words of a list of buffers on the GPU, by buffer name, in one
//! submission; 32-bit float images are copied into buffers first.

use crate::error::{Error, Result};
use crate::vulkan::{
    Buffer, Context, Image, Kernel, KernelModule, MemoryLocation, compute_barrier,
};
use ash::vk;
use gi_shared::finite_check::{FINITE_CHECK_GROUP, FiniteCheckPush, MAX_RECORD_WORDS};
use gi_shared::layout::FloatLayout;

/// Most workgroups one dispatch runs (65 536 invocations, enough to fill any GPU): a larger
/// buffer is covered by each invocation looping over several words.
const MAX_GROUPS: u32 = 1024;

crate::bindings! {
    /// The finite check's set 0 (`kernels::finite_check::count_non_finite`).
    pub(crate) struct CountNonFinite<'a> {
        words: &'a Buffer,
        counts: &'a Buffer,
    }
}

/// Which words of a buffer are `f32`s: the buffer is a sequence of records of `record_words`
/// words, and word `i` of each record is a float when bit `i` of `float_mask` is set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FloatWords {
    record_words: u32,
    float_mask: u32,
}

impl FloatWords {
    /// Every word is an `f32` (`[f32; N]` and structs of floats alone).
    pub const ALL: Self = Self {
        record_words: 1,
        float_mask: 1,
    };

    /// Records of `record_words` words (1 to 32) whose words `floats` (each below
    /// `record_words`) are `f32`s. Errors on an out-of-range size or index.
    pub fn new(record_words: u32, floats: &[u32]) -> Result<Self> {
        let bad = |why: String| {
            Err(Error::InvalidArgument {
                name: "FloatWords",
                why,
            })
        };
        if record_words == 0 || record_words > MAX_RECORD_WORDS {
            return bad(format!(
                "{record_words} words per record: must be 1 to {MAX_RECORD_WORDS}"
            ));
        }
        let mut float_mask = 0;
        for &i in floats {
            if i >= record_words {
                return bad(format!("word {i} of a {record_words}-word record"));
            }
            float_mask |= 1 << i;
        }
        Ok(Self {
            record_words,
            float_mask,
        })
    }
}

impl FloatWords {
    /// The float words of records of type `T`, as `T` declares them.
    pub fn of<T: FloatLayout>() -> Result<Self> {
        Self::new((std::mem::size_of::<T>() / 4) as u32, T::FLOAT_WORDS)
    }
}

/// The counting kernel's pipeline.
pub struct FiniteCheck {
    kernel: Kernel,
}

impl FiniteCheck {
    /// The kernel's entry point.
    pub const ENTRY: &str = "finite_check::count_non_finite";

    /// Creates the pipeline.
    pub fn new(ctx: &Context, module: &KernelModule) -> Result<Self> {
        Ok(Self {
            kernel: Kernel::new::<CountNonFinite>(
                ctx,
                module,
                Self::ENTRY,
                std::mem::size_of::<FiniteCheckPush>() as u32,
            )?,
        })
    }

    /// The number of non-finite floats in each of `buffers` (whatever wrote them must have been
    /// submitted before), with the buffer's name, in the order given. Each buffer's whole size is
    /// checked; a trailing partial record is read with the same mask.
    pub fn count(
        &self,
        ctx: &Context,
        buffers: &[(&Buffer, FloatWords)],
    ) -> Result<Vec<(String, u32)>> {
        if buffers.is_empty() {
            return Ok(Vec::new());
        }
        let counts = Buffer::device_zeroed::<u32>(ctx, "non-finite counts", buffers.len())?;
        let max_groups = ctx.capabilities().max_workgroup_count[0].min(MAX_GROUPS);
        let recorded = ctx.submit(|cmd| -> Result<()> {
            for (slot, (buffer, floats)) in buffers.iter().enumerate() {
                let word_count = u32::try_from(buffer.size / 4).unwrap_or(u32::MAX);
                let push = FiniteCheckPush {
                    word_count,
                    record_words: floats.record_words,
                    float_mask: floats.float_mask,
                    slot: slot as u32,
                };
                let groups = word_count.div_ceil(FINITE_CHECK_GROUP).clamp(1, max_groups);
                self.kernel.dispatch(
                    ctx,
                    cmd,
                    &CountNonFinite {
                        words: buffer,
                        counts: &counts,
                    },
                    bytemuck::bytes_of(&push),
                    [groups, 1, 1],
                )?;
            }
            compute_barrier(ctx, cmd);
            Ok(())
        });
        recorded??;
        let found: Vec<u32> = counts.read_back(ctx)?;
        Ok(buffers
            .iter()
            .zip(found)
            .map(|((b, _), n)| (b.name().to_owned(), n))
            .collect())
    }

    /// The number of non-finite texels' channels in each of `images` (whatever wrote them must
    /// have been submitted before), with the image's name, in the order given. Each image is
    /// copied on the GPU into a scratch buffer that is then counted like a buffer. Only 32-bit
    /// float formats can be read this way: another format is an error naming the image.
    pub fn count_images(&self, ctx: &Context, images: &[&Image]) -> Result<Vec<(String, u32)>> {
        for image in images {
            if !matches!(
                image.format,
                vk::Format::R32_SFLOAT | vk::Format::R32G32B32A32_SFLOAT
            ) {
                return Err(Error::InvalidArgument {
                    name: "image",
                    why: format!(
                        "{:?} is {:?}: the finite check reads 32-bit float texels only",
                        image.name(),
                        image.format
                    ),
                });
            }
        }
        let copies = images
            .iter()
            .map(|i| {
                let name = format!("{} (finite check)", i.name());
                Buffer::new(
                    ctx,
                    &name,
                    i.byte_size(),
                    vk::BufferUsageFlags::empty(),
                    MemoryLocation::GpuOnly,
                )
            })
            .collect::<Result<Vec<_>>>()?;
        ctx.submit(|cmd| {
            for (image, copy) in images.iter().zip(&copies) {
                image.record_copy_to(ctx, cmd, copy);
            }
        })?;
        let buffers: Vec<(&Buffer, FloatWords)> =
            copies.iter().map(|b| (b, FloatWords::ALL)).collect();
        let counts = self.count(ctx, &buffers)?;
        Ok(images
            .iter()
            .zip(counts)
            .map(|(i, (_, n))| (i.name().to_owned(), n))
            .collect())
    }
}
