//! What a frame is asked to be ([`RenderSettings`], [`SplatMode`]) and what it did
//! ([`FrameStats`]).

use glam::Vec3;

/// How splats are drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SplatMode {
    /// Deferred blended surface splatting: overlapping splats of one surface blend their colour
    /// and normal with a smooth kernel and every pixel is shaded with its blended normal (the
    /// smooth image; the default).
    #[default]
    Blended,
    /// Opaque oriented discs, each shaded with its one normal (faster; disc edges show close up).
    Discs,
    /// Screen-aligned round points (the fastest fallback).
    Points,
}

impl SplatMode {
    /// Every mode, by its name.
    pub const ALL: [(&'static str, SplatMode); 3] =
        [("blended", SplatMode::Blended), ("discs", SplatMode::Discs), ("points", SplatMode::Points)];

    /// Its name in `--splats` and `kiosk.toml`.
    pub fn name(self) -> &'static str {
        Self::ALL.iter().find(|(_, m)| *m == self).map_or("blended", |(n, _)| n)
    }
}

impl std::fmt::Display for SplatMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for SplatMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL.iter().find(|(n, _)| *n == s).map(|(_, m)| *m).ok_or_else(|| {
            let names: Vec<&str> = Self::ALL.iter().map(|(n, _)| *n).collect();
            format!("unknown splat mode '{s}' (one of: {})", names.join(", "))
        })
    }
}

/// Rendering settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    /// Blended splats, opaque discs or round points.
    pub mode: SplatMode,
    /// Multiplies every splat radius.
    pub radius_scale: f32,
    /// Direction toward the user light (model axes).
    pub light_dir: Vec3,
    /// Weight of the user light against the headlight.
    pub light_mix: f32,
    /// Ambient term.
    pub ambient: f32,
    /// Strength of the Blinn–Phong highlight (0: matte).
    pub specular: f32,
    /// Blinn–Phong exponent of the highlight.
    pub shininess: f32,
    /// Blended mode: how far behind the front surface, in splat radii along the view ray, a
    /// splat still blends into a pixel (see [`DEFAULT_BLEND_EPSILON`]).
    pub blend_epsilon: f32,
    /// Blended mode: the kernel's Gaussian exponent at the disc's edge (larger: sharper).
    pub kernel_sharpness: f32,
    /// Smallest splat radius in pixels: a far splat is enlarged to it so that none falls between
    /// pixel centres.
    pub min_pixel_radius: f32,
    /// Eye-dome lighting strength (0: off).
    pub edl_strength: f32,
    /// Eye-dome lighting neighbour distance in pixels.
    pub edl_radius: f32,
    /// Background colour (linear RGBA).
    pub background: [f64; 4],
    /// GPU memory the node cache may use.
    pub gpu_budget_bytes: u64,
    /// Largest upload per frame (the rest waits; cached ancestors stand in).
    pub upload_budget_bytes: u64,
}

/// The blend epsilon: 1 splat radius. Neighbouring splats of one surface, each a disc tangent
/// to it, differ in depth at a pixel by at most about a radius where the surface curves or is
/// seen obliquely, so they blend; a surface behind another is in front of it by more than the
/// sampling's radius wherever the model is sampled finely enough to show it, so it is rejected.
pub const DEFAULT_BLEND_EPSILON: f32 = 2.0;

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            mode: SplatMode::Blended,
            radius_scale: 1.0,
            light_dir: Vec3::new(0.4, 0.8, 0.5),
            light_mix: 0.35,
            ambient: 0.12,
            specular: 0.12,
            shininess: 24.0,
            blend_epsilon: DEFAULT_BLEND_EPSILON,
            kernel_sharpness: 2.5,
            min_pixel_radius: 0.75,
            edl_strength: 0.0,
            edl_radius: 1.5,
            background: [0.02, 0.02, 0.025, 1.0],
            gpu_budget_bytes: 512 << 20,
            upload_budget_bytes: 48 << 20,
        }
    }
}

/// What a frame did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FrameStats {
    /// Nodes drawn.
    pub nodes: usize,
    /// Splats drawn.
    pub splats: u64,
    /// Nodes uploaded this frame.
    pub uploads: usize,
    /// Bytes uploaded this frame.
    pub uploaded_bytes: u64,
    /// Visible nodes drawn as a cached ancestor: not uploaded yet (over the upload budget), or
    /// corrupt (every frame they are visible).
    pub substituted: usize,
    /// Bytes held by the cache after the frame.
    pub cache_bytes: u64,
    /// Nodes found corrupt this frame (see [`crate::Renderer::corrupt_nodes`]).
    pub corrupt: usize,
}
