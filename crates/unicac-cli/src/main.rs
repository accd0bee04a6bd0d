//! The `unicac` binary: the CLI of `lib.rs` with this process's arguments.

use std::process::ExitCode;

fn main() -> ExitCode {
    ExitCode::from(unicac_cli::run(std::env::args_os(), &unicac_cli::Host::default()))
}
