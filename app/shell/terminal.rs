//! The terminal side of `kiosk import`: its progress bar, and the cleanup of running imports when
//! the process is stopped by Ctrl+C or SIGTERM.

use indicatif::{ProgressBar, ProgressStyle};
use kiosk_content::import::Phase;

/// An import's progress bar on standard error: a bar when the phase's total is known, else the
/// count (a PLY, OBJ or glTF file does not say how many samples it makes).
pub struct ImportBar {
    shown: bool,
    /// The bar of the phase shown, with that phase and whether it has a total.
    bar: Option<(ProgressBar, Phase, bool)>,
}

impl ImportBar {
    /// A bar on the terminal, or none.
    pub fn new(shown: bool) -> Self {
        Self { shown, bar: None }
    }

    /// Shows that `phase` has done `done` of `total` (0: unknown).
    pub fn report(&mut self, phase: Phase, done: u64, total: u64) {
        if !self.shown {
            return;
        }
        let known = total > 0;
        match &self.bar {
            Some((pb, p, k)) if (*p, *k) == (phase, known) => {
                pb.set_length(total);
                pb.set_position(done);
            }
            _ => {
                // A new bar, whole before its first draw.
                if let Some((pb, ..)) = self.bar.take() {
                    pb.finish_and_clear();
                }
                let template = if known {
                    "{msg:>10} [{bar:40}] {human_pos}/{human_len} eta {eta}"
                } else {
                    "{msg:>10} {human_pos} samples, {elapsed}"
                };
                let style = ProgressStyle::with_template(template)
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> ");
                let pb =
                    ProgressBar::new(total).with_style(style).with_message(phase.name()).with_position(done);
                self.bar = Some((pb, phase, known));
            }
        }
    }
}

impl Drop for ImportBar {
    fn drop(&mut self) {
        if let Some((pb, ..)) = self.bar.take() {
            pb.finish_and_clear();
        }
    }
}

/// For `kiosk import`: on Ctrl+C or SIGTERM, removes the import's work directory, then exits
/// with status 130. (The kiosk closes on them as on Ctrl+Q: `windows::run`.)
pub fn clean_up_imports_on_signals() {
    let installed = ctrlc::set_handler(|| {
        kiosk_content::import::remove_work_dirs();
        std::process::exit(130);
    });
    if let Err(e) = installed {
        tracing::warn!("cannot clean up imports on signals: {e}");
    }
}
