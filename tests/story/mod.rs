//! The information graph, the recommendation engine and the radial selector.

mod engine;
mod sessions;

use glam::DVec3;
use kiosk::MappedStore;
use kiosk_core::camera::Camera;
use kiosk_core::graph::{Edge, InfoGraph, Node, PerLanguage};
use rand::{Rng, SeedableRng};

/// A node looking at `target` from `eye`.
pub fn node(id: &str, eye: DVec3, target: DVec3, importance: f64) -> Node {
    let mut title = PerLanguage::default();
    title.0.insert("en".into(), format!("Node {id}"));
    let mut text = PerLanguage::default();
    text.0.insert("en".into(), "A short text.".into());
    Node {
        id: id.into(),
        view: {
            let mut c = Camera { eye, target, up: DVec3::Y, fov_y: 0.8 };
            c.up = kiosk_core::camera::orthonormal_up(c.forward(), DVec3::Y, DVec3::Z);
            c
        },
        importance,
        title,
        text,
        overlay: PerLanguage::default(),
        narration: PerLanguage::default(),
        thumbnail: None,
        roi_mask: None,
        roi_bbox: None,
    }
}

/// A graph of the paper's shape on a model: 109 nodes in a 5-level DAG, 132 edges (12
/// mandatory, 36 at 0.8, the rest at 0.2); views around the model looking at its samples.
pub fn paper_graph(store: &MappedStore, seed: u64) -> InfoGraph {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let center = store.to_model(store.bbox().center());
    let diag = f64::from(store.bbox().diagonal());
    let cut = kiosk_core::Cut::leaves(store);
    let targets = store.sample_cut(&cut, 109, &mut rng);
    let levels = [5usize, 15, 25, 30, 34];
    let mut level_of = Vec::new();
    for (l, &n) in levels.iter().enumerate() {
        level_of.extend(std::iter::repeat_n(l, n));
    }
    let nodes: Vec<Node> = (0..109)
        .map(|i| {
            let t = store.to_model(targets[i]);
            let out = (t - center).normalize_or_zero();
            let eye =
                t + (out + DVec3::new(0.0, 0.2, 0.0)).normalize_or_zero() * diag * rng.random_range(0.3..0.8);
            node(&format!("n{i:03}"), eye, t, rng.random_range(0.3..1.0))
        })
        .collect();
    // Edges between consecutive levels (and some skipping one), no duplicates.
    let mut pairs = std::collections::BTreeSet::new();
    let start: Vec<usize> = levels
        .iter()
        .scan(0, |acc, &n| {
            let s = *acc;
            *acc += n;
            Some(s)
        })
        .collect();
    while pairs.len() < 132 {
        let to = rng.random_range(levels[0]..109);
        let lt = level_of[to];
        let lf = rng.random_range(0..lt);
        let from = start[lf] + rng.random_range(0..levels[lf]);
        pairs.insert((from, to));
    }
    let edges = pairs
        .into_iter()
        .enumerate()
        .map(|(k, (from, to))| Edge {
            from,
            to,
            weight: if k % 11 == 0 && k / 11 < 12 {
                1.0
            } else if k % 11 < 4 {
                0.8
            } else {
                0.2
            },
        })
        .collect::<Vec<_>>();
    InfoGraph { default_lang: "en".into(), nodes, edges }
}
