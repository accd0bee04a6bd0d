//! `unicac`: one CLI over the pipeline. Argument definitions live in `args.rs`; each command in
//! `commands/`. Errors become one clear line on stderr and a non-zero exit code.

mod args;
mod commands;
mod lens_input;

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    // Like any Unix filter, stop quietly when the reader of stdout goes away (`unicac ... | head`),
    // instead of Rust's default of ignoring SIGPIPE and panicking on the next write.
    // SAFETY: restoring the default disposition of a signal before any thread starts.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = args::Cli::parse();
    match commands::run(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
