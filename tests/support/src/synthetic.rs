//! Synthetic content for tests and benchmarks: information graphs of the paper's shape on a real
//! model (thesis 11.6: 109 nodes, 132 edges — 12 mandatory, 36 at 0.8, the rest at 0.2 — in a
//! 5-level DAG), scaled to any size.

use glam::DVec3;
use kiosk_content::MappedStore;
use kiosk_core::camera::{Camera, orthonormal_up};
use kiosk_core::graph::{Edge, InfoGraph, Node, PerLanguage};
use rand::{Rng, SeedableRng};

/// A node looking at `target` from `eye`, with an English title and a short text.
pub fn node(id: &str, eye: DVec3, target: DVec3, importance: f64) -> Node {
    let mut title = PerLanguage::default();
    title.0.insert("en".into(), format!("Node {id}"));
    let mut text = PerLanguage::default();
    text.0.insert("en".into(), "A short text.".into());
    let mut view = Camera { eye, target, up: DVec3::Y, fov_y: 0.8 };
    view.up = orthonormal_up(view.forward(), DVec3::Y, DVec3::Z);
    Node { importance, title, text, ..Node::new(id, view) }
}

/// A graph of the paper's shape with `n` nodes (109 in the paper): a 5-level DAG with
/// 132/109 × n edges, 12/132 of them mandatory and 36/132 at 0.8; views around the model, each
/// looking at one of its samples from 0.3–0.8 diagonals away.
pub fn paper_graph(store: &MappedStore, n: usize, seed: u64) -> InfoGraph {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let center = store.to_model(store.bbox().center());
    let diag = f64::from(store.bbox().diagonal());
    let cut = kiosk_core::Cut::leaves(store);
    let targets = store.sample_cut(&cut, n, &mut rng);
    // Level sizes in the paper's proportions 5 : 15 : 25 : 30 : 34.
    let mut levels: Vec<usize> = [5usize, 15, 25, 30].iter().map(|&k| (k * n / 109).max(1)).collect();
    levels.push(n.saturating_sub(levels.iter().sum::<usize>()).max(1));
    let level_of: Vec<usize> =
        levels.iter().enumerate().flat_map(|(l, &k)| std::iter::repeat_n(l, k)).take(n).collect();
    let start: Vec<usize> = levels
        .iter()
        .scan(0, |acc, &k| {
            let s = *acc;
            *acc += k;
            Some(s)
        })
        .collect();
    let nodes: Vec<Node> = (0..n)
        .map(|i| {
            let t = store.to_model(targets[i]);
            let out = (t - center).normalize_or_zero();
            let eye =
                t + (out + DVec3::new(0.0, 0.2, 0.0)).normalize_or_zero() * diag * rng.random_range(0.3..0.8);
            node(&format!("n{i:05}"), eye, t, rng.random_range(0.3..1.0))
        })
        .collect();
    let n_edges = 132 * n / 109;
    let mut pairs = std::collections::BTreeSet::new();
    while n > levels[0] && pairs.len() < n_edges {
        let to = rng.random_range(levels[0]..n);
        let lt = level_of[to];
        let lf = rng.random_range(0..lt.max(1));
        let from = start[lf] + rng.random_range(0..levels[lf]);
        if from < to {
            pairs.insert((from, to));
        }
    }
    let (mandatory, strong) = (12 * n_edges / 132, 36 * n_edges / 132);
    let mut order: Vec<(usize, usize)> = pairs.into_iter().collect();
    // Spread the weights over the edges deterministically.
    for i in (1..order.len()).rev() {
        order.swap(i, rng.random_range(0..=i));
    }
    let edges = order
        .into_iter()
        .enumerate()
        .map(|(k, (from, to))| Edge {
            from,
            to,
            weight: if k < mandatory {
                1.0
            } else if k < mandatory + strong {
                0.8
            } else {
                0.2
            },
        })
        .collect();
    InfoGraph { default_lang: "en".into(), nodes, edges }
}

/// The full-resolution Stanford dragon for benchmarks (`tests/data`).
pub fn dragon_scan() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/scans/stanford-dragon/dragon_vrip.ply.gz")
}

/// The dragon imported into `dir/dragon.kstore` as a curator would, quietly; returns that path.
pub fn dragon_store(dir: &std::path::Path) -> anyhow::Result<std::path::PathBuf> {
    let store = dir.join("dragon.kstore");
    kiosk_content::import::import(
        &dragon_scan(),
        &store,
        &Default::default(),
        &mut kiosk_content::import::quiet,
    )?;
    Ok(store)
}
