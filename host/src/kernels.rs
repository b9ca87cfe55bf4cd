//! The two compiled kernel modules and the choice between them.
//!
//! The modules are embedded: by default those shipped in `host/kernels-spirv/` (built by
//! `scripts/build-kernels.sh`), with the `build-kernels` feature those rust-gpu just built from
//! `kernels/` (`host/build.rs`).
//!
//! The common module has every kernel, tracing (if at all) in software; the ray-query module has
//! only the kernels that trace, with ray queries. A context running ray queries takes its tracing
//! kernels from the latter and every other kernel from the former.

use crate::error::{Error, Result};
use crate::vulkan::Capabilities;
use std::fmt;
use std::sync::OnceLock;

/// How the user wants rays traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum TraceMode {
    /// Ray queries where the device has them, software BVH traversal otherwise.
    #[default]
    Auto,
    /// `VK_KHR_ray_query`; an error on devices without it.
    RayQuery,
    /// Software BVH traversal, on any device.
    Software,
}

/// How a context's kernels trace rays.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KernelVariant {
    /// Traces with `VK_KHR_ray_query` against device-built acceleration structures.
    RayQuery,
    /// Walks the shared crate's BVH in software.
    Software,
}

// The build script's folder: the shipped modules, or those it built from source (`build-kernels`).
const SOFTWARE_SPV: &[u8] = include_bytes!(concat!(env!("GI_KERNELS_DIR"), "/software.spv"));
const RAY_QUERY_SPV: &[u8] = include_bytes!(concat!(env!("GI_KERNELS_DIR"), "/ray-query.spv"));

impl KernelVariant {
    /// Both variants, software first.
    pub const ALL: [Self; 2] = [Self::Software, Self::RayQuery];

    /// Applies `mode` to a device: `Auto` prefers ray queries; a forced mode the device cannot run
    /// is an error naming the missing feature.
    pub fn resolve(mode: TraceMode, caps: &Capabilities) -> Result<Self> {
        match mode {
            TraceMode::Software => Ok(Self::Software),
            TraceMode::Auto if caps.ray_query => Ok(Self::RayQuery),
            TraceMode::Auto => Ok(Self::Software),
            TraceMode::RayQuery if caps.ray_query => Ok(Self::RayQuery),
            TraceMode::RayQuery => Err(Error::MissingFeature {
                device: caps.name.clone(),
                feature:
                    "VK_KHR_ray_query (with VK_KHR_acceleration_structure and bufferDeviceAddress)"
                        .into(),
                needed_for: "--trace ray-query".into(),
            }),
        }
    }

    /// The module this variant's tracing kernels come from, as words (the common module in
    /// software).
    pub fn tracing_spirv_words(self) -> Vec<u32> {
        match self {
            Self::RayQuery => words(RAY_QUERY_SPV),
            Self::Software => common_spirv_words(),
        }
    }

    /// The names of every kernel a context of this variant runs.
    pub fn entry_points(self) -> Vec<String> {
        let mut names = entry_points(&common_spirv_words());
        if self == Self::RayQuery {
            // The tracing kernels are in both modules: list them once.
            names.retain(|n| !traces(n));
            names.extend(entry_points(&words(RAY_QUERY_SPV)));
        }
        names
    }
}

/// The common module (every kernel, tracing in software), as words.
pub fn common_spirv_words() -> Vec<u32> {
    words(SOFTWARE_SPV)
}

fn words(bytes: &[u8]) -> Vec<u32> {
    // The build script checked the module against its manifest; a malformed one is a build bug.
    ash::util::read_spv(&mut std::io::Cursor::new(bytes)).unwrap_or_default()
}

/// Whether kernel `entry` traces rays: the kernels built with ray queries are exactly those.
pub fn traces(entry: &str) -> bool {
    static TRACING: OnceLock<Vec<String>> = OnceLock::new();
    TRACING
        .get_or_init(|| entry_points(&words(RAY_QUERY_SPV)))
        .iter()
        .any(|e| e == entry)
}

impl fmt::Display for KernelVariant {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::RayQuery => "ray query",
            Self::Software => "software BVH traversal",
        })
    }
}

/// Entry point names declared by `OpEntryPoint` instructions of a SPIR-V module.
pub fn entry_points(words: &[u32]) -> Vec<String> {
    const OP_ENTRY_POINT: u32 = 15;
    let mut names = vec![];
    let mut i = 5; // past the header
    while i < words.len() {
        let count = (words[i] >> 16) as usize;
        if count == 0 || i + count > words.len() {
            break;
        }
        if words[i] & 0xffff == OP_ENTRY_POINT && count > 3 {
            let bytes: Vec<u8> = words[i + 3..i + count]
                .iter()
                .flat_map(|w| w.to_le_bytes())
                .take_while(|&b| b != 0)
                .collect();
            names.push(String::from_utf8_lossy(&bytes).into_owned());
        }
        i += count;
    }
    names
}

#[cfg(test)]
mod tests {
    use super::*;

    fn caps(ray_query: bool) -> Capabilities {
        Capabilities::for_tests(ray_query)
    }

    #[test]
    fn auto_prefers_ray_queries_and_falls_back_to_software() {
        assert_eq!(
            KernelVariant::resolve(TraceMode::Auto, &caps(true)).unwrap(),
            KernelVariant::RayQuery
        );
        assert_eq!(
            KernelVariant::resolve(TraceMode::Auto, &caps(false)).unwrap(),
            KernelVariant::Software
        );
        assert_eq!(
            KernelVariant::resolve(TraceMode::Software, &caps(true)).unwrap(),
            KernelVariant::Software
        );
    }

    #[test]
    fn forced_ray_queries_without_them_name_the_missing_feature() {
        let err = KernelVariant::resolve(TraceMode::RayQuery, &caps(false)).unwrap_err();
        assert!(matches!(err, Error::MissingFeature { .. }), "{err:?}");
        // One line: the device, the feature, and the setting that needs it.
        assert_eq!(
            err.to_string(),
            "device \"test device\" lacks VK_KHR_ray_query (with VK_KHR_acceleration_structure \
             and bufferDeviceAddress), needed for --trace ray-query"
        );
    }

    #[test]
    fn entry_points_are_read_from_the_modules() {
        assert!(
            KernelVariant::Software
                .entry_points()
                .contains(&"smoke::smoke".to_string())
        );
        assert!(entry_points(&[]).is_empty());
        // Only tracing kernels are built twice.
        assert!(traces("trace_rays::trace_rays"));
        assert!(!traces("smoke::smoke"));
        let rq = KernelVariant::RayQuery.entry_points();
        assert!(rq.contains(&"smoke::smoke".to_string()), "{rq:?}");
        assert_eq!(rq.len(), KernelVariant::Software.entry_points().len());
        // A truncated module yields what was complete, without panicking.
        let words = KernelVariant::RayQuery.tracing_spirv_words();
        let _ = entry_points(&words[..words.len() / 2]);
    }

    /// The modules just built from source are those shipped for builds without the nightly, and
    /// the shipped manifest is the one these sources give (the hash a precompiled build checks).
    #[cfg(feature = "build-kernels")]
    #[test]
    fn shipped_kernels_are_the_ones_built_from_source() {
        let shipped = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("kernels-spirv");
        let built = std::path::Path::new(env!("GI_KERNELS_DIR"));
        // Read at run time: a missing shipped file fails this test, not the workspace's build.
        for file in ["software.spv", "ray-query.spv", "manifest.toml"] {
            let read = |dir: &std::path::Path| std::fs::read(dir.join(file)).unwrap_or_default();
            let (shipped, built) = (read(&shipped), read(built));
            assert!(
                !built.is_empty() && built == shipped,
                "kernels changed: run scripts/build-kernels.sh (host/kernels-spirv/{file}: \
                 {} bytes shipped, {} built from source)",
                shipped.len(),
                built.len()
            );
        }
    }
}
