//! The library's [`platoon_app::Progress`] as a progress bar on the terminal (indicatif), and
//! its messages on stderr.
use std::sync::Mutex;

/// A progress bar per stage, drawn on stderr.
pub struct Bar {
    bar: Mutex<Option<indicatif::ProgressBar>>,
    /// What the stages count ("steps").
    unit: &'static str,
    /// Show the time left (stages whose units take long, such as campaign cells).
    eta: bool,
}

impl Default for Bar {
    /// A bar of simulated steps.
    fn default() -> Self {
        Self::counting("steps")
    }
}

impl Bar {
    /// A bar whose stages count `unit`s ("platoons", "runs").
    pub fn counting(unit: &'static str) -> Self {
        Self {
            bar: Mutex::default(),
            unit,
            eta: false,
        }
    }

    /// A bar of campaign cells, with the time left; a stage's first position is where it
    /// starts (cells finished before), not progress.
    pub fn cells() -> Self {
        Self {
            eta: true,
            ..Self::counting("")
        }
    }
}

impl platoon_app::Progress for Bar {
    fn start(&self, what: &str, total: u64) {
        let bar = indicatif::ProgressBar::new(total);
        let template = if self.eta {
            format!("{{spinner}} {what} {{pos}}/{{len}} [{{elapsed}} elapsed, ETA {{eta}}] {{wide_bar}} {{msg}}")
        } else {
            format!(
                "{{spinner}} {what} {{pos}}/{{len}} {} [{{elapsed}}] {{wide_bar}} {{msg}}",
                self.unit
            )
        };
        bar.set_style(indicatif::ProgressStyle::with_template(&template).expect("static template"));
        if let Some(old) = self
            .bar
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .replace(bar)
        {
            old.finish_and_clear();
        }
    }

    fn at(&self, done: u64) {
        if let Some(bar) = &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            let first = bar.position() == 0;
            bar.set_position(done);
            if self.eta && first {
                bar.reset_eta();
            }
        }
    }

    fn detail(&self, text: &str) {
        if let Some(bar) = &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            bar.set_message(text.to_string());
        }
    }

    fn finish(&self) {
        if let Some(bar) = self.bar.lock().unwrap_or_else(|e| e.into_inner()).take() {
            bar.finish_and_clear();
        }
    }

    fn message(&self, text: &str) {
        match &*self.bar.lock().unwrap_or_else(|e| e.into_inner()) {
            Some(bar) => bar.suspend(|| eprintln!("{text}")),
            None => eprintln!("{text}"),
        }
    }
}
