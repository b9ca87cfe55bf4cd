//! [`AtomicWords`] on the GPU: SPIR-V atomics on a storage buffer at device scope
//! ([`DeviceWords`]) and on workgroup memory at workgroup scope ([`WorkgroupWords`]), so that the
//! shared algorithms built on the trait (append lists, hash-cell inserts, bounds reductions) run
//! unchanged in the kernels.
//!
//! Memory semantics under the Vulkan memory model: read-modify-writes are acquire-release, loads
//! acquire and stores release, each on the storage class the words live in. An invocation that
//! wins a compare-exchange or an append slot therefore sees every write the previous owners
//! released before their atomic, and its own earlier writes are visible to whoever acquires the
//! word after it (a hash cell's payload written before its key is published, for instance).
//! Device scope needs the `VulkanMemoryModelDeviceScope` capability (`gi_shared::abi`).

use gi_shared::atomics::AtomicWords;
use spirv_std::arch::{
    atomic_compare_exchange, atomic_exchange, atomic_i_add, atomic_load, atomic_store,
    atomic_u_max, atomic_u_min,
};
use spirv_std::memory::{Scope, Semantics};

/// Device scope: every invocation of the dispatch (and of later dispatches) sees the words.
const DEVICE: u32 = Scope::Device as u32;
/// Workgroup scope: the invocations of one workgroup.
const WORKGROUP: u32 = Scope::Workgroup as u32;
/// Storage buffers are `UniformMemory` in SPIR-V's semantics.
const BUFFER_ACQ_REL: u32 = Semantics::UNIFORM_MEMORY.bits() | Semantics::ACQUIRE_RELEASE.bits();
const BUFFER_ACQUIRE: u32 = Semantics::UNIFORM_MEMORY.bits() | Semantics::ACQUIRE.bits();
const BUFFER_RELEASE: u32 = Semantics::UNIFORM_MEMORY.bits() | Semantics::RELEASE.bits();
const SHARED_ACQ_REL: u32 = Semantics::WORKGROUP_MEMORY.bits() | Semantics::ACQUIRE_RELEASE.bits();
const SHARED_ACQUIRE: u32 = Semantics::WORKGROUP_MEMORY.bits() | Semantics::ACQUIRE.bits();
const SHARED_RELEASE: u32 = Semantics::WORKGROUP_MEMORY.bits() | Semantics::RELEASE.bits();
/// A failed compare-exchange only reads: acquire (release is not allowed on the unequal path).
const BUFFER_CAS_UNEQUAL: u32 = BUFFER_ACQUIRE;
const SHARED_CAS_UNEQUAL: u32 = SHARED_ACQUIRE;

/// A storage buffer of `u32` words (`#[spirv(storage_buffer)] words: &mut [u32]`) under
/// device-scope atomics.
pub struct DeviceWords<'a>(pub &'a mut [u32]);

/// Workgroup memory (`#[spirv(workgroup)] words: &mut [u32; N]`) under workgroup-scope atomics.
pub struct WorkgroupWords<'a, const N: usize>(pub &'a mut [u32; N]);

/// Implements [`AtomicWords`] for a wrapper whose `.0` indexes like a slice, at the given scope
/// with the given semantics.
macro_rules! atomic_words {
    ([$($generics:tt)*] $ty:ty, $scope:ident, $acq_rel:ident, $acquire:ident, $release:ident, $unequal:ident) => {
        impl<$($generics)*> AtomicWords for $ty {
            #[inline]
            fn word_count(&self) -> usize {
                self.0.len()
            }
            #[inline]
            fn load(&self, i: usize) -> u32 {
                unsafe { atomic_load::<u32, $scope, $acquire>(&self.0[i]) }
            }
            #[inline]
            fn store(&mut self, i: usize, value: u32) {
                unsafe { atomic_store::<u32, $scope, $release>(&mut self.0[i], value) }
            }
            #[inline]
            fn fetch_add(&mut self, i: usize, value: u32) -> u32 {
                unsafe { atomic_i_add::<u32, $scope, $acq_rel>(&mut self.0[i], value) }
            }
            #[inline]
            fn swap(&mut self, i: usize, value: u32) -> u32 {
                unsafe { atomic_exchange::<u32, $scope, $acq_rel>(&mut self.0[i], value) }
            }
            #[inline]
            fn compare_exchange(&mut self, i: usize, current: u32, new: u32) -> u32 {
                unsafe {
                    atomic_compare_exchange::<u32, $scope, $acq_rel, $unequal>(
                        &mut self.0[i],
                        new,
                        current,
                    )
                }
            }
            #[inline]
            fn fetch_min(&mut self, i: usize, value: u32) -> u32 {
                unsafe { atomic_u_min::<u32, $scope, $acq_rel>(&mut self.0[i], value) }
            }
            #[inline]
            fn fetch_max(&mut self, i: usize, value: u32) -> u32 {
                unsafe { atomic_u_max::<u32, $scope, $acq_rel>(&mut self.0[i], value) }
            }
        }
    };
}

atomic_words!(
    []
    DeviceWords<'_>,
    DEVICE,
    BUFFER_ACQ_REL,
    BUFFER_ACQUIRE,
    BUFFER_RELEASE,
    BUFFER_CAS_UNEQUAL
);
atomic_words!(
    [const N: usize]
    WorkgroupWords<'_, N>,
    WORKGROUP,
    SHARED_ACQ_REL,
    SHARED_ACQUIRE,
    SHARED_RELEASE,
    SHARED_CAS_UNEQUAL
);
