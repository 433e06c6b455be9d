//! What the tests and benchmarks share and the kiosk does not ship: synthetic information graphs
//! of the thesis's shape, and image metrics (SSIM, PSNR) for golden images and the renderer's
//! speed/accuracy tables, a reader of the test meshes for the mesh reference renderer, the PNG
//! beside each benchmark's SVG plot, and a copy of an exhibit to break in a test.

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

/// Copies a directory tree (an exhibit, to edit or break a copy of it in a test).
pub fn copy_dir(from: &std::path::Path, to: &std::path::Path) -> std::io::Result<()> {
    std::fs::create_dir_all(to)?;
    for e in std::fs::read_dir(from)? {
        let e = e?;
        let target = to.join(e.file_name());
        if e.file_type()?.is_dir() {
            copy_dir(&e.path(), &target)?;
        } else {
            std::fs::copy(e.path(), &target)?;
        }
    }
    Ok(())
}
