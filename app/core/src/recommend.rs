//! The stochastic recommendation engine (thesis 11.3–11.4.1) and the radial point-of-interest
//! selector (thesis 9.4, 9.7.2). Pure: `(state, event, now) → (state, effects)`; the effects are
//! data that the kiosk shell executes and the replay trace records.
//!
//! States: discover → attract → propose → go-to → display (→ discover). Scores (Eq. 11.1–11.2):
//! S = γ · D · R · σ, D = Π (1 − ω (1 − visⱼ)), R = min((ΔT / T_max)², 1) after a display or a
//! proposal (1 before), σ from Eq. 11.3 for views in sight with enough ROI samples, else
//! Eq. 11.4. Selection is proportional to the score, among visible candidates first.

use crate::camera::Camera;
use crate::graph::{InfoGraph, MANDATORY};
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
    cam.ndc(p, aspect).map(|(x, y, _)| DVec2::new(x, y))
}

/// Close similarity, Eq. 11.3, of `view` to `ctx.camera` over the samples; `None` when fewer
/// than `min_roi` samples fall in the view's region of interest (its ROI box, or its frustum).
pub fn similarity_close(
    view: &Camera,
    roi: Option<(DVec3, DVec3)>,
    ctx: &ViewContext<'_>,
    min_roi: usize,
) -> Option<f64> {
    let k = ctx.samples.len();
    if k == 0 {
        return None;
    }
    let mut r = 0usize;
    let mut sum = 0.0;
    for &s in ctx.samples {
        let pi = ndc2(view, s, ctx.aspect);
        let in_roi = match roi {
            Some((lo, hi)) => s.cmpge(lo).all() && s.cmple(hi).all(),
            None => pi.is_some_and(|p| p.x.abs() <= 1.0 && p.y.abs() <= 1.0),
        };
        if !in_roi {
            continue;
        }
        r += 1;
        let d2 = match (pi, ndc2(&ctx.camera, s, ctx.aspect)) {
            (Some(a), Some(b)) => (a - b).length_squared(),
            _ => XI2,
        };
        sum += d2.min(XI2);
    }
    if r < min_roi {
        return None;
    }
    Some((1.0 - (XI2 * (k - r) as f64 + sum) / (k as f64 * XI2)).clamp(0.0, 1.0))
}

/// Far similarity, Eq. 11.4.
pub fn similarity_far(view: &Camera, ctx: &ViewContext<'_>) -> f64 {
    let visible: Vec<DVec3> = ctx
        .samples
        .iter()
        .copied()
        .filter(|&s| ndc2(&ctx.camera, s, ctx.aspect).is_some_and(|p| p.x.abs() <= 1.0 && p.y.abs() <= 1.0))
        .collect();
    let t_cur = if visible.is_empty() {
        ctx.camera.target
    } else {
        visible.iter().fold(DVec3::ZERO, |a, p| a + *p) / visible.len() as f64
    };
    let t_i = view.eye + view.forward() * (t_cur - ctx.camera.eye).length();
    let delta = ctx.diagonal.max(f64::MIN_POSITIVE);
    (1.0 - ((view.eye - ctx.camera.eye).length() + (t_i - t_cur).length()) / (2.0 * delta)).clamp(0.0, 1.0)
}

/// View distance d = (1/S) Σ ‖P V_view s − P V_cur s‖ in NDC over the samples seen by both
/// (thesis 9.7.2); ∞ when none is.
pub fn view_distance(view: &Camera, ctx: &ViewContext<'_>) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for &s in ctx.samples {
        if let (Some(a), Some(b)) = (ndc2(view, s, ctx.aspect), ndc2(&ctx.camera, s, ctx.aspect))
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
    similarity_close(&n.view, n.roi_bbox, ctx, settings.min_roi_samples)
        .unwrap_or_else(|| similarity_far(&n.view, ctx))
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
        Self {
            settings,
            state: RecState::Discover { since: now },
            stats: vec![NodeStats::default(); n],
            mandatory,
            preds,
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

    /// Scores of every node (Eq. 11.1–11.4).
    pub fn scores(&self, graph: &InfoGraph, ctx: &ViewContext<'_>, now: f64) -> Vec<Score> {
        (0..graph.nodes.len())
            .map(|i| {
                if !self.feasible(i) {
                    return Score { score: 0.0, visible: false };
                }
                let n = &graph.nodes[i];
                let d: f64 = self.preds[i]
                    .iter()
                    .map(|&(j, w)| 1.0 - w * (1.0 - f64::from(u8::from(self.stats[j].visited))))
                    .product();
                let r = match self.stats[i].last_event {
                    None => 1.0,
                    Some(t) => (((now - t).max(0.0) / self.settings.t_max_secs).powi(2)).min(1.0),
                };
                let close = similarity_close(&n.view, n.roi_bbox, ctx, self.settings.min_roi_samples)
                    .filter(|&s| s > self.settings.visible_threshold);
                let (sigma, visible) = match close {
                    Some(s) => (s, true),
                    None => (similarity_far(&n.view, ctx), false),
                };
                let score = n.importance * d * r * sigma;
                Score { score: if score.is_finite() { score.max(0.0) } else { 0.0 }, visible }
            })
            .collect()
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
            RecState::Propose { node: p, .. } => effects.push(Effect::HideInset { node: p }),
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
                if view_distance(&graph.nodes[node].view, ctx) <= s.accept_distance {
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
                    || view_distance(&graph.nodes[node].view, ctx) <= s.accept_distance
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
    /// motion; slows the motion near the view (friction). Returns the new hover.
    pub fn guide(&self, graph: &InfoGraph, ctx: &ViewContext<'_>, hover: (f64, f64)) -> (f64, f64) {
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
        let along = m / speed;
        let ortho = toward - along * toward.dot(along);
        let mut out = m + ortho * (self.settings.nudge_gain * speed);
        if view_distance(&graph.nodes[node].view, ctx) <= self.settings.friction_distance {
            out *= self.settings.friction;
        }
        (out.x, out.y)
    }
}

/// The radial point-of-interest selector (thesis 9.4, 9.7.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RadialSettings {
    /// Nearest views considered (N).
    pub nearest: usize,
    /// Views presented (M).
    pub slots: usize,
    /// Largest angle between the view directions (thesis: 90°).
    pub max_angle: f64,
    /// Largest mean NDC distance (thesis: 2).
    pub max_ndc_distance: f64,
}

impl Default for RadialSettings {
    fn default() -> Self {
        Self { nearest: 24, slots: 8, max_angle: std::f64::consts::FRAC_PI_2, max_ndc_distance: 2.0 }
    }
}

/// Candidates for the radial menu, nearest first: the `nearest` views closest to the eye whose
/// direction is within `max_angle` of the current one and that are in line of sight
/// (`line_of_sight(from, to)`, a ray cast on the scene by the caller), filtered by the mean NDC
/// distance over the samples; at most `slots`.
pub fn radial_candidates(
    graph: &InfoGraph,
    ctx: &ViewContext<'_>,
    settings: &RadialSettings,
    line_of_sight: &mut dyn FnMut(DVec3, DVec3) -> bool,
) -> Vec<usize> {
    let cam = &ctx.camera;
    let mut by_distance: Vec<(f64, usize)> =
        graph.nodes.iter().enumerate().map(|(i, n)| ((n.view.eye - cam.eye).length_squared(), i)).collect();
    let keep = settings.nearest.min(by_distance.len());
    if keep == 0 {
        return Vec::new();
    }
    by_distance.select_nth_unstable_by(keep - 1, |a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    by_distance.truncate(keep);
    by_distance.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let cos_max = settings.max_angle.cos();
    let mut out = Vec::new();
    for (_, i) in by_distance {
        let v = &graph.nodes[i].view;
        if v.forward().dot(cam.forward()) < cos_max {
            continue;
        }
        if !line_of_sight(cam.eye, v.eye) {
            continue;
        }
        let (mut sum, mut n) = (0.0, 0usize);
        for &s in ctx.samples {
            if let (Some(a), Some(b)) = (ndc2(v, s, ctx.aspect), ndc2(cam, s, ctx.aspect)) {
                sum += (a - b).length();
                n += 1;
            }
        }
        if n == 0 || sum / n as f64 > settings.max_ndc_distance {
            continue;
        }
        out.push(i);
        if out.len() == settings.slots {
            break;
        }
    }
    out
}

/// The radial slot chosen by a finger direction (radians, 0 = up, clockwise) among `count`
/// slots laid out with the nearest at the top and the rest clockwise.
pub fn slot_for_angle(angle: f64, count: usize) -> Option<usize> {
    if count == 0 || !angle.is_finite() {
        return None;
    }
    let step = std::f64::consts::TAU / count as f64;
    Some(((angle.rem_euclid(std::f64::consts::TAU) / step).round() as usize) % count)
}
