//! `gi`: the command-line program of the GI-1.0 port.

use clap::{Parser, Subcommand};
use gi_host::TraceMode;
use gi_host::vulkan::{Context, ContextOptions};
use std::process::ExitCode;

/// Real-time global illumination (GI-1.0 two-level radiance caching) on any Vulkan device.
#[derive(Parser)]
#[command(version, about)]
struct Cli {
    /// Device to use: index or part of its name (also GI_DEVICE). Default: discrete GPU, then
    /// integrated, then CPU (lavapipe).
    #[arg(long, global = true)]
    device: Option<String>,
    /// How rays are traced: ray queries where available (auto), forced ray queries, or the
    /// software BVH traversal that runs everywhere.
    #[arg(long, value_enum, default_value_t = TraceMode::Auto, global = true)]
    trace: TraceMode,
    /// Turn the Vulkan validation layer on and fail on any message it prints.
    #[arg(long, global = true)]
    validation: bool,
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Report the chosen device and its capabilities, then run a smoke dispatch (the default).
    Info {
        /// Invocations of the smoke kernel.
        #[arg(long, default_value_t = 1 << 16)]
        invocations: u32,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(&cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: &Cli) -> Result<(), Box<dyn std::error::Error>> {
    let options = ContextOptions {
        validation: cli.validation,
        device: cli.device.clone(),
        trace: cli.trace,
    };
    let invocations = match cli.command {
        Some(Command::Info { invocations }) => invocations,
        None => 1 << 16,
    };
    let ctx = Context::new(&options)?;
    println!("{}", ctx.capabilities());
    println!("kernels:             {}", ctx.variant());
    let report = gi_host::smoke::run(&ctx, invocations)?;
    let timing = report
        .gpu_ms
        .map(|ms| format!(" in {ms:.3} ms GPU time"))
        .unwrap_or_default();
    if let Some(messages) = ctx.validation_messages()
        && !messages.is_empty()
    {
        return Err(format!("{} validation messages (printed above)", messages.len()).into());
    }
    if report.mismatches > 0 {
        return Err(format!(
            "smoke dispatch: {} of {} results differ from the CPU",
            report.mismatches, report.invocations
        )
        .into());
    }
    println!(
        "smoke dispatch:      ok, {} invocations match the CPU{timing}",
        report.invocations
    );
    Ok(())
}
