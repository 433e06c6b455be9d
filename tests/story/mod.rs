//! The information graph, the recommendation engine and the radial selector.

mod engine;
mod sessions;
mod visit;

use kiosk::MappedStore;
pub use kiosk::synthetic::node;
use kiosk_core::graph::InfoGraph;

/// The paper's graph: 109 nodes, 132 edges.
pub fn paper_graph(store: &MappedStore, seed: u64) -> InfoGraph {
    kiosk::synthetic::paper_graph(store, 109, seed)
}
