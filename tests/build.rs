//! Third-party scenes stay beside the repository, in `../shared`: the tests that read them are
//! ignored, saying why, where it is absent (a user's clone). Sets `cfg(third_party_scenes)`.

use std::path::PathBuf;

fn main() {
    let third_party =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes/third-party");
    println!("cargo::rustc-check-cfg=cfg(third_party_scenes)");
    // A watched path that does not exist reruns this script (and rebuilds the tests) on every
    // build: watch the deepest ancestor that exists, which changes when the scenes appear.
    let watched = third_party
        .ancestors()
        .find(|p| p.exists())
        .unwrap_or(&third_party);
    println!("cargo::rerun-if-changed={}", watched.display());
    if third_party.is_dir() {
        println!("cargo::rustc-cfg=third_party_scenes");
    }
}
