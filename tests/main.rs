//! The integration tests of IsoKiosk: one binary (see `Cargo.toml`).

mod common;
mod scene;
