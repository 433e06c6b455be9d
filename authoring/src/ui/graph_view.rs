//! The graph view: nodes in levels (the longest chain of predecessors above them), edges as
//! arrows coloured by weight; a click selects a node.

use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Stroke, pos2, vec2};
use kiosk_core::graph::InfoGraph;

/// The level of every node: 0 for nodes without predecessors, else 1 + the deepest predecessor
/// (cycles, which validation reports, are cut).
pub fn levels(graph: &InfoGraph) -> Vec<usize> {
    let n = graph.nodes.len();
    let mut level = vec![0usize; n];
    // Bellman-Ford style relaxation, at most n rounds (a cycle stops growing after that).
    for _ in 0..n {
        let mut changed = false;
        for e in &graph.edges {
            if e.from < n && e.to < n && level[e.to] < level[e.from] + 1 && level[e.from] + 1 < n {
                level[e.to] = level[e.from] + 1;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    level
}

/// Where each node is drawn in `rect`.
pub fn layout(graph: &InfoGraph, rect: Rect) -> Vec<Pos2> {
    let level = levels(graph);
    let depth = level.iter().copied().max().unwrap_or(0) + 1;
    let mut rows: Vec<Vec<usize>> = vec![Vec::new(); depth];
    for (i, &l) in level.iter().enumerate() {
        rows[l].push(i);
    }
    let mut pos = vec![Pos2::ZERO; graph.nodes.len()];
    for (l, row) in rows.iter().enumerate() {
        let y = rect.top() + rect.height() * (l as f32 + 0.5) / depth as f32;
        for (k, &i) in row.iter().enumerate() {
            let x = rect.left() + rect.width() * (k as f32 + 0.5) / row.len() as f32;
            pos[i] = pos2(x, y);
        }
    }
    pos
}

/// Colour of an edge weight: mandatory red, strong amber, weak grey.
fn weight_color(w: f64) -> Color32 {
    if w >= 0.999 {
        Color32::from_rgb(220, 80, 70)
    } else if w >= 0.5 {
        Color32::from_rgb(230, 170, 60)
    } else {
        Color32::from_gray(150)
    }
}

/// Draws the graph; returns the node clicked, if any.
pub fn show(ui: &mut egui::Ui, graph: &InfoGraph, selected: Option<usize>, height: f32) -> Option<usize> {
    let (rect, response) = ui.allocate_exact_size(vec2(ui.available_width(), height), Sense::click());
    let p = ui.painter_at(rect);
    p.rect_filled(rect, 4.0, Color32::from_gray(24));
    let pos = layout(graph, rect.shrink(24.0));
    for e in &graph.edges {
        let (Some(&a), Some(&b)) = (pos.get(e.from), pos.get(e.to)) else { continue };
        let dir = (b - a).normalized();
        let (a, b) = (a + dir * 14.0, b - dir * 14.0);
        let stroke = Stroke::new(1.0 + 2.0 * e.weight as f32, weight_color(e.weight));
        p.line_segment([a, b], stroke);
        let side = vec2(-dir.y, dir.x) * 5.0;
        p.add(egui::Shape::convex_polygon(
            vec![b, b - dir * 10.0 + side, b - dir * 10.0 - side],
            stroke.color,
            Stroke::NONE,
        ));
    }
    let mut clicked = None;
    let pointer = response.interact_pointer_pos();
    for (i, (node, &at)) in graph.nodes.iter().zip(&pos).enumerate() {
        let on = selected == Some(i);
        p.circle_filled(at, 12.0, if on { Color32::from_rgb(236, 190, 90) } else { Color32::from_gray(90) });
        p.text(
            at + vec2(0.0, 16.0),
            Align2::CENTER_TOP,
            &node.id,
            FontId::proportional(12.0),
            Color32::WHITE,
        );
        if response.clicked() && pointer.is_some_and(|q| q.distance(at) <= 16.0) {
            clicked = Some(i);
        }
    }
    clicked
}
