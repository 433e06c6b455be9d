//! The pure core of IsoKiosk.
//!
//! Everything a visitor's gesture changes is computed here by deterministic code that takes time
//! and randomness as inputs. This crate never touches the GPU, windows, audio, the filesystem or
//! the clock: the shell hands it byte slices (memory maps) and timestamps. `clippy.toml` in this
//! crate disallows the clock and the filesystem so the compiler guards that promise.

// The core holds no unsafe code, and cannot be given any.
#![forbid(unsafe_code)]

pub mod camera;
pub mod clock;
pub mod explore;
pub mod geom;
pub mod gesture;
pub mod graph;
pub mod kiosk;
pub mod light;
pub mod radial;
pub mod recommend;
pub mod replay;
pub mod scene;
pub mod session;
pub mod stats;
pub mod trace;

pub use geom::Aabb;
pub use scene::{
    BoxTree, Cut, CutParams, CutStats, Hit, Level, NodeId, NodeRecord, QueryParams, Splat, Store, StoreError,
    StoreHeader, TargetQuery, ViewParams,
};
