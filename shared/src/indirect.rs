//! Indirect dispatch from a GPU counter, the "dispatch what exists" of append-scan-dispatch: the
//! `indirect::dispatch_from_counter` kernel turns a counter word into the workgroup count of a
//! later `vkCmdDispatchIndirect`, so the host never reads the count back.

use crate::abi::WORKGROUP_SIZE;
use crate::append_list::clamped_count;
use bytemuck::{Pod, Zeroable};

/// `VkDispatchIndirectCommand`: workgroup counts along x, y and z.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct DispatchIndirect {
    /// Workgroups along x.
    pub x: u32,
    /// Workgroups along y.
    pub y: u32,
    /// Workgroups along z.
    pub z: u32,
}

/// Push constants of `indirect::dispatch_from_counter`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct IndirectPush {
    /// The counter word, in the counters binding.
    pub counter_index: u32,
    /// The most items the list holds: the counter counts attempts and may exceed it.
    pub capacity: u32,
    /// `maxComputeWorkGroupCount[0]` of the device.
    pub max_groups: u32,
    /// Which [`DispatchIndirect`] of the arguments binding to write.
    pub args_index: u32,
}

/// The dispatch of one invocation per item of an append list, [`WORKGROUP_SIZE`] per workgroup, for a counter
/// reading `count`: `x = ceil(min(count, capacity) / WORKGROUP_SIZE)` capped at `max_groups`
/// (0 when the list is empty: a dispatch of zero workgroups is valid and does nothing).
#[inline]
pub fn dispatch_for_count(count: u32, capacity: u32, max_groups: u32) -> DispatchIndirect {
    DispatchIndirect {
        x: clamped_count(count, capacity)
            .div_ceil(WORKGROUP_SIZE)
            .min(max_groups),
        y: 1,
        z: 1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dispatch_covers_the_clamped_count() {
        let g = WORKGROUP_SIZE;
        assert_eq!(dispatch_for_count(0, 100, 65535).x, 0);
        assert_eq!(dispatch_for_count(1, 100, 65535).x, 1);
        assert_eq!(dispatch_for_count(g, 1000, 65535).x, 1);
        assert_eq!(dispatch_for_count(g + 1, 1000, 65535).x, 2);
        // An overflowing counter dispatches the capacity, no more.
        assert_eq!(dispatch_for_count(u32::MAX, 10 * g, 65535).x, 10);
        // The device limit caps it.
        assert_eq!(dispatch_for_count(u32::MAX, u32::MAX, 65535).x, 65535);
        let d = dispatch_for_count(5, 5, 7);
        assert_eq!((d.y, d.z), (1, 1));
    }
}
