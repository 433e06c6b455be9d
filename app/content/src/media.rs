//! The media files an exhibit's graph names (overlays, narrations, thumbnails, ROI masks), opened
//! so that nothing outside the exhibit is ever read.
//!
//! A graph path is first checked as text by the core ([`kiosk_core::graph::check_media_path`]:
//! relative, no `..`), then here on disk: the path with links resolved must lie inside the
//! exhibit's directory (links resolved too), be a regular file (a FIFO would block the kiosk) and
//! hold at most [`MAX_MEDIA_BYTES`]. SVG overlays are drawn without access to any file: an
//! `<image>` that names one is left out (embedded `data:` images still draw).

use std::path::{Path, PathBuf};

/// Largest media file read, in bytes (a 1280×720 PNG overlay is a few MB; narrations of several
/// minutes in WAV are tens of MB).
pub const MAX_MEDIA_BYTES: u64 = 256 << 20;

/// Largest image decoded, in pixels per side (overlays are drawn at the projection's size).
pub const MAX_IMAGE_SIDE: u32 = 8192;

/// The file that `rel` names inside the exhibit directory `dir`, or why it may not be read.
pub fn resolve(dir: &Path, rel: &str) -> Result<PathBuf, String> {
    kiosk_core::graph::check_media_path(rel)?;
    let root = dir.canonicalize().map_err(|e| format!("exhibit {}: {e}", dir.display()))?;
    let path = dir.join(rel);
    let real = path.canonicalize().map_err(|e| match e.kind() {
        std::io::ErrorKind::NotFound => "file not found".to_string(),
        _ => e.to_string(),
    })?;
    if !real.starts_with(&root) {
        return Err(format!("{rel} leads outside the exhibit (to {})", real.display()));
    }
    let meta = std::fs::metadata(&real).map_err(|e| e.to_string())?;
    if !meta.is_file() {
        return Err(format!("{rel} is not a regular file"));
    }
    if meta.len() > MAX_MEDIA_BYTES {
        return Err(format!("{rel} holds {} bytes, more than the {MAX_MEDIA_BYTES} allowed", meta.len()));
    }
    Ok(real)
}

/// Whether a path names an SVG drawing (by its extension).
pub fn is_svg(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("svg"))
}

/// Reads an image: PNG or JPEG (at most [`MAX_IMAGE_SIDE`] pixels a side), or SVG drawn at
/// 1280×720 (the view's size), fitted and centred. Errors name the file.
pub fn read_image(path: &Path) -> Result<image::RgbaImage, String> {
    let data = read_bounded(path)?;
    if is_svg(path) {
        return svg_to_rgba(&data).map_err(|e| format!("{}: {e}", path.display()));
    }
    let mut reader = image::ImageReader::new(std::io::Cursor::new(data))
        .with_guessed_format()
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_IMAGE_SIDE);
    limits.max_image_height = Some(MAX_IMAGE_SIDE);
    reader.limits(limits);
    reader.decode().map(|i| i.to_rgba8()).map_err(|e| format!("{}: {e}", path.display()))
}

/// Reads a whole file, refusing anything but a regular file of at most [`MAX_MEDIA_BYTES`].
fn read_bounded(path: &Path) -> Result<Vec<u8>, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("{}: {e}", path.display()))?;
    if !meta.is_file() || meta.len() > MAX_MEDIA_BYTES {
        return Err(format!("{}: not a regular file of at most {MAX_MEDIA_BYTES} bytes", path.display()));
    }
    std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Draws an SVG document at 1280×720 with straight alpha, reading no file: images it links to
/// by path are left out.
pub fn svg_to_rgba(data: &[u8]) -> Result<image::RgbaImage, String> {
    use resvg::usvg;
    // The system's fonts, loaded once: an overlay's labels are text.
    static FONTS: std::sync::OnceLock<std::sync::Arc<usvg::fontdb::Database>> = std::sync::OnceLock::new();
    let fontdb = FONTS
        .get_or_init(|| {
            let mut db = usvg::fontdb::Database::new();
            db.load_system_fonts();
            // The generic families name fonts a Linux machine may lack (Arial, Times New
            // Roman): they fall to a font it has.
            let families: Vec<String> =
                db.faces().filter_map(|f| f.families.first().map(|(name, _)| name.clone())).collect();
            let pick = |wanted: &[&str]| {
                wanted
                    .iter()
                    .find_map(|w| families.iter().find(|f| f.as_str() == *w))
                    .or_else(|| families.first())
                    .cloned()
            };
            if let Some(f) = pick(&["DejaVu Sans", "Liberation Sans", "Noto Sans"]) {
                db.set_sans_serif_family(f);
            }
            if let Some(f) = pick(&["DejaVu Serif", "Liberation Serif", "Noto Serif"]) {
                db.set_serif_family(f);
            }
            if let Some(f) = pick(&["DejaVu Sans Mono", "Liberation Mono", "Noto Sans Mono"]) {
                db.set_monospace_family(f);
            }
            std::sync::Arc::new(db)
        })
        .clone();
    let mut options = usvg::Options { resources_dir: None, fontdb, ..usvg::Options::default() };
    // Only images embedded in the document itself (data: URLs) are decoded.
    options.image_href_resolver.resolve_string = Box::new(|_, _| None);
    let tree = usvg::Tree::from_data(data, &options).map_err(|e| format!("not a valid SVG: {e}"))?;
    let (w, h) = (1280u32, 720u32);
    let mut pixmap = resvg::tiny_skia::Pixmap::new(w, h).ok_or("cannot allocate the drawing")?;
    let size = tree.size();
    let scale = (w as f32 / size.width()).min(h as f32 / size.height());
    let dx = (w as f32 - size.width() * scale) * 0.5;
    let dy = (h as f32 - size.height() * scale) * 0.5;
    let transform = resvg::tiny_skia::Transform::from_row(scale, 0.0, 0.0, scale, dx, dy);
    resvg::render(&tree, transform, &mut pixmap.as_mut());
    // tiny-skia stores premultiplied alpha; PNG overlays are straight alpha.
    let mut rgba = Vec::with_capacity((w * h * 4) as usize);
    for px in pixmap.pixels() {
        let c = px.demultiply();
        rgba.extend_from_slice(&[c.red(), c.green(), c.blue(), c.alpha()]);
    }
    image::RgbaImage::from_raw(w, h, rgba).ok_or_else(|| "size mismatch".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_regular_files_inside_the_exhibit_resolve() {
        let root = tempfile::tempdir().expect("temp dir");
        let ex = root.path().join("exhibit");
        std::fs::create_dir_all(ex.join("overlays")).expect("dirs");
        std::fs::write(ex.join("overlays/a b.png"), b"x").expect("write");
        std::fs::write(root.path().join("secret.txt"), b"s").expect("write");
        assert!(resolve(&ex, "overlays/a b.png").is_ok());
        let e = resolve(&ex, "../secret.txt").expect_err("parent");
        assert!(e.contains(".."), "{e}");
        let e = resolve(&ex, "/etc/hostname").expect_err("absolute");
        assert!(e.contains("relative"), "{e}");
        assert_eq!(resolve(&ex, "overlays/none.png").expect_err("missing"), "file not found");
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(root.path().join("secret.txt"), ex.join("overlays/link.png"))
                .expect("symlink");
            let e = resolve(&ex, "overlays/link.png").expect_err("a link leading out");
            assert!(e.contains("outside the exhibit"), "{e}");
            let fifo = ex.join("overlays/fifo.png");
            let status = std::process::Command::new("mkfifo").arg(&fifo).status().expect("mkfifo");
            assert!(status.success());
            let e = resolve(&ex, "overlays/fifo.png").expect_err("a FIFO");
            assert!(e.contains("not a regular file"), "{e}");
            let e = read_image(&fifo).expect_err("a FIFO is not read");
            assert!(e.contains("not a regular file"), "{e}");
        }
    }

    #[test]
    fn an_svg_overlay_draws_but_reads_no_file() {
        let dir = tempfile::tempdir().expect("temp dir");
        let red = image::RgbaImage::from_pixel(4, 4, image::Rgba([255, 0, 0, 255]));
        let png = dir.path().join("red.png");
        red.save(&png).expect("png");
        let svg = format!(
            r##"<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" width="16" height="9">
  <rect x="0" y="0" width="8" height="9" fill="#00ff00"/>
  <image x="8" y="0" width="8" height="9" xlink:href="{}"/>
</svg>"##,
            png.display()
        );
        let path = dir.path().join("overlay.svg");
        std::fs::write(&path, svg).expect("svg");
        let img = read_image(&path).expect("an SVG overlay is read");
        assert_eq!(img.dimensions(), (1280, 720));
        assert_eq!(img.get_pixel(320, 360).0, [0, 255, 0, 255], "the drawing's own rectangle");
        assert_eq!(img.get_pixel(960, 360).0[3], 0, "the linked file is not embedded");
    }

    #[test]
    fn an_svg_overlays_labels_are_drawn() {
        // Curators label overlays with text: it is drawn with the system's fonts (.ci/setup
        // installs DejaVu), not left out.
        let svg = br##"<svg xmlns="http://www.w3.org/2000/svg" width="16" height="9">
  <text x="1" y="7" font-family="sans-serif" font-size="6" fill="#ffffff">Ear</text>
</svg>"##;
        let img = svg_to_rgba(svg).expect("an SVG with text");
        let inked = img.pixels().filter(|p| p[3] > 128).count();
        assert!(inked > 2000, "{inked} pixels of text drawn");
    }
}
