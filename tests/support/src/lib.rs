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

/// A headless GPU and renderer for a test, with the Vulkan validation layers on; panics, naming
/// `.ci/setup`, when lavapipe (or another Vulkan driver) or the validation layers are missing:
/// GPU tests never skip, and without the layers they would pass unchecked.
pub fn test_gpu() -> (kiosk_render::Gpu, kiosk_render::Renderer) {
    assert!(
        validation_layers_installed(),
        "the Vulkan validation layers are not installed (VkLayer_khronos_validation.json in none of \
         the loader's layer directories). Run .ci/setup (installs vulkan-validationlayers): the GPU \
         tests fail on any validation message."
    );
    kiosk_content::snapshot::offscreen().unwrap_or_else(|e| {
        panic!("no GPU adapter: {e:#}. Run .ci/setup (installs lavapipe) — GPU tests never skip.")
    })
}

/// Whether the Khronos validation layer's manifest is where the Vulkan loader looks for explicit
/// layers (`VK_LAYER_PATH`, `VK_ADD_LAYER_PATH`, the XDG data and config directories, /etc, /usr).
fn validation_layers_installed() -> bool {
    let var = |k: &str| std::env::var(k).unwrap_or_default();
    let mut dirs: Vec<std::path::PathBuf> = Vec::new();
    for k in ["VK_LAYER_PATH", "VK_ADD_LAYER_PATH"] {
        dirs.extend(var(k).split(':').filter(|d| !d.is_empty()).map(std::path::PathBuf::from));
    }
    let data = var("XDG_DATA_DIRS");
    let data = if data.is_empty() { "/usr/local/share:/usr/share".to_string() } else { data };
    let config = var("XDG_CONFIG_DIRS");
    let config = if config.is_empty() { "/etc/xdg".to_string() } else { config };
    let roots = data.split(':').chain(config.split(':')).chain(["/etc", "/usr/share", "/usr/local/share"]);
    dirs.extend(
        roots.filter(|d| !d.is_empty()).map(|d| std::path::Path::new(d).join("vulkan/explicit_layer.d")),
    );
    if let Some(home) = std::env::var_os("HOME") {
        dirs.push(std::path::Path::new(&home).join(".local/share/vulkan/explicit_layer.d"));
    }
    dirs.iter().any(|d| d.join("VkLayer_khronos_validation.json").is_file())
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
