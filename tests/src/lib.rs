//! Support for the integration tests: contexts with validation on, and the check that it stayed
//! silent.

use gi_host::vulkan::{Context, ContextOptions};
use gi_host::{KernelVariant, TraceMode};

/// A context on the test device with the validation layer on, running `variant`.
pub fn context(variant: KernelVariant) -> Context {
    let trace = match variant {
        KernelVariant::RayQuery => TraceMode::RayQuery,
        KernelVariant::Software => TraceMode::Software,
    };
    let ctx = Context::new(&ContextOptions {
        validation: true,
        device: None,
        trace,
    })
    .unwrap_or_else(|e| panic!("cannot open a Vulkan device for {variant} kernels: {e}"));
    assert_eq!(ctx.variant(), variant);
    ctx
}

/// Destroys `ctx` and fails the test on any validation warning or error, leaks included.
pub fn finish_without_validation_messages(ctx: Context) {
    let messages = ctx.finish().expect("tests always run with validation on");
    assert!(
        messages.is_empty(),
        "{} validation messages:\n{}",
        messages.len(),
        messages.join("\n")
    );
}

/// Path of a file under the repository's `scenes/`.
pub fn scene_path(file: &str) -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../scenes")
        .join(file)
}
