//! Replay: a touch session run at a fixed clock (60 Hz) with no window and no GPU, producing the
//! trace of DESIGN §11 — the test harness of the whole interaction path. Same store, session,
//! settings and seed → byte-identical trace.

use crate::camera::{
    Acevit, AcevitSettings, Camera, Controller, GoTo, IsoCam, IsoCamSettings, SceneRef, Trackball,
};
use crate::gesture::{GestureSettings, Gestures, MenuEvent};
use crate::graph::InfoGraph;
use crate::recommend::{
    Effect, RadialSettings, RecEvent, RecSettings, RecState, Recommender, ViewContext, ViewIndex,
    radial_candidates, slot_for_angle,
};
use crate::scene::{Cut, CutParams, Level, Store};
use crate::session::Session;
use glam::DVec3;
use rand::SeedableRng;
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
    /// Vertical field of view (radians).
    pub fov_y: f64,
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

impl Trace {
    /// The trace in its file format (JSON Lines).
    pub fn to_jsonl(&self, seed: u64, fps: f64) -> String {
        let mut out = String::new();
        let mut push = |v: Result<String, serde_json::Error>| {
            out.push_str(&v.unwrap_or_else(|e| format!("{{\"error\":\"{e}\"}}")));
            out.push('\n');
        };
        push(serde_json::to_string(&HeaderLine { trace: 1, controller: self.controller, seed, fps }));
        for f in &self.frames {
            push(serde_json::to_string(f));
        }
        push(serde_json::to_string(&SummaryLine { summary: &self.summary }));
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

/// Builds the controller of a replay (or of the kiosk).
pub fn make_controller<B: AsRef<[u8]>>(
    scene: SceneRef<'_, B>,
    cam: Camera,
    kind: ControllerKind,
    min_distance: f64,
    up: DVec3,
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
            AcevitSettings { samples: 256, sigma_xy: 0.5, sigma_depth: 0.5, min_radius: min_distance },
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
    let mut rng = rand_pcg::Pcg64::seed_from_u64(settings.seed);
    let diag = f64::from(store.bbox().diagonal());
    let min_distance = settings.min_distance_fraction * diag;
    let aspect = f64::from(settings.size_px.0) / f64::from(settings.size_px.1.max(1));
    let cam0 = initial_camera(store, settings.fov_y, settings.up);
    let mut cut = Cut::root(store);
    if let Some(v) = cam0.view_params(store, settings.size_px) {
        cut.update(store, &v, &CutParams { max_changes: usize::MAX, ..settings.cut });
    }
    let mut controller =
        make_controller(SceneRef { store, cut: &cut }, cam0, settings.controller, min_distance, settings.up);
    let mut gestures = Gestures::new(settings.gestures);
    let mut rec = graph.map(|g| Recommender::new(g, settings.recommend, 0.0));
    let view_index = graph.map(ViewIndex::new);
    let mut menu: Option<Vec<usize>> = None;
    let mut goto: Option<GoTo> = None;
    let dt = 1.0 / settings.fps;
    let frames = ((session.duration() + settings.tail_secs) * settings.fps).ceil() as u64 + 1;
    let mut next = 0usize;
    let mut summary = Summary { min_surface_distance: f64::INFINITY, ..Summary::default() };
    let mut out = Vec::with_capacity(frames as usize);
    let tolerance = match &controller {
        Controller::IsoCam(c) => c.settings.reproject_tolerance,
        _ => 0.01,
    };
    for k in 0..frames {
        let t = k as f64 * dt;
        while next < session.events.len() && session.events[next].t <= t + 1e-9 {
            gestures.event(&session.events[next]);
            next += 1;
        }
        let mut intent = gestures.frame(t, dt);
        let samples: Vec<DVec3> = match graph {
            Some(_) => store
                .sample_cut(&cut, settings.similarity_samples, &mut rng)
                .into_iter()
                .map(|p| store.to_model(p))
                .collect(),
            None => Vec::new(),
        };
        let ctx = ViewContext {
            camera: controller.camera(),
            aspect,
            samples: &samples,
            diagonal: diag,
            moving: !intent.is_idle(),
        };
        let mut rec_event = RecEvent::Tick;
        for m in gestures.take_menu_events() {
            match m {
                MenuEvent::Open { .. } => {
                    if matches!(rec.as_ref().map(|r| r.state), Some(RecState::Propose { .. })) {
                        // A long press accepts the proposal instead of opening the menu.
                        gestures.menu_cancel();
                        gestures.take_menu_events();
                        rec_event = RecEvent::LongPress;
                    } else {
                        summary.menu_requests += 1;
                        menu = Some(match (graph, view_index.as_ref()) {
                            (Some(g), Some(vi)) => radial_candidates(
                                g,
                                vi,
                                &ctx,
                                &settings.radial,
                                &mut |from: DVec3, to: DVec3| {
                                    let d = to - from;
                                    let len = d.length();
                                    len <= 0.0 || store.ray_cast(Level::Cut(&cut), from, d, len).is_none()
                                },
                            ),
                            _ => Vec::new(),
                        });
                    }
                }
                MenuEvent::Select { angle } => {
                    summary.menu_selections += 1;
                    if let Some(c) = menu.take()
                        && let Some(slot) = slot_for_angle(angle, c.len())
                    {
                        rec_event = RecEvent::MenuSelect(c[slot]);
                    }
                }
                MenuEvent::Cancel => menu = None,
                MenuEvent::Point { .. } => {}
            }
        }
        let menu_open = gestures.menu_open();
        if let (Some(r), Some(g)) = (rec.as_ref(), graph) {
            let h = r.guide(g, &ctx, (intent.hover.0 + intent.pan.0, intent.hover.1 + intent.pan.1));
            intent.hover = h;
            intent.pan = (0.0, 0.0);
        }
        let scene = SceneRef { store, cut: &cut };
        match goto {
            Some(a) => {
                if a.done(t) {
                    controller.set_camera(scene, a.to);
                    goto = None;
                }
            }
            None => {
                if !menu_open {
                    controller.apply(scene, &intent, &mut rng);
                }
            }
        }
        if let (Some(r), Some(g)) = (rec.as_mut(), graph) {
            let before = r.state;
            let ctx = ViewContext { camera: controller.camera(), ..ctx };
            for fx in r.step(g, &ctx, rec_event, t, &mut rng) {
                match fx {
                    Effect::StartGoTo { node, duration } => {
                        goto = Some(GoTo {
                            from: controller.camera(),
                            to: g.nodes[node].view,
                            start: t,
                            duration,
                        });
                    }
                    Effect::ShowOverlay { node } => summary.nodes_displayed.push(g.nodes[node].id.clone()),
                    _ => {}
                }
            }
            match (before, r.state) {
                (RecState::Propose { .. }, RecState::GoTo { .. }) => summary.proposals_accepted += 1,
                (RecState::Propose { .. }, RecState::Discover { .. }) => summary.proposals_ignored += 1,
                _ => {}
            }
        }
        let cam = match goto {
            Some(a) => a.camera_at(t, SceneRef { store, cut: &cut }, min_distance),
            None => controller.camera(),
        };
        if let Some(v) = cam.view_params(store, settings.size_px) {
            cut.update(store, &v, &settings.cut);
        }
        let surface = store.nearest_sample(cam.eye).map_or(f64::NAN, |(d, _)| d);
        if surface < min_distance * (1.0 - tolerance) {
            summary.collisions += 1;
        }
        summary.min_surface_distance = summary.min_surface_distance.min(surface);
        let state = if menu_open {
            "menu"
        } else if goto.is_some() {
            "go-to"
        } else if intent.zoom != 0.0 {
            "zoom"
        } else if intent.hover != (0.0, 0.0) || intent.pan != (0.0, 0.0) {
            "hover"
        } else if intent.twist != 0.0 {
            "twist"
        } else {
            "idle"
        };
        let id = |i: usize| graph.map(|g| g.nodes[i].id.clone());
        out.push(Frame {
            t,
            eye: cam.eye.to_array(),
            target: cam.target.to_array(),
            up: cam.up.to_array(),
            surface_distance: surface,
            min_distance,
            controller: state,
            isolevel: match &controller {
                Controller::IsoCam(c) => Some(c.isolevel()),
                _ => None,
            },
            recommender: rec.as_ref().map(|r| r.state.name().to_string()),
            node: rec.as_ref().and_then(|r| r.state.node()).and_then(id),
            overlay: match rec.as_ref().map(|r| r.state) {
                Some(RecState::Display { node, .. }) => id(node),
                _ => None,
            },
            menu: menu_open.then(|| MenuTrace {
                open: true,
                candidates: menu.iter().flatten().filter_map(|&i| id(i)).collect(),
            }),
            cut_nodes: cut.nodes().len(),
        });
    }
    summary.frames = frames;
    Trace { controller: controller.name(), frames: out, summary }
}
