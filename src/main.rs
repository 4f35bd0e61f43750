//! The `lincal` command line; its contract is `shared/interface.md`.
//!
//! ```text
//! lincal basis SPEC [--format text|json]
//! lincal calibrate SPEC DATA.csv [--refine] [--format text|json]
//! lincal simulate SPEC --poses N [--seed S] [--truth TRUTH.yaml] [--noise-track M]
//!                 [--noise-encoder RAD] [--noise-measure M] [--noise-orientation RAD]
//!                 [--truth-out FILE]
//! lincal import ROBOT.urdf --base LINK --tip LINK [--tool x,y,z] [--convention dh|mdh]
//!                 [--constraint measured|point|plane|sphere|line]          # spec on stdout
//! lincal predict SPEC (--params RESULT.json | --nominal) DATA.csv...      # tips, CSV
//! lincal evaluate SPEC (--params RESULT.json | --nominal) DATA.csv... [--format text|json]
//! lincal compensate SPEC (--params RESULT.json | --nominal) TARGETS.csv [--format text|json]
//!                 [--allow-failed]                       # compensated joints, CSV
//! lincal demo
//! ```
//! `calibrate` and `predict` take several data files (one per constraint of a list),
//! `--angles rad|deg|auto` (the unit of revolute readings, default `auto`) and
//! `--no-header --columns q1,q2,…`; `calibrate` writes `--write-spec OUT.yaml` and
//! `--write-urdf OUT.urdf`, and judges held-out data with `--validate A.csv[,B.csv]`
//! (repeatable, one placement each) and `--folds K` (cross-validation).
//! Exit status: 0 on success, 2 on bad input (the message names the file, line and field; a
//! command-line usage error is bad input too), 1 on anything else (degenerate data, with the
//! reason). A panic is caught and reported as an internal error (exit 1); none is expected on
//! any input.
//!
//! This file only starts the process and dispatches: each subcommand lives in its own file of
//! [`cli`], with its clap arguments and its run function.

use std::io::Write as _;
use std::process::ExitCode;

use lincal::error::ErrorClass;

mod cli;
mod facts_cache;
mod heap;
mod html_report;
mod inputs;
mod outputs;
mod progress;

fn main() -> ExitCode {
    heap::tune_for_engine();
    // A write past the file-size limit fails with EFBIG (the temporary output is removed
    // and the error named) instead of the signal killing the process mid-write.
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to "ignore" before any thread is started.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
    std::panic::set_hook(Box::new(|info| {
        eprintln!("lincal: internal error (a bug, please report it): {info}");
    }));
    match std::panic::catch_unwind(run) {
        Ok(code) => code,
        Err(_) => ExitCode::from(1),
    }
}

/// Parses the command line and runs it; the exit status.
fn run() -> ExitCode {
    let parsed = match cli::Cli::try_parse_args() {
        Ok(parsed) => parsed,
        Err(e) => {
            let _ = e.print();
            return if e.use_stderr() {
                ExitCode::from(2)
            } else {
                ExitCode::SUCCESS
            };
        }
    };
    let out = std::io::stdout();
    let mut out = std::io::BufWriter::new(out.lock());
    let result = cli::execute(parsed.command, parsed.max_terms, &mut out)
        .and_then(|()| out.flush().map_err(|e| cli::io_err(&e)));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if cli::is_broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            for line in e.to_string().lines() {
                eprintln!("lincal: error: {line}");
            }
            match e.class() {
                ErrorClass::Input => ExitCode::from(2),
                ErrorClass::Degenerate | ErrorClass::Other => ExitCode::from(1),
            }
        }
    }
}
