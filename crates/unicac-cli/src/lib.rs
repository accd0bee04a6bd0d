//! `unicac`: one CLI over the pipeline, as a library so that the binary (`main.rs`) and the Python
//! package's `unicac` command (`unicac._native.main`, crates/unicac-py) run the same code. Argument
//! definitions live in `args.rs`; each command in `commands/`. Errors become one clear line on stderr
//! and a non-zero exit code.

mod args;
mod commands;
mod lens_input;
mod outputs;
mod progress_display;

use clap::Parser;
use std::ffi::OsString;
use std::io::Write;
use std::path::PathBuf;

/// What the process running the CLI knows about itself.
#[derive(Debug, Clone, Default)]
pub struct Host {
    /// The Python interpreter running the CLI (the `unicac` command of the Python package): its
    /// packages are the first place onnxruntime is looked for after `UNICAC_PYTHON`, and its pip
    /// fetches weights.
    pub python: Option<PathBuf>,
}

/// Runs `unicac ARGS...` (`argv[0]` is the program name) and returns the process's exit code: 0 on
/// success, 1 on an error (printed on stderr), 2 on a usage error (clap's message). Stdout is flushed
/// before returning.
pub fn run(argv: impl IntoIterator<Item = impl Into<OsString> + Clone>, host: &Host) -> u8 {
    // Like any Unix filter, stop quietly when the reader of stdout goes away (`unicac ... | head`),
    // instead of ignoring SIGPIPE (Rust's and Python's default) and failing on the next write.
    // SAFETY: setting a signal's disposition to its default has no preconditions.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    give_vulkan_a_runtime_dir();
    let code = match args::Cli::try_parse_from(argv) {
        Ok(cli) => match commands::run(cli.command, host) {
            Ok(()) => 0,
            Err(error) => {
                eprintln!("error: {}", message(&error));
                1
            }
        },
        // Help and version go to stdout with code 0, usage errors to stderr with code 2.
        Err(usage) => {
            let _ = usage.print();
            u8::try_from(usage.exit_code()).unwrap_or(2)
        }
    };
    // A Python host exits without Rust's runtime cleanup, which is what flushes stdout in a binary.
    let _ = std::io::stdout().flush();
    code
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
/// error of this run. Point it at a private directory (mode 0700, as the XDG spec requires) before the
/// command starts any thread; a set variable is left alone.
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
        // SAFETY: no thread of the CLI runs yet; a Python host runs the CLI from its main thread with
        // the GIL released and starts no threads of its own for the `unicac` command.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}
