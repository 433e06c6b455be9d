//! The integration tests of IsoKiosk: one binary (see `Cargo.toml`).

mod camera;
mod common;
mod render;
mod scene;
mod story;
mod windows;
