//! `unicac`: one CLI over the pipeline. Argument definitions live in `args.rs`; each command in
//! `commands/`. Errors become one clear line on stderr and a non-zero exit code.

mod args;
mod commands;
mod lens_input;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = args::Cli::parse();
    match commands::run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
