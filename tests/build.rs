//! Third-party scenes stay beside the repository, in `../shared`: the tests that read them are
//! ignored, saying why, where it is absent (a user's clone). Sets `cfg(third_party_scenes)`.

use std::path::PathBuf;

fn main() {
    let third_party =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes/third-party");
    println!("cargo::rustc-check-cfg=cfg(third_party_scenes)");
    println!("cargo::rerun-if-changed={}", third_party.display());
    if third_party.is_dir() {
        println!("cargo::rustc-cfg=third_party_scenes");
    }
}
