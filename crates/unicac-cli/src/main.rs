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
    give_vulkan_a_runtime_dir();
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

/// Mesa's Vulkan drivers print "error: XDG_RUNTIME_DIR is invalid or not set in the environment" when a
/// device is opened from a shell without that variable (su, ssh without a session, cron, CI): not an
/// error of this run. Point it at a private directory (mode 0700, as the XDG spec requires) before any
/// thread starts; a set variable is left alone.
fn give_vulkan_a_runtime_dir() {
    use std::os::unix::fs::DirBuilderExt;
    if std::env::var_os("XDG_RUNTIME_DIR").is_some() {
        return;
    }
    // SAFETY: getuid has no preconditions and cannot fail.
    let uid = unsafe { libc::getuid() };
    let dir = std::env::temp_dir().join(format!("unicac-runtime-{uid}"));
    let made = std::fs::DirBuilder::new().mode(0o700).create(&dir);
    let usable = made.is_ok() || std::fs::metadata(&dir).is_ok_and(|m| m.is_dir());
    if usable {
        // SAFETY: single-threaded here (first thing in main), so no other thread reads the environment.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}
