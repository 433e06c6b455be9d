//! The kiosk's behaviour above one exploration (thesis 9.5, 9.8.10): a gallery of models
//! on the controller (swipe, tap), help/back/language buttons while exploring, the attract loop
//! after inactivity (the recommender tours the model on its own), and the reset to the gallery,
//! its first model and the default language after a longer inactivity.
//!
//! The light button (while exploring): a finger that lands on it steers the light
//! ([`crate::light`]) until it lifts, wherever it goes; a tap on it switches the light on, and
//! then every one-finger drag steers the light (other fingers are ignored) until it is tapped
//! again, the visitor goes back to the gallery or the attract loop starts (which eases the
//! light back to the start light; the reset starts the next visit with it).
//!
//! The kiosk holds its scene, the gallery's models ([`ModelRef`]: store, story, up axis and
//! front), for its whole lifetime: they are given once to [`Kiosk::new`], and each exploration
//! ([`Explorer`]) holds the one it explores.
//!
//! Pure like the rest of the core: the shell hands in touch events and times; the kiosk hands back
//! what to draw and what to play. A recorded session replayed through [`run_session`] gives the
//! same frames as the live kiosk did.
//!
//! Visits and statistics ([`crate::stats`]): a visit starts with a touch and ends at the reset
//! (or the same timeout in the gallery), when a touch takes over the attract loop, or when the
//! shell closes it ([`Kiosk::end_visit`]); the finished records wait in [`Kiosk::take_visits`].
//! Each model's long-run statistics live in the kiosk across visits ([`Kiosk::stats`]); the
//! shell loads and saves them. With `popularity` on, each new exploration's γ comes from them.

use crate::clock::{Playing, SessionFeed, Stepper, Touchable};
use crate::explore::ExploreSettings;
use crate::explore::Explorer;
use crate::gesture::{TouchEvent, TouchKind};
use crate::graph::InfoGraph;
use crate::recommend::{Effect, RecState};
use crate::scene::Store;
use crate::session::Session;
use crate::stats::{ExhibitStats, Observer, PopularitySettings, VisitEnd, VisitRecord, adjusted_importance};
use crate::trace::Frame;
use serde::Serialize;
use std::collections::BTreeMap;

/// What the kiosk shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// The gallery of models on the controller.
    Gallery,
    /// A visitor explores a model.
    Explore,
    /// Nobody touched for a while: the engine tours the model on its own.
    Attract,
}

/// A button of the controller window.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ButtonKind {
    /// Back to the gallery.
    Back,
    /// Show or hide the help.
    Help,
    /// Next language.
    Language,
    /// Previous model of the gallery.
    Previous,
    /// Next model of the gallery.
    Next,
    /// Explore the gallery's current model.
    Explore,
    /// Steer the light: drag from it, or tap it to make one-finger drags steer the light.
    Light,
}

/// A button and where it is on the controller surface (normalised, origin top-left).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Button {
    /// What it does.
    pub kind: ButtonKind,
    /// `[x0, y0, x1, y1]`.
    pub rect: [f64; 4],
}

impl Button {
    /// Whether the point is inside.
    pub fn contains(&self, x: f64, y: f64) -> bool {
        x >= self.rect[0] && x <= self.rect[2] && y >= self.rect[1] && y <= self.rect[3]
    }
}

const BACK: Button = Button { kind: ButtonKind::Back, rect: [0.0, 0.0, 0.16, 0.14] };
const HELP: Button = Button { kind: ButtonKind::Help, rect: [0.84, 0.0, 1.0, 0.14] };
const LIGHT: Button = Button { kind: ButtonKind::Light, rect: [0.48, 0.0, 0.64, 0.14] };
const LANGUAGE: Button = Button { kind: ButtonKind::Language, rect: [0.66, 0.0, 0.82, 0.14] };
const PREVIOUS: Button = Button { kind: ButtonKind::Previous, rect: [0.0, 0.3, 0.12, 0.7] };
const NEXT: Button = Button { kind: ButtonKind::Next, rect: [0.88, 0.3, 1.0, 0.7] };
const EXPLORE: Button = Button { kind: ButtonKind::Explore, rect: [0.3, 0.78, 0.7, 0.94] };

/// The buttons of the controller in a mode (the shell draws them where they are hit-tested).
pub fn buttons(mode: Mode) -> &'static [Button] {
    match mode {
        Mode::Gallery => &[LANGUAGE, PREVIOUS, NEXT, EXPLORE],
        Mode::Explore => &[BACK, LIGHT, LANGUAGE, HELP],
        Mode::Attract => &[],
    }
}

/// Settings of the kiosk's behaviour.
#[derive(Clone, Debug)]
pub struct KioskSettings {
    /// Seconds without a touch while exploring before the attract loop starts.
    pub attract_after_secs: f64,
    /// Seconds without a touch before the reset to the gallery (counted from the last touch).
    pub reset_after_secs: f64,
    /// Languages offered, the first is the default.
    pub languages: Vec<String>,
    /// A gallery swipe: horizontal travel at least this (fraction of the width).
    pub swipe_min: f64,
    /// A tap: released within this many seconds…
    pub tap_max_secs: f64,
    /// …having moved at most this far.
    pub tap_max_move: f64,
    /// Settings of each exploration (controller, gestures, recommender, radial menu, seed).
    pub explore: ExploreSettings,
    /// Whether and how popularity adjusts γ ([`crate::stats`]).
    pub popularity: PopularitySettings,
}

impl Default for KioskSettings {
    fn default() -> Self {
        Self {
            attract_after_secs: 60.0,
            reset_after_secs: 180.0,
            languages: vec!["en".into(), "it".into()],
            swipe_min: 0.12,
            tap_max_secs: 0.5,
            tap_max_move: 0.03,
            explore: ExploreSettings::default(),
            popularity: PopularitySettings::default(),
        }
    }
}

/// One model of the exhibit as the kiosk sees it.
pub struct ModelRef<'a, B: AsRef<[u8]>> {
    /// Its store.
    pub store: &'a Store<B>,
    /// Its story, if any.
    pub graph: Option<&'a InfoGraph>,
    /// The model's up direction (unit, any direction; scanners and photogrammetry often give Z
    /// up): the explorer's start framing and IsoCam's up follow it.
    pub up: glam::DVec3,
    /// The side the start view looks at (exhibit.toml's `front`); `None`: the default.
    pub front: Option<glam::DVec3>,
}

/// What the shell must do besides drawing.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "effect", rename_all = "kebab-case")]
pub enum KioskEffect {
    /// Play a node's narration in a language (stopping any other).
    PlayNarration {
        /// Model index.
        model: usize,
        /// Node index.
        node: usize,
        /// Language.
        lang: String,
    },
    /// Stop the narration.
    StopNarration,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Route {
    Button(ButtonKind),
    Explorer,
    Gallery {
        t0: f64,
        x0: f64,
        y0: f64,
        moved: f64,
    },
    /// A finger steering the light: where it landed and when, where it was last, how far it
    /// went, and whether it landed on the light button.
    Light {
        t0: f64,
        from: (f64, f64),
        last: (f64, f64),
        moved: f64,
        on_button: bool,
    },
    /// The touch that woke the kiosk from the attract loop, or a finger ignored while another
    /// steers the light: spent.
    Spent,
}

/// One line of the kiosk's trace.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct KioskFrame {
    /// Kiosk time.
    pub t: f64,
    /// Mode.
    pub mode: Mode,
    /// The model shown (gallery: the current card).
    pub model: usize,
    /// Language.
    pub lang: String,
    /// Whether the help is shown.
    pub help: bool,
    /// Whether the light button is on (one-finger drags steer the light).
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub light_on: bool,
    /// Seconds until the reset (attract loop).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub countdown: Option<f64>,
    /// The exploration's frame (exploring or attracting).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub explore: Option<Frame>,
    /// Effects of this frame.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub effects: Vec<KioskEffect>,
}

/// The kiosk, over the models it holds while it lives.
pub struct Kiosk<'a, B: AsRef<[u8]>> {
    /// Settings.
    pub settings: KioskSettings,
    mode: Mode,
    model: usize,
    models: Vec<ModelRef<'a, B>>,
    explorers: Vec<Option<Explorer<'a, B>>>,
    lang: usize,
    help: bool,
    light_on: bool,
    last_input: f64,
    now: f64,
    routes: BTreeMap<i64, Route>,
    narrating: Option<(usize, usize)>,
    visits: u64,
    pending: Vec<KioskEffect>,
    stats: Vec<ExhibitStats>,
    observers: Vec<Observer>,
    visit: Option<VisitRecord>,
    finished: Vec<VisitRecord>,
}

impl<B: AsRef<[u8]>> Touchable for Kiosk<'_, B> {
    fn touch(&mut self, e: &TouchEvent) {
        Kiosk::touch(self, e);
    }
}

impl<'a, B: AsRef<[u8]>> Kiosk<'a, B> {
    /// A kiosk over `models` (the gallery, in order), starting in the gallery at time `now`.
    pub fn new(settings: KioskSettings, models: Vec<ModelRef<'a, B>>, now: f64) -> Self {
        let n = models.len();
        Self {
            settings,
            mode: Mode::Gallery,
            model: 0,
            models,
            explorers: (0..n).map(|_| None).collect(),
            lang: 0,
            help: false,
            light_on: false,
            last_input: now,
            now,
            routes: BTreeMap::new(),
            narrating: None,
            visits: 0,
            pending: Vec::new(),
            stats: vec![ExhibitStats::default(); n],
            observers: vec![Observer::default(); n],
            visit: None,
            finished: Vec::new(),
        }
    }

    /// Each model's long-run statistics.
    pub fn stats(&self) -> &[ExhibitStats] {
        &self.stats
    }

    /// Sets a model's statistics (loaded by the shell at start).
    pub fn set_stats(&mut self, model: usize, stats: ExhibitStats) {
        if let Some(s) = self.stats.get_mut(model) {
            *s = stats;
        }
    }

    /// The visits finished since the last call.
    pub fn take_visits(&mut self) -> Vec<VisitRecord> {
        std::mem::take(&mut self.finished)
    }

    /// The visit in progress, if any.
    pub fn visit(&self) -> Option<&VisitRecord> {
        self.visit.as_ref()
    }

    /// Ends the visit in progress at `t` (the shell closes: [`VisitEnd::Exit`]), counting the
    /// display shown until then.
    pub fn end_visit(&mut self, t: f64, how: VisitEnd) {
        self.close_displays(t, true);
        self.finish_visit(t, how);
    }

    /// Ends the counting of displays of the models not being explored by a visitor (all: `all`).
    fn close_displays(&mut self, t: f64, all: bool) {
        for (m, o) in self.observers.iter_mut().enumerate() {
            if o.counting()
                && (all || m != self.model || self.mode != Mode::Explore)
                && let Some(g) = self.models.get(m).and_then(|x| x.graph)
            {
                let visit = self.visit.as_mut().map(|v| v.model(m));
                o.close(g, t, &mut self.stats[m], visit);
            }
        }
    }

    fn finish_visit(&mut self, t: f64, how: VisitEnd) {
        if let Some(mut v) = self.visit.take() {
            v.end = t;
            v.ended = how;
            for m in &v.models {
                if let Some(s) = self.stats.get_mut(m.model) {
                    s.visits += 1;
                }
            }
            self.finished.push(v);
        }
    }

    /// Mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// The current model (the gallery's card, or the one explored).
    pub fn model(&self) -> usize {
        self.model
    }

    /// Current language.
    pub fn lang(&self) -> &str {
        self.settings.languages.get(self.lang).map_or("en", String::as_str)
    }

    /// Whether the help is shown.
    pub fn help(&self) -> bool {
        self.help
    }

    /// Whether the light button is on: one-finger drags steer the light.
    pub fn light_on(&self) -> bool {
        self.light_on
    }

    /// Whether a finger steers the light now (from the button, or with the light on).
    pub fn light_active(&self) -> bool {
        self.light_on || self.routes.values().any(|r| matches!(r, Route::Light { .. }))
    }

    /// The exploration of the current model, while exploring or attracting.
    pub fn explorer(&self) -> Option<&Explorer<'a, B>> {
        match self.mode {
            Mode::Gallery => None,
            _ => self.explorers.get(self.model).and_then(Option::as_ref),
        }
    }

    /// The narration playing: (model, node).
    pub fn narrating(&self) -> Option<(usize, usize)> {
        self.narrating
    }

    /// Seconds until the reset, in the attract loop.
    pub fn countdown(&self) -> Option<f64> {
        (self.mode == Mode::Attract)
            .then(|| (self.settings.reset_after_secs - (self.now - self.last_input)).max(0.0))
    }

    /// Seconds since the last touch.
    pub fn idle_secs(&self) -> f64 {
        self.now - self.last_input
    }

    fn stop_narration(&mut self) {
        if self.narrating.take().is_some() {
            self.pending.push(KioskEffect::StopNarration);
        }
    }

    fn press(&mut self, kind: ButtonKind) {
        match kind {
            ButtonKind::Back => {
                self.stop_narration();
                if let Some(e) = self.explorers.get_mut(self.model).and_then(Option::as_mut) {
                    e.release_all(self.now);
                    e.close_menu();
                }
                self.mode = Mode::Gallery;
                self.help = false;
                self.light_on = false;
            }
            ButtonKind::Help => self.help = !self.help,
            ButtonKind::Light => self.light_on = !self.light_on,
            ButtonKind::Language => {
                self.lang = (self.lang + 1) % self.settings.languages.len().max(1);
                if let Some((model, node)) = self.narrating {
                    self.pending.push(KioskEffect::PlayNarration {
                        model,
                        node,
                        lang: self.lang().to_string(),
                    });
                }
                let lang = self.lang().to_string();
                if let Some(v) = self.visit.as_mut() {
                    v.language(&lang);
                }
            }
            ButtonKind::Previous => {
                self.model = (self.model + self.models.len().max(1) - 1) % self.models.len().max(1)
            }
            ButtonKind::Next => self.model = (self.model + 1) % self.models.len().max(1),
            ButtonKind::Explore => self.mode = Mode::Explore,
        }
    }

    /// Feeds one touch event of the controller surface (its `t` is the kiosk's clock).
    pub fn touch(&mut self, e: &TouchEvent) {
        if !(e.t.is_finite() && e.x.is_finite() && e.y.is_finite()) {
            return;
        }
        self.last_input = self.last_input.max(e.t);
        if e.ev == TouchKind::Menu {
            self.menu_button(e);
            return;
        }
        if e.ev == TouchKind::Down {
            let took_over = self.mode == Mode::Attract;
            if took_over {
                self.take_over_tour(e.t);
            }
            self.note_touch(e.t);
            let route = match self.mode {
                // The finger that stopped the tour is spent.
                _ if took_over => Route::Spent,
                // A radial menu opened with the mouse's right button has no finger down: the
                // next press picks from it, wherever it lands.
                Mode::Explore if self.explorer().is_some_and(|x| x.menu().is_some()) => Route::Explorer,
                mode => {
                    let exploring = self.routes.values().any(|r| *r == Route::Explorer);
                    let lighting = self.routes.values().any(|r| matches!(r, Route::Light { .. }));
                    let light = |on_button| Route::Light {
                        t0: e.t,
                        from: (e.x, e.y),
                        last: (e.x, e.y),
                        moved: 0.0,
                        on_button,
                    };
                    match buttons(mode).iter().find(|b| b.contains(e.x, e.y)) {
                        Some(b) if b.kind == ButtonKind::Light && !exploring && !lighting => light(true),
                        Some(b) if !exploring && !lighting => Route::Button(b.kind),
                        _ if mode == Mode::Gallery => {
                            Route::Gallery { t0: e.t, x0: e.x, y0: e.y, moved: 0.0 }
                        }
                        // With the light on, one finger steers it; others are ignored.
                        _ if self.light_on && !exploring && !lighting => light(false),
                        _ if self.light_on || lighting => Route::Spent,
                        _ => Route::Explorer,
                    }
                }
            };
            self.routes.insert(e.id, route);
            match route {
                Route::Explorer => self.feed_explorer(e),
                Route::Light { .. } => {
                    if let Some(x) = self.explorers.get_mut(self.model).and_then(Option::as_mut) {
                        x.light_drag_start();
                    }
                }
                _ => {}
            }
            return;
        }
        if self.routes.contains_key(&e.id) {
            self.note_touch(e.t);
        }
        let Some(route) = self.routes.get_mut(&e.id) else { return };
        let end = matches!(e.ev, TouchKind::Up | TouchKind::Cancel);
        match route {
            Route::Explorer => {
                let e = *e;
                if end {
                    self.routes.remove(&e.id);
                }
                self.feed_explorer(&e);
            }
            Route::Gallery { t0, x0, y0, moved } => {
                *moved = moved.max((e.x - *x0).hypot(e.y - *y0));
                let (t0, dx, dy, moved) = (*t0, e.x - *x0, e.y - *y0, *moved);
                if end {
                    self.routes.remove(&e.id);
                    if e.ev == TouchKind::Up {
                        if dx.abs() >= self.settings.swipe_min && dx.abs() > dy.abs() {
                            // Swipe left shows the next model, as a page turns.
                            self.press(if dx < 0.0 { ButtonKind::Next } else { ButtonKind::Previous });
                        } else if e.t - t0 <= self.settings.tap_max_secs
                            && moved <= self.settings.tap_max_move
                        {
                            self.press(ButtonKind::Explore);
                        }
                    }
                }
            }
            Route::Button(kind) => {
                let kind = *kind;
                if end {
                    self.routes.remove(&e.id);
                    let inside = buttons(self.mode).iter().any(|b| b.kind == kind && b.contains(e.x, e.y));
                    if e.ev == TouchKind::Up && inside {
                        self.press(kind);
                    }
                }
            }
            Route::Light { t0, from, last, moved, on_button } => {
                let (dx, dy) = (e.x - last.0, e.y - last.1);
                *last = (e.x, e.y);
                *moved = moved.max((e.x - from.0).hypot(e.y - from.1));
                let (t0, moved, on_button) = (*t0, *moved, *on_button);
                let x = self.explorers.get_mut(self.model).and_then(Option::as_mut);
                if let Some(x) = x {
                    if e.ev == TouchKind::Move || e.ev == TouchKind::Up {
                        x.light_drag(dx, dy);
                    }
                    if end {
                        x.light_drag_end();
                    }
                }
                if end {
                    self.routes.remove(&e.id);
                    // A tap on the button switches the light on or off.
                    if on_button
                        && e.ev == TouchKind::Up
                        && e.t - t0 <= self.settings.tap_max_secs
                        && moved <= self.settings.tap_max_move
                    {
                        self.press(ButtonKind::Light);
                    }
                }
            }
            Route::Spent => {
                if end {
                    self.routes.remove(&e.id);
                }
            }
        }
    }

    /// A touch: the visit goes on, or a new one starts.
    fn note_touch(&mut self, t: f64) {
        let lang = self.lang().to_string();
        self.visit.get_or_insert_with(|| VisitRecord::new(t, &lang)).last_touch = t;
    }

    fn feed_explorer(&mut self, e: &TouchEvent) {
        if let Some(x) = self.explorers.get_mut(self.model).and_then(Option::as_mut) {
            x.touch(e);
        }
    }

    /// The mouse's right button (thesis 9.5.2): the radial menu at once, or closed if open.
    /// During the attract loop it takes over as a touch does, with the menu open.
    fn menu_button(&mut self, e: &TouchEvent) {
        if self.mode == Mode::Attract {
            self.take_over_tour(e.t);
        }
        self.note_touch(e.t);
        if self.mode == Mode::Explore {
            self.feed_explorer(e);
        }
    }

    /// A visitor's touch or click at `t` stops the attract tour: whoever explored before has gone
    /// (a new visit), and exploring is the visitor's again.
    fn take_over_tour(&mut self, t: f64) {
        self.finish_visit(t, VisitEnd::NewVisitor);
        self.mode = Mode::Explore;
        if let Some(x) = self.explorers.get_mut(self.model).and_then(Option::as_mut) {
            x.autopilot = false;
        }
    }

    fn reset(&mut self) {
        self.stop_narration();
        self.mode = Mode::Gallery;
        self.model = 0;
        self.lang = 0;
        self.help = false;
        self.light_on = false;
        self.routes.clear();
        for e in &mut self.explorers {
            *e = None;
        }
    }

    /// Advances to `t` (one frame of the exploration's clock after the previous step).
    pub fn step(&mut self, t: f64) -> KioskFrame {
        self.now = t;
        let idle = t - self.last_input;
        let touched = !self.routes.is_empty();
        let mut ended = None;
        if !touched && idle >= self.settings.reset_after_secs && self.visit.is_some() {
            ended = Some(if self.mode == Mode::Gallery { VisitEnd::Back } else { VisitEnd::Reset });
        }
        if !touched
            && idle >= self.settings.reset_after_secs
            && (self.mode != Mode::Gallery || self.model != 0 || self.lang != 0)
        {
            self.reset();
        } else if !touched && self.mode == Mode::Explore && idle >= self.settings.attract_after_secs {
            self.mode = Mode::Attract;
            self.help = false;
            self.light_on = false;
            if let Some(x) = self.explorers.get_mut(self.model).and_then(Option::as_mut) {
                x.restore_light(t);
                // A menu opened with the mouse and left open would hold the tour still.
                x.close_menu();
            }
        }
        let mut frame = None;
        if self.mode != Mode::Gallery
            && let Some(m) = self.models.get(self.model)
        {
            let model = self.model;
            let slot = &mut self.explorers[model];
            if slot.is_none() {
                // Each visit gets its own seed: a different story order per visitor, reproducible.
                let mut s = self.settings.explore;
                s.seed = s.seed.wrapping_add(self.visits);
                s.up = m.up;
                s.front = m.front;
                self.visits += 1;
                let mut x = Explorer::new(m.store, m.graph, &s, t);
                if let Some(gamma) = m
                    .graph
                    .and_then(|g| adjusted_importance(g, &self.stats[model], &self.settings.popularity))
                {
                    x.set_gamma(gamma);
                }
                *slot = Some(x);
            }
            if let Some(x) = slot.as_mut() {
                x.autopilot = self.mode == Mode::Attract;
                let before = x.recommender().map(|r| r.state);
                let menus = x.summary.menu_requests;
                let (f, effects) = x.step(t);
                if let (Some(g), Some(before), Some(after)) =
                    (m.graph, before, x.recommender().map(|r| r.state))
                {
                    let active = self.mode == Mode::Explore;
                    let mut visit = self.visit.as_mut().map(|v| v.model(model));
                    if active && let Some(v) = visit.as_deref_mut() {
                        v.menu_opens += (x.summary.menu_requests - menus) as u32;
                    }
                    self.observers[model].step(g, (before, after), t, active, &mut self.stats[model], visit);
                }
                for fx in effects {
                    match fx {
                        Effect::PlayNarration { node } => {
                            self.narrating = Some((model, node));
                            let lang = self.lang().to_string();
                            self.pending.push(KioskEffect::PlayNarration { model, node, lang });
                        }
                        Effect::StopNarration { .. } => self.stop_narration(),
                        _ => {}
                    }
                }
                frame = Some(f);
            }
        }
        self.close_displays(t, false);
        if let Some(how) = ended {
            self.finish_visit(t, how);
        }
        // A narration ends with its display, whatever ended it.
        if let Some((model, node)) = self.narrating {
            let displayed = self.explorer().and_then(|x| x.recommender()).map(|r| r.state);
            if model != self.model
                || !matches!(displayed, Some(RecState::Display { node: n, .. }) if n == node)
            {
                self.stop_narration();
            }
        }
        KioskFrame {
            t,
            mode: self.mode,
            model: self.model,
            lang: self.lang().to_string(),
            help: self.help,
            light_on: self.light_on,
            countdown: self.countdown(),
            explore: frame,
            effects: std::mem::take(&mut self.pending),
        }
    }
}

/// Runs a recorded session through the kiosk at its fixed clock and returns every frame: the
/// kiosk's own replay (the same path as the live windows).
pub fn run_session<B: AsRef<[u8]>>(
    models: &[ModelRef<'_, B>],
    session: &Session,
    settings: &KioskSettings,
    extra_secs: f64,
) -> Vec<KioskFrame> {
    let held = models
        .iter()
        .map(|m| ModelRef { store: m.store, graph: m.graph, up: m.up, front: m.front })
        .collect();
    let mut kiosk = Kiosk::new(settings.clone(), held, 0.0);
    let mut stepper = Stepper::new(settings.explore.fps, Playing::new(session, SessionFeed::once()));
    let end = stepper.clock().end_of(session.duration() + extra_secs);
    let mut out = Vec::new();
    while let Some(t) = stepper.next(end, &mut kiosk) {
        out.push(kiosk.step(t));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gesture::{GestureSettings, Gestures, TouchEvent, TouchKind};

    fn overlap(a: [f64; 4], b: [f64; 4]) -> bool {
        a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
    }

    #[test]
    fn no_button_of_the_exploration_overlaps_the_zoom_bar() {
        let settings = GestureSettings::default();
        let bar = settings.zoom_bar_rect();
        for b in buttons(Mode::Explore) {
            assert!(!overlap(b.rect, bar), "{:?} at {:?} overlaps the zoom bar at {bar:?}", b.kind, b.rect);
        }
        // The bar is where the gestures take it: a touch in it zooms, one above it does not.
        let zooms = |y: f64| {
            let mut g = Gestures::new(settings);
            g.event(&TouchEvent { t: 0.0, ev: TouchKind::Down, id: 1, x: 0.5 * bar[2], y });
            g.event(&TouchEvent { t: 0.1, ev: TouchKind::Move, id: 1, x: 0.5 * bar[2], y: y - 0.05 });
            g.frame(0.1, 1.0 / 60.0).zoom != 0.0
        };
        assert!(zooms(0.6));
        assert!(!zooms(bar[1] - 0.02));
    }
}
