//! Replay: a touch session run at a fixed clock (60 Hz) with no window and no GPU, producing the
//! trace ([`crate::trace`]) — the test harness of the whole interaction path. Same store, session,
//! settings and seed → byte-identical trace.

use crate::clock::{Playing, SessionFeed, Stepper};
use crate::explore::{ExploreSettings, Explorer};
use crate::graph::InfoGraph;
use crate::scene::Store;
use crate::session::Session;
use crate::trace::{Frame, Summary, Trace};

/// Runs a session without an information graph and returns its trace.
pub fn run<B: AsRef<[u8]>>(store: &Store<B>, session: &Session, settings: &ExploreSettings) -> Trace {
    run_story(store, session, settings, None)
}

/// Runs a session, with the recommendation engine and the radial menu when a graph is given.
pub fn run_story<B: AsRef<[u8]>>(
    store: &Store<B>,
    session: &Session,
    settings: &ExploreSettings,
    graph: Option<&InfoGraph>,
) -> Trace {
    let mut frames = Vec::new();
    let (controller, summary) = run_story_with(store, session, settings, graph, &mut |f| frames.push(f));
    Trace { controller, frames, summary }
}

/// Runs a session like [`run_story`], handing each frame to `frame` as it is made instead of
/// keeping them (memory stays flat however long the session); returns the controller's name and
/// the summary.
pub fn run_story_with<B: AsRef<[u8]>>(
    store: &Store<B>,
    session: &Session,
    settings: &ExploreSettings,
    graph: Option<&InfoGraph>,
    frame: &mut dyn FnMut(Frame),
) -> (&'static str, Summary) {
    let mut explorer = Explorer::new(store, graph, settings, 0.0);
    let mut stepper = Stepper::new(settings.fps, Playing::new(session, SessionFeed::once()));
    // Session times are bounded when parsed (`session::MAX_SESSION_SECS`).
    let end = stepper.clock().end_of(session.duration() + settings.tail_secs);
    while let Some(t) = stepper.next(end, &mut explorer) {
        frame(explorer.step(t).0);
    }
    (explorer.controller_name(), explorer.summary)
}
