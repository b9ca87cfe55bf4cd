//! Scene arrays larger than one storage binding: one read ([`Elements`]) for a plain slice (the
//! CPU) and for an array split into chunks (the kernels), so the traversal and the shading code
//! that read the scene's vertices, triangles and BVH nodes are written once.
//!
//! # Splitting
//!
//! A storage buffer binding holds at most `maxStorageBufferRange` bytes (lavapipe: 128 MiB), so an
//! array that scales with the triangle count is stored in up to [`SCENE_BUFFER_CHUNKS`] buffers,
//! bound as one descriptor array. An array that fits one binding is one chunk, of its exact
//! length; a larger one is split into chunks of [`chunk_elements`] (a power of two), the last one
//! shorter. The slots past the last chunk hold a buffer shorter than one element: length 0.
//!
//! The kernels need no parameter to find an element: the first chunk's length rounded up to a
//! power of two ([`ChunkIndex`]) is the chunk size when there are several chunks, and covers the
//! whole array when there is one, so element `i` is element `i & mask` of chunk `i >> shift`.

use crate::layout::SCENE_BUFFER_CHUNKS;

/// An array the scene's readers index: a slice on the CPU, a split binding in the kernels.
pub trait Elements: Copy {
    /// What one element reads as.
    type Item;

    /// Number of elements.
    fn len(&self) -> usize;

    /// Element `i`, which must be below [`Elements::len`] (callers check, as they would a slice).
    fn get(&self, i: usize) -> Self::Item;

    /// Whether there are no elements.
    #[inline]
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

impl<T: Copy> Elements for &[T] {
    type Item = T;

    #[inline]
    fn len(&self) -> usize {
        <[T]>::len(self)
    }

    #[inline]
    fn get(&self, i: usize) -> T {
        self[i]
    }
}

impl<T: Copy, const N: usize> Elements for &[T; N] {
    type Item = T;

    #[inline]
    fn len(&self) -> usize {
        N
    }

    #[inline]
    fn get(&self, i: usize) -> T {
        self[i]
    }
}

/// Elements per chunk of an array of `stride`-byte elements that does not fit one binding of
/// `max_binding_bytes`: the largest power of two whose chunk fits it (0 when not even one
/// element does). Host only: kernels declare no 64-bit integers.
#[cfg(not(target_arch = "spirv"))]
pub fn chunk_elements(stride: usize, max_binding_bytes: u64) -> usize {
    let fit = (max_binding_bytes / stride.max(1) as u64).min(1 << 31) as usize;
    if fit == 0 { 0 } else { 1 << fit.ilog2() }
}

/// Where element `i` of a split array is: chunk `i >> shift`, element `i & mask` of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ChunkIndex {
    shift: u32,
    mask: u32,
}

impl ChunkIndex {
    /// The index of an array whose first chunk holds `first_len` elements (see the module
    /// documentation).
    #[inline]
    pub fn new(first_len: u32) -> Self {
        // ceil(log2(first_len)); 0 for 0 and 1. Chunks hold at most 2³¹ elements.
        let shift = (u32::BITS - (first_len.max(1) - 1).leading_zeros()).min(31);
        Self {
            shift,
            mask: (1u32 << shift) - 1,
        }
    }

    /// The chunk of element `i` and its index there.
    #[inline]
    pub fn locate(self, i: u32) -> (u32, u32) {
        (i >> self.shift, i & self.mask)
    }
}

/// A split array on the CPU, chunk by chunk as the device binds it: what the tests read the
/// scene through to check the splitting. At most [`SCENE_BUFFER_CHUNKS`] chunks, all but the last
/// of one power-of-two length.
#[derive(Clone, Copy, Debug)]
pub struct ChunkedSlices<'a, T> {
    chunks: &'a [&'a [T]],
    index: ChunkIndex,
    len: usize,
}

impl<'a, T> ChunkedSlices<'a, T> {
    /// The array held by `chunks`; `None` when they are not laid out as the module documentation
    /// says.
    pub fn new(chunks: &'a [&'a [T]]) -> Option<Self> {
        let first = chunks.first().map_or(0, |c| c.len());
        let index = ChunkIndex::new(first as u32);
        let full = chunks.len() <= 1 || first.is_power_of_two();
        let (last, rest) = chunks.split_last()?;
        let valid = chunks.len() <= SCENE_BUFFER_CHUNKS
            && full
            && rest.iter().all(|c| c.len() == first)
            && last.len() <= first;
        valid.then(|| Self {
            chunks,
            index,
            len: chunks.iter().map(|c| c.len()).sum(),
        })
    }
}

impl<T: Copy> Elements for ChunkedSlices<'_, T> {
    type Item = T;

    #[inline]
    fn len(&self) -> usize {
        self.len
    }

    #[inline]
    fn get(&self, i: usize) -> T {
        let (chunk, j) = self.index.locate(i as u32);
        self.chunks[chunk as usize][j as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chunk_sizes_are_powers_of_two_that_fit() {
        assert_eq!(chunk_elements(32, 128 << 20), 1 << 22);
        assert_eq!(chunk_elements(64, 4096), 64);
        // 4095 bytes hold 255 triangles of 16 bytes: 128 is the power of two below.
        assert_eq!(chunk_elements(16, 4095), 128);
        assert_eq!(chunk_elements(48, 4096), 64);
        assert_eq!(chunk_elements(64, 63), 0);
        // NVIDIA's 4 GiB - 1 of 4-byte elements: capped at 2³¹ elements, within `u32` indices.
        assert_eq!(chunk_elements(4, u64::from(u32::MAX)), 1 << 29);
        assert_eq!(chunk_elements(1, u64::MAX), 1 << 31);
    }

    #[test]
    fn the_first_chunk_gives_the_index() {
        for (first, shift) in [
            (0, 0),
            (1, 0),
            (2, 1),
            (3, 2),
            (4, 2),
            (5, 3),
            (64, 6),
            (65, 7),
        ] {
            let index = ChunkIndex::new(first);
            assert_eq!(index.shift, shift, "first chunk of {first}");
            assert_eq!(index.mask, (1 << shift) - 1);
        }
        // One chunk of any length: every element is in chunk 0.
        let one = ChunkIndex::new(1000);
        assert_eq!(one.locate(999), (0, 999));
        // Chunks of 64: the boundaries.
        let split = ChunkIndex::new(64);
        assert_eq!(split.locate(0), (0, 0));
        assert_eq!(split.locate(63), (0, 63));
        assert_eq!(split.locate(64), (1, 0));
        assert_eq!(split.locate(127), (1, 63));
        assert_eq!(split.locate(128), (2, 0));
        assert_eq!(
            ChunkIndex::new(1 << 31).locate(u32::MAX),
            (1, (1 << 31) - 1)
        );
    }

    #[test]
    fn a_split_array_reads_like_the_whole() {
        let whole: Vec<u32> = (0..300).map(|i| i * 7 + 1).collect();
        for chunk in [1, 2, 64, 128, 256, 512] {
            let chunks: Vec<&[u32]> = whole.chunks(chunk).collect();
            let Some(split) = ChunkedSlices::new(&chunks) else {
                assert!(chunks.len() > SCENE_BUFFER_CHUNKS, "chunks of {chunk}");
                continue;
            };
            assert_eq!(Elements::len(&split), whole.len());
            for (i, &w) in whole.iter().enumerate() {
                assert_eq!(split.get(i), w, "element {i}, chunks of {chunk}");
            }
        }
        // One chunk of any length, and chunks of 64 with a short last one (300 = 4 × 64 + 44).
        assert!(ChunkedSlices::new(&[&whole[..]]).is_some());
        let chunks: Vec<&[u32]> = whole.chunks(64).collect();
        let split = ChunkedSlices::new(&chunks).unwrap();
        assert_eq!((split.get(63), split.get(64)), (whole[63], whole[64]));
        assert_eq!((split.get(255), split.get(256)), (whole[255], whole[256]));
        assert_eq!(split.get(299), whole[299]);
    }

    #[test]
    fn malformed_splits_are_refused() {
        let whole = [0u8; 300];
        // Chunks of 100: not a power of two.
        let chunks: Vec<&[u8]> = whole.chunks(100).collect();
        assert!(ChunkedSlices::new(&chunks).is_none());
        // A middle chunk shorter than the first.
        assert!(ChunkedSlices::new(&[&whole[..64], &whole[..32], &whole[..64]]).is_none());
        // More chunks than the binding's array.
        let chunks: Vec<&[u8]> = whole.chunks(16).collect();
        assert!(chunks.len() > SCENE_BUFFER_CHUNKS);
        assert!(ChunkedSlices::new(&chunks).is_none());
        assert!(ChunkedSlices::<u8>::new(&[]).is_none());
    }
}
