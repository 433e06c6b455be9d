//! What the tests and benchmarks share and the kiosk does not ship: synthetic information graphs
//! of the thesis's shape, and image metrics (SSIM, PSNR) for golden images and the renderer's
//! speed/accuracy tables, and a reader of the test meshes for the mesh reference renderer.

pub mod mesh;
pub mod metrics;
pub mod synthetic;
