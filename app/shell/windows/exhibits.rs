//! The gallery's exhibits as the windows hold them (model, story, pose and start view), loaded
//! from the configuration so that a broken one is left out and the rest shows; and the kiosk's
//! behaviour settings from the configuration.

use super::config::Config;
use kiosk_content::MappedStore;
use kiosk_core::camera::{Camera, start_camera};
use kiosk_core::explore::ExploreSettings;
use kiosk_core::graph::InfoGraph;
use kiosk_core::kiosk::KioskSettings;
use std::path::PathBuf;

/// One exhibit of the gallery.
pub struct Exhibit {
    /// Its directory.
    pub dir: PathBuf,
    /// Its place in the gallery (the configuration's order).
    pub place: usize,
    /// Its model.
    pub store: MappedStore,
    /// Its story.
    pub graph: Option<InfoGraph>,
    /// Its model's up direction (`exhibit.toml`).
    pub up: glam::DVec3,
    /// The side its start view looks at (`exhibit.toml`), if it says.
    pub front: Option<glam::DVec3>,
    /// Its start view, framed once (the gallery's turntable asks at every frame, and a turned
    /// model's framing reads samples of the store).
    start: std::sync::OnceLock<Camera>,
}

impl Exhibit {
    /// Its start view (`fov_y`: the kiosk's, the same for the whole run).
    pub fn start_camera(&self, fov_y: f64) -> Camera {
        *self.start.get_or_init(|| start_camera(&self.store, fov_y, self.up, self.front))
    }

    /// The title shown in the gallery: the first node's title, else the directory name.
    pub fn title(&self, lang: &str) -> String {
        self.graph
            .as_ref()
            .and_then(|g| g.nodes.first())
            .and_then(|n| n.title.get(lang, self.default_lang()))
            .map(str::to_string)
            .unwrap_or_else(|| self.dir.file_name().map_or("?".into(), |n| n.to_string_lossy().into_owned()))
    }

    fn default_lang(&self) -> &str {
        self.graph.as_ref().map_or("en", |g| g.default_lang.as_str())
    }
}

/// The exhibits of the configuration, each with its place in the gallery.
pub fn gallery_places(config: &Config) -> anyhow::Result<Vec<(usize, PathBuf)>> {
    Ok(config.exhibit_dirs()?.into_iter().enumerate().collect())
}

/// Loads the exhibits at `places` (of `n` in the gallery), in order; a broken one is logged and
/// left out. Without `import`, an exhibit whose scan must be imported into the cache first is
/// not loaded but returned, with its place, among those waiting (the kiosk opens its gallery
/// without them and imports them behind it).
pub fn load_places(
    places: Vec<(usize, PathBuf)>,
    n: usize,
    import: bool,
    status: &mut dyn FnMut(Status),
) -> (Vec<Exhibit>, Vec<(usize, PathBuf)>) {
    let (mut out, mut waiting) = (Vec::new(), Vec::new());
    let cache = kiosk_content::exhibit::cache_dir();
    for (place, dir) in places {
        status(Status::Exhibit(place, n));
        let opened = if import {
            kiosk_content::exhibit::open_model_warned(&dir, &cache, &mut |line| {
                status(Status::Line(line.to_string()))
            })
            .map(Some)
        } else {
            kiosk_content::exhibit::open_model_cached(&dir, &cache)
        };
        let store = match opened {
            Ok(Some((s, warnings))) => {
                kiosk_content::exhibit::log_warnings(&dir, &warnings);
                s
            }
            Ok(None) => {
                waiting.push((place, dir));
                continue;
            }
            Err(e) => {
                tracing::error!("exhibit {}: {e:#}; left out of the gallery", dir.display());
                continue;
            }
        };
        let graph = match kiosk_content::exhibit::open_graph(&dir) {
            Ok(Some((g, problems))) => {
                for p in problems {
                    tracing::warn!("{}: {p}", dir.join("graph.xml").display());
                }
                Some(g)
            }
            Ok(None) => None,
            Err(e) => {
                tracing::error!("exhibit {}: {e:#}; shown without its story", dir.display());
                None
            }
        };
        // What exhibit.toml could give: a key it could not take is left at its default.
        let settings = kiosk_content::exhibit::exhibit_settings(&dir);
        let pose = settings.pose;
        for message in settings.messages() {
            tracing::error!("{message}");
        }
        tracing::info!("exhibit {}: {} samples", dir.display(), store.header().leaf_point_count);
        out.push(Exhibit {
            dir,
            place,
            store,
            graph,
            up: pose.up,
            front: pose.front,
            start: std::sync::OnceLock::new(),
        });
    }
    (out, waiting)
}

/// What [`load_places`] is doing, for the windows to show while it works.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// Exhibit i (from 0) of n starts loading.
    Exhibit(usize, usize),
    /// A line its import into the cache logs (which scan, the phase and how far).
    Line(String),
}

/// The kiosk's behaviour settings from the configuration, for a projection of `size` pixels and
/// a controller of aspect `controller_aspect`.
pub fn kiosk_settings(config: &Config, size: (u32, u32), controller_aspect: f64, seed: u64) -> KioskSettings {
    let mut explore = ExploreSettings {
        size_px: size,
        fov_y: config.fov_y(),
        real_scale: config.real_scale.is_some(),
        seed,
        ..Default::default()
    };
    explore.cut.tolerance_px = config.tolerance_px;
    explore.gestures.aspect = controller_aspect;
    KioskSettings {
        attract_after_secs: config.attract_after_secs,
        reset_after_secs: config.reset_after_secs,
        languages: config.languages.clone(),
        explore,
        popularity: config.popularity,
        ..Default::default()
    }
}
