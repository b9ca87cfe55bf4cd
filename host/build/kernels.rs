//! Compiles `kernels/` to SPIR-V twice, both builds at once: without features (every kernel,
//! tracing by walking the BVH in software) and with `ray-query` (only the kernels that trace, with
//! `VK_KHR_ray_query`). The host takes non-tracing kernels from the first module in either
//! variant (see `kernels::KernelVariant`).
//!
//! This file's text is part of the sources hash of the shipped modules (`manifest.rs`): every
//! option that shapes the modules lives here.

use spirv_builder::{Capability, ModuleResult, SpirvBuilder, SpirvMetadata};
use std::path::{Path, PathBuf};
use std::str::FromStr;

struct Variant {
    /// The module's file name, in `kernels-spirv/` and in the build's output.
    file: &'static str,
    target_dir: &'static str,
    features: &'static [&'static str],
    capabilities: &'static [Capability],
    extensions: &'static [&'static str],
}

const VARIANTS: &[Variant] = &[
    Variant {
        file: super::manifest::MODULES[0],
        target_dir: "spirv-software",
        features: &[],
        capabilities: &[],
        extensions: &[],
    },
    Variant {
        file: super::manifest::MODULES[1],
        target_dir: "spirv-ray-query",
        features: &["ray-query"],
        capabilities: &[Capability::RayQueryKHR],
        extensions: &["SPV_KHR_ray_query"],
    },
];

/// Builds both variants and returns each module's file name and the path rust-gpu wrote it to.
pub fn build_all(kernels: &Path) -> Vec<(&'static str, PathBuf)> {
    // Each build is one mostly serial rustc: side by side they take the time of the longer.
    std::thread::scope(|s| {
        let builds: Vec<_> = VARIANTS
            .iter()
            .map(|v| s.spawn(|| (v.file, build(kernels, v))))
            .collect();
        builds
            .into_iter()
            .map(|b| b.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    })
}

/// Builds one variant and returns the module's path.
fn build(kernels: &Path, v: &Variant) -> PathBuf {
    // Names of interface variables only: no `OpLine`/`OpString`, so no absolute path of this
    // checkout gets into the module (the shipped modules are compared byte for byte).
    let mut b = SpirvBuilder::new(kernels, "spirv-unknown-vulkan1.2")
        .target_dir_path(v.target_dir)
        .spirv_metadata(SpirvMetadata::NameVariables)
        .shader_crate_features(v.features.iter().map(|s| s.to_string()));
    b.build_script.defaults = true;
    // The host enables a device feature for each of these (gi_shared::abi).
    for name in gi_shared::abi::KERNEL_CAPABILITIES {
        let c = Capability::from_str(name)
            .unwrap_or_else(|()| panic!("unknown SPIR-V capability {name}"));
        b = b.capability(c);
    }
    for c in v.capabilities {
        b = b.capability(*c);
    }
    for e in v.extensions {
        b = b.extension(*e);
    }
    let result = b
        .build()
        .unwrap_or_else(|e| panic!("kernels ({}): {e}", v.file));
    match result.module {
        ModuleResult::SingleModule(path) => path,
        ModuleResult::MultiModule(_) => panic!("kernels ({}): expected one module", v.file),
    }
}
