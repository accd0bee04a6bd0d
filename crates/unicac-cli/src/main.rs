//! `unicac`: one CLI over the pipeline. Argument definitions live in `args.rs`; each command in
//! `commands/`. Errors become one clear line on stderr and a non-zero exit code.

mod args;
mod commands;
mod lens_input;
mod outputs;

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
            eprintln!("error: {}", message(&error));
            ExitCode::FAILURE
        }
    }
}

/// The error and its causes on one line, each cause once: errors that already quote their source
/// (`path: No such file or directory`) do not get it appended a second time.
fn message(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let part = cause.to_string();
        if !text.contains(&part) {
            if !text.is_empty() {
                text.push_str(": ");
            }
            text.push_str(&part);
        }
    }
    text
}
