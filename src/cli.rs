//! How a `firefleet` binary starts and ends: logging to stderr, a closed pipe ending the
//! process quietly, an error's message and exit status.
//!
//! Not here: any command (the binaries' own modules).

use std::future::Future;
use std::process::ExitCode;

/// Run a command's `work` on a multi-threaded runtime, logging at `warn` when `quiet` (a
/// command that prints tables) and at `info` otherwise, unless `RUST_LOG` says otherwise.
/// An error is printed as `error: ...` with its causes and exits 2.
pub fn run(quiet: bool, work: impl Future<Output = anyhow::Result<ExitCode>>) -> ExitCode {
    end_quietly_on_a_closed_pipe();
    init_logging(if quiet { "warn" } else { "info,zenoh=warn" });
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("tokio runtime");
    match runtime.block_on(work) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

/// Log to stderr; `RUST_LOG` overrides `default`. Colour only on a terminal: a journal or a
/// log file would keep the escape codes.
fn init_logging(default: &str) {
    use std::io::IsTerminal as _;
    let filter =
        tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| default.into());
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
}

/// A reader that stops reading (`firefleet status | head`) ends this process quietly with
/// the status a shell gives a program a closed pipe stopped (141), instead of a panic on
/// the next `println!`. Not by restoring SIGPIPE's default: then a TLS link whose peer went
/// away (rustls writes with `writev`, which cannot ask for no signal) would kill a role
/// mid-incident; with SIGPIPE ignored, as Rust starts programs, a socket write fails with
/// an error its owner handles, and only printing to a closed stdout ends the process.
fn end_quietly_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or_default();
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(CLOSED_PIPE);
        }
        default(info);
    }));
}

/// The exit status of a program stopped by a closed pipe, as shells report it (128 +
/// SIGPIPE).
const CLOSED_PIPE: i32 = 141;
