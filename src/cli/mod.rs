//! The `trimorph` command line.
//!
//! Exit codes: 0 success; 1 bad input or I/O failure; 2 the edit is not solvable
//! (`trimorph solve`). Outputs are written atomically (temporary file, then rename).

mod bench;
mod solve;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// Exit code for bad input and I/O errors.
pub const EXIT_INPUT: i32 = 1;
/// Exit code for an edit that is not solvable.
pub const EXIT_UNSOLVABLE: i32 = 2;

/// Smooth (C1), exactly constrained, editable deformations.
#[derive(Parser, Debug)]
#[command(name = "trimorph", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Edit parameters under exact affine constraints (ECLES) from a JSON problem.
    Solve {
        /// Problem file (JSON; `-` for standard input).
        system: PathBuf,
        /// Output file (JSON); standard output when absent.
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Run the demonstration on the bundled examples.
    Demo {
        /// Folder for the demo's outputs.
        #[arg(short, long, default_value = "out/demo")]
        output: PathBuf,
    },
    /// Measurements and experiments.
    Bench {
        #[command(subcommand)]
        which: BenchCommand,
    },
}

#[derive(Subcommand, Debug)]
enum BenchCommand {
    /// Bit-size growth of the fraction-free LDU factors (thesis figs. 7.1-7.10): CSV + PNG.
    Bitgrowth {
        /// Output folder.
        #[arg(short, long, default_value = "out/bitgrowth")]
        output: PathBuf,
        /// Random matrices per point.
        #[arg(long, default_value_t = 20)]
        trials: usize,
        /// Fewer x values (for a fast check).
        #[arg(long)]
        quick: bool,
        /// Random seed.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Run only the experiments whose id contains this text (e.g. fig7_1).
        #[arg(long)]
        only: Option<String>,
    },
}

/// An error that maps to a specific exit code.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
pub struct Exit {
    /// Process exit code.
    pub code: i32,
    /// Human-readable text (already printed when `printed`).
    pub message: String,
    /// Whether the message was already written to stderr.
    pub printed: bool,
}

/// Parses the arguments, runs the command and returns the exit code.
pub fn run() -> i32 {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Solve { system, output } => solve::run(&system, output.as_deref()),
        Command::Demo { output } => solve::demo(&output),
        Command::Bench { which: BenchCommand::Bitgrowth { output, trials, quick, seed, only } } => {
            bench::bitgrowth(&output, trials, quick, seed, only.as_deref())
        }
    };
    match result {
        Ok(()) => 0,
        Err(e) => match e.downcast_ref::<Exit>() {
            Some(x) => {
                if !x.printed {
                    eprintln!("error: {}", x.message);
                }
                x.code
            }
            None => {
                // A closed pipe (`trimorph ... | head`) is not an error of ours.
                if let Some(io) = e.downcast_ref::<std::io::Error>() {
                    if io.kind() == std::io::ErrorKind::BrokenPipe {
                        return 0;
                    }
                }
                eprintln!("error: {e:#}");
                EXIT_INPUT
            }
        },
    }
}
