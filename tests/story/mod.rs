//! The information graph, the recommendation engine and the radial selector.

mod check;
mod engine;
mod sessions;
mod visit;

use kiosk_content::MappedStore;
use kiosk_core::graph::InfoGraph;
pub use kiosk_testkit::synthetic::node;

/// The paper's graph: 109 nodes, 132 edges.
pub fn paper_graph(store: &MappedStore, seed: u64) -> InfoGraph {
    kiosk_testkit::synthetic::paper_graph(store, 109, seed)
}
