//! What the tests and benchmarks share and the kiosk does not ship: synthetic information graphs
//! of the thesis's shape, and image metrics (SSIM, PSNR) for golden images and the renderer's
//! speed/accuracy tables, a reader of the test meshes for the mesh reference renderer, and the
//! PNG beside each benchmark's SVG plot.

pub mod mesh;
pub mod metrics;
pub mod synthetic;

/// Draws a benchmark's SVG plot into a PNG beside it (to look at without an SVG viewer) and
/// returns the PNG's path.
pub fn png_beside(svg: &std::path::Path) -> std::io::Result<std::path::PathBuf> {
    let png = svg.with_extension("png");
    kiosk_content::media::svg_to_rgba(&std::fs::read(svg)?)
        .map_err(std::io::Error::other)?
        .save(&png)
        .map_err(std::io::Error::other)?;
    Ok(png)
}
