//! One visitor exploring one model: gestures → camera controller → recommender → radial menu,
//! advanced one frame at a time at injected times. `replay` drives it from a session file; the
//! kiosk drives it from a window's touch events. Both take exactly this path.
//!
//! An [`Explorer`] holds its scene, the model's store and its information graph if any, for its
//! whole lifetime: they are given once to [`Explorer::new`], and each [`Explorer::step`] takes
//! only the time.
//!
//! The projection: the configured field of view ([`ExploreSettings::fov_y`]) holds. When it is a
//! real-scale projection ([`ExploreSettings::real_scale`]), it holds always: a go-to ends at the
//! node's eye, target and up with the configured field of view, never the node's. Otherwise a
//! node's field of view frames its go-to (the animation ends at the node's exact view, so its
//! overlay lines up) and stays while the visitor does not move; once the visitor moves again the
//! field of view eases back to the configured one ([`FOV_EASE_SECS`]).
//!
//! The distance: the eye may be at most [`ExploreSettings::max_distance_factor`] framing
//! distances (the initial view's distance, the whole model in view) from the model's centre (the
//! start view's target: the middle of the model's box in its upright frame).
//! Beyond it (any controller), zooming out is damped to nothing at 1.5 times the bound and the
//! camera eases back to the bound ([`DISTANCE_EASE_SECS`]), moving straight toward the centre
//! with its view direction kept.
//!
//! The light ([`crate::light`]): the exploration holds the user light's direction and weight,
//! steered by the visitor ([`Explorer::light_drag`]), turned by go-tos to nodes with a stored
//! light, eased back by the attract loop ([`Explorer::restore_light`]); each frame traces it.
//!
//! The recommender's hidden guidance (thesis 11.4.1) is applied per controller
//! ([`guide_intent`]): IsoCam hovers with two-finger pan too and moves the eye with the input;
//! the trackballs keep pan as a pan and move the eye against the input.

use crate::camera::{Camera, Controller, GoTo, Intent, SceneRef};
use crate::camera::{ControllerKind, make_controller, start_camera};
use crate::gesture::GestureSettings;
use crate::gesture::{Gestures, MenuEvent, TouchEvent};
use crate::graph::InfoGraph;
use crate::light::{Light, Lighting};
use crate::radial::{RadialSettings, ViewIndex, radial_candidates, slot_for_angle};
use crate::recommend::{Effect, RecEvent, RecSettings, RecState, Recommender, Sense, ViewContext};
use crate::scene::{Cut, CutParams, Level, Store};
use crate::trace::{Frame, MenuTrace, Summary};
use glam::DVec3;
use rand::SeedableRng;

/// Settings of an exploration (the kiosk's and a replay's).
#[derive(Clone, Copy, Debug)]
pub struct ExploreSettings {
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
    /// Global up vector (the model's up axis).
    pub up: DVec3,
    /// The side of the model the start view looks at (perpendicular to `up`); `None`: the
    /// default ([`crate::camera::default_front`]).
    pub front: Option<DVec3>,
    /// Recommendation engine settings (used when a graph is given).
    pub recommend: RecSettings,
    /// Radial menu settings.
    pub radial: RadialSettings,
    /// Points of the cut sampled per frame for view similarity.
    pub similarity_samples: usize,
}

impl Default for ExploreSettings {
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
            front: None,
            recommend: RecSettings::default(),
            radial: RadialSettings::default(),
            similarity_samples: 64,
        }
    }
}

/// Time constant (seconds) of the field of view's return to the configured one.
pub const FOV_EASE_SECS: f64 = 0.4;

/// Time constant (seconds) of the return to the distance bound.
pub const DISTANCE_EASE_SECS: f64 = 0.3;

/// The recommender's guidance of a frame's intent for this controller: IsoCam treats two-finger
/// pan as hover and moves the eye with the input; the trackballs keep pan as a pan and move the
/// eye against their input (they turn or slide the model under the finger), so their nudge is
/// given in that sense. Either way the nudge moves the eye toward the attracting view.
pub fn guide_intent(
    rec: &Recommender,
    graph: &InfoGraph,
    ctx: &ViewContext<'_>,
    intent: Intent,
    controller: &Controller,
) -> Intent {
    let mut out = intent;
    match controller {
        Controller::IsoCam(_) => {
            let h = (intent.hover.0 + intent.pan.0, intent.hover.1 + intent.pan.1);
            out.hover = rec.guide(graph, ctx, h, Sense::WithInput);
            out.pan = (0.0, 0.0);
        }
        Controller::Trackball(_) | Controller::Acevit(_) => {
            out.hover = rec.guide(graph, ctx, intent.hover, Sense::AgainstInput);
            out.pan = rec.guide(graph, ctx, intent.pan, Sense::AgainstInput);
        }
    }
    out
}

/// The radial menu while it is open.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RadialMenu {
    /// Where the long press happened (controller surface, normalised).
    pub origin: (f64, f64),
    /// Candidate nodes, clockwise from the top.
    pub candidates: Vec<usize>,
    /// Direction the finger points (radians, 0 = up, clockwise), once it moved.
    pub pointing: Option<f64>,
}

/// The state of one exploration of one model, which it holds (store and graph) while it lives.
#[derive(Clone, Debug)]
pub struct Explorer<'a, B: AsRef<[u8]>> {
    store: &'a Store<B>,
    graph: Option<&'a InfoGraph>,
    settings: ExploreSettings,
    rng: rand_pcg::Pcg64,
    cut: Cut,
    controller: Controller,
    gestures: Gestures,
    rec: Option<Recommender>,
    view_index: Option<ViewIndex>,
    menu: Option<RadialMenu>,
    goto: Option<GoTo>,
    camera: Camera,
    diag: f64,
    min_distance: f64,
    aspect: f64,
    center: DVec3,
    max_distance: f64,
    tolerance: f64,
    light: Lighting,
    /// When the last finger landed (a gesture begun during a flight takes the camera).
    last_down: f64,
    /// Counts over the exploration.
    pub summary: Summary,
    /// When set, proposals are accepted without a visitor (the kiosk's attract loop).
    pub autopilot: bool,
}

impl<B: AsRef<[u8]>> crate::clock::Touchable for Explorer<'_, B> {
    fn touch(&mut self, e: &TouchEvent) {
        Explorer::touch(self, e);
    }
}

impl<'a, B: AsRef<[u8]>> Explorer<'a, B> {
    /// Starts at the model's framing view, exploring `store` (with the recommender and the
    /// radial menu when `graph` is given) for the explorer's lifetime; `now` is the clock of the
    /// recommender.
    pub fn new(
        store: &'a Store<B>,
        graph: Option<&'a InfoGraph>,
        settings: &ExploreSettings,
        now: f64,
    ) -> Self {
        let diag = f64::from(store.bbox().diagonal());
        let min_distance = settings.min_distance_fraction * diag;
        let aspect = f64::from(settings.size_px.0) / f64::from(settings.size_px.1.max(1));
        let cam0 = start_camera(store, settings.fov_y, settings.up, settings.front);
        // The start view's target: the centre of the model's box in its upright frame.
        let center = cam0.target;
        // At least the framing distance (NaN: that); infinite: no bound.
        let max_distance = settings.max_distance_factor.max(1.0) * (cam0.eye - center).length();
        let mut cut = Cut::root(store);
        if let Some(v) = cam0.view_params(store, settings.size_px) {
            cut.update(store, &v, &CutParams { max_changes: usize::MAX, ..settings.cut });
        }
        let controller = make_controller(
            SceneRef { store, cut: &cut },
            cam0,
            settings.controller,
            min_distance,
            settings.up,
            aspect,
        );
        let tolerance = match &controller {
            Controller::IsoCam(c) => c.settings.reproject_tolerance,
            _ => 0.01,
        };
        let start_light = crate::light::start_dir(&cam0);
        Self {
            store,
            graph,
            settings: *settings,
            rng: rand_pcg::Pcg64::seed_from_u64(settings.seed),
            cut,
            controller,
            gestures: Gestures::new(settings.gestures),
            rec: graph.map(|g| Recommender::new(g, settings.recommend, now)),
            view_index: graph.map(ViewIndex::new),
            menu: None,
            goto: None,
            camera: cam0,
            diag,
            min_distance,
            aspect,
            center,
            max_distance,
            tolerance,
            light: Lighting::new(start_light),
            last_down: f64::NEG_INFINITY,
            summary: Summary { min_surface_distance: f64::INFINITY, ..Summary::default() },
            autopilot: false,
        }
    }

    /// Feeds one touch event (to be followed by `step` at a time ≥ the event's).
    pub fn touch(&mut self, e: &TouchEvent) {
        if e.ev == crate::gesture::TouchKind::Down {
            self.last_down = e.t;
        }
        self.gestures.event(e);
    }

    /// Lifts every finger (a touch that belongs to someone else now, or a mode change).
    pub fn release_all(&mut self, t: f64) {
        for id in self.gestures.finger_ids() {
            self.gestures.event(&TouchEvent { t, ev: crate::gesture::TouchKind::Cancel, id, x: 0.0, y: 0.0 });
        }
    }

    /// Closes the radial menu, if open, without a selection (nobody is there to pick).
    pub fn close_menu(&mut self) {
        self.gestures.menu_cancel();
    }

    /// The camera shown (the go-to animation's while one runs).
    pub fn camera(&self) -> Camera {
        self.camera
    }

    /// The light of the last frame (what the renderer shows).
    pub fn light(&self) -> Light {
        self.light.light()
    }

    /// Where the light is on the steering pad of the current view (centre: from the eye; rim:
    /// grazing), for the controller's light indicator.
    pub fn light_pad(&self) -> glam::DVec2 {
        crate::light::to_pad(&self.camera, self.light.light().dir)
    }

    /// Whether a finger steers the light.
    pub fn light_dragging(&self) -> bool {
        self.light.dragging()
    }

    /// A finger starts steering the light (from where it is now, as seen from the current view):
    /// any animation of it stops and the user light comes to dominate.
    pub fn light_drag_start(&mut self) {
        self.light.drag_start(&self.camera);
    }

    /// The steering finger moved by `(dx, dy)` (controller widths and heights, y down); starts a
    /// drag if none runs.
    pub fn light_drag(&mut self, dx: f64, dy: f64) {
        self.light.drag(&self.camera, dx, dy, self.settings.gestures.aspect);
    }

    /// The steering finger lifted: the light stays where it is.
    pub fn light_drag_end(&mut self) {
        self.light.drag_end();
    }

    /// The attract loop: the light eases back to the one the exploration started with, the
    /// headlight dominating again (a go-to to a node with a light still turns it).
    pub fn restore_light(&mut self, t: f64) {
        self.light.restore(t);
    }

    /// The current cut.
    pub fn cut(&self) -> &Cut {
        &self.cut
    }

    /// The recommender, when the model has a graph.
    pub fn recommender(&self) -> Option<&Recommender> {
        self.rec.as_ref()
    }

    /// The recommender's γ per node (popularity, [`crate::stats`]); see [`Recommender::set_gamma`].
    pub fn set_gamma(&mut self, gamma: Vec<f64>) {
        if let Some(r) = self.rec.as_mut() {
            r.set_gamma(gamma);
        }
    }

    /// The radial menu, when open.
    pub fn menu(&self) -> Option<&RadialMenu> {
        self.menu.as_ref().filter(|_| self.gestures.menu_open())
    }

    /// The minimum distance to the surface in force.
    pub fn min_distance(&self) -> f64 {
        self.min_distance
    }

    /// The farthest the eye may be from the model's centre (it eases back from beyond).
    pub fn max_distance(&self) -> f64 {
        self.max_distance
    }

    /// The model's centre (the distance bound is measured from it).
    pub fn center(&self) -> DVec3 {
        self.center
    }

    /// Whether a go-to animation runs.
    pub fn animating(&self) -> bool {
        self.goto.is_some()
    }

    /// Whether any finger is on the surface.
    pub fn touched(&self) -> bool {
        self.gestures.active()
    }

    /// Advances one frame to time `t` (seconds, after the previous step) and returns the frame's
    /// trace line and the recommender's effects.
    pub fn step(&mut self, t: f64) -> (Frame, Vec<Effect>) {
        let (store, graph) = (self.store, self.graph);
        let settings = &self.settings;
        let dt = 1.0 / settings.fps;
        let mut intent = self.gestures.frame(t, dt);
        let samples: Vec<DVec3> = match graph {
            Some(_) => store
                .sample_cut(&self.cut, settings.similarity_samples, &mut self.rng)
                .into_iter()
                .map(|p| store.to_model(p))
                .collect(),
            None => Vec::new(),
        };
        let ctx = ViewContext {
            camera: self.controller.camera(),
            aspect: self.aspect,
            samples: &samples,
            diagonal: self.diag,
            moving: !intent.is_idle(),
        };
        let mut rec_event = RecEvent::Tick;
        if self.autopilot
            && let Some(r) = self.rec.as_mut()
        {
            r.release_hold();
        }
        if self.autopilot && matches!(self.rec.as_ref().map(|r| r.state), Some(RecState::Propose { .. })) {
            rec_event = RecEvent::LongPress;
        }
        for m in self.gestures.take_menu_events() {
            match m {
                MenuEvent::Open { at } => {
                    if matches!(self.rec.as_ref().map(|r| r.state), Some(RecState::Propose { .. })) {
                        // A long press accepts the proposal instead of opening the menu.
                        self.gestures.menu_cancel();
                        self.gestures.take_menu_events();
                        rec_event = RecEvent::LongPress;
                    } else {
                        self.summary.menu_requests += 1;
                        let cut = &self.cut;
                        // The view on display (or being flown to) is not offered again.
                        let shown = self.rec.as_ref().and_then(|r| match r.state {
                            RecState::Display { node, .. } | RecState::GoTo { node, .. } => Some(node),
                            _ => None,
                        });
                        let candidates = match (graph, self.view_index.as_ref()) {
                            (Some(g), Some(vi)) => radial_candidates(
                                g,
                                vi,
                                &ctx,
                                &settings.radial,
                                shown,
                                &mut |from: DVec3, to: DVec3| {
                                    let d = to - from;
                                    let len = d.length();
                                    len <= 0.0 || store.ray_cast(Level::Cut(cut), from, d, len).is_none()
                                },
                            ),
                            _ => Vec::new(),
                        };
                        self.menu = Some(RadialMenu { origin: at, candidates, pointing: None });
                    }
                }
                MenuEvent::Point { angle } => {
                    if let Some(m) = self.menu.as_mut() {
                        m.pointing = Some(angle);
                    }
                }
                MenuEvent::Select { angle } => {
                    self.summary.menu_selections += 1;
                    if let Some(m) = self.menu.take()
                        && let Some(slot) = slot_for_angle(angle, m.candidates.len())
                    {
                        rec_event = RecEvent::MenuSelect(m.candidates[slot]);
                    }
                }
                MenuEvent::Cancel => self.menu = None,
            }
        }
        let menu_open = self.gestures.menu_open();
        if menu_open && rec_event == RecEvent::Tick {
            rec_event = RecEvent::MenuOpen;
        }
        if let (Some(r), Some(g)) = (self.rec.as_ref(), graph) {
            intent = guide_intent(r, g, &ctx, intent, &self.controller);
        }
        let scene = SceneRef { store, cut: &self.cut };
        // A gesture begun during a flight takes the camera where the flight has brought it: the
        // flight stops and its node is not displayed. (The gesture that led to a flight, a
        // visitor's drag that reached a node's view, goes on under it.)
        let taken = |a: &GoTo| self.last_down >= a.start && !intent.is_idle() && !menu_open;
        if let Some(a) = self.goto.filter(taken) {
            self.controller.set_camera(scene, a.camera_at(t, scene, self.min_distance));
            // The flight's roll halfway is nobody's choice: a small one eases back upright.
            self.controller.rest_upright();
            self.goto = None;
            if let Some(r) = self.rec.as_mut() {
                r.abandon_go_to(t);
            }
        }
        match self.goto {
            Some(a) => {
                if a.done(t) {
                    self.controller.set_camera(scene, a.to);
                    self.goto = None;
                }
            }
            None => {
                if !menu_open {
                    // Zooming out beyond the distance bound is damped, to nothing at 1.5 × it.
                    let d = (self.controller.camera().eye - self.center).length();
                    if intent.zoom < 0.0 && d > self.max_distance {
                        intent.zoom *=
                            ((1.5 * self.max_distance - d) / (0.5 * self.max_distance)).clamp(0.0, 1.0);
                    }
                    self.controller.apply(scene, &intent, &mut self.rng);
                    if !self.gestures.active() {
                        self.controller.level(dt);
                    }
                    // The visitor moves: the configured projection comes back.
                    let fov = self.controller.camera().fov_y;
                    if !intent.is_idle() && fov != settings.fov_y {
                        let k = 1.0 - (-dt / FOV_EASE_SECS).exp();
                        let next = fov + (settings.fov_y - fov) * k;
                        let done = (next - settings.fov_y).abs() <= 1e-4 * settings.fov_y.abs();
                        self.controller.set_fov(if done { settings.fov_y } else { next });
                    }
                    // Beyond the distance bound: ease back.
                    let d = (self.controller.camera().eye - self.center).length();
                    if d > self.max_distance {
                        let k = (-dt / DISTANCE_EASE_SECS).exp();
                        let back = self.max_distance + (d - self.max_distance) * k;
                        let back = if back - self.max_distance <= 1e-9 * self.max_distance {
                            self.max_distance
                        } else {
                            back
                        };
                        self.controller.pull_toward(scene, self.center, back);
                    }
                }
            }
        }
        let mut effects = Vec::new();
        if let (Some(r), Some(g)) = (self.rec.as_mut(), graph) {
            let before = r.state;
            let ctx = ViewContext { camera: self.controller.camera(), ..ctx };
            effects = r.step(g, &ctx, rec_event, t, &mut self.rng);
            for fx in &effects {
                match *fx {
                    Effect::StartGoTo { node, duration } => {
                        let mut to = g.nodes[node].view;
                        if settings.real_scale {
                            // A real-scale projection holds: the node's view at the configured
                            // field of view.
                            to.fov_y = settings.fov_y;
                        }
                        self.goto = Some(GoTo { from: self.controller.camera(), to, start: t, duration });
                        // The node's light, if it has one, turns with the camera; else the light
                        // stays. A finger on the light keeps it.
                        if let Some(light) = g.nodes[node].light {
                            self.light.turn_to(light, t, duration);
                        }
                    }
                    Effect::ShowOverlay { node } => {
                        self.summary.nodes_displayed.push(g.nodes[node].id.clone())
                    }
                    _ => {}
                }
            }
            match (before, r.state) {
                // A menu pick while a proposal is shown supersedes it: the pick is counted as a
                // menu selection, the proposal as ignored.
                (RecState::Propose { .. }, RecState::GoTo { .. }) => match rec_event {
                    RecEvent::MenuSelect(_) => self.summary.proposals_ignored += 1,
                    _ => self.summary.proposals_accepted += 1,
                },
                (RecState::Propose { .. }, RecState::Discover { .. }) => self.summary.proposals_ignored += 1,
                _ => {}
            }
        }
        let cam = match self.goto {
            Some(a) => a.camera_at(t, SceneRef { store, cut: &self.cut }, self.min_distance),
            None => self.controller.camera(),
        };
        self.camera = cam;
        self.light.step(t, dt);
        if let Some(v) = cam.view_params(store, settings.size_px) {
            self.cut.update(store, &v, &settings.cut);
        }
        let surface = store.nearest_sample(cam.eye).map_or(f64::NAN, |(d, _)| d);
        if surface < self.min_distance * (1.0 - self.tolerance) {
            self.summary.collisions += 1;
        }
        self.summary.min_surface_distance = self.summary.min_surface_distance.min(surface);
        self.summary.frames += 1;
        let state = if menu_open {
            "menu"
        } else if self.goto.is_some() {
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
        let id = |i: usize| graph.and_then(|g| g.nodes.get(i)).map(|n| n.id.clone());
        let rec = self.rec.as_ref();
        let frame = Frame {
            t,
            eye: cam.eye.to_array(),
            target: cam.target.to_array(),
            up: cam.up.to_array(),
            surface_distance: surface,
            min_distance: self.min_distance,
            controller: state,
            isolevel: match &self.controller {
                Controller::IsoCam(c) => Some(c.isolevel()),
                _ => None,
            },
            recommender: rec.map(|r| r.state.name().to_string()),
            node: rec.and_then(|r| r.state.node()).and_then(id),
            overlay: match rec.map(|r| r.state) {
                Some(RecState::Display { node, .. }) => id(node),
                _ => None,
            },
            menu: menu_open.then(|| MenuTrace {
                open: true,
                candidates: self.menu.iter().flat_map(|m| &m.candidates).filter_map(|&i| id(i)).collect(),
            }),
            cut_nodes: self.cut.nodes().len(),
            light: self.light.light().dir.to_array(),
            light_mix: self.light.light().mix,
        };
        (frame, effects)
    }

    /// The controller's name (isocam, trackball, acevit).
    pub fn controller_name(&self) -> &'static str {
        self.controller.name()
    }
}
