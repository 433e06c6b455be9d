//! Replay: a touch session run at a fixed clock (60 Hz) with no window and no GPU, producing the
//! trace (JSON Lines, one line per frame, then a summary) — the test harness of the whole
//! interaction path. Same store, session, settings and seed → byte-identical trace.

use crate::camera::{
    Acevit, AcevitSettings, Camera, Controller, IsoCam, IsoCamSettings, SceneRef, Trackball,
};
use crate::explore::Explorer;
use crate::gesture::GestureSettings;
use crate::graph::InfoGraph;
use crate::recommend::{RadialSettings, RecSettings};
use crate::scene::{CutParams, Store};
use crate::session::Session;
use glam::DVec3;
use serde::Serialize;

/// Which controller a replay uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ControllerKind {
    /// IsoCam.
    IsoCam,
    /// Virtual trackball.
    Trackball,
    /// ACeViT.
    Acevit,
}

impl ControllerKind {
    /// Its name in traces and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::IsoCam => "isocam",
            Self::Trackball => "trackball",
            Self::Acevit => "acevit",
        }
    }
}

impl std::str::FromStr for ControllerKind {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "isocam" => Ok(Self::IsoCam),
            "trackball" => Ok(Self::Trackball),
            "acevit" => Ok(Self::Acevit),
            other => Err(format!("unknown controller '{other}' (isocam, trackball, acevit)")),
        }
    }
}

/// Settings of a replay.
#[derive(Clone, Copy, Debug)]
pub struct ReplaySettings {
    /// Frames per second of the fixed clock.
    pub fps: f64,
    /// Viewport of the projection (pixels) for the cut.
    pub size_px: (u32, u32),
    /// Vertical field of view (radians): the configured projection.
    pub fov_y: f64,
    /// Whether `fov_y` is a real-scale projection (the angle the screen subtends at the viewer):
    /// then it holds always, a node's own field of view is not used (see [`crate::explore`]).
    pub real_scale: bool,
    /// Farthest the eye may be from the model's centre, in framing distances (the distance of
    /// the initial view, which shows the whole model); beyond it the camera eases back
    /// (infinite: no bound).
    pub max_distance_factor: f64,
    /// Seconds simulated after the last event.
    pub tail_secs: f64,
    /// The controller.
    pub controller: ControllerKind,
    /// Seed of every random choice.
    pub seed: u64,
    /// Gesture thresholds.
    pub gestures: GestureSettings,
    /// Cut settings.
    pub cut: CutParams,
    /// Minimum distance as a fraction of the model diagonal.
    pub min_distance_fraction: f64,
    /// Global up vector.
    pub up: DVec3,
    /// Recommendation engine settings (used when a graph is given).
    pub recommend: RecSettings,
    /// Radial menu settings.
    pub radial: RadialSettings,
    /// Points of the cut sampled per frame for view similarity.
    pub similarity_samples: usize,
}

impl Default for ReplaySettings {
    fn default() -> Self {
        Self {
            fps: 60.0,
            size_px: (1920, 1080),
            fov_y: 0.8,
            real_scale: false,
            max_distance_factor: 3.0,
            tail_secs: 1.0,
            controller: ControllerKind::IsoCam,
            seed: 0,
            gestures: GestureSettings::default(),
            cut: CutParams::default(),
            min_distance_fraction: 0.01,
            up: DVec3::Y,
            recommend: RecSettings::default(),
            radial: RadialSettings::default(),
            similarity_samples: 64,
        }
    }
}

/// The radial menu as traced.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MenuTrace {
    /// Whether it is open.
    pub open: bool,
    /// Candidate node ids (the POI selector comes with the information graph).
    pub candidates: Vec<String>,
}

/// One line of the trace.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Frame {
    /// Session time.
    pub t: f64,
    /// Eye (model coordinates).
    pub eye: [f64; 3],
    /// Target (model coordinates).
    pub target: [f64; 3],
    /// Up vector.
    pub up: [f64; 3],
    /// Distance from the eye to the nearest full-resolution sample.
    pub surface_distance: f64,
    /// The minimum distance in force.
    pub min_distance: f64,
    /// Controller state: idle, hover, zoom, twist, menu.
    pub controller: &'static str,
    /// IsoCam's isolevel (null for the trackballs).
    pub isolevel: Option<f64>,
    /// Recommender state (information-graph issue; null until then).
    pub recommender: Option<String>,
    /// Node attracted, proposed or displayed (null until the information graph exists).
    pub node: Option<String>,
    /// Overlay displayed (null until the information graph exists).
    pub overlay: Option<String>,
    /// The radial menu, when open.
    pub menu: Option<MenuTrace>,
    /// Nodes in the cut.
    pub cut_nodes: usize,
}

/// The final line's counts.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    /// Frames simulated.
    pub frames: u64,
    /// Frames whose eye was closer to the surface than the minimum distance (less the
    /// re-projection tolerance).
    pub collisions: u64,
    /// Smallest surface distance seen.
    pub min_surface_distance: f64,
    /// Menu requests (long presses).
    pub menu_requests: u64,
    /// Menu selections.
    pub menu_selections: u64,
    /// Nodes displayed, in order (information-graph issue).
    pub nodes_displayed: Vec<String>,
    /// Proposals accepted (information-graph issue).
    pub proposals_accepted: u64,
    /// Proposals ignored (information-graph issue).
    pub proposals_ignored: u64,
}

/// A complete trace.
#[derive(Clone, Debug, PartialEq)]
pub struct Trace {
    /// The controller used.
    pub controller: &'static str,
    /// Frames.
    pub frames: Vec<Frame>,
    /// Summary.
    pub summary: Summary,
}

#[derive(Serialize)]
struct SummaryLine<'a> {
    summary: &'a Summary,
}

#[derive(Serialize)]
struct HeaderLine<'a> {
    trace: u32,
    controller: &'a str,
    seed: u64,
    fps: f64,
}

/// A value as one line of JSON, with its newline.
fn json_line(v: Result<String, serde_json::Error>) -> String {
    let mut line = v.unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}"));
    line.push('\n');
    line
}

/// The first line of a trace file.
pub fn header_line(controller: &str, seed: u64, fps: f64) -> String {
    json_line(serde_json::to_string(&HeaderLine { trace: 1, controller, seed, fps }))
}

/// The last line of a trace file.
pub fn summary_line(summary: &Summary) -> String {
    json_line(serde_json::to_string(&SummaryLine { summary }))
}

impl Frame {
    /// The frame as a line of a trace file.
    pub fn to_line(&self) -> String {
        json_line(serde_json::to_string(self))
    }
}

impl Trace {
    /// The trace in its file format (JSON Lines).
    pub fn to_jsonl(&self, seed: u64, fps: f64) -> String {
        let mut out = header_line(self.controller, seed, fps);
        for f in &self.frames {
            out.push_str(&f.to_line());
        }
        out.push_str(&summary_line(&self.summary));
        out
    }
}

/// The camera the kiosk starts with: the whole model framed, looking along −Z with up +Y.
pub fn initial_camera<B: AsRef<[u8]>>(store: &Store<B>, fov_y: f64, up: DVec3) -> Camera {
    let center = store.to_model(store.bbox().center());
    let radius = f64::from(store.bbox().diagonal()) * 0.5;
    let from = if up.dot(DVec3::Z).abs() > 0.9 { DVec3::NEG_Y } else { DVec3::Z };
    Camera::framing(center, radius.max(f64::MIN_POSITIVE), from, up, fov_y)
}

/// Builds the controller of a replay (or of the kiosk); `aspect` is the projection's width /
/// height.
pub fn make_controller<B: AsRef<[u8]>>(
    scene: SceneRef<'_, B>,
    cam: Camera,
    kind: ControllerKind,
    min_distance: f64,
    up: DVec3,
    aspect: f64,
) -> Controller {
    match kind {
        ControllerKind::IsoCam => {
            let mut s = IsoCamSettings::for_model(scene.diagonal());
            s.min_distance = min_distance;
            s.up = up;
            Controller::IsoCam(IsoCam::new(scene, cam, s))
        }
        ControllerKind::Trackball => Controller::Trackball(Trackball::new(cam, min_distance)),
        ControllerKind::Acevit => Controller::Acevit(Acevit::new(
            cam,
            AcevitSettings {
                samples: 256,
                sigma_xy: 0.5,
                sigma_depth: 0.5,
                min_radius: min_distance,
                aspect,
            },
        )),
    }
}

/// Runs a session without an information graph and returns its trace.
pub fn run<B: AsRef<[u8]>>(store: &Store<B>, session: &Session, settings: &ReplaySettings) -> Trace {
    run_story(store, session, settings, None)
}

/// Runs a session, with the recommendation engine and the radial menu when a graph is given.
pub fn run_story<B: AsRef<[u8]>>(
    store: &Store<B>,
    session: &Session,
    settings: &ReplaySettings,
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
    settings: &ReplaySettings,
    graph: Option<&InfoGraph>,
    frame: &mut dyn FnMut(Frame),
) -> (&'static str, Summary) {
    let mut explorer = Explorer::new(store, graph, settings, 0.0);
    let dt = 1.0 / settings.fps;
    // Session times are bounded when parsed (`session::MAX_SESSION_SECS`).
    let frames = ((session.duration() + settings.tail_secs) * settings.fps).ceil() as u64 + 1;
    let mut next = 0usize;
    for k in 0..frames {
        let t = k as f64 * dt;
        while next < session.events.len() && session.events[next].t <= t + 1e-9 {
            explorer.touch(&session.events[next]);
            next += 1;
        }
        frame(explorer.step(store, graph, t).0);
    }
    (explorer.controller_name(), explorer.summary)
}
