//! The trace of an exploration: one JSON line per frame of the fixed 60 Hz clock (eye, target,
//! up, distance to the surface, the controller's and the recommender's state, the node, the menu,
//! the light),
//! a header line and a summary line. Written by `kiosk replay` and the kiosk's `--trace`; same
//! store, session, settings and seed → byte-identical trace.

use serde::Serialize;

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
    /// Direction toward the user light (unit, model axes; [`crate::light`]).
    pub light: [f64; 3],
    /// Weight of the user light against the headlight.
    pub light_mix: f64,
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
