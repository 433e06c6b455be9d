//! Textures of meshes: an 8-bit sRGB image with its wrap modes, sampled bilinearly in linear
//! light (the texels are decoded from sRGB, interpolated, and the result encoded back into the
//! store's sRGB colour), and the conversions between sRGB bytes and linear values.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// How texture coordinates outside [0, 1] are brought back into the image (glTF samplers; an
/// OBJ map repeats unless `-clamp on`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles the plane.
    #[default]
    Repeat,
    /// The image tiles the plane, every other copy mirrored.
    MirroredRepeat,
    /// The edge texels extend outwards.
    ClampToEdge,
}

impl Wrap {
    /// The texel index `i` brought into `0..n`.
    #[inline]
    fn apply(self, i: i64, n: i64) -> usize {
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::ClampToEdge => i.clamp(0, n - 1),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m < n { m } else { 2 * n - 1 - m }
            }
        }) as usize
    }
}

/// A texture that cannot be used: the file (or the glTF image) it comes from, and why.
#[derive(Debug, thiserror::Error)]
#[error("texture {}: {msg}", .source_name)]
pub struct TextureError {
    /// The image file, or where the image is in the model (e.g. "image 2 (buffer view 5)").
    pub source_name: String,
    /// What is wrong.
    pub msg: String,
}

/// An RGBA8 image in sRGB (row 0 at the top) with its wrap modes.
#[derive(Clone, Debug)]
pub struct Texture {
    /// Where it comes from (a file name or an image of a glTF), for messages.
    pub name: String,
    /// Size in texels.
    pub width: u32,
    /// Size in texels.
    pub height: u32,
    /// Texels, row by row from the top, 4 bytes each (sRGB, alpha linear).
    pub rgba: Vec<u8>,
    /// Wrap modes along u and v.
    pub wrap: [Wrap; 2],
}

/// Largest side of a texture: 32 k texels (a 16 k atlas is the largest photogrammetry tools
/// write; a broken header asking for more is an error, not a huge allocation).
pub const MAX_SIDE: u32 = 32_768;

impl Texture {
    /// Decodes an image (PNG or JPEG, found by content) from memory.
    pub fn decode(name: &str, bytes: &[u8]) -> Result<Self, TextureError> {
        let err = |msg: String| TextureError { source_name: name.to_string(), msg };
        let reader = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| err(format!("cannot read: {e}")))?;
        if reader.format().is_none() {
            return Err(err("not an image format the importer reads (PNG or JPEG)".into()));
        }
        let (w, h) = reader.into_dimensions().map_err(|e| err(format!("cannot decode: {e}")))?;
        if w == 0 || h == 0 || w > MAX_SIDE || h > MAX_SIDE {
            return Err(err(format!("{w} × {h} texels: a texture is 1 to {MAX_SIDE} texels a side")));
        }
        let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| err(format!("cannot read: {e}")))?;
        reader.no_limits();
        let img =
            crate::formats::guarded(|| reader.decode().map_err(|e| err(format!("cannot decode: {e}"))), err)?;
        let rgba = img.to_rgba8();
        Ok(Self {
            name: name.to_string(),
            width: rgba.width(),
            height: rgba.height(),
            rgba: rgba.into_raw(),
            wrap: [Wrap::Repeat; 2],
        })
    }

    /// Reads an image file.
    pub fn load(path: &Path) -> Result<Self, TextureError> {
        let name = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| TextureError {
            source_name: name.clone(),
            msg: if e.kind() == std::io::ErrorKind::NotFound {
                "file not found".into()
            } else {
                format!("cannot read: {e}")
            },
        })?;
        Self::decode(&name, &bytes)
    }

    /// A texture of one colour (tests).
    pub fn solid(rgba: [u8; 4]) -> Self {
        Self { name: "solid".into(), width: 1, height: 1, rgba: rgba.to_vec(), wrap: [Wrap::Repeat; 2] }
    }

    /// The colour at texture coordinates `(u, v)` (0,0 the top-left corner of the image, 1,1
    /// the bottom-right), bilinear between the four nearest texel centres in linear light, with
    /// the wrap modes; alpha is interpolated as is.
    #[inline]
    pub fn sample(&self, u: f32, v: f32) -> [f32; 4] {
        let lut = srgb_to_linear_lut();
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        // Texel centres are at half-integers; a non-finite coordinate samples texel 0.
        let x = if u.is_finite() { f64::from(u) * w as f64 - 0.5 } else { 0.0 };
        let y = if v.is_finite() { f64::from(v) * h as f64 - 0.5 } else { 0.0 };
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
        // Far outside the image (huge coordinates) the index saturates; wrapping keeps it inside.
        let (x0, y0) = (
            x0.clamp(-(1i64 << 52) as f64, (1i64 << 52) as f64) as i64,
            y0.clamp(-(1i64 << 52) as f64, (1i64 << 52) as f64) as i64,
        );
        let xs = [self.wrap[0].apply(x0, w), self.wrap[0].apply(x0 + 1, w)];
        let ys = [self.wrap[1].apply(y0, h), self.wrap[1].apply(y0 + 1, h)];
        let texel = |xi: usize, yi: usize| {
            let at = (yi * self.width as usize + xi) * 4;
            let t = &self.rgba[at..at + 4];
            [lut[t[0] as usize], lut[t[1] as usize], lut[t[2] as usize], f32::from(t[3]) / 255.0]
        };
        let (a, b, c, d) =
            (texel(xs[0], ys[0]), texel(xs[1], ys[0]), texel(xs[0], ys[1]), texel(xs[1], ys[1]));
        let mut out = [0.0; 4];
        for k in 0..4 {
            let top = a[k] + (b[k] - a[k]) * fx;
            let bottom = c[k] + (d[k] - c[k]) * fx;
            out[k] = top + (bottom - top) * fy;
        }
        out
    }
}

/// The texture files of a model, each loaded once (several materials may share an atlas).
#[derive(Default)]
pub(crate) struct TextureCache {
    loaded: Vec<(PathBuf, [Wrap; 2], std::sync::Arc<Texture>)>,
    /// Paths looked at besides those loaded (see [`image_path`]).
    looked: Vec<PathBuf>,
}

impl TextureCache {
    /// The texture of `path` with `wrap`, loaded at its first use.
    pub(crate) fn get(
        &mut self,
        path: &Path,
        wrap: [Wrap; 2],
    ) -> Result<std::sync::Arc<Texture>, TextureError> {
        if let Some((_, _, t)) = self.loaded.iter().find(|(p, w, _)| p == path && *w == wrap) {
            return Ok(t.clone());
        }
        let texture = match self.loaded.iter().find(|(p, _, _)| p == path) {
            Some((_, _, t)) => Texture { wrap, ..(**t).clone() },
            None => Texture { wrap, ..Texture::load(path)? },
        };
        let texture = std::sync::Arc::new(texture);
        self.loaded.push((path.to_path_buf(), wrap, texture.clone()));
        Ok(texture)
    }

    /// Notes paths looked at for an image, besides the one loaded.
    pub(crate) fn looked_at(&mut self, paths: Vec<PathBuf>) {
        self.looked.extend(paths);
    }

    /// The files loaded or looked at, each once.
    pub(crate) fn paths(&self) -> Vec<PathBuf> {
        let mut paths: Vec<PathBuf> = Vec::new();
        for p in self.loaded.iter().map(|(p, ..)| p).chain(&self.looked) {
            if !paths.contains(p) {
                paths.push(p.clone());
            }
        }
        paths
    }
}

/// The image file a scan names `named` (a path relative to `dir`, the scan's or its library's
/// directory; `\\` read as `/`). Exporters often write the absolute path the image had on their
/// machine (`C:\\Users\\…\\atlas.jpg`): when the named file is not there but one of its name
/// is in `dir`, that one is taken, with a warning saying so.
///
/// Returns the path to read, and the paths looked at (the named one, and the one read if it is
/// another: both are the scan's inputs, so that the named file appearing later imports it again).
pub(crate) fn image_path(dir: &Path, named: &str, warnings: &mut Vec<String>) -> (PathBuf, Vec<PathBuf>) {
    let path = dir.join(named.replace('\\', "/"));
    let base = named.rsplit(['/', '\\']).next().unwrap_or(named);
    let beside = dir.join(base);
    if !path.is_file() && base != named && beside.is_file() {
        warnings.push(format!("image '{named}' not found; using {}, of that name", beside.display()));
        return (beside.clone(), vec![path, beside]);
    }
    (path.clone(), vec![path])
}

/// sRGB byte → linear value.
pub(crate) fn srgb_to_linear_lut() -> &'static [f32; 256] {
    static LUT: OnceLock<[f32; 256]> = OnceLock::new();
    LUT.get_or_init(|| std::array::from_fn(|i| srgb_to_linear(i as f32 / 255.0)))
}

/// sRGB value (0–1) → linear value.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

/// Linear value (0–1) → sRGB value.
pub fn linear_to_srgb(c: f32) -> f32 {
    if c <= 0.003_130_8 { c * 12.92 } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }
}

/// Entries of the table of [`encode_srgb`]: fine enough that the byte it gives is the correctly
/// rounded one within one step near black, where the curve is steepest.
const ENCODE_STEPS: usize = 1 << 14;

/// Linear value → sRGB byte (rounded; outside 0–1 clamped), by table.
#[inline]
pub(crate) fn encode_srgb(c: f32) -> u8 {
    static LUT: OnceLock<Vec<u8>> = OnceLock::new();
    let lut = LUT.get_or_init(|| {
        (0..=ENCODE_STEPS)
            .map(|i| (linear_to_srgb(i as f32 / ENCODE_STEPS as f32) * 255.0).round().clamp(0.0, 255.0) as u8)
            .collect()
    });
    let i = if c.is_finite() { (c.clamp(0.0, 1.0) * ENCODE_STEPS as f32).round() as usize } else { 0 };
    lut[i]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_bytes_survive_decoding_and_encoding() {
        for b in 0..=255u8 {
            assert_eq!(encode_srgb(srgb_to_linear_lut()[b as usize]), b);
        }
    }

    #[test]
    fn bilinear_interpolates_in_linear_light_and_wraps() {
        let mut t = Texture {
            name: "t".into(),
            width: 2,
            height: 1,
            rgba: vec![0, 0, 0, 255, 255, 255, 255, 255],
            wrap: [Wrap::ClampToEdge; 2],
        };
        // Halfway between black and white texel centres: linear 0.5, sRGB 188.
        let mid = t.sample(0.5, 0.5);
        assert!((mid[0] - 0.5).abs() < 1e-6);
        assert_eq!(encode_srgb(mid[0]), 188);
        // Clamped: left of the first centre is black.
        assert_eq!(t.sample(0.1, 0.5)[0], 0.0);
        assert_eq!(t.sample(-3.0, 0.5)[0], 0.0);
        // Repeat: just left of 0 blends the last texel in.
        t.wrap = [Wrap::Repeat; 2];
        assert!(t.sample(0.0, 0.5)[0] > 0.4);
        assert_eq!(t.sample(1.25, 0.5), t.sample(0.25, 0.5));
        // Mirrored: 1.25 is 0.75.
        t.wrap = [Wrap::MirroredRepeat; 2];
        assert_eq!(t.sample(1.25, 0.5), t.sample(0.75, 0.5));
        assert_eq!(Wrap::MirroredRepeat.apply(-1, 2), 0);
        assert_eq!(Wrap::MirroredRepeat.apply(2, 2), 1);
        assert_eq!(Wrap::MirroredRepeat.apply(3, 2), 0);
    }
}
