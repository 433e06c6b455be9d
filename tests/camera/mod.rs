//! IsoCam, gestures and replay: scripted touch sessions on real scans, properties, extremes.

mod extremes;
mod properties;
mod sessions;

use crate::common;
use kiosk_core::camera::ControllerKind;
use kiosk_core::explore::ExploreSettings;
use kiosk_core::replay;
pub use kiosk_core::session::Script;
use kiosk_core::trace::Trace;

pub fn run(store: &kiosk_content::MappedStore, script: &Script, controller: ControllerKind) -> Trace {
    let settings = ExploreSettings { controller, ..ExploreSettings::default() };
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
