//! The stochastic recommendation engine (thesis 11.3–11.4.1). Pure: `(state, event, now) →
//! (state, effects)`; the effects are data that the kiosk shell executes and the replay trace
//! records. The radial point-of-interest selector, which ranks views by the engine's
//! similarity, is [`crate::radial`].
//!
//! States: discover → attract → propose → go-to → display (→ discover). Scores (Eq. 11.1–11.2):
//! S = γ · D · R · σ, D = Π (1 − ω (1 − visⱼ)), R = min((ΔT / T_max)², 1) after a display or a
//! proposal (1 before), σ from Eq. 11.3 for views in sight with enough ROI samples, else
//! Eq. 11.4. Selection is proportional to the score, among visible candidates first.
//!
//! Eq. 11.3 as the thesis states it: the samples s_j in the region of interest of view i are
//! those that project, through view i, onto a set pixel of the node's ROI mask
//! ([`crate::graph::Node::roi_bitmap`], loaded by the shell); the ROI box is only the fast
//! pre-filter (11.3.1, 11.5), and decides alone when the mask is missing or unreadable. The
//! distances compare P V_i s and P V_cur s with the same, current, projection P: a node's own
//! field of view serves only to place its mask.

use crate::camera::Camera;
use crate::graph::{InfoGraph, MANDATORY, Node};
use glam::{DVec2, DVec3};
use rand::Rng;
use serde::Serialize;

/// Every timer and threshold of the engine, with documented defaults (the thesis gives none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecSettings {
    /// Seconds in discover before selecting (avoids a continuous flow of suggestions).
    pub discover_secs: f64,
    /// Seconds of hidden attraction before proposing.
    pub attract_secs: f64,
    /// Seconds a proposal stays before it counts as ignored.
    pub propose_secs: f64,
    /// Duration of the go-to animation.
    pub goto_secs: f64,
    /// Display time: at least this many seconds…
    pub display_min_secs: f64,
    /// …plus this many per character of the text.
    pub display_secs_per_char: f64,
    /// T_max of the recency weight R.
    pub t_max_secs: f64,
    /// View distance d (mean NDC distance of the samples, thesis 9.7.2 and 11.4.1) under which
    /// attract or propose turns into go-to (auto-accept / snap).
    pub accept_distance: f64,
    /// During display, moving beyond this view distance ends the display.
    pub leave_distance: f64,
    /// Visible views whose close similarity is at most this count as invisible (11.3.4).
    pub visible_threshold: f64,
    /// Fewest ROI samples for the close metric (Eq. 11.3).
    pub min_roi_samples: usize,
    /// Most nodes compared with the close metric per step (nearest potentially visible first).
    pub max_close: usize,
    /// Attraction: orthogonal nudge as a fraction of the user's motion.
    pub nudge_gain: f64,
    /// Friction: under this view distance, the user's motion is slowed…
    pub friction_distance: f64,
    /// …by this factor.
    pub friction: f64,
}

impl Default for RecSettings {
    fn default() -> Self {
        Self {
            discover_secs: 3.0,
            attract_secs: 8.0,
            propose_secs: 8.0,
            goto_secs: 2.0,
            display_min_secs: 6.0,
            display_secs_per_char: 0.06,
            t_max_secs: 120.0,
            accept_distance: 0.1,
            leave_distance: 0.5,
            visible_threshold: 0.0,
            min_roi_samples: 4,
            max_close: 16,
            nudge_gain: 0.5,
            friction_distance: 0.3,
            friction: 0.5,
        }
    }
}

/// The engine's state.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(tag = "state", rename_all = "kebab-case")]
pub enum RecState {
    /// Waiting before choosing.
    Discover {
        /// Entered at.
        since: f64,
    },
    /// Hidden attraction toward `node`.
    Attract {
        /// Node index.
        node: usize,
        /// Entered at.
        since: f64,
    },
    /// `node` proposed in an inset.
    Propose {
        /// Node index.
        node: usize,
        /// Entered at.
        since: f64,
    },
    /// Animating toward `node`.
    GoTo {
        /// Node index.
        node: usize,
        /// Entered at.
        since: f64,
        /// Whether it was chosen in the radial menu (its overlay then stays until the visitor
        /// moves away).
        from_menu: bool,
    },
    /// Showing `node`'s overlay.
    Display {
        /// Node index.
        node: usize,
        /// Entered at.
        since: f64,
        /// See `GoTo::from_menu`.
        from_menu: bool,
    },
}

impl RecState {
    /// The state's name as traced.
    pub fn name(&self) -> &'static str {
        match self {
            Self::Discover { .. } => "discover",
            Self::Attract { .. } => "attract",
            Self::Propose { .. } => "propose",
            Self::GoTo { .. } => "go-to",
            Self::Display { .. } => "display",
        }
    }

    /// The node concerned, if any.
    pub fn node(&self) -> Option<usize> {
        match *self {
            Self::Discover { .. } => None,
            Self::Attract { node, .. }
            | Self::Propose { node, .. }
            | Self::GoTo { node, .. }
            | Self::Display { node, .. } => Some(node),
        }
    }
}

/// What happened, besides time passing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum RecEvent {
    /// A frame.
    Tick,
    /// A long press while a proposal is shown: accept it.
    LongPress,
    /// The radial menu picked this node.
    MenuSelect(usize),
    /// A frame with the radial menu open: the visitor is choosing, so nothing is accepted for
    /// them (a view they happen to be near does not start a flight under the menu).
    MenuOpen,
}

/// What the shell must do (and the trace records).
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "effect", rename_all = "kebab-case")]
pub enum Effect {
    /// Show the suggestion inset for a node (with the animated path from the current view).
    ShowInset {
        /// Node index.
        node: usize,
    },
    /// Hide it.
    HideInset {
        /// Node index.
        node: usize,
    },
    /// Start the go-to animation to the node's view.
    StartGoTo {
        /// Node index.
        node: usize,
        /// Duration in seconds.
        duration: f64,
    },
    /// Show the node's overlay.
    ShowOverlay {
        /// Node index.
        node: usize,
    },
    /// Hide it.
    HideOverlay {
        /// Node index.
        node: usize,
    },
    /// Play the node's narration.
    PlayNarration {
        /// Node index.
        node: usize,
    },
    /// Stop it.
    StopNarration {
        /// Node index.
        node: usize,
    },
}

/// Run-time statistics per node (for the analytics to come).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct NodeStats {
    /// Times displayed.
    pub displays: u32,
    /// Seconds displayed in total.
    pub dwell_secs: f64,
    /// Proposals ignored.
    pub refusals: u32,
    /// Proposals made.
    pub proposals: u32,
    /// Time of the last display or proposal.
    pub last_event: Option<f64>,
    /// Whether it has been displayed in this visit.
    pub visited: bool,
}

/// What the engine sees of the visitor's view this frame.
#[derive(Clone, Copy, Debug)]
pub struct ViewContext<'a> {
    /// The current camera.
    pub camera: Camera,
    /// Projection aspect ratio (width / height).
    pub aspect: f64,
    /// A random sample of points of the current cut (model coordinates).
    pub samples: &'a [DVec3],
    /// Diagonal of the model's bounding box (δ of Eq. 11.4).
    pub diagonal: f64,
    /// Whether the visitor is moving the camera this frame.
    pub moving: bool,
}

/// ξ² of Eq. 11.3: the largest squared distance between two points of the [−1, 1]² screen.
const XI2: f64 = 8.0;

fn ndc2(cam: &Camera, p: DVec3, aspect: f64) -> Option<DVec2> {
    Projector::new(cam).ndc(p, aspect)
}

/// A camera's projection to normalised device coordinates, with its basis precomputed.
#[derive(Clone, Copy, Debug)]
pub struct Projector {
    eye: DVec3,
    right: DVec3,
    up: DVec3,
    forward: DVec3,
    inv_tan: f64,
}

impl Projector {
    /// Precomputes a camera's projection.
    pub fn new(cam: &Camera) -> Self {
        let forward = cam.forward();
        let right = cam.right();
        Self {
            eye: cam.eye,
            right,
            up: right.cross(forward),
            forward,
            inv_tan: 1.0 / (cam.fov_y * 0.5).tan(),
        }
    }

    /// The same view seen with another projection (`inv_tan` = 1 / tan(fov_y / 2)).
    #[inline]
    fn with_inv_tan(self, inv_tan: f64) -> Self {
        Self { inv_tan, ..self }
    }

    /// The view-space x and y of `p` over its depth (NDC before the projection's scale and
    /// aspect), `None` behind the eye.
    #[inline]
    fn unscaled(&self, p: DVec3) -> Option<DVec2> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        (z > 0.0).then(|| DVec2::new(d.dot(self.right), d.dot(self.up)) / z)
    }

    /// NDC (x, y) of `p` for a viewport of the given aspect ratio, `None` behind the eye.
    #[inline]
    pub fn ndc(&self, p: DVec3, aspect: f64) -> Option<DVec2> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        (z > 0.0).then(|| DVec2::new(d.dot(self.right) / aspect, d.dot(self.up)) * (self.inv_tan / z))
    }
}

/// What a recommendation step computes once from the context: the samples' projections in the
/// current view and the centre of the visible samples (the radial selector ranks with it too).
pub(crate) struct StepFrame<'a> {
    ctx: &'a ViewContext<'a>,
    cur: Projector,
    cur_ndc: Vec<Option<DVec2>>,
    t_cur: DVec3,
}

impl<'a> StepFrame<'a> {
    pub(crate) fn new(ctx: &'a ViewContext<'a>) -> Self {
        let cur = Projector::new(&ctx.camera);
        let cur_ndc: Vec<Option<DVec2>> = ctx.samples.iter().map(|&s| cur.ndc(s, ctx.aspect)).collect();
        let (mut sum, mut n) = (DVec3::ZERO, 0usize);
        for (s, p) in ctx.samples.iter().zip(&cur_ndc) {
            if p.is_some_and(|p| p.x.abs() <= 1.0 && p.y.abs() <= 1.0) {
                sum += *s;
                n += 1;
            }
        }
        let t_cur = if n == 0 { ctx.camera.target } else { sum / n as f64 };
        Self { ctx, cur, cur_ndc, t_cur }
    }

    /// The mean NDC distance between the samples seen through `own` (a node's view) with the
    /// current projection and the same samples in the current view, over the samples both see;
    /// `None` when none is.
    pub(crate) fn mean_ndc_distance(&self, own: &Projector) -> Option<f64> {
        let through_p = own.with_inv_tan(self.cur.inv_tan);
        let (mut sum, mut n) = (0.0, 0usize);
        for (&s, cur) in self.ctx.samples.iter().zip(&self.cur_ndc) {
            if let (Some(a), Some(b)) = (through_p.ndc(s, self.ctx.aspect), cur) {
                sum += (a - *b).length();
                n += 1;
            }
        }
        (n > 0).then(|| sum / n as f64)
    }

    /// Eq. 11.3 for a node seen through `own` (its view with its own field of view). The samples
    /// s_j "inside the region of interest of view i" are those inside the node's ROI box (a fast
    /// pre-filter) that project, through the node's own view, onto a set cell of its ROI mask;
    /// without a mask the box alone decides, without either the node's frustum. The distances
    /// compare P V_i s and P V_cur s with the same, current, projection P (the visitor's field
    /// of view and aspect), as the equation has it.
    pub(crate) fn close(&self, own: &Projector, node: &Node, min_roi: usize) -> Option<f64> {
        let k = self.ctx.samples.len();
        if k == 0 {
            return None;
        }
        let aspect = self.ctx.aspect;
        // One projection per sample: the node's own frame and the current P differ only in scale.
        let screen = |u: DVec2, aspect: f64, inv_tan: f64| DVec2::new(u.x / aspect, u.y) * inv_tan;
        let (mut r, mut sum) = (0usize, 0.0);
        for (&s, cur) in self.ctx.samples.iter().zip(&self.cur_ndc) {
            if let Some((lo, hi)) = node.roi_bbox
                && !(s.cmpge(lo).all() && s.cmple(hi).all())
            {
                continue;
            }
            let u = own.unscaled(s);
            let in_roi = match (&node.roi_bitmap, node.roi_bbox) {
                (Some(mask), _) => u.is_some_and(|u| mask.covers(screen(u, mask.aspect, own.inv_tan))),
                (None, Some(_)) => true,
                (None, None) => u.is_some_and(|u| {
                    let p = screen(u, aspect, own.inv_tan);
                    p.x.abs() <= 1.0 && p.y.abs() <= 1.0
                }),
            };
            if !in_roi {
                continue;
            }
            r += 1;
            let d2 = match (u, cur) {
                (Some(u), Some(b)) => (screen(u, aspect, self.cur.inv_tan) - *b).length_squared(),
                _ => XI2,
            };
            sum += d2.min(XI2);
        }
        if r < min_roi {
            return None;
        }
        Some((1.0 - (XI2 * (k - r) as f64 + sum) / (k as f64 * XI2)).clamp(0.0, 1.0))
    }

    /// Eq. 11.4.
    pub(crate) fn far(&self, view: &Camera) -> f64 {
        let ctx = self.ctx;
        let t_i = view.eye + view.forward() * (self.t_cur - ctx.camera.eye).length();
        let delta = ctx.diagonal.max(f64::MIN_POSITIVE);
        (1.0 - ((view.eye - ctx.camera.eye).length() + (t_i - self.t_cur).length()) / (2.0 * delta))
            .clamp(0.0, 1.0)
    }

    /// Whether a point is on screen in the current view.
    fn on_screen(&self, p: DVec3) -> bool {
        self.cur.ndc(p, self.ctx.aspect).is_some_and(|q| q.x.abs() <= 1.0 && q.y.abs() <= 1.0)
    }
}

/// Close similarity, Eq. 11.3, of a node's view to `ctx.camera` over the samples; `None` when
/// fewer than `min_roi` samples fall in the node's region of interest (its ROI mask within its
/// box, its box, or its frustum: see the module documentation).
pub fn similarity_close(node: &Node, ctx: &ViewContext<'_>, min_roi: usize) -> Option<f64> {
    StepFrame::new(ctx).close(&Projector::new(&node.view), node, min_roi)
}

/// Far similarity, Eq. 11.4.
pub fn similarity_far(view: &Camera, ctx: &ViewContext<'_>) -> f64 {
    StepFrame::new(ctx).far(view)
}

/// View distance d = (1/S) Σ ‖P V_view s − P V_cur s‖ in NDC over the samples seen by both
/// (thesis 9.7.2); ∞ when none is. One P, the current projection, for both: a view is reached
/// when the visitor stands where it stands, whatever field of view it was authored with (in
/// real-scale mode the kiosk keeps its own).
pub fn view_distance(view: &Camera, ctx: &ViewContext<'_>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    let view = Camera { fov_y: ctx.camera.fov_y, ..*view };
    for &s in ctx.samples {
        if let (Some(a), Some(b)) = (ndc2(&view, s, ctx.aspect), ndc2(&ctx.camera, s, ctx.aspect))
            && b.x.abs() <= 1.0
            && b.y.abs() <= 1.0
        {
            sum += (a - b).length();
            n += 1;
        }
    }
    if n == 0 { f64::INFINITY } else { sum / n as f64 }
}

/// The similarity of a node's view to the current one: close metric when it applies, else far.
pub fn similarity(graph: &InfoGraph, node: usize, ctx: &ViewContext<'_>, settings: &RecSettings) -> f64 {
    let n = &graph.nodes[node];
    similarity_close(n, ctx, settings.min_roi_samples).unwrap_or_else(|| similarity_far(&n.view, ctx))
}

/// A node's score and whether it was scored with the close metric ("visible").
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Score {
    /// S_i.
    pub score: f64,
    /// Visible set (close metric above the threshold) or not.
    pub visible: bool,
}

/// The recommendation engine.
#[derive(Clone, Debug)]
pub struct Recommender {
    /// Settings.
    pub settings: RecSettings,
    /// Current state.
    pub state: RecState,
    /// Statistics per node.
    pub stats: Vec<NodeStats>,
    /// Mandatory predecessors per node.
    mandatory: Vec<Vec<usize>>,
    /// All predecessors (node, ω) per node.
    preds: Vec<Vec<(usize, f64)>>,
    /// Each node's view projection, precomputed.
    projectors: Vec<Projector>,
    /// γ per node when it differs from the graph's importance (popularity, [`crate::stats`]);
    /// empty: the graph's.
    gamma: Vec<f64>,
}

impl Recommender {
    /// A fresh engine for a graph, starting in discover at `now`.
    pub fn new(graph: &InfoGraph, settings: RecSettings, now: f64) -> Self {
        let n = graph.nodes.len();
        let mut preds = vec![Vec::new(); n];
        let mut mandatory = vec![Vec::new(); n];
        for e in &graph.edges {
            preds[e.to].push((e.from, e.weight));
            if e.weight >= MANDATORY {
                mandatory[e.to].push(e.from);
            }
        }
        let projectors = graph.nodes.iter().map(|n| Projector::new(&n.view)).collect();
        Self {
            settings,
            state: RecState::Discover { since: now },
            stats: vec![NodeStats::default(); n],
            mandatory,
            preds,
            projectors,
            gamma: Vec::new(),
        }
    }

    /// Uses these γ instead of the graph's importances (one per node; any other length: the
    /// graph's).
    pub fn set_gamma(&mut self, gamma: Vec<f64>) {
        self.gamma = if gamma.len() == self.preds.len() { gamma } else { Vec::new() };
    }

    /// A display chosen in the radial menu normally stays until the visitor moves away; once
    /// nobody is there (the kiosk's attract loop) it times out like any other.
    pub fn release_hold(&mut self) {
        match &mut self.state {
            RecState::GoTo { from_menu, .. } | RecState::Display { from_menu, .. } => *from_menu = false,
            _ => {}
        }
    }

    /// The visitor took the camera during the flight to a node: the flight is abandoned, the node
    /// is not displayed, and the engine discovers again from `now`.
    pub fn abandon_go_to(&mut self, now: f64) {
        if let RecState::GoTo { .. } = self.state {
            self.state = RecState::Discover { since: now };
        }
    }

    /// Forgets the visit (history and state), keeping the long-run statistics.
    pub fn reset_visit(&mut self, now: f64) {
        for s in &mut self.stats {
            s.visited = false;
            s.last_event = None;
        }
        self.state = RecState::Discover { since: now };
    }

    /// Whether every mandatory predecessor of `node` has been displayed.
    pub fn feasible(&self, node: usize) -> bool {
        self.mandatory[node].iter().all(|&p| self.stats[p].visited)
    }

    /// Scores of every node (Eq. 11.1–11.4), as thesis 11.5 organises them: nodes whose
    /// γ · D · R is zero (e.g. a mandatory predecessor not yet shown) are not compared at all;
    /// the close metric (Eq. 11.3) is computed only for the `max_close` potentially visible
    /// nodes (focus point on screen) nearest to the eye; every other node uses the O(1) far
    /// metric (Eq. 11.4).
    pub fn scores(&self, graph: &InfoGraph, ctx: &ViewContext<'_>, now: f64) -> Vec<Score> {
        let frame = StepFrame::new(ctx);
        let mut out = vec![Score { score: 0.0, visible: false }; graph.nodes.len()];
        let mut base = vec![0.0; graph.nodes.len()];
        let mut visible = Vec::new();
        for (i, n) in graph.nodes.iter().enumerate() {
            if !self.feasible(i) {
                continue;
            }
            let d: f64 = self.preds[i]
                .iter()
                .map(|&(j, w)| 1.0 - w * (1.0 - f64::from(u8::from(self.stats[j].visited))))
                .product();
            let r = match self.stats[i].last_event {
                None => 1.0,
                Some(t) => (((now - t).max(0.0) / self.settings.t_max_secs).powi(2)).min(1.0),
            };
            base[i] = self.gamma.get(i).copied().unwrap_or(n.importance) * d * r;
            if base[i].is_nan() || base[i] <= 0.0 {
                continue;
            }
            let focus = n.roi_bbox.map_or(n.view.target, |(lo, hi)| (lo + hi) * 0.5);
            if frame.on_screen(focus) {
                visible.push(((n.view.eye - ctx.camera.eye).length_squared(), i));
            }
        }
        visible.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        visible.truncate(self.settings.max_close);
        for &(_, i) in &visible {
            let n = &graph.nodes[i];
            if let Some(sigma) = frame
                .close(&self.projectors[i], n, self.settings.min_roi_samples)
                .filter(|&s| s > self.settings.visible_threshold)
            {
                out[i] = Score { score: base[i] * sigma, visible: true };
            }
        }
        for (i, n) in graph.nodes.iter().enumerate() {
            if base[i] > 0.0 && !out[i].visible {
                out[i] = Score { score: base[i] * frame.far(&n.view), visible: false };
            }
            if !out[i].score.is_finite() || out[i].score < 0.0 {
                out[i].score = 0.0;
            }
        }
        out
    }

    /// Picks a node with probability proportional to its score, among the visible candidates
    /// with a positive score, else among the others.
    pub fn select(scores: &[Score], rng: &mut impl Rng) -> Option<usize> {
        for visible in [true, false] {
            let total: f64 = scores.iter().filter(|s| s.visible == visible).map(|s| s.score).sum();
            if total > 0.0 && total.is_finite() {
                let mut x = rng.random_range(0.0..total);
                let mut last = None;
                for (i, s) in scores.iter().enumerate().filter(|(_, s)| s.visible == visible && s.score > 0.0)
                {
                    last = Some(i);
                    if x < s.score {
                        return Some(i);
                    }
                    x -= s.score;
                }
                return last;
            }
        }
        None
    }

    fn display_secs(&self, graph: &InfoGraph, node: usize) -> f64 {
        let chars = graph.nodes[node]
            .text
            .get(&graph.default_lang, &graph.default_lang)
            .map_or(0, |t| t.chars().count());
        self.settings.display_min_secs + self.settings.display_secs_per_char * chars as f64
    }

    fn go_to(&mut self, node: usize, now: f64, from_menu: bool, effects: &mut Vec<Effect>) {
        match self.state {
            RecState::Propose { node: p, .. } => {
                effects.push(Effect::HideInset { node: p });
                if from_menu {
                    // A menu pick supersedes the proposal: it counts as refused.
                    self.stats[p].refusals += 1;
                    self.stats[p].last_event = Some(now);
                }
            }
            RecState::Display { node: d, since, .. } => {
                effects.push(Effect::HideOverlay { node: d });
                effects.push(Effect::StopNarration { node: d });
                self.stats[d].dwell_secs += (now - since).max(0.0);
            }
            _ => {}
        }
        effects.push(Effect::StartGoTo { node, duration: self.settings.goto_secs });
        self.state = RecState::GoTo { node, since: now, from_menu };
    }

    /// Advances the engine: `(state, event, now) → (state, effects)`.
    pub fn step(
        &mut self,
        graph: &InfoGraph,
        ctx: &ViewContext<'_>,
        event: RecEvent,
        now: f64,
        rng: &mut impl Rng,
    ) -> Vec<Effect> {
        let mut fx = Vec::new();
        if graph.nodes.is_empty() || !now.is_finite() {
            return fx;
        }
        let s = self.settings;
        if let RecEvent::MenuSelect(node) = event
            && node < graph.nodes.len()
        {
            self.go_to(node, now, true, &mut fx);
            return fx;
        }
        match self.state {
            RecState::Discover { since } => {
                if now - since >= s.discover_secs {
                    let scores = self.scores(graph, ctx, now);
                    match Self::select(&scores, rng) {
                        Some(node) => self.state = RecState::Attract { node, since: now },
                        None => self.state = RecState::Discover { since: now },
                    }
                }
            }
            RecState::Attract { node, since } => {
                if event != RecEvent::MenuOpen
                    && view_distance(&graph.nodes[node].view, ctx) <= s.accept_distance
                {
                    self.go_to(node, now, false, &mut fx);
                } else if now - since >= s.attract_secs {
                    fx.push(Effect::ShowInset { node });
                    self.stats[node].proposals += 1;
                    self.stats[node].last_event = Some(now);
                    self.state = RecState::Propose { node, since: now };
                }
            }
            RecState::Propose { node, since } => {
                if event == RecEvent::LongPress
                    || (event != RecEvent::MenuOpen
                        && view_distance(&graph.nodes[node].view, ctx) <= s.accept_distance)
                {
                    self.go_to(node, now, false, &mut fx);
                } else if now - since >= s.propose_secs {
                    fx.push(Effect::HideInset { node });
                    self.stats[node].refusals += 1;
                    self.stats[node].last_event = Some(now);
                    self.state = RecState::Discover { since: now };
                }
            }
            RecState::GoTo { node, since, from_menu } => {
                if now - since >= s.goto_secs {
                    fx.push(Effect::ShowOverlay { node });
                    if !graph.nodes[node].narration.is_empty() {
                        fx.push(Effect::PlayNarration { node });
                    }
                    let st = &mut self.stats[node];
                    st.displays += 1;
                    st.visited = true;
                    st.last_event = Some(now);
                    self.state = RecState::Display { node, since: now, from_menu };
                }
            }
            RecState::Display { node, since, from_menu } => {
                let moved_away = ctx.moving && view_distance(&graph.nodes[node].view, ctx) > s.leave_distance;
                let timed_out = !from_menu && now - since >= self.display_secs(graph, node);
                if moved_away || timed_out {
                    fx.push(Effect::HideOverlay { node });
                    if !graph.nodes[node].narration.is_empty() {
                        fx.push(Effect::StopNarration { node });
                    }
                    self.stats[node].dwell_secs += (now - since).max(0.0);
                    self.stats[node].last_event = Some(now);
                    self.state = RecState::Discover { since: now };
                }
            }
        }
        fx
    }

    /// Guidance (11.4.1) of a hover intent while attracting: adds the component of the
    /// direction toward the node's eye (in screen units) orthogonal to the motion, scaled by the
    /// motion; slows the motion near the view (friction). `sense` says which way the
    /// controller moves the eye on screen for this input, so that the nudge moves the eye
    /// toward the node's. Returns the new motion.
    pub fn guide(
        &self,
        graph: &InfoGraph,
        ctx: &ViewContext<'_>,
        hover: (f64, f64),
        sense: Sense,
    ) -> (f64, f64) {
        let RecState::Attract { node, .. } = self.state else { return hover };
        let m = DVec2::new(hover.0, hover.1);
        let speed = m.length();
        if speed == 0.0 || !speed.is_finite() {
            return hover;
        }
        let cam = &ctx.camera;
        let to = graph.nodes[node].view.eye - cam.eye;
        let right = cam.right();
        let up = right.cross(cam.forward());
        let Some(toward) = DVec2::new(to.dot(right), to.dot(up)).try_normalize() else { return hover };
        // The input that moves the eye toward the node's eye.
        let toward = match sense {
            Sense::WithInput => toward,
            Sense::AgainstInput => -toward,
        };
        let along = m / speed;
        let ortho = toward - along * toward.dot(along);
        let mut out = m + ortho * (self.settings.nudge_gain * speed);
        if view_distance(&graph.nodes[node].view, ctx) <= self.settings.friction_distance {
            out *= self.settings.friction;
        }
        (out.x, out.y)
    }
}

/// Which way a controller moves the eye on screen for a motion input (x right, y up).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sense {
    /// The eye moves with the input (IsoCam's hover: finger right, camera right).
    WithInput,
    /// The eye moves against it (the trackballs turn and pan the model under the finger: finger
    /// right, camera left).
    AgainstInput,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::graph::{Node, RoiMask};
    use crate::radial::{RadialSettings, ViewIndex, radial_candidates, slot_for_angle};
    use rand::SeedableRng;

    fn graph(n: usize) -> InfoGraph {
        let mut r = rand_pcg::Pcg64::seed_from_u64(1);
        let nodes = (0..n)
            .map(|i| {
                let eye = DVec3::new(
                    r.random_range(-5.0..5.0),
                    r.random_range(-5.0..5.0),
                    r.random_range(-5.0..5.0),
                ) + 1e7;
                Node::new(
                    format!("v{i}"),
                    Camera { eye, target: DVec3::splat(1e7), up: DVec3::Y, fov_y: 0.8 },
                )
            })
            .collect();
        InfoGraph { default_lang: "en".into(), nodes, edges: vec![] }
    }

    #[test]
    fn view_index_finds_the_nearest_views_like_brute_force() {
        let g = graph(1000);
        let index = ViewIndex::new(&g);
        let mut r = rand_pcg::Pcg64::seed_from_u64(2);
        for _ in 0..100 {
            let p =
                DVec3::new(r.random_range(-6.0..6.0), r.random_range(-6.0..6.0), r.random_range(-6.0..6.0))
                    + 1e7;
            let got = index.nearest(&g, p, 10);
            let mut all: Vec<(f64, usize)> =
                g.nodes.iter().enumerate().map(|(i, n)| ((n.view.eye - p).length_squared(), i)).collect();
            all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            let want: Vec<usize> = all.iter().take(10).map(|x| x.1).collect();
            assert_eq!(got, want);
        }
    }

    fn node_at(id: &str, eye: DVec3, target: DVec3, fov_y: f64) -> Node {
        let mut view = Camera { eye, target, up: DVec3::Y, fov_y };
        view.up = crate::camera::orthonormal_up(view.forward(), DVec3::Y, DVec3::Z);
        Node::new(id, view)
    }

    fn graph_of(nodes: Vec<Node>) -> InfoGraph {
        InfoGraph { default_lang: "en".into(), nodes, edges: vec![] }
    }

    /// The visitor's view: from (0, 0, 5) toward the origin, fov 0.8.
    fn front() -> Camera {
        Camera { eye: DVec3::new(0.0, 0.0, 5.0), target: DVec3::ZERO, up: DVec3::Y, fov_y: 0.8 }
    }

    /// 200 samples on the plane z = 0 spread over the whole 16:9 view of [`front`].
    fn wall() -> Vec<DVec3> {
        (0..20)
            .flat_map(|i| {
                (0..10).map(move |j| {
                    DVec3::new(-3.5 + 0.35 * (f64::from(i) + 0.5), -2.0 + 0.4 * (f64::from(j) + 0.5), 0.0)
                })
            })
            .collect()
    }

    fn ctx(camera: Camera, samples: &[DVec3]) -> ViewContext<'_> {
        ViewContext { camera, aspect: 16.0 / 9.0, samples, diagonal: 10.0, moving: false }
    }

    fn everything() -> Option<(DVec3, DVec3)> {
        Some((DVec3::splat(-10.0), DVec3::splat(10.0)))
    }

    #[test]
    fn eq_11_3_counts_only_the_samples_that_fall_on_the_roi_mask() {
        let samples = wall();
        let c = ctx(front(), &samples);
        let s = RecSettings::default();
        let mut n = node_at("a", front().eye, DVec3::ZERO, 0.8);
        n.roi_bbox = everything();
        // The box alone: every sample is in the ROI and projects where it does now.
        let sigma = similarity(&graph_of(vec![n.clone()]), 0, &c, &s);
        assert!((sigma - 1.0).abs() < 1e-9, "{sigma}");
        // The mask covers the left half of the view: the right half's samples are outside the
        // ROI and count as ξ² (Eq. 11.3), whatever the box says.
        n.roi_bitmap = RoiMask::from_fn(16, 9, 16.0 / 9.0, |x, _| x < 8);
        let sigma = similarity(&graph_of(vec![n.clone()]), 0, &c, &s);
        assert!((sigma - 0.5).abs() < 1e-9, "{sigma}");
        // The box stays a pre-filter: a box over the right half and a mask over the left half
        // leave no sample in the ROI.
        n.roi_bbox = Some((DVec3::new(0.0, -10.0, -10.0), DVec3::splat(10.0)));
        assert_eq!(similarity_close(&n, &c, 1), None);
        // A mask over a corner no sample falls on: too few ROI samples for the close metric.
        n.roi_bbox = everything();
        n.roi_bitmap = RoiMask::from_fn(32, 18, 16.0 / 9.0, |x, y| x == 0 && y == 0);
        assert_eq!(similarity_close(&n, &c, 1), None);
    }

    #[test]
    fn eq_11_3_projects_both_views_with_the_current_projection() {
        let samples = wall();
        let c = ctx(front(), &samples);
        // The visitor's eye and direction, authored with a narrower field of view: with the same
        // P for both (Eq. 11.3), every ROI sample projects exactly where it does now.
        let mut n = node_at("zoomed", front().eye, DVec3::ZERO, 0.4);
        n.roi_bbox = everything();
        let sigma = similarity(&graph_of(vec![n]), 0, &c, &RecSettings::default());
        assert!(sigma > 1.0 - 1e-9, "{sigma}");
    }

    #[test]
    fn the_view_distance_projects_both_views_with_the_current_projection() {
        // Thesis 9.7.2: one P. Standing at a view authored with a narrower field of view (as in
        // real-scale mode, where the kiosk keeps its own) is being at that view.
        let samples = wall();
        let c = ctx(front(), &samples);
        let n = node_at("zoomed", front().eye, DVec3::ZERO, 0.4);
        let d = view_distance(&n.view, &c);
        assert!(d < 1e-9, "{d}");
        // A view elsewhere is still at a distance.
        let away = node_at("left", DVec3::new(-2.0, 0.0, 5.0), DVec3::new(-2.0, 0.0, 0.0), 0.4);
        assert!(view_distance(&away.view, &c) > 0.3);
    }

    #[test]
    fn a_roi_mask_is_downsampled_keeping_thin_strokes() {
        let m = RoiMask::from_fn(1280, 720, 16.0 / 9.0, |x, y| x == 700 || y == 0).expect("a mask");
        assert_eq!((m.w, m.h), (128, 72));
        assert!(m.get(70, 40) && m.get(3, 0) && !m.get(3, 1) && !m.get(128, 0));
        assert_eq!(m.count(), 128 + 71);
        assert!(m.covers(DVec2::new(0.0938, -0.5)) && !m.covers(DVec2::new(0.5, -0.5)));
        assert!(!m.covers(DVec2::new(1.5, 0.99)), "off the view");
        assert_eq!(RoiMask::from_fn(0, 10, 1.0, |_, _| true), None);
    }

    fn radial(g: &InfoGraph, c: &ViewContext<'_>, exclude: Option<usize>) -> Vec<usize> {
        radial_candidates(g, &ViewIndex::new(g), c, &RadialSettings::default(), exclude, &mut |_, _| true)
    }

    #[test]
    fn the_radial_menu_searches_past_a_dense_cluster_of_views_facing_away() {
        let samples = wall();
        let c = ctx(front(), &samples);
        // 30 views right at the visitor's eye, looking back (angle > 90°)…
        let mut nodes: Vec<Node> = (0..30)
            .map(|k| {
                let eye = front().eye + DVec3::new(0.01 * f64::from(k % 6), 0.01 * f64::from(k / 6), 0.0);
                node_at(&format!("back{k}"), eye, eye + DVec3::Z, 0.8)
            })
            .collect();
        // …and three views a bit farther that look where the visitor looks.
        for (k, x) in [-0.5, 0.0, 0.5].into_iter().enumerate() {
            nodes.push(node_at(
                &format!("good{k}"),
                DVec3::new(x, 0.0, 6.0 + 0.1 * k as f64),
                DVec3::ZERO,
                0.8,
            ));
        }
        let g = graph_of(nodes);
        assert_eq!(radial(&g, &c, None), vec![31, 30, 32], "nearest first");
    }

    #[test]
    fn the_radial_menu_offers_the_most_similar_views_not_just_the_nearest() {
        let samples = wall();
        let c = ctx(front(), &samples);
        // Eight views close to the eye looking aside, eight farther ones looking at the same
        // place: all within 90° and a mean NDC distance of 2.
        let mut nodes = Vec::new();
        for k in 0..8 {
            let x = 0.1 * f64::from(k) - 0.35;
            nodes.push(node_at(
                &format!("aside{k}"),
                DVec3::new(x, 0.25, 5.0),
                DVec3::new(2.0, 1.0, 0.0),
                0.8,
            ));
        }
        for k in 0..8 {
            let x = 0.1 * f64::from(k) - 0.35;
            nodes.push(node_at(&format!("same{k}"), DVec3::new(x, 0.0, 6.0), DVec3::new(x, 0.0, 0.0), 0.8));
        }
        let g = graph_of(nodes);
        let got = radial(&g, &c, None);
        let mut set = got.clone();
        set.sort_unstable();
        assert_eq!(set, (8..16).collect::<Vec<_>>(), "{got:?}");
        let dist = |i: &usize| (g.nodes[*i].view.eye - front().eye).length();
        assert!(got.windows(2).all(|w| dist(&w[0]) <= dist(&w[1])), "laid out nearest first: {got:?}");
    }

    #[test]
    fn the_radial_menu_does_not_offer_the_view_on_display() {
        let samples = wall();
        let c = ctx(front(), &samples);
        let nodes = vec![
            node_at("shown", front().eye, DVec3::ZERO, 0.8),
            node_at("left", DVec3::new(-0.5, 0.0, 5.5), DVec3::ZERO, 0.8),
            node_at("right", DVec3::new(0.6, 0.0, 5.5), DVec3::ZERO, 0.8),
        ];
        let g = graph_of(nodes);
        assert_eq!(radial(&g, &c, None), vec![0, 1, 2]);
        assert_eq!(radial(&g, &c, Some(0)), vec![1, 2]);
    }

    #[test]
    fn a_node_whose_mandatory_predecessor_is_unseen_is_still_offered_and_shown() {
        let samples = wall();
        let c = ctx(front(), &samples);
        let mut g = graph_of(vec![
            node_at("intro", DVec3::new(0.0, 0.0, -5.0), DVec3::ZERO, 0.8),
            node_at("detail", DVec3::new(0.3, 0.0, 5.5), DVec3::ZERO, 0.8),
        ]);
        g.edges.push(crate::graph::Edge { from: 0, to: 1, weight: MANDATORY });
        let mut rec = Recommender::new(&g, RecSettings::default(), 0.0);
        assert!(!rec.feasible(1));
        assert_eq!(radial(&g, &c, None), vec![1], "the intro is behind the visitor");
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        rec.step(&g, &c, RecEvent::MenuSelect(1), 0.0, &mut rng);
        rec.step(&g, &c, RecEvent::Tick, 10.0, &mut rng);
        assert!(matches!(rec.state, RecState::Display { node: 1, .. }), "{:?}", rec.state);
        assert!(rec.stats[1].visited && !rec.stats[0].visited);
    }

    #[test]
    fn nothing_is_accepted_by_distance_while_the_visitor_chooses_in_the_menu() {
        let samples = wall();
        let c = ctx(front(), &samples);
        let g = graph_of(vec![node_at("here", front().eye, DVec3::ZERO, 0.8)]);
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        for start in [RecState::Attract { node: 0, since: 0.0 }, RecState::Propose { node: 0, since: 0.0 }] {
            let mut rec = Recommender::new(&g, RecSettings::default(), 0.0);
            rec.state = start;
            assert!(rec.step(&g, &c, RecEvent::MenuOpen, 1.0, &mut rng).is_empty());
            assert_eq!(rec.state, start, "the menu is open: the view the visitor is at waits");
            let fx = rec.step(&g, &c, RecEvent::Tick, 1.1, &mut rng);
            assert_eq!(
                fx.last(),
                Some(&Effect::StartGoTo { node: 0, duration: 2.0 }),
                "menu closed: {start:?}"
            );
        }
    }

    #[test]
    fn radial_slots_go_clockwise_from_the_top() {
        assert_eq!(slot_for_angle(0.0, 8), Some(0));
        assert_eq!(slot_for_angle(std::f64::consts::FRAC_PI_4, 8), Some(1));
        assert_eq!(slot_for_angle(-0.1, 8), Some(0));
        assert_eq!(slot_for_angle(std::f64::consts::PI, 4), Some(2));
        assert_eq!(slot_for_angle(1.0, 0), None);
        assert_eq!(slot_for_angle(f64::NAN, 3), None);
    }
}
