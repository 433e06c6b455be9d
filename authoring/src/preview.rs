//! Previews of a story before it reaches the museum: the walk the engine would take on its own
//! with a seed (the kiosk's attract loop: every proposal accepted), and a recorded kiosk session
//! replayed against the graph being edited.

use kiosk_content::MappedStore;
use kiosk_content::exhibit::ModelPose;
use kiosk_core::clock::{Playing, SessionFeed, Stepper};
use kiosk_core::explore::{ExploreSettings, Explorer};
use kiosk_core::graph::InfoGraph;
use kiosk_core::kiosk::{KioskSettings, Mode, ModelRef, run_session};
use kiosk_core::session::Session;

/// The nodes the engine displays, in order, when nobody touches for `secs` seconds (each
/// proposal accepted), with this seed.
pub fn simulate_walk(
    store: &MappedStore,
    graph: &InfoGraph,
    pose: ModelPose,
    seed: u64,
    secs: f64,
) -> Vec<String> {
    // 20 Hz is plenty for a walk without a visitor and keeps the preview instant.
    let settings = ExploreSettings {
        seed,
        fps: 20.0,
        size_px: (1280, 720),
        up: pose.up,
        front: pose.front,
        ..ExploreSettings::default()
    };
    let mut explorer = Explorer::new(store, Some(graph), &settings, 0.0);
    explorer.autopilot = true;
    // The kiosk's own loop, with nobody touching.
    let nobody = Session::default();
    let mut stepper = Stepper::new(settings.fps, Playing::new(&nobody, SessionFeed::once()));
    let end = stepper.clock().end_of(secs);
    while let Some(t) = stepper.next(end, &mut explorer) {
        explorer.step(t);
    }
    explorer.summary.nodes_displayed.clone()
}

/// What a recorded kiosk session does against the graph.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SessionPreview {
    /// Nodes displayed, in order.
    pub displayed: Vec<String>,
    /// Seconds of the session.
    pub duration: f64,
    /// Seconds spent exploring this model.
    pub exploring_secs: f64,
}

/// Replays a kiosk session (recorded with `kiosk --record`) with this model alone in the gallery,
/// standing as its exhibit says.
pub fn replay_session(
    store: &MappedStore,
    graph: &InfoGraph,
    pose: ModelPose,
    session: &Session,
) -> SessionPreview {
    let settings = KioskSettings::default();
    let models = [ModelRef { store, graph: Some(graph), up: pose.up, front: pose.front }];
    let frames = run_session(&models, session, &settings, 1.0);
    let dt = 1.0 / settings.explore.fps;
    let mut displayed: Vec<String> = Vec::new();
    let mut last: Option<String> = None;
    for f in &frames {
        let overlay = f.explore.as_ref().and_then(|e| e.overlay.clone());
        if let Some(o) = &overlay
            && last.as_ref() != Some(o)
        {
            displayed.push(o.clone());
        }
        last = overlay;
    }
    SessionPreview {
        displayed,
        duration: session.duration(),
        exploring_secs: frames.iter().filter(|f| f.mode != Mode::Gallery).count() as f64 * dt,
    }
}
