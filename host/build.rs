//! Compiles `kernels/` to SPIR-V twice, both builds at once: without features (every kernel,
//! tracing by walking the BVH in software) and with `ray-query` (only the kernels that trace, with
//! `VK_KHR_ray_query`). The host takes non-tracing kernels from the first module in either
//! variant (see `kernels::KernelVariant`).
//!
//! Without the `kernels` feature only the scene configuration below is done: rust-gpu's backend
//! is not even a dependency then.

use std::path::PathBuf;

/// Where the third-party scenes are, from this package's directory.
const THIRD_PARTY_SCENES: &str = "../../shared/scenes/third-party";

fn main() {
    // Third-party scenes stay beside the repository, in ../shared: tests and benchmarks that
    // read them are ignored, saying why, where it is absent (a user's clone).
    let third_party = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join(THIRD_PARTY_SCENES);
    println!("cargo::rustc-check-cfg=cfg(third_party_scenes)");
    // Cargo reruns a build script on every build that watches a path which does not exist (and
    // rebuilds the crate): watch the deepest ancestor that does, which changes when it appears.
    let watched = third_party
        .ancestors()
        .find(|p| p.exists())
        .unwrap_or(&third_party);
    println!("cargo::rerun-if-changed={}", watched.display());
    if third_party.is_dir() {
        println!("cargo::rustc-cfg=third_party_scenes");
    }
    #[cfg(feature = "kernels")]
    kernels::build_all();
}

/// The kernel builds.
#[cfg(feature = "kernels")]
mod kernels {
    use spirv_builder::{Capability, ModuleResult, SpirvBuilder, SpirvMetadata};
    use std::path::{Path, PathBuf};
    use std::str::FromStr;

    struct Variant {
        env: &'static str,
        target_dir: &'static str,
        features: &'static [&'static str],
        capabilities: &'static [Capability],
        extensions: &'static [&'static str],
    }

    const VARIANTS: &[Variant] = &[
        Variant {
            env: "GI_KERNELS_SOFTWARE_SPV",
            target_dir: "spirv-software",
            features: &[],
            capabilities: &[],
            extensions: &[],
        },
        Variant {
            env: "GI_KERNELS_RAY_QUERY_SPV",
            target_dir: "spirv-ray-query",
            features: &["ray-query"],
            capabilities: &[Capability::RayQueryKHR],
            extensions: &["SPV_KHR_ray_query"],
        },
    ];

    /// Builds both variants and tells rustc where their modules are.
    pub fn build_all() {
        let kernels = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../kernels");
        // Each build is one mostly serial rustc: side by side they take the time of the longer.
        let modules: Vec<(&str, PathBuf)> = std::thread::scope(|s| {
            let builds: Vec<_> = VARIANTS
                .iter()
                .map(|v| s.spawn(|| (v.env, build(&kernels, v))))
                .collect();
            builds
                .into_iter()
                .map(|b| b.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        });
        for (env, path) in modules {
            println!("cargo::rustc-env={env}={}", path.display());
        }
    }

    /// Builds one variant and returns the module's path.
    fn build(kernels: &Path, v: &Variant) -> PathBuf {
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
            .unwrap_or_else(|e| panic!("kernels ({}): {e}", v.env));
        match result.module {
            ModuleResult::SingleModule(path) => path,
            ModuleResult::MultiModule(_) => panic!("kernels ({}): expected one module", v.env),
        }
    }
}
