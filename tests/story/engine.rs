//! The engine on its own: scores, stochastic selection, dependencies, extremes.

use super::{node, paper_graph};
use crate::common;
use glam::DVec3;
use kiosk_core::camera::Camera;
use kiosk_core::graph::{Edge, InfoGraph};
use kiosk_core::recommend::{RecEvent, RecSettings, RecState, Recommender, Score, ViewContext};
use rand::SeedableRng;

fn rng(seed: u64) -> rand_pcg::Pcg64 {
    rand_pcg::Pcg64::seed_from_u64(seed)
}

#[test]
fn paper_graph_has_the_papers_shape_and_round_trips_through_xml() {
    let b = common::build(&common::read("scans/stanford-bunny/bun_zipper.ply"), common::small_nodes());
    let g = paper_graph(&b.store, 1);
    assert_eq!(g.nodes.len(), 109);
    assert_eq!(g.edges.len(), 132);
    assert_eq!(g.edges.iter().filter(|e| e.weight == 1.0).count(), 12);
    assert_eq!(g.edges.iter().filter(|e| e.weight == 0.8).count(), 36);
    assert!(g.never_shown().is_empty());
    let (again, problems) = InfoGraph::from_xml(&g.to_xml()).expect("own XML");
    assert!(problems.is_empty(), "{problems:?}");
    assert!(again == g, "the graph changed through XML");
}

/// Critical values of χ² at significance 0.001.
fn chi2_critical_001(df: usize) -> f64 {
    match df {
        4 => 18.467,
        9 => 27.877,
        _ => panic!("no table entry for {df} degrees of freedom"),
    }
}

#[test]
fn selection_frequencies_match_the_normalised_scores() {
    let raw = [0.05, 0.1, 0.2, 0.3, 0.05, 0.4, 0.15, 0.25, 0.35, 0.12];
    let scores: Vec<Score> = raw.iter().map(|&s| Score { score: s, visible: true }).collect();
    let n = 20_000;
    let mut counts = [0usize; 10];
    let mut r = rng(11);
    for _ in 0..n {
        counts[Recommender::select(&scores, &mut r).expect("positive scores")] += 1;
    }
    let total: f64 = raw.iter().sum();
    let chi2: f64 = raw
        .iter()
        .zip(counts)
        .map(|(&s, c)| {
            let e = s / total * n as f64;
            (c as f64 - e).powi(2) / e
        })
        .sum();
    assert!(chi2 < chi2_critical_001(9), "χ² = {chi2:.2} (df 9, α = 0.001)");
    // Visible candidates come first; zero scores are never drawn.
    let mixed = [
        Score { score: 0.0, visible: true },
        Score { score: 0.5, visible: true },
        Score { score: 9.0, visible: false },
    ];
    for _ in 0..1000 {
        assert_eq!(Recommender::select(&mixed, &mut r), Some(1));
    }
    let invisible_only = [Score { score: 0.2, visible: false }, Score { score: 0.0, visible: true }];
    assert_eq!(Recommender::select(&invisible_only, &mut r), Some(0));
    assert_eq!(Recommender::select(&[], &mut r), None);
}

/// Drives the engine through a whole visit: every proposal is accepted with a long press.
fn visit(g: &InfoGraph, ctx: &ViewContext<'_>, seed: u64, max_displays: usize) -> Vec<usize> {
    let mut r = rng(seed);
    let mut rec = Recommender::new(g, RecSettings::default(), 0.0);
    let mut shown = Vec::new();
    let mut now = 0.0;
    for _ in 0..20_000 {
        now += 0.5;
        let ev =
            if matches!(rec.state, RecState::Propose { .. }) { RecEvent::LongPress } else { RecEvent::Tick };
        for fx in rec.step(g, ctx, ev, now, &mut r) {
            if let kiosk_core::recommend::Effect::ShowOverlay { node } = fx {
                shown.push(node);
            }
        }
        if shown.len() >= max_displays {
            break;
        }
    }
    shown
}

#[test]
fn mandatory_predecessors_always_come_first_in_a_thousand_visits() {
    let b = common::build(&common::read("scans/stanford-bunny/bun_zipper_res2.ply"), common::small_nodes());
    let g = paper_graph(&b.store, 2);
    let cut = kiosk_core::Cut::leaves(&b.store);
    let samples: Vec<DVec3> =
        b.store.sample_cut(&cut, 64, &mut rng(3)).into_iter().map(|p| b.store.to_model(p)).collect();
    let camera = kiosk_core::camera::initial_camera(&b.store, 0.8, DVec3::Y);
    let ctx = ViewContext {
        camera,
        aspect: 16.0 / 9.0,
        samples: &samples,
        diagonal: f64::from(b.store.bbox().diagonal()),
        moving: false,
    };
    let mut distinct_orders = std::collections::BTreeSet::new();
    for v in 0..1000 {
        let shown = visit(&g, &ctx, v, 12);
        assert!(!shown.is_empty());
        for e in g.edges.iter().filter(|e| e.weight == 1.0) {
            if let Some(pos) = shown.iter().position(|&n| n == e.to) {
                let pred = shown.iter().position(|&n| n == e.from);
                assert!(
                    pred.is_some_and(|p| p < pos),
                    "visit {v}: {} shown before its mandatory {}",
                    e.to,
                    e.from
                );
            }
        }
        distinct_orders.insert(shown);
    }
    // Never the same walk twice (almost).
    assert!(distinct_orders.len() > 950, "only {} distinct walks", distinct_orders.len());
}

#[test]
fn extremes_do_not_panic_and_behave_as_documented() {
    let camera = Camera { eye: DVec3::new(0.0, 0.0, 3.0), target: DVec3::ZERO, up: DVec3::Y, fov_y: 0.8 };
    let samples: Vec<DVec3> =
        (0..50).map(|i| DVec3::new((i % 7) as f64 * 0.1 - 0.3, (i / 7) as f64 * 0.1 - 0.3, 0.0)).collect();
    let ctx = ViewContext { camera, aspect: 16.0 / 9.0, samples: &samples, diagonal: 1.0, moving: false };
    let mut r = rng(5);
    // Empty graph: nothing happens, ever.
    let empty = InfoGraph::default();
    let mut rec = Recommender::new(&empty, RecSettings::default(), 0.0);
    for k in 0..100 {
        assert!(rec.step(&empty, &ctx, RecEvent::Tick, k as f64, &mut r).is_empty());
    }
    // One node: shown, then not again before T_max has passed.
    let one = InfoGraph {
        default_lang: "en".into(),
        nodes: vec![node("a", DVec3::new(1.0, 0.0, 3.0), DVec3::ZERO, 1.0)],
        edges: vec![],
    };
    let shown = super::engine::visit(&one, &ctx, 1, 3);
    assert_eq!(shown, vec![0, 0, 0]);
    // All γ = 0: never proposed.
    let zero = InfoGraph {
        nodes: one.nodes.iter().map(|n| kiosk_core::graph::Node { importance: 0.0, ..n.clone() }).collect(),
        ..one.clone()
    };
    assert!(super::engine::visit(&zero, &ctx, 1, 1).is_empty());
    // A chain where every edge is mandatory: shown in chain order.
    let chain = InfoGraph {
        default_lang: "en".into(),
        nodes: (0..8)
            .map(|i| node(&format!("c{i}"), DVec3::new(i as f64 * 0.1, 0.0, 3.0), DVec3::ZERO, 1.0))
            .collect(),
        edges: (0..7).map(|i| Edge { from: i, to: i + 1, weight: 1.0 }).collect(),
    };
    // First showings follow the chain (a node may come back once T_max has passed).
    let shown = super::engine::visit(&chain, &ctx, 2, 20);
    let mut first = Vec::new();
    for n in shown {
        if !first.contains(&n) {
            first.push(n);
        }
    }
    assert_eq!(first, (0..8).collect::<Vec<_>>());
    // Days of elapsed time and 10 000 nodes: finite scores, a selection, no panic.
    let big = InfoGraph {
        default_lang: "en".into(),
        nodes: (0..10_000)
            .map(|i| {
                node(
                    &format!("b{i}"),
                    DVec3::new((i % 100) as f64 * 0.02, (i / 100) as f64 * 0.02, 3.0),
                    DVec3::ZERO,
                    0.5,
                )
            })
            .collect(),
        edges: (1..10_000).step_by(3).map(|i| Edge { from: i - 1, to: i, weight: 0.2 }).collect(),
    };
    let mut rec = Recommender::new(&big, RecSettings::default(), 0.0);
    let days = 3.0 * 86_400.0;
    rec.step(&big, &ctx, RecEvent::Tick, days, &mut r);
    assert!(matches!(rec.state, RecState::Attract { .. }));
    let scores = rec.scores(&big, &ctx, days * 2.0);
    assert!(scores.iter().all(|s| s.score.is_finite() && s.score >= 0.0));
}
