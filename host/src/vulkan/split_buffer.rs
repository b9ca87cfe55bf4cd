//! A scene array stored in up to [`SCENE_BUFFER_CHUNKS`] storage buffers, so that it may exceed
//! one storage binding (`maxStorageBufferRange`); bound as one descriptor array
//! ([`super::BindingKind::SplitBuffer`]) that the kernels read through `gi_shared::elements`.

use super::context::Context;
use super::memory::{Buffer, StagedWrites};
use crate::error::{Error, Result};
use ash::vk;
use gi_shared::elements::chunk_elements;
use gi_shared::layout::SCENE_BUFFER_CHUNKS;

/// An array of `T`s split into chunks as `gi_shared::elements` lays them out: one chunk when it
/// fits one binding, else chunks of a power of two of elements, the last one shorter.
pub struct SplitBuffer {
    /// The chunks, in order; none for an empty array.
    chunks: Vec<Buffer>,
    /// Bound in the slots past the last chunk: 4 bytes, shorter than any element, so the kernels
    /// read those slots as empty. `None` when every slot holds a chunk.
    filler: Option<Buffer>,
    /// Elements of every chunk but the last.
    chunk_elements: usize,
    /// Bytes of one element.
    stride: usize,
}

/// Elements per chunk of `count` elements of `stride` bytes split for bindings of at most
/// `max_binding_bytes`: all of them when they fit one. Errors, naming the array `name` and the
/// sizes, when [`SCENE_BUFFER_CHUNKS`] chunks cannot hold them.
pub fn split_layout(
    name: &'static str,
    count: usize,
    stride: usize,
    max_binding_bytes: u64,
) -> Result<usize> {
    let bytes = count as u64 * stride as u64;
    if bytes <= max_binding_bytes {
        return Ok(count);
    }
    let chunk = chunk_elements(stride, max_binding_bytes);
    if chunk == 0 || count.div_ceil(chunk) > SCENE_BUFFER_CHUNKS {
        return Err(Error::InvalidArgument {
            name,
            why: format!(
                "{count} elements of {stride} bytes ({bytes} bytes) do not fit the \
                 {SCENE_BUFFER_CHUNKS} storage bindings of {chunk} elements ({} bytes, a power of \
                 two within the binding limit of {max_binding_bytes} bytes) that hold the array",
                chunk as u64 * stride as u64
            ),
        });
    }
    Ok(chunk)
}

impl SplitBuffer {
    /// Uploads `data` to device-local chunks of at most `max_binding_bytes` each (see
    /// [`split_layout`] for the errors).
    pub fn device_local<T: bytemuck::Pod>(
        ctx: &Context,
        name: &'static str,
        data: &[T],
        max_binding_bytes: u64,
    ) -> Result<Self> {
        let stride = size_of::<T>();
        let chunk_elements = split_layout(name, data.len(), stride, max_binding_bytes)?;
        let chunks = if data.is_empty() {
            vec![]
        } else {
            data.chunks(chunk_elements)
                .map(|chunk| Buffer::device_local(ctx, name, chunk, vk::BufferUsageFlags::empty()))
                .collect::<Result<Vec<_>>>()?
        };
        let filler = match chunks.len() < SCENE_BUFFER_CHUNKS {
            true => Some(Buffer::device_zeroed::<u32>(
                ctx,
                &format!("{name} empty chunk"),
                1,
            )?),
            false => None,
        };
        Ok(Self {
            chunks,
            filler,
            chunk_elements,
            stride,
        })
    }

    /// The buffer of each of the binding's [`SCENE_BUFFER_CHUNKS`] slots.
    pub fn slots(&self) -> impl Iterator<Item = &Buffer> {
        let filler = self.filler.iter().cycle();
        self.chunks.iter().chain(filler).take(SCENE_BUFFER_CHUNKS)
    }

    /// The chunks, in order, each named like the array (none for an empty array).
    pub fn chunks(&self) -> &[Buffer] {
        &self.chunks
    }

    /// Bytes of device memory of the chunks.
    pub fn bytes(&self) -> u64 {
        self.chunks.iter().map(|c| c.size).sum()
    }

    /// Queues `data` to be written over the elements from `first` on, across chunks. Errors,
    /// queueing nothing, when it does not fit the array or its elements are not the array's.
    pub fn stage<'a, T: bytemuck::Pod>(
        &'a self,
        writes: &mut StagedWrites<'a>,
        first: usize,
        data: &[T],
    ) -> Result<()> {
        let len: u64 = self.bytes() / self.stride.max(1) as u64;
        if size_of::<T>() != self.stride || (first + data.len()) as u64 > len {
            return Err(Error::InvalidArgument {
                name: "split buffer write",
                why: format!(
                    "{} elements of {} bytes from element {first} do not fit an array of {len} \
                     elements of {} bytes",
                    data.len(),
                    size_of::<T>(),
                    self.stride
                ),
            });
        }
        let mut at = first;
        let mut rest = data;
        while !rest.is_empty() {
            let (chunk, offset) = (at / self.chunk_elements, at % self.chunk_elements);
            let n = rest.len().min(self.chunk_elements - offset);
            let (now, later) = rest.split_at(n);
            writes.write(&self.chunks[chunk], (offset * self.stride) as u64, now)?;
            at += n;
            rest = later;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arrays_within_one_binding_stay_whole() {
        assert_eq!(split_layout("vertices", 1000, 32, 32_000).unwrap(), 1000);
        assert_eq!(split_layout("vertices", 0, 32, 4096).unwrap(), 0);
    }

    #[test]
    fn larger_arrays_split_into_powers_of_two() {
        // 4 KiB bindings: 128 vertices of 32 bytes per chunk, 1000 in 8 chunks.
        assert_eq!(split_layout("vertices", 1000, 32, 4096).unwrap(), 128);
        assert_eq!(split_layout("vertices", 1024, 32, 4096).unwrap(), 128);
        // 10 M triangles of 16 bytes under lavapipe's 128 MiB: 2 chunks of 2²³.
        assert_eq!(
            split_layout("triangles", 10_000_000, 16, 128 << 20).unwrap(),
            1 << 23
        );
    }

    #[test]
    fn arrays_beyond_every_chunk_are_errors_naming_the_array_and_sizes() {
        let err = split_layout("vertices", 1025, 32, 4096).unwrap_err();
        assert!(
            matches!(
                err,
                Error::InvalidArgument {
                    name: "vertices",
                    ..
                }
            ),
            "{err}"
        );
        let text = err.to_string();
        for part in ["1025 elements", "32 bytes", "128 elements", "4096 bytes"] {
            assert!(text.contains(part), "{part:?} missing from: {text}");
        }
        assert!(split_layout("bvh nodes", 2, 64, 63).is_err());
    }
}
