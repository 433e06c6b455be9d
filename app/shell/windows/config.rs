//! The kiosk's configuration file (TOML): which content, which monitor each window goes to,
//! fullscreen or not, portrait rotation, real-scale projection, timeouts, languages, volume.
//! Every key is optional; unknown keys are an error naming them (a typo must not pass silently).

use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Largest window side accepted in the configuration (the GPU may allow less; that is checked
/// when the windows open).
pub const MAX_WINDOW_SIDE: u32 = 16384;

/// One window's placement.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct WindowConfig {
    /// Monitor index (winit's order); out of range → the first monitor, logged.
    pub monitor: usize,
    /// Borderless fullscreen on that monitor.
    pub fullscreen: bool,
    /// Size when not fullscreen (pixels).
    pub size: [u32; 2],
    /// Content rotation in degrees (0, 90, 180, 270): a projector mounted on its side.
    pub rotation: u32,
}

impl WindowConfig {
    fn projection() -> Self {
        Self { monitor: 0, fullscreen: true, size: [1280, 720], rotation: 0 }
    }
    fn controller() -> Self {
        Self { monitor: 1, fullscreen: true, size: [800, 480], rotation: 0 }
    }
}

impl Default for WindowConfig {
    fn default() -> Self {
        Self::projection()
    }
}

/// Real-scale display (thesis 9.8.10): the vertical field of view is the angle the screen
/// subtends at the viewer, so one model unit (metre) shows as one metre on the wall.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RealScale {
    /// Height of the projected image in metres.
    pub screen_height_m: f64,
    /// Distance from the viewer's eyes to the screen in metres.
    pub viewer_distance_m: f64,
}

impl RealScale {
    /// The vertical field of view in radians.
    pub fn fov_y(&self) -> f64 {
        2.0 * (0.5 * self.screen_height_m / self.viewer_distance_m.max(1e-3)).atan()
    }
}

/// The whole configuration.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields, default)]
pub struct Config {
    /// The content directory (one sub-directory per exhibit); relative to the config file.
    pub content: PathBuf,
    /// Exhibits in gallery order (sub-directory names); empty = every sub-directory, sorted.
    pub exhibits: Vec<String>,
    /// The projection window.
    pub projection: WindowConfig,
    /// The controller (touch) window.
    pub controller: WindowConfig,
    /// Vertical field of view in degrees, unless `real_scale` is given.
    pub fov_deg: f64,
    /// Real-scale projection.
    pub real_scale: Option<RealScale>,
    /// Seconds without a touch before the attract loop.
    pub attract_after_secs: f64,
    /// Seconds without a touch before the reset to the gallery.
    pub reset_after_secs: f64,
    /// Seconds between two looks at the content when no exhibit could be loaded (the content not
    /// there yet, or every exhibit broken): the windows say the exhibition is closed, and the
    /// exhibits are tried again when the content changed. At most a day.
    pub retry_after_secs: f64,
    /// Languages offered; the first is the default.
    pub languages: Vec<String>,
    /// Narration volume in [0, 1].
    pub volume: f64,
    /// Seed of the recommendations (each visit adds its number).
    pub seed: u64,
    /// Pixel tolerance of the cut (larger = faster, coarser).
    pub tolerance_px: f32,
    /// Where the visit statistics and log go (default: [`kiosk_content::stats::state_dir`]); relative
    /// to the config file.
    pub state_dir: Option<PathBuf>,
    /// Whether and how popularity adjusts the nodes' importance.
    pub popularity: kiosk_core::stats::PopularitySettings,
    /// How splats are drawn: "blended" (smooth, the default), "discs" or "points" (faster).
    pub splats: String,
    /// Eye-dome lighting strength (0 = off), for scans without colour.
    pub edl: f32,
}

impl Default for Config {
    fn default() -> Self {
        Self {
            content: PathBuf::from("content"),
            exhibits: Vec::new(),
            projection: WindowConfig::projection(),
            controller: WindowConfig::controller(),
            fov_deg: 45.8,
            real_scale: None,
            attract_after_secs: 60.0,
            reset_after_secs: 180.0,
            retry_after_secs: 60.0,
            languages: vec!["en".into(), "it".into()],
            volume: 1.0,
            seed: 0,
            tolerance_px: 1.5,
            state_dir: None,
            popularity: kiosk_core::stats::PopularitySettings::default(),
            splats: kiosk_render::SplatMode::default().name().into(),
            edl: 0.0,
        }
    }
}

impl Config {
    /// Parses a configuration; errors name the line and key.
    pub fn parse(text: &str) -> Result<Self, String> {
        let c: Self = toml::from_str(text).map_err(|e| e.to_string())?;
        c.check()?;
        Ok(c)
    }

    /// Reads a configuration file; relative paths in it are taken from its directory.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| anyhow::anyhow!("cannot read config {}: {e}", path.display()))?;
        let mut c = Self::parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        if c.content.is_relative()
            && let Some(dir) = path.parent()
        {
            c.content = dir.join(&c.content);
        }
        if let (Some(s), Some(dir)) = (c.state_dir.as_mut(), path.parent())
            && s.is_relative()
        {
            *s = dir.join(&*s);
        }
        Ok(c)
    }

    fn check(&self) -> Result<(), String> {
        for (name, w) in [("projection", &self.projection), ("controller", &self.controller)] {
            if w.rotation % 90 != 0 || w.rotation >= 360 {
                return Err(format!("[{name}] rotation = {}: must be 0, 90, 180 or 270", w.rotation));
            }
            if !(1..=MAX_WINDOW_SIDE).contains(&w.size[0]) || !(1..=MAX_WINDOW_SIDE).contains(&w.size[1]) {
                return Err(format!(
                    "[{name}] size = {:?}: each side must be 1 to {MAX_WINDOW_SIDE} pixels",
                    w.size
                ));
            }
        }
        if !(self.fov_deg > 1.0 && self.fov_deg < 170.0) {
            return Err(format!("fov_deg = {}: must be between 1 and 170", self.fov_deg));
        }
        if let Some(r) = &self.real_scale {
            let positive = |v: f64| v.is_finite() && v > 0.0;
            if !(positive(r.screen_height_m) && positive(r.viewer_distance_m)) {
                return Err(format!(
                    "[real_scale] screen_height_m = {}, viewer_distance_m = {}: must be positive and finite",
                    r.screen_height_m, r.viewer_distance_m
                ));
            }
            // The same range as fov_deg: an infinite screen, or a viewer against it, would ask
            // for a field of view of 180 degrees, which no projection shows.
            let fov = r.fov_y().to_degrees();
            if !(fov > 1.0 && fov < 170.0) {
                return Err(format!(
                    "[real_scale] a screen {} m high seen from {} m is {fov:.1} degrees: must be between 1 and 170",
                    r.screen_height_m, r.viewer_distance_m
                ));
            }
        }
        if !(self.attract_after_secs > 0.0 && self.reset_after_secs >= self.attract_after_secs) {
            return Err(format!(
                "attract_after_secs = {}, reset_after_secs = {}: need 0 < attract ≤ reset",
                self.attract_after_secs, self.reset_after_secs
            ));
        }
        if !(self.retry_after_secs > 0.0 && self.retry_after_secs <= 86_400.0) {
            return Err(format!(
                "retry_after_secs = {}: must be a positive number of seconds, at most a day (86400)",
                self.retry_after_secs
            ));
        }
        if self.languages.is_empty() {
            return Err("languages: at least one".into());
        }
        if !(0.0..=1.0).contains(&self.volume) {
            return Err(format!("volume = {}: must be in [0, 1]", self.volume));
        }
        if !tolerance_ok(self.tolerance_px) {
            return Err(format!("tolerance_px = {}: must be a positive number of pixels", self.tolerance_px));
        }
        self.popularity.check()?;
        self.splat_mode().map_err(|e| format!("splats: {e}"))?;
        if !edl_ok(self.edl) {
            return Err(format!("edl = {}: must be in [0, 4]", self.edl));
        }
        Ok(())
    }

    /// The renderer's settings this configuration asks for.
    pub fn render_settings(&self) -> kiosk_render::RenderSettings {
        kiosk_render::RenderSettings {
            mode: self.splat_mode().unwrap_or_default(),
            edl_strength: self.edl,
            ..Default::default()
        }
    }

    fn splat_mode(&self) -> Result<kiosk_render::SplatMode, String> {
        self.splats.parse()
    }

    /// The vertical field of view in radians.
    pub fn fov_y(&self) -> f64 {
        self.real_scale.as_ref().map_or(self.fov_deg.to_radians(), RealScale::fov_y)
    }

    /// The state directory: the configured one, else [`kiosk_content::stats::state_dir`].
    pub fn state_dir(&self) -> PathBuf {
        self.state_dir.clone().unwrap_or_else(kiosk_content::stats::state_dir)
    }

    /// The exhibit directories in gallery order.
    pub fn exhibit_dirs(&self) -> anyhow::Result<Vec<PathBuf>> {
        if !self.exhibits.is_empty() {
            return Ok(self.exhibits.iter().map(|e| self.content.join(e)).collect());
        }
        let mut dirs: Vec<PathBuf> = std::fs::read_dir(&self.content)
            .map_err(|e| anyhow::anyhow!("cannot read content directory {}: {e}", self.content.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_dir())
            .collect();
        dirs.sort();
        Ok(dirs)
    }
}

/// A cut tolerance the renderer can use (`tolerance_px`, `kiosk snapshot --tolerance`): a
/// positive, finite number of pixels.
pub fn tolerance_ok(px: f32) -> bool {
    px > 0.0 && px.is_finite()
}

/// An eye-dome lighting strength (`edl`, `kiosk snapshot --edl`): 0 (off) to 4.
pub fn edl_ok(strength: f32) -> bool {
    (0.0..=4.0).contains(&strength)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_and_overrides() {
        let c = Config::parse("").expect("empty config");
        assert_eq!(c, Config::default());
        let c = Config::parse(
            "languages = [\"it\", \"en\"]\nattract_after_secs = 5\nreset_after_secs = 9\n\
             [projection]\nmonitor = 1\nrotation = 90\n[real_scale]\nscreen_height_m = 2.5\nviewer_distance_m = 3.0\n",
        )
        .expect("valid config");
        assert_eq!(c.languages, ["it", "en"]);
        assert_eq!(c.projection.rotation, 90);
        assert!(c.projection.fullscreen, "unspecified keys keep their defaults");
        // 2.5 m seen from 3 m: 2·atan(1.25/3) = 45.24°.
        assert!((c.fov_y().to_degrees() - 45.2397).abs() < 1e-3, "{}", c.fov_y().to_degrees());
    }

    #[test]
    fn the_readmes_example_configuration_is_valid() {
        let readme = include_str!("../../../README.md");
        let start = readme.find("```toml\n").expect("a TOML example in the README") + 8;
        let end = start + readme[start..].find("```").expect("its end");
        let c = Config::parse(&readme[start..end]).unwrap_or_else(|e| panic!("README's kiosk.toml: {e}"));
        assert_eq!(c.controller.monitor, 1);
    }

    #[test]
    fn errors_name_the_key() {
        let e = Config::parse("atract_after_secs = 5").expect_err("typo");
        assert!(e.contains("atract_after_secs"), "{e}");
        let e = Config::parse("[controller]\nrotation = 45").expect_err("rotation");
        assert!(e.contains("rotation = 45"), "{e}");
        let e = Config::parse("[popularity]\nbound = 1.5").expect_err("bound");
        assert!(e.contains("[popularity] bound"), "{e}");
        let c = Config::parse("[popularity]\nenabled = true").expect("popularity");
        assert!(c.popularity.enabled && c.popularity.bound == 0.25);
        let e = Config::parse("volume = 2.0").expect_err("volume");
        assert!(e.contains("volume"), "{e}");
        let e = Config::parse("fov_deg = \"wide\"").expect_err("type");
        assert!(e.contains("line 1") || e.contains("fov_deg"), "{e}");
        let e = Config::parse("attract_after_secs = 100\nreset_after_secs = 50").expect_err("order");
        assert!(e.contains("attract"), "{e}");
        for size in ["[100000, 100000]", "[20000, 100]", "[0, 720]"] {
            let e = Config::parse(&format!("[projection]\nsize = {size}")).expect_err("size");
            assert!(e.contains("[projection] size"), "{size}: {e}");
        }
        let e = Config::parse("splats = \"fuzzy\"").expect_err("mode");
        assert!(e.contains("splats") && e.contains("blended, discs, points"), "{e}");
        for secs in ["0", "-5", "inf", "nan", "1e20"] {
            let e = Config::parse(&format!("retry_after_secs = {secs}")).expect_err("retry");
            assert!(e.contains("retry_after_secs"), "{e}");
        }
        let e = Config::parse("edl = -1").expect_err("edl");
        assert!(e.contains("edl = -1"), "{e}");
        // A field of view of 180 degrees (tan(fov/2) infinite) was accepted through real_scale;
        // the kiosk_toml fuzz target's assertion caught it.
        for (h, d, what) in
            [("inf", "1.0", "finite"), ("2.5", "nan", "finite"), ("10.0", "0.1", "177.7 degrees")]
        {
            let text = format!("[real_scale]\nscreen_height_m = {h}\nviewer_distance_m = {d}");
            let e = Config::parse(&text).expect_err("real_scale");
            assert!(e.contains("[real_scale]") && e.contains(what), "{text}: {e}");
        }
    }

    #[test]
    fn the_splat_mode_reaches_the_renderer() {
        assert_eq!(Config::default().render_settings().mode, kiosk_render::SplatMode::Blended);
        let c = Config::parse("splats = \"points\"\nedl = 0.5").expect("valid");
        let r = c.render_settings();
        assert_eq!((r.mode, r.edl_strength), (kiosk_render::SplatMode::Points, 0.5));
    }
}
