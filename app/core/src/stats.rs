//! Visit statistics and popularity (thesis 11.3.1, "user-determined and evolving popularity"):
//! the kiosk collects, per node, how often visitors saw it and for how long, how they answered
//! its proposals and how they reached it; over many visits these counts give each node a
//! popularity that adjusts its importance γ within bounds the curator sets.
//!
//! Pure like the rest of the core: the kiosk feeds an [`Observer`] with the recommender's state
//! before and after each step; the shell loads and saves [`ExhibitStats`] (JSON) and writes the
//! [`VisitRecord`]s. Only a visitor's own exploration counts: the attract loop's tour (nobody
//! there, proposals accepted automatically) is not recorded.
//!
//! **Popularity.** For node i with d displays, w seconds displayed, and answers to the engine
//! (positives a = accepted proposals + reached by attraction + menu picks, trials
//! n = proposals + reached by attraction + menu picks), three smoothed rates in [0, 1]:
//!
//! - acceptance A = (a + 1) / (n + 2) (Laplace: ½ without data);
//! - visits V = d / (d + d̄ + 1), d̄ the mean displays over the graph's nodes (0 never shown,
//!   about ½ at the mean, → 1 far above it);
//! - dwell W = m / (m + m̄), m = (w + K m̄) / (d + K) the node's mean seconds per display shrunk
//!   toward the exhibit's mean m̄ with K = 2 pseudo-displays (½ without data);
//!
//! and p = (A + V + W) / 3. With p̄ the mean of p over the nodes, strength s and bound b:
//! γ' = clamp(γ · (1 + s · (p − p̄)), γ · (1 − b), γ · (1 + b)), then clamped to [0, 1]. Without
//! any data every p is equal and γ' = γ exactly; with popularity off the engine uses γ, so its
//! choices are today's. Eq. 11.2 (mandatory predecessors) is untouched: a node whose mandatory
//! predecessor was not shown is not a candidate whatever its γ'.

use crate::graph::InfoGraph;
use crate::recommend::RecState;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Version of the statistics file's format.
pub const STATS_VERSION: u32 = 1;

/// Pseudo-displays of the dwell's shrinkage (K in the module doc).
const DWELL_PRIOR: f64 = 2.0;

/// Long-run counts of one node.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct NodeTotals {
    /// Times its overlay was shown.
    pub displays: u64,
    /// Seconds its overlay was shown in total.
    pub dwell_secs: f64,
    /// Times it was proposed (the suggestion inset).
    pub proposals: u64,
    /// Proposals accepted (long press, or the visitor went there).
    pub accepted: u64,
    /// Proposals ignored (timed out, or superseded by a menu pick).
    pub refusals: u64,
    /// Times the visitor reached it while attracted, before any proposal.
    pub by_attraction: u64,
    /// Times it was picked in the radial menu.
    pub menu_picks: u64,
}

impl NodeTotals {
    /// Acceptance rate of its proposals (accepted / proposals), `None` before any.
    pub fn acceptance(&self) -> Option<f64> {
        (self.proposals > 0).then(|| self.accepted as f64 / self.proposals as f64)
    }

    /// Mean seconds per display, `None` before any.
    pub fn mean_dwell(&self) -> Option<f64> {
        (self.displays > 0).then(|| self.dwell_secs / self.displays as f64)
    }
}

/// Long-run statistics of one exhibit: what survives the visit reset and a restart.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ExhibitStats {
    /// Format version ([`STATS_VERSION`]).
    pub version: u32,
    /// Visits that explored this exhibit.
    pub visits: u64,
    /// Counts per node id (ids survive the graph's edits; indices do not).
    pub nodes: BTreeMap<String, NodeTotals>,
}

impl Default for ExhibitStats {
    fn default() -> Self {
        Self { version: STATS_VERSION, visits: 0, nodes: BTreeMap::new() }
    }
}

impl ExhibitStats {
    /// The counts of a node (zero if it has none yet).
    pub fn get(&self, id: &str) -> NodeTotals {
        self.nodes.get(id).copied().unwrap_or_default()
    }

    fn node(&mut self, graph: &InfoGraph, i: usize) -> Option<&mut NodeTotals> {
        let id = &graph.nodes.get(i)?.id;
        Some(self.nodes.entry(id.clone()).or_default())
    }
}

/// How popularity adjusts γ (`[popularity]` in kiosk.toml).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PopularitySettings {
    /// Off: the graph's γ, exactly today's choices.
    pub enabled: bool,
    /// Largest relative change of γ (b ∈ [0, 1]: γ' ∈ [γ(1 − b), γ(1 + b)]).
    pub bound: f64,
    /// How strongly popularity moves γ (s ≥ 0).
    pub strength: f64,
}

impl Default for PopularitySettings {
    fn default() -> Self {
        Self { enabled: false, bound: 0.25, strength: 1.0 }
    }
}

impl PopularitySettings {
    /// Checks the ranges; the error names the key.
    pub fn check(&self) -> Result<(), String> {
        if !(0.0..=1.0).contains(&self.bound) {
            return Err(format!("[popularity] bound = {}: must be in [0, 1]", self.bound));
        }
        if !(self.strength.is_finite() && self.strength >= 0.0) {
            return Err(format!("[popularity] strength = {}: must be ≥ 0", self.strength));
        }
        Ok(())
    }
}

/// Popularity p ∈ [0, 1] of each node of the graph (module doc).
pub fn popularity(graph: &InfoGraph, stats: &ExhibitStats) -> Vec<f64> {
    let totals: Vec<NodeTotals> = graph.nodes.iter().map(|n| stats.get(&n.id)).collect();
    let n = totals.len().max(1) as f64;
    let mean_displays = totals.iter().map(|t| t.displays as f64).sum::<f64>() / n;
    let all_displays: u64 = totals.iter().map(|t| t.displays).sum();
    let all_dwell: f64 = totals.iter().map(|t| t.dwell_secs.max(0.0)).sum();
    let mean_dwell = if all_displays > 0 { all_dwell / all_displays as f64 } else { 0.0 };
    totals
        .iter()
        .map(|t| {
            let positives = (t.accepted + t.by_attraction + t.menu_picks) as f64;
            let trials = (t.proposals + t.by_attraction + t.menu_picks) as f64;
            let a = ((positives + 1.0) / (trials + 2.0)).clamp(0.0, 1.0);
            let d = t.displays as f64;
            let v = d / (d + mean_displays + 1.0);
            let w = if mean_dwell > 0.0 {
                let m = (t.dwell_secs.max(0.0) + DWELL_PRIOR * mean_dwell) / (d + DWELL_PRIOR);
                m / (m + mean_dwell)
            } else {
                0.5
            };
            let p = (a + v + w) / 3.0;
            if p.is_finite() { p } else { 0.5 }
        })
        .collect()
}

/// γ' of every node (module doc), or `None` when popularity is off (the graph's γ).
pub fn adjusted_importance(
    graph: &InfoGraph,
    stats: &ExhibitStats,
    settings: &PopularitySettings,
) -> Option<Vec<f64>> {
    if !settings.enabled || graph.nodes.is_empty() {
        return None;
    }
    let p = popularity(graph, stats);
    let mean = p.iter().sum::<f64>() / p.len() as f64;
    let b = settings.bound.clamp(0.0, 1.0);
    Some(
        graph
            .nodes
            .iter()
            .zip(&p)
            .map(|(n, &pi)| {
                let g = n.importance;
                let raw = g * (1.0 + settings.strength.max(0.0) * (pi - mean));
                let (lo, hi) = (g * (1.0 - b), g * (1.0 + b));
                let out = raw.clamp(lo.min(hi), lo.max(hi)).clamp(0.0, 1.0);
                if out.is_finite() { out } else { g }
            })
            .collect(),
    )
}

/// How a visit ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum VisitEnd {
    /// Nobody touched while exploring or in the attract loop: the reset to the gallery.
    Reset,
    /// Nobody touched after going back to the gallery (or without ever exploring).
    Back,
    /// A touch took over the attract loop: a new visitor.
    NewVisitor,
    /// The kiosk was closed during the visit.
    Exit,
}

/// One node displayed during a visit.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NodeVisit {
    /// Node id.
    pub node: String,
    /// Seconds its overlay was shown.
    pub dwell_secs: f64,
}

/// One model explored during a visit.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct ModelVisit {
    /// Model index in the gallery.
    pub model: usize,
    /// The exhibit's name (filled by the shell; the core knows indices).
    pub exhibit: String,
    /// Nodes displayed, in order, with their dwell.
    pub displayed: Vec<NodeVisit>,
    /// Nodes whose proposal was accepted.
    pub accepted: Vec<String>,
    /// Nodes whose proposal was ignored.
    pub refused: Vec<String>,
    /// Nodes reached while attracted, before any proposal.
    pub by_attraction: Vec<String>,
    /// Radial menus opened.
    pub menu_opens: u32,
    /// Nodes picked in the radial menu.
    pub menu_picks: Vec<String>,
}

/// One visit: what `visits.jsonl` holds a line of. Anonymous: counts and times only.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VisitRecord {
    /// Kiosk time of the visit's first touch.
    pub start: f64,
    /// Kiosk time at which it was closed.
    pub end: f64,
    /// Kiosk time of its last touch.
    pub last_touch: f64,
    /// Wall-clock start, Unix seconds (supplied by the shell).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_start: Option<f64>,
    /// Wall-clock end, Unix seconds (supplied by the shell).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_end: Option<f64>,
    /// Languages used, in order.
    pub languages: Vec<String>,
    /// Models explored, in order.
    pub models: Vec<ModelVisit>,
    /// How it ended.
    pub ended: VisitEnd,
}

impl VisitRecord {
    /// A visit starting at `t` in `lang`.
    pub fn new(t: f64, lang: &str) -> Self {
        Self {
            start: t,
            end: t,
            last_touch: t,
            wall_start: None,
            wall_end: None,
            languages: vec![lang.to_string()],
            models: Vec::new(),
            ended: VisitEnd::Reset,
        }
    }

    /// The entry of a model, created on first use.
    pub fn model(&mut self, model: usize) -> &mut ModelVisit {
        let i = match self.models.iter().position(|m| m.model == model) {
            Some(i) => i,
            None => {
                self.models.push(ModelVisit { model, ..ModelVisit::default() });
                self.models.len() - 1
            }
        };
        &mut self.models[i]
    }

    /// Notes a language in use.
    pub fn language(&mut self, lang: &str) {
        if self.languages.last().is_none_or(|l| l != lang) {
            self.languages.push(lang.to_string());
        }
    }
}

/// Watches one exploration's recommender and turns its state changes into statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Observer {
    /// The display being counted: (node, since).
    open: Option<(usize, f64)>,
}

impl Observer {
    /// One step of the recommender, from state `before` to `after` at time `t`. `active`: a visitor
    /// explores (not the attract loop); inactive steps only end the display being counted.
    pub fn step(
        &mut self,
        graph: &InfoGraph,
        (before, after): (RecState, RecState),
        t: f64,
        active: bool,
        stats: &mut ExhibitStats,
        visit: Option<&mut ModelVisit>,
    ) {
        let mut visit = visit;
        if let Some((node, since)) = self.open {
            let same =
                matches!(after, RecState::Display { node: n, since: s, .. } if n == node && s == since);
            if !active || !same {
                self.close(graph, t, stats, visit.as_deref_mut());
            }
        }
        if !active || before == after {
            return;
        }
        use RecState::*;
        let mut count = |i: usize, f: &mut dyn FnMut(&mut NodeTotals)| {
            if let Some(x) = stats.node(graph, i) {
                f(x);
            }
        };
        match (before, after) {
            (Attract { node, .. }, GoTo { node: g, from_menu: false, .. }) if g == node => {
                count(node, &mut |x| x.by_attraction += 1);
                if let Some(v) = visit.as_deref_mut() {
                    v.by_attraction.push(graph.nodes[node].id.clone());
                }
            }
            (Attract { node, .. }, Propose { node: p, .. }) if p == node => {
                count(node, &mut |x| x.proposals += 1);
            }
            (Propose { node, .. }, GoTo { node: g, from_menu: false, .. }) if g == node => {
                count(node, &mut |x| x.accepted += 1);
                if let Some(v) = visit.as_deref_mut() {
                    v.accepted.push(graph.nodes[node].id.clone());
                }
            }
            (Propose { node, .. }, Discover { .. } | GoTo { from_menu: true, .. }) => {
                count(node, &mut |x| x.refusals += 1);
                if let Some(v) = visit.as_deref_mut() {
                    v.refused.push(graph.nodes[node].id.clone());
                }
            }
            (GoTo { node, .. }, Display { node: d, since, .. }) if d == node => {
                count(node, &mut |x| x.displays += 1);
                self.open = Some((node, since));
            }
            _ => {}
        }
        if let GoTo { node, since, from_menu: true } = after
            && since == t
        {
            count(node, &mut |x| x.menu_picks += 1);
            if let Some(v) = visit {
                v.menu_picks.push(graph.nodes[node].id.clone());
            }
        }
    }

    /// Ends the display being counted (if any) at `t`: its dwell goes to the statistics and
    /// the visit.
    pub fn close(
        &mut self,
        graph: &InfoGraph,
        t: f64,
        stats: &mut ExhibitStats,
        visit: Option<&mut ModelVisit>,
    ) {
        let Some((node, since)) = self.open.take() else { return };
        let dwell = (t - since).max(0.0);
        if let Some(x) = stats.node(graph, node) {
            x.dwell_secs += dwell;
        }
        if let (Some(v), Some(n)) = (visit, graph.nodes.get(node)) {
            v.displayed.push(NodeVisit { node: n.id.clone(), dwell_secs: dwell });
        }
    }

    /// Whether a display is being counted.
    pub fn counting(&self) -> bool {
        self.open.is_some()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::graph::{Edge, MANDATORY, Node};
    use crate::recommend::{RecEvent, RecSettings, Recommender, ViewContext};
    use glam::DVec3;
    use rand::SeedableRng;

    /// Six views around the origin, γ = 0.5 each; node 1 needs node 0 (mandatory).
    fn graph() -> InfoGraph {
        let nodes = (0..6)
            .map(|i| {
                let a = i as f64;
                Node {
                    importance: 0.5,
                    ..Node::new(
                        format!("n{i}"),
                        Camera {
                            eye: DVec3::new(a.cos() * 3.0, 0.2 * a, a.sin() * 3.0),
                            target: DVec3::ZERO,
                            up: DVec3::Y,
                            fov_y: 0.8,
                        },
                    )
                }
            })
            .collect();
        InfoGraph {
            default_lang: "en".into(),
            nodes,
            edges: vec![Edge { from: 0, to: 1, weight: MANDATORY }],
        }
    }

    /// The simulated visitors like nodes 0, 1 and 3 (they accept their proposals) and ignore
    /// the others' (the proposal times out).
    const LIKED: [usize; 3] = [0, 1, 3];

    /// One 300-second visit; returns the nodes selected (attracted toward), in order. Checks
    /// that node 1 is never selected before node 0 was displayed.
    fn visit(
        g: &InfoGraph,
        stats: &mut ExhibitStats,
        pop: Option<&PopularitySettings>,
        seed: u64,
    ) -> Vec<usize> {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut rec = Recommender::new(g, RecSettings::default(), 0.0);
        if let Some(gamma) = pop.and_then(|p| adjusted_importance(g, stats, p)) {
            rec.set_gamma(gamma);
        }
        let camera = Camera { eye: DVec3::new(0.0, 0.0, 4.0), target: DVec3::ZERO, up: DVec3::Y, fov_y: 0.8 };
        let ctx = ViewContext { camera, aspect: 16.0 / 9.0, samples: &[], diagonal: 4.0, moving: false };
        let mut obs = Observer::default();
        let mut mv = ModelVisit::default();
        let (mut selected, mut shown) = (Vec::new(), Vec::new());
        let mut now = 0.0;
        while now < 300.0 {
            now += 0.5;
            let before = rec.state;
            let ev = match before {
                RecState::Propose { node, .. } if LIKED.contains(&node) => RecEvent::LongPress,
                _ => RecEvent::Tick,
            };
            rec.step(g, &ctx, ev, now, &mut rng);
            obs.step(g, (before, rec.state), now, true, stats, Some(&mut mv));
            match (before, rec.state) {
                (RecState::Discover { .. }, RecState::Attract { node, .. }) => {
                    assert!(node != 1 || shown.contains(&0), "visit {seed}: node 1 before its mandatory 0");
                    selected.push(node);
                }
                (_, RecState::Display { node, .. }) if !matches!(before, RecState::Display { .. }) => {
                    shown.push(node)
                }
                _ => {}
            }
        }
        obs.close(g, now, stats, Some(&mut mv));
        stats.visits += 1;
        assert_eq!(mv.displayed.len(), shown.len());
        selected
    }

    fn liked_share(selections: &[Vec<usize>]) -> f64 {
        let all: Vec<usize> = selections.iter().flatten().copied().collect();
        all.iter().filter(|n| LIKED.contains(n)).count() as f64 / all.len().max(1) as f64
    }

    #[test]
    fn without_data_or_switched_off_gamma_is_the_graphs() {
        let g = graph();
        let on = PopularitySettings { enabled: true, bound: 0.5, strength: 2.0 };
        assert_eq!(adjusted_importance(&g, &ExhibitStats::default(), &on), Some(vec![0.5; 6]));
        let mut busy = ExhibitStats::default();
        busy.nodes.insert("n3".into(), NodeTotals { displays: 50, dwell_secs: 400.0, ..Default::default() });
        assert_eq!(adjusted_importance(&g, &busy, &PopularitySettings::default()), None);
        // Within the bounds, and the popular node above the others.
        let gamma = adjusted_importance(&g, &busy, &on).expect("on");
        assert!(gamma.iter().all(|&x| (0.25..=0.75).contains(&x)), "{gamma:?}");
        assert!(gamma[3] > gamma[0] && gamma[0] == gamma[5], "{gamma:?}");
        // A bound of 0 changes nothing.
        let zero = PopularitySettings { bound: 0.0, ..on };
        assert_eq!(adjusted_importance(&g, &busy, &zero), Some(vec![0.5; 6]));
    }

    #[test]
    fn over_many_visits_the_engine_leans_toward_popular_nodes_and_keeps_the_mandatory_order() {
        let g = graph();
        let on = PopularitySettings { enabled: true, bound: 0.5, strength: 2.0 };
        let off = PopularitySettings::default();
        let (mut with, mut without, mut today) =
            (ExhibitStats::default(), ExhibitStats::default(), ExhibitStats::default());
        let (mut chosen_on, mut chosen_off, mut chosen_today) = (Vec::new(), Vec::new(), Vec::new());
        for seed in 0..300 {
            chosen_on.push(visit(&g, &mut with, Some(&on), seed));
            chosen_off.push(visit(&g, &mut without, Some(&off), seed));
            chosen_today.push(visit(&g, &mut today, None, seed));
        }
        // Switched off: exactly today's choices, visit after visit.
        assert_eq!(chosen_off, chosen_today);
        assert_eq!(without, today);
        // The first visit knows nothing yet: the same choices either way.
        assert_eq!(chosen_on[0], chosen_off[0]);
        // Learned: the liked nodes are chosen more often than without popularity.
        let (share_on, share_off) = (liked_share(&chosen_on[100..]), liked_share(&chosen_off[100..]));
        assert!(
            share_on > share_off + 0.06,
            "liked share {share_on:.3} with popularity, {share_off:.3} without"
        );
        // The counts say what the visitors did.
        let n3 = with.get("n3");
        let n4 = with.get("n4");
        assert_eq!(n3.refusals, 0);
        assert_eq!(n3.accepted, n3.proposals);
        assert!(n3.displays > 0 && n3.dwell_secs >= 6.0 * n3.displays as f64);
        assert_eq!((n4.accepted, n4.displays), (0, 0));
        assert!(n4.refusals > 0 && n4.refusals == n4.proposals);
        assert_eq!(with.visits, 300);
        let p = popularity(&g, &with);
        assert!(p[3] > p[4] && p[0] > p[5], "{p:?}");
    }

    #[test]
    fn menu_picks_and_attraction_are_counted() {
        let g = graph();
        let mut stats = ExhibitStats::default();
        let mut mv = ModelVisit::default();
        let mut o = Observer::default();
        let attract = RecState::Attract { node: 2, since: 0.0 };
        let propose = RecState::Propose { node: 2, since: 1.0 };
        {
            let mut step = |before, after, t, active| {
                o.step(&g, (before, after), t, active, &mut stats, Some(&mut mv));
            };
            step(attract, RecState::GoTo { node: 2, since: 1.0, from_menu: false }, 1.0, true);
            let pick = RecState::GoTo { node: 4, since: 2.0, from_menu: true };
            step(propose, pick, 2.0, true);
            let shown = RecState::Display { node: 4, since: 4.0, from_menu: true };
            step(pick, shown, 4.0, true);
            // The attract loop takes over: the display's dwell ends there.
            step(shown, shown, 9.5, false);
            // Attract-loop steps count nothing.
            step(
                RecState::Attract { node: 5, since: 10.0 },
                RecState::Propose { node: 5, since: 11.0 },
                11.0,
                false,
            );
        }
        assert_eq!(stats.get("n2"), NodeTotals { by_attraction: 1, refusals: 1, ..Default::default() });
        assert_eq!(
            stats.get("n4"),
            NodeTotals { menu_picks: 1, displays: 1, dwell_secs: 5.5, ..Default::default() }
        );
        assert_eq!(stats.get("n5"), NodeTotals::default());
        assert_eq!(
            (mv.by_attraction.as_slice(), mv.refused.as_slice(), mv.menu_picks.as_slice()),
            (&["n2".to_string()][..], &["n2".to_string()][..], &["n4".to_string()][..])
        );
        assert_eq!(mv.displayed, vec![NodeVisit { node: "n4".into(), dwell_secs: 5.5 }]);
        let json = serde_json::to_string(&stats).expect("json");
        assert_eq!(serde_json::from_str::<ExhibitStats>(&json).expect("back"), stats);
    }
}
