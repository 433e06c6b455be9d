//! IsoCam, gestures and replay: scripted touch sessions on real scans, properties, extremes.

mod extremes;
mod properties;
mod sessions;

use crate::common;
use kiosk_core::gesture::{TouchEvent, TouchKind};
use kiosk_core::replay::{self, ControllerKind, ReplaySettings, Trace};
use kiosk_core::session::Session;

/// A finger's path in a drag: (id, from, to), positions normalised to the surface.
pub type Path = (i64, (f64, f64), (f64, f64));

/// A touch script, written like a choreography.
#[derive(Default, Clone)]
pub struct Script {
    pub t: f64,
    pub events: Vec<TouchEvent>,
}

impl Script {
    pub fn new() -> Self {
        Self::default()
    }
    fn push(&mut self, ev: TouchKind, id: i64, x: f64, y: f64) {
        self.events.push(TouchEvent { t: self.t, ev, id, x, y });
    }
    pub fn down(mut self, id: i64, x: f64, y: f64) -> Self {
        self.push(TouchKind::Down, id, x, y);
        self
    }
    pub fn up(mut self, id: i64, x: f64, y: f64) -> Self {
        self.push(TouchKind::Up, id, x, y);
        self
    }
    pub fn cancel(mut self, id: i64) -> Self {
        self.push(TouchKind::Cancel, id, 0.5, 0.5);
        self
    }
    pub fn wait(mut self, secs: f64) -> Self {
        self.t += secs;
        self
    }
    /// Moves fingers linearly from `from` to `to` over `secs`, one event per finger every 16 ms.
    pub fn drag(mut self, fingers: &[Path], secs: f64) -> Self {
        let n = (secs / 0.016).ceil().max(1.0) as usize;
        let t0 = self.t;
        for k in 1..=n {
            let s = k as f64 / n as f64;
            self.t = t0 + secs * s;
            for &(id, a, b) in fingers {
                self.push(TouchKind::Move, id, a.0 + (b.0 - a.0) * s, a.1 + (b.1 - a.1) * s);
            }
        }
        self
    }
    /// One finger: down at the centre, push to `offset` quickly, hold for `secs` (joystick), up.
    pub fn joystick(self, id: i64, offset: (f64, f64), secs: f64) -> Self {
        let end = (0.5 + offset.0, 0.5 + offset.1);
        self.down(id, 0.5, 0.5).drag(&[(id, (0.5, 0.5), end)], 0.1).wait(secs).up(id, end.0, end.1)
    }
    /// Two-finger pinch: the fingers' distance goes from `d0` to `d1` (screen heights).
    pub fn pinch(self, d0: f64, d1: f64, secs: f64) -> Self {
        let a0 = (0.5 - d0 / 2.0 / (16.0 / 9.0), 0.5);
        let b0 = (0.5 + d0 / 2.0 / (16.0 / 9.0), 0.5);
        let a1 = (0.5 - d1 / 2.0 / (16.0 / 9.0), 0.5);
        let b1 = (0.5 + d1 / 2.0 / (16.0 / 9.0), 0.5);
        self.down(1, a0.0, a0.1)
            .down(2, b0.0, b0.1)
            .drag(&[(1, a0, a1), (2, b0, b1)], secs)
            .up(1, a1.0, a1.1)
            .up(2, b1.0, b1.1)
    }
    pub fn session(&self) -> Session {
        let mut events = self.events.clone();
        events.sort_by(|a, b| a.t.total_cmp(&b.t));
        Session { header: None, events }
    }
}

pub fn run(store: &kiosk::MappedStore, script: &Script, controller: ControllerKind) -> Trace {
    let settings = ReplaySettings { controller, ..ReplaySettings::default() };
    replay::run(store, &script.session(), &settings)
}

/// Builds a real scan into a store with small nodes.
pub fn scan(rel: &str) -> common::Built {
    common::build(&common::read(rel), common::small_nodes())
}

/// Asserts what every trace must satisfy: finite camera, never closer than the minimum distance
/// (less the re-projection tolerance), for IsoCam.
pub fn assert_safe(trace: &Trace) {
    for f in &trace.frames {
        let finite = f.eye.iter().chain(&f.target).chain(&f.up).all(|v| v.is_finite());
        assert!(finite, "non-finite camera at t={}: {f:?}", f.t);
        assert!(f.surface_distance.is_finite());
    }
    assert_eq!(trace.summary.collisions, 0, "closest approach {}", trace.summary.min_surface_distance);
}
