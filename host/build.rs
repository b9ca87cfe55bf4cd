//! The scene configuration, and the kernels: with the `build-kernels` feature compiled from
//! `kernels/` by rust-gpu (`build/kernels.rs`), else the modules shipped in `kernels-spirv/`,
//! checked against the sources beside them when those are present (`build/manifest.rs`). Either
//! way rustc gets `GI_KERNELS_DIR`, the folder with the modules and their manifest.

#[cfg(feature = "build-kernels")]
#[path = "build/kernels.rs"]
mod kernels;
#[path = "build/manifest.rs"]
mod manifest;

use std::path::{Path, PathBuf};

/// Where the third-party scenes are, from this package's directory.
const THIRD_PARTY_SCENES: &str = "../../shared/scenes/third-party";
/// The shipped modules, from this package's directory.
const SHIPPED: &str = "kernels-spirv";
/// What to do when the shipped modules do not match.
const REMEDY: &str = "run scripts/build-kernels.sh (needs the pinned nightly), or build gi-host \
                      with its `build-kernels` feature";

fn main() {
    let host = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    // Third-party scenes stay beside the repository, in ../shared: tests and benchmarks that
    // read them are ignored, saying why, where it is absent (a user's clone).
    let third_party = host.join(THIRD_PARTY_SCENES);
    println!("cargo::rustc-check-cfg=cfg(third_party_scenes)");
    watch(&third_party);
    if third_party.is_dir() {
        println!("cargo::rustc-cfg=third_party_scenes");
    }

    let repo = host.parent().expect("the package has a parent directory");
    let shipped = host.join(SHIPPED);
    let sources =
        manifest::Provenance::of_sources(repo).unwrap_or_else(|e| panic!("kernel sources: {e}"));
    let stale = manifest::check(&shipped, sources.as_ref()).err();
    if sources.is_some() {
        for input in manifest::inputs() {
            watch(&repo.join(input));
        }
    }
    watch(&shipped);
    #[cfg(feature = "build-kernels")]
    let dir = {
        let sources = sources.expect("building the kernels needs kernels/ beside host/");
        if let Some(stale) = stale {
            // A build without the feature would fail; the tests fail too (kernels::tests).
            println!("cargo::warning=kernels changed: {stale}; {REMEDY}");
        }
        let dir =
            PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR")).join(SHIPPED);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        let mut modules = vec![];
        for (file, built) in kernels::build_all(&repo.join("kernels")) {
            let bytes =
                std::fs::read(&built).unwrap_or_else(|e| panic!("{}: {e}", built.display()));
            std::fs::write(dir.join(file), &bytes)
                .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
            modules.push((file, bytes));
        }
        std::fs::write(dir.join(manifest::MANIFEST), sources.manifest(&modules))
            .unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        dir
    };
    #[cfg(not(feature = "build-kernels"))]
    let dir = {
        if let Some(stale) = stale {
            panic!("kernels changed: {stale}; {REMEDY}");
        }
        shipped
    };
    println!("cargo::rustc-env=GI_KERNELS_DIR={}", dir.display());
}

/// Reruns this script when `path` changes. Cargo reruns a build script on every build that
/// watches a path which does not exist (and rebuilds the crate): watch the deepest ancestor that
/// does, which changes when it appears.
fn watch(path: &Path) {
    let watched = path.ancestors().find(|p| p.exists()).unwrap_or(path);
    println!("cargo::rerun-if-changed={}", watched.display());
}
