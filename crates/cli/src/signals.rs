//! SIGINT and SIGTERM for long commands (`run`, `campaign`): the first one sets a flag the work
//! loop checks, so the command stops cleanly, writes what it has and exits with 128 + the
//! signal, as shells report it.
use anyhow::{Context, Result};
use std::sync::atomic::{AtomicBool, AtomicI32, Ordering};
use std::sync::Arc;

/// Set by SIGINT or SIGTERM.
pub struct Interrupt {
    /// Stop taking new work.
    pub stop: Arc<AtomicBool>,
    signal: Arc<AtomicI32>,
}

impl Interrupt {
    /// Installs the handlers; `message` is printed when a signal arrives.
    pub fn install(message: &'static str) -> Result<Self> {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let me = Self {
            stop: Arc::new(AtomicBool::new(false)),
            signal: Arc::new(AtomicI32::new(0)),
        };
        let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])
            .context("installing the SIGINT/SIGTERM handler")?;
        let (stop, signal) = (me.stop.clone(), me.signal.clone());
        // A thread blocked on the signal pipe: woken only by a signal.
        std::thread::spawn(move || {
            if let Some(sig) = signals.forever().next() {
                signal.store(sig, Ordering::SeqCst);
                stop.store(true, Ordering::SeqCst);
                eprintln!("\n{}: {message}", name(sig));
            }
        });
        Ok(me)
    }

    /// The signal received, if any.
    pub fn signal(&self) -> Option<i32> {
        match self.signal.load(Ordering::SeqCst) {
            0 => None,
            s => Some(s),
        }
    }

    /// Prints `message` and exits with the code of the signal received (SIGINT's when none
    /// was: the work stopped for it all the same).
    pub fn exit(&self, message: &str) -> ! {
        let sig = self.signal().unwrap_or(libc::SIGINT);
        eprintln!("{message}");
        std::process::exit(exit_code(sig));
    }
}

/// `SIGINT` or `SIGTERM`.
pub fn name(sig: i32) -> &'static str {
    if sig == libc::SIGINT {
        "SIGINT"
    } else {
        "SIGTERM"
    }
}

/// 130 for SIGINT, 143 for SIGTERM.
pub fn exit_code(sig: i32) -> i32 {
    128 + sig
}
