//! `wavetrace`: render glTF scenes on a Vulkan device or the CPU, list devices, benchmark,
//! verify, compare and merge renders. Dispatch only: each command lives in its own file of
//! `src/cmd/`, with its arguments beside it. Scripts depend on these names; keep them.

mod cmd;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(
    name = "wavetrace",
    version = cmd::version::LONG,
    about = "Headless GPU wavefront path tracer with a CPU reference integrator"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a glTF scene (.gltf or .glb) to EXR or PNG.
    Render(cmd::options::RenderArgs),
    /// List the Vulkan devices and their indices for --gpu-index.
    Devices,
    /// Measure samples/s and rays/s of the GPU and CPU integrators on the committed scenes.
    Bench(cmd::bench_args::BenchArgs),
    /// Render each scene on the GPU and with the CPU reference (or once against a stored
    /// reference) and test per tile that they agree; exit status 0 if every scene agrees, 1 if
    /// one differs, 2 on errors. Writes JUnit, JSON and an HTML report on request.
    Verify(cmd::verify::VerifyArgs),
    /// Test whether two EXR renders by wavetrace have the same expectation (per-tile Welch
    /// tests); exit status 0 if they agree, 1 if they differ, 2 on errors, like diff(1).
    Compare(cmd::compare::CompareArgs),
    /// Merge shards of one render (EXRs written with --sample-range or --shard, in any order)
    /// into the EXR one render of all their samples gives; refuses shards of different
    /// settings, overlapping ranges or missing samples, naming the files.
    Merge(cmd::merge::MergeArgs),
    /// The lecture's Monte Carlo estimators on 1-D integrals with known values: each one's mean,
    /// measured variance and the variance the lecture's formulas predict; exit status 1 if a
    /// check fails.
    Estimators(cmd::estimators::EstimatorsArgs),
}

fn main() -> ExitCode {
    // A closed pipe (`wavetrace compare a b | head`) ends the process quietly, as for any Unix
    // tool, instead of making println! panic.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) if args.frames.is_some() => cmd::sequence::render_sequence(&args),
        Command::Render(args) => cmd::render::render(&args),
        Command::Devices => cmd::devices::devices(),
        Command::Bench(args) => cmd::bench::bench(&args),
        Command::Estimators(args) => return exit_like_diff(cmd::estimators::estimators(&args)),
        Command::Verify(args) => return exit_like_diff(cmd::verify::verify(&args)),
        Command::Compare(args) => return exit_like_diff(cmd::compare::compare(&args)),
        Command::Merge(args) => cmd::merge::merge(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Exit status of the commands that answer a yes/no question, like diff(1): 0 yes, 1 no,
/// 2 error. Every command's errors exit 2 (docs/usage.md, "Exit status"): 1 always means a
/// check that ran and failed.
fn exit_like_diff(answer: Result<bool>) -> ExitCode {
    match answer {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
