//! What drives the kiosk's 60 Hz loop and what watches it, kept apart from the windows:
//! - [`Input`]: where touches come from — the live windows (recorded with `--record`, queued
//!   until their step; the mouse is a finger of its own, [`Pointer`]) and, with `--session`, a
//!   recorded session played at its own timing (over and over for a soak run, each new visitor
//!   2 s after the last one's final event). It is the touch source of the core's fixed-clock
//!   loop ([`kiosk_core::clock::Stepper`]).
//! - [`Probes`]: what the loop reports — the trace (`--trace`, one JSON line per step), the
//!   screenshots due (`--screenshot-at`) and a soak run's reports (`--run-for`): resident memory,
//!   open file descriptors and the size of the state directory (statistics and visit log).

use kiosk_core::clock::{SessionFeed, TouchSource};
use kiosk_core::gesture::{TouchEvent, TouchKind};
use kiosk_core::session::Session;
use std::io::Write;

/// Seconds between the end of a replayed visit and the next one in a soak run.
const NEXT_VISITOR_SECS: f64 = 2.0;

/// The touches of the live windows and of a recorded session, handed out at their step.
pub(super) struct Input {
    live: Vec<TouchEvent>,
    /// Where live touches are recorded (`--record`), until a write fails.
    record: Option<std::io::BufWriter<std::fs::File>>,
    /// The recorded session and where its playing stands (the core's feed, as replays use it).
    session: Option<(Session, SessionFeed)>,
}

impl Input {
    /// Live input recorded to `record`, plus `session` played from kiosk time 0 (again and
    /// again when `repeat`).
    pub(super) fn new(
        session: Option<Session>,
        repeat: bool,
        record: Option<std::io::BufWriter<std::fs::File>>,
    ) -> Self {
        let feed = if repeat { SessionFeed::repeating(NEXT_VISITOR_SECS) } else { SessionFeed::once() };
        Self { live: Vec::new(), record, session: session.map(|s| (s, feed)) }
    }

    /// Queues a live touch for the step at or after its time, and records it. A record that
    /// cannot be written stops (the error is returned once); the touch is queued all the same.
    pub(super) fn push(&mut self, e: TouchEvent) -> std::io::Result<()> {
        self.live.push(e);
        let Some(w) = self.record.as_mut() else { return Ok(()) };
        let line = serde_json::to_string(&e).unwrap_or_default();
        writeln!(w, "{line}").and_then(|()| w.flush()).inspect_err(|_| self.record = None)
    }

    /// Kiosk time at which a session run is over (`run_for` for a soak run), `None` when live.
    pub(super) fn end(&self, run_for: Option<f64>) -> Option<f64> {
        self.session.as_ref().map(|(s, _)| run_for.unwrap_or(s.duration() + 1.0))
    }
}

impl TouchSource for Input {
    /// Hands `feed` every touch due at kiosk time `t`, the session's first, in order; a live
    /// touch stamped after the step's time waits for its step.
    fn due(&mut self, t: f64, feed: &mut dyn FnMut(&TouchEvent)) {
        if let Some((session, playing)) = &mut self.session {
            playing.due(session, t, feed);
        }
        self.live.retain(|e| {
            if e.t <= t + 1e-9 {
                feed(&TouchEvent { t: e.t.min(t), ..*e });
                false
            } else {
                true
            }
        });
    }
}

/// The id of the mouse's left button as a finger.
const MOUSE_FINGER: i64 = 1 << 40;

/// The mouse as a finger: its left button held down is a touch that follows the cursor, and
/// released outside the window it is cancelled (as a desktop button is): a visitor who drags
/// out of the window to give up picks nothing from the radial menu and presses no button. The
/// right button is [`TouchKind::Menu`].
#[derive(Clone, Copy, Debug)]
pub(super) struct Pointer {
    /// Where the cursor is, on the controller's canvas (0–1, clamped).
    at: (f64, f64),
    /// Whether the cursor is over the window.
    inside: bool,
    down: bool,
}

impl Default for Pointer {
    fn default() -> Self {
        Self { at: (0.5, 0.5), inside: true, down: false }
    }
}

impl Pointer {
    /// The cursor moved to `(x, y)` at kiosk time `t`, over the window or not (outside, the
    /// point is the nearest of the window's edge): a move of the finger while the button is
    /// down.
    pub(super) fn moved(&mut self, t: f64, x: f64, y: f64, inside: bool) -> Option<TouchEvent> {
        self.at = (x, y);
        self.inside = inside;
        self.down.then_some(TouchEvent { t, ev: TouchKind::Move, id: MOUSE_FINGER, x, y })
    }

    /// The cursor left the window, or came back over it.
    pub(super) fn over_window(&mut self, inside: bool) {
        self.inside = inside;
    }

    /// The left button pressed or released at `t`: the finger down, or up (cancelled outside
    /// the window). A release without a press, e.g. of a press outside the window, is nothing.
    pub(super) fn left(&mut self, t: f64, pressed: bool) -> Option<TouchEvent> {
        let ev = match (pressed, self.down) {
            (true, _) => TouchKind::Down,
            (false, true) if self.inside => TouchKind::Up,
            (false, true) => TouchKind::Cancel,
            (false, false) => return None,
        };
        self.down = pressed;
        let (x, y) = self.at;
        Some(TouchEvent { t, ev, id: MOUSE_FINGER, x, y })
    }

    /// The right button pressed at `t`: the radial menu where the cursor is (or closed).
    pub(super) fn right(&self, t: f64) -> TouchEvent {
        let (x, y) = self.at;
        TouchEvent { t, ev: TouchKind::Menu, id: MOUSE_FINGER, x, y }
    }
}

/// The trace, the screenshots due and a soak run's memory reports.
pub(super) struct Probes {
    trace: Option<std::io::BufWriter<std::fs::File>>,
    /// Kiosk times of the screenshots still to take, in order.
    screenshots: Vec<f64>,
    /// A soak run: kiosk time after which memory is the reference, that reference, and the state
    /// directory whose size is reported.
    soak: Option<(f64, Option<u64>, std::path::PathBuf)>,
}

impl Probes {
    pub(super) fn new(
        trace: Option<std::io::BufWriter<std::fs::File>>,
        mut screenshots: Vec<f64>,
        soak_warmup: Option<f64>,
        state_dir: &std::path::Path,
    ) -> Self {
        screenshots.sort_by(f64::total_cmp);
        Self { trace, screenshots, soak: soak_warmup.map(|w| (w, None, state_dir.to_path_buf())) }
    }

    /// After the step at `t` (`steps` made, `dt` apart): its trace line, and in a soak run the
    /// memory, open files and state size every 300 s of kiosk time, and memory once after the
    /// warm-up.
    pub(super) fn stepped(
        &mut self,
        frame: &impl serde::Serialize,
        t: f64,
        steps: u64,
        dt: f64,
    ) -> std::io::Result<()> {
        if let Some(w) = self.trace.as_mut() {
            writeln!(w, "{}", serde_json::to_string(frame).unwrap_or_default())?;
        }
        if let Some((warmup, warm, state)) = &mut self.soak {
            if steps.is_multiple_of((300.0 / dt).round() as u64) {
                println!(
                    "soak: t = {t:.0} s, RSS {} kB, {} open files, state {} B, anon {} kB, file {} kB, heap {} kB",
                    rss_kb().unwrap_or(0),
                    open_files().unwrap_or(0),
                    dir_bytes(state),
                    status_kb("RssAnon:").unwrap_or(0),
                    status_kb("RssFile:").unwrap_or(0),
                    super::heap::in_use_kb().unwrap_or(0)
                );
            }
            if warm.is_none() && t >= *warmup {
                *warm = rss_kb();
                tracing::info!("soak: RSS after warm-up {} kB", warm.unwrap_or(0));
            }
        }
        Ok(())
    }

    /// The screenshot due at `t`, if any (taken once).
    pub(super) fn screenshot_due(&mut self, t: f64) -> Option<f64> {
        self.screenshots.first().is_some_and(|&at| t + 1e-9 >= at).then(|| self.screenshots.remove(0))
    }

    /// At the end of a session run: what was not taken, the soak's memory change, the trace
    /// flushed.
    pub(super) fn finish(
        &mut self,
        sim_t: f64,
        wall_secs: f64,
        steps: u64,
        rendered: u64,
    ) -> std::io::Result<()> {
        if !self.screenshots.is_empty() {
            tracing::warn!("screenshots after the session's end were not taken: {:?}", self.screenshots);
        }
        if let (Some((_, Some(warm), _)), Some(end)) = (&self.soak, rss_kb()) {
            let warm = *warm;
            let change = 100.0 * (end as f64 - warm as f64) / warm.max(1) as f64;
            println!(
                "soak: {sim_t:.0} s of kiosk time in {wall_secs:.0} s, {steps} steps, {rendered} frames rendered, RSS after warm-up {warm} kB, at the end {end} kB ({change:+.1} %)"
            );
        }
        match self.trace.as_mut() {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }
}

/// The number of file descriptors the process holds open (Linux).
fn open_files() -> Option<usize> {
    Some(std::fs::read_dir("/proc/self/fd").ok()?.count())
}

/// The total size of the files directly in `dir` (the statistics and the visit log).
fn dir_bytes(dir: &std::path::Path) -> u64 {
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    entries.filter_map(|e| e.ok()?.metadata().ok()).filter(|m| m.is_file()).map(|m| m.len()).sum()
}

/// The process's resident memory (Linux), in kB.
pub(super) fn rss_kb() -> Option<u64> {
    status_kb("VmRSS:")
}

/// A kB figure of /proc/self/status (`VmRSS:`; `RssAnon:` is the heap and the driver's memory,
/// `RssFile:` the pages of memory-mapped files such as the stores).
fn status_kb(key: &str) -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    s.lines().find_map(|l| l.strip_prefix(key)).and_then(|v| v.split_whitespace().next()?.parse().ok())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_mouse_is_a_finger_while_its_button_is_down() {
        let mut p = Pointer::default();
        assert_eq!(p.moved(0.0, 0.2, 0.3, true), None, "a cursor moving with the button up touches nothing");
        assert_eq!(p.left(0.1, false), None, "a release without a press is nothing");
        let down = p.left(0.2, true).expect("down");
        assert_eq!((down.ev, down.x, down.y, down.id), (TouchKind::Down, 0.2, 0.3, MOUSE_FINGER));
        let moved = p.moved(0.3, 0.4, 0.5, true).expect("move");
        assert_eq!((moved.ev, moved.t, moved.x, moved.y), (TouchKind::Move, 0.3, 0.4, 0.5));
        let up = p.left(0.4, false).expect("up");
        assert_eq!((up.ev, up.x, up.y), (TouchKind::Up, 0.4, 0.5));
        assert_eq!(p.moved(0.5, 0.6, 0.6, true), None);
        let menu = p.right(0.6);
        assert_eq!(
            (menu.ev, menu.x, menu.y),
            (TouchKind::Menu, 0.6, 0.6),
            "the right button where the cursor is"
        );
    }

    #[test]
    fn the_mouse_released_outside_the_window_cancels_its_touch() {
        let mut p = Pointer::default();
        p.moved(0.0, 0.5, 0.5, true);
        p.left(0.1, true).expect("down");
        // Dragged out past the right edge (the point stays on the edge), released there.
        let out = p.moved(0.2, 1.0, 0.5, false).expect("move");
        assert_eq!((out.ev, out.x), (TouchKind::Move, 1.0));
        assert_eq!(p.left(0.3, false).expect("release").ev, TouchKind::Cancel);
        // Dragged out and back in: a release over the window is a lift.
        p.left(0.4, true).expect("down");
        p.over_window(false);
        p.moved(0.5, 0.9, 0.5, true);
        assert_eq!(p.left(0.6, false).expect("release").ev, TouchKind::Up);
    }
}
