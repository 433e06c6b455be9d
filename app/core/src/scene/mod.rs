//! The scene: the multiresolution point hierarchy (bettio09 §3, balsa12 §4, thesis 9.7), shared by
//! the renderer and by every geometric query of the camera, the POI selector and the recommender.
//!
//! - [`store`]: the file format, read zero-copy from a memory map.
//! - [`boxtree`]: the per-node implicit box hierarchy used by every search.
//! - [`cut`]: the view-dependent cut (a front through the tree), updated incrementally.
//! - [`query`]: fine and coarse targets on the cut, exact nearest sample, ray casts, samples.

pub mod boxtree;
pub mod cut;
pub mod query;
pub mod splat;
pub mod store;

pub use boxtree::{BoxTree, HasPosition, KBest};
pub use cut::{Cut, CutParams, CutStats, ViewParams};
pub use query::{Hit, Level, QueryParams, TargetQuery};
pub use splat::Splat;
pub use store::{NodeId, NodeRecord, Store, StoreError, StoreHeader};
