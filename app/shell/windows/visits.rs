//! Where the kiosk keeps what visitors did, across resets and restarts: each exhibit's statistics
//! (`EXHIBIT/stats.json`, loaded when the windows open) and the visit log (`visits.jsonl`), in the
//! state directory. The core hands over the visits that ended; they are stamped with wall-clock
//! times (kiosk time 0 is when the windows opened; a soak run's kiosk time runs `speed` times the
//! wall's) and written at a visit's end, not every frame.

use super::Exhibit;
use kiosk_content::stats;
use kiosk_core::kiosk::Kiosk;
use std::path::{Path, PathBuf};

/// The state directory and the wall-clock origin of the kiosk's time.
pub(super) struct VisitLog {
    state_dir: PathBuf,
    /// Unix time of kiosk time 0.
    wall_origin: f64,
    /// Kiosk seconds per wall second.
    speed: f64,
}

impl VisitLog {
    /// The log in `state_dir`, kiosk time 0 now; each exhibit's saved statistics handed to `kiosk`.
    pub(super) fn open<B: AsRef<[u8]>>(
        state_dir: PathBuf,
        speed: f64,
        exhibits: &[&Exhibit],
        kiosk: &mut Kiosk<'_, B>,
    ) -> Self {
        tracing::info!("visit statistics in {}", state_dir.display());
        let wall_origin = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0.0, |d| d.as_secs_f64());
        let log = Self { state_dir, wall_origin, speed: speed.max(1e-3) };
        log.hand_stats(exhibits, kiosk);
        log
    }

    /// Each exhibit's saved statistics handed to `kiosk`, whose models are `exhibits` in order
    /// (at the start, and when exhibits imported behind the gallery join it).
    pub(super) fn hand_stats<B: AsRef<[u8]>>(&self, exhibits: &[&Exhibit], kiosk: &mut Kiosk<'_, B>) {
        for (i, ex) in exhibits.iter().enumerate() {
            let path = stats::stats_path(&self.state_dir, &stats::exhibit_name(&ex.dir));
            kiosk.set_stats(i, stats::load_stats(&path));
        }
    }

    /// The state directory.
    pub(super) fn dir(&self) -> &Path {
        &self.state_dir
    }

    /// Writes the visits that ended to the log, and the statistics of the exhibits they explored
    /// (all of them at `exit`); a write that fails goes to `report` (what, error).
    pub(super) fn persist<B: AsRef<[u8]>>(
        &self,
        kiosk: &mut Kiosk<'_, B>,
        exhibits: &[&Exhibit],
        exit: bool,
        report: &mut dyn FnMut(&str, String),
    ) {
        let mut touched = std::collections::BTreeSet::new();
        for mut v in kiosk.take_visits() {
            v.wall_start = Some(self.wall_origin + v.start / self.speed);
            v.wall_end = Some(self.wall_origin + v.end / self.speed);
            for m in &mut v.models {
                m.exhibit = exhibits.get(m.model).map(|e| stats::exhibit_name(&e.dir)).unwrap_or_default();
                touched.insert(m.model);
            }
            if let Err(e) = stats::append_visit(&self.state_dir, &v, stats::LogLimits::default()) {
                report("visit log", format!("{e:#}"));
            }
        }
        if exit {
            touched.extend(0..exhibits.len());
        }
        for i in touched {
            let (Some(ex), Some(s)) = (exhibits.get(i), kiosk.stats().get(i)) else { continue };
            if s.visits == 0 && s.nodes.is_empty() {
                continue;
            }
            let path = stats::stats_path(&self.state_dir, &stats::exhibit_name(&ex.dir));
            if let Err(e) = stats::save_stats(&path, s) {
                report("statistics", format!("{e:#}"));
            }
        }
    }
}
