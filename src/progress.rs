//! Progress bars on stderr, drawn with indicatif only when stderr is a terminal: the binary's
//! implementation of [`lincal::progress::Progress`] (the core stays free of terminal
//! concerns), and a spinner for a long symbolic expansion.

use std::io::IsTerminal as _;
use std::sync::mpsc;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use lincal::progress::Progress;

/// Poses from which `calibrate` and `simulate` show their progress.
pub const MANY_POSES: usize = 100_000;

/// `--folds` work ([`lincal::calibrate::validation::fold_work`]) from which `calibrate` shows
/// its progress: about 3 s.
pub const LONG_FOLD_WORK: u64 = 200_000_000;

/// A data file at least this large (3 MiB: about 10⁵ poses of a two-joint arm, fewer of a
/// longer one) is read with a bar.
pub const BIG_FILE: u64 = 3 << 20;

/// How long an expansion runs before its spinner appears (a small spec never shows one).
pub const SPINNER_DELAY: Duration = Duration::from_millis(500);

/// Whether progress may be drawn at all: stderr is a terminal.
fn terminal() -> bool {
    std::io::stderr().is_terminal()
}

/// A progress bar on stderr, or nothing; cleared when finished or dropped (so an error
/// message is never printed over it).
pub struct Bar(Option<ProgressBar>);

impl Bar {
    /// A bar shown when `show` holds and stderr is a terminal; nothing otherwise.
    pub fn new(show: bool) -> Bar {
        // Hidden until its first stage is set up.
        Bar((show && terminal()).then(ProgressBar::hidden))
    }
}

impl Progress for Bar {
    fn stage(&self, name: &str, len: Option<u64>) {
        let Some(bar) = &self.0 else {
            return;
        };
        // Style, message and length first, then drawing: no frame of a half-set bar.
        let template = match len {
            Some(_) => "{msg} [{bar:40.cyan/blue}] {percent:>3}% ({elapsed}, {eta} left)",
            None => "{spinner} {msg} ({elapsed})",
        };
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style.progress_chars("=> "));
        }
        bar.set_message(name.to_string());
        match len {
            Some(len) => {
                bar.disable_steady_tick();
                bar.set_length(len);
            }
            None => bar.unset_length(),
        }
        bar.reset();
        if bar.is_hidden() {
            bar.set_draw_target(ProgressDrawTarget::stderr());
        }
        if len.is_none() {
            bar.enable_steady_tick(Duration::from_millis(120));
        }
    }

    fn inc(&self, delta: u64) {
        if let Some(bar) = &self.0 {
            bar.inc(delta);
        }
    }

    fn finish(&self) {
        if let Some(bar) = &self.0 {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Bar {
    fn drop(&mut self) {
        self.finish();
    }
}

/// A spinner that appears on stderr (a terminal only) when the work it watches lasts longer
/// than a delay, and goes away when dropped.
pub struct Spinner {
    done: Option<mpsc::Sender<()>>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Spinner {
    /// Watches the work until the spinner is dropped; after `delay`, shows `message`.
    pub fn after(delay: Duration, message: &str) -> Spinner {
        if !terminal() {
            return Spinner {
                done: None,
                thread: None,
            };
        }
        let (tx, rx) = mpsc::channel::<()>();
        let message = message.to_string();
        let thread = std::thread::spawn(move || {
            if rx.recv_timeout(delay) != Err(mpsc::RecvTimeoutError::Timeout) {
                return;
            }
            let bar = Bar::new(true);
            bar.stage(&message, None);
            // Until the sender is dropped.
            let _ = rx.recv();
            bar.finish();
        });
        Spinner {
            done: Some(tx),
            thread: Some(thread),
        }
    }
}

impl Drop for Spinner {
    fn drop(&mut self) {
        self.done.take();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}
