//! Progress of a solver list on the terminal.

use std::io::IsTerminal;

/// Prints progress on a terminal as a bar, otherwise as plain lines every 10 %.
pub struct Progress {
    bar: Option<indicatif::ProgressBar>,
    total: u64,
    next_report: u64,
}

impl Progress {
    /// Progress of `total` steps of the list `label`, nothing done yet.
    pub fn new(label: &str, total: u64) -> Self {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = indicatif::ProgressBar::new(total);
            if let Ok(style) = indicatif::ProgressStyle::with_template(
                "{msg} [{bar:40}] {pos}/{len} steps, {elapsed_precise} elapsed, ETA {eta}",
            ) {
                bar.set_style(style.progress_chars("=> "));
            }
            bar.set_message(label.to_string());
            bar
        });
        Self {
            bar,
            total,
            next_report: 1,
        }
    }

    /// Step `step` is done.
    pub fn update(&mut self, step: u64) {
        if let Some(bar) = &self.bar {
            bar.set_position(step);
        } else if self.total > 0 && step * 10 >= self.next_report * self.total {
            eprintln!(
                "  step {step}/{} ({}%)",
                self.total,
                step * 100 / self.total
            );
            self.next_report = step * 10 / self.total + 1;
        }
    }

    /// The list ended (or stopped): the bar is closed.
    pub fn finish(self) {
        if let Some(bar) = self.bar {
            bar.finish();
        }
    }
}
