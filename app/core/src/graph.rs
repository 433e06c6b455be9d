//! The information graph (thesis 11.2–11.3.1): annotated views (nodes) and their
//! dependencies (edges), read from and written to XML.
//!
//! Format (version 1), paths relative to the graph file; every text and media element may be
//! given per language (`lang`; without it, the default language):
//! ```xml
//! <infograph version="1" default-lang="en">
//!   <node id="intro" importance="1.0">
//!     <view eye="0 1 3" target="0 1 0" up="0 1 0" fov="0.8" light="-1 0.2 0.3"/>
//!     <title lang="en">The bust</title>
//!     <title lang="it">Il busto</title>
//!     <text lang="en">Demosthenes, Athenian orator…</text>
//!     <overlay lang="en" src="overlays/intro.png"/>
//!     <narration lang="en" src="audio/intro-en.ogg"/>
//!     <thumbnail src="thumbs/intro.png"/>
//!     <roi mask="roi/intro.png" min="-0.2 0.8 -0.1" max="0.2 1.2 0.2"/>
//!   </node>
//!   <edge from="intro" to="beard" weight="1.0"/>
//! </infograph>
//! ```
//! A view's `light` (optional) is the direction toward the user light in model axes, any length
//! (normalised when read; zero or non-finite: ignored with a problem); a go-to to the node turns
//! the light to it ([`crate::light`]).
//!
//! Loading is lenient, as a kiosk must keep showing what is valid: structural problems drop the
//! offending node or edge and are reported with the node's id; only unreadable XML or an unknown
//! version is fatal.

use crate::camera::{Camera, orthonormal_up};
use glam::DVec3;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

/// The graph format version this build reads and writes.
pub const GRAPH_VERSION: u32 = 1;

/// Edge weight of a mandatory dependency.
pub const MANDATORY: f64 = 1.0;

/// Texts or file paths per language.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PerLanguage(pub BTreeMap<String, String>);

impl PerLanguage {
    /// The value in `lang`, else in `default`, else any.
    pub fn get(&self, lang: &str, default: &str) -> Option<&str> {
        self.0
            .get(lang)
            .or_else(|| self.0.get(default))
            .or_else(|| self.0.values().next())
            .map(String::as_str)
    }

    /// Whether no language has a value.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// An annotated view.
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Stable id.
    pub id: String,
    /// The view (model coordinates).
    pub view: Camera,
    /// The view's light: unit direction toward the user light (model axes), if the curator
    /// stored one (`<view … light="x y z"/>`).
    pub light: Option<DVec3>,
    /// Author importance γ ∈ [0, 1].
    pub importance: f64,
    /// Title per language.
    pub title: PerLanguage,
    /// Text per language.
    pub text: PerLanguage,
    /// Overlay image per language (PNG with alpha or SVG; path relative to the graph file).
    pub overlay: PerLanguage,
    /// Narration audio per language.
    pub narration: PerLanguage,
    /// Thumbnail image.
    pub thumbnail: Option<String>,
    /// Region-of-interest mask image (absent: the whole view).
    pub roi_mask: Option<String>,
    /// Bounding box of the model points under the ROI (computed by the authoring tool).
    pub roi_bbox: Option<(DVec3, DVec3)>,
    /// The ROI mask's pixels, downsampled: handed over by whoever loads the graph with its
    /// files (the kiosk and the authoring tool read `roi_mask` when they open the exhibit; the
    /// core opens no file). Not part of the XML; absent (no mask, or an unreadable one): the
    /// ROI is the box alone.
    pub roi_bitmap: Option<RoiMask>,
}

/// A region-of-interest mask as a small bitmap stretched over a node's view (thesis 11.3.1: "a
/// bit-mask denoting the relevant part of the view"). Row 0 is the top of the view.
#[derive(Clone, Debug, PartialEq)]
pub struct RoiMask {
    /// Columns.
    pub w: u32,
    /// Rows.
    pub h: u32,
    /// Width / height of the view the mask is stretched over (the authored view's aspect).
    pub aspect: f64,
    /// One bit per cell, row-major, 64 per word.
    pub bits: Vec<u64>,
}

impl RoiMask {
    /// Longest side of a downsampled mask, in cells.
    pub const MAX_SIDE: u32 = 128;

    /// A mask from `w × h` pixels (row-major, top row first) where `set(x, y)` says whether a
    /// pixel is in the region, downsampled to at most [`Self::MAX_SIDE`] cells a side: a cell
    /// is set when any of its pixels is (thin strokes survive). `None` for an empty image or a
    /// non-finite aspect.
    pub fn from_fn(w: u32, h: u32, aspect: f64, set: impl Fn(u32, u32) -> bool) -> Option<Self> {
        if w == 0 || h == 0 || !(aspect.is_finite() && aspect > 0.0) {
            return None;
        }
        let scale = (f64::from(w.max(h)) / f64::from(Self::MAX_SIDE)).max(1.0);
        let cw = ((f64::from(w) / scale).ceil() as u32).clamp(1, Self::MAX_SIDE);
        let ch = ((f64::from(h) / scale).ceil() as u32).clamp(1, Self::MAX_SIDE);
        let mut mask = Self { w: cw, h: ch, aspect, bits: vec![0; (cw as usize * ch as usize).div_ceil(64)] };
        for y in 0..h {
            let cy = (u64::from(y) * u64::from(ch) / u64::from(h)) as u32;
            for x in 0..w {
                if set(x, y) {
                    let cx = (u64::from(x) * u64::from(cw) / u64::from(w)) as u32;
                    let k = cy as usize * cw as usize + cx as usize;
                    mask.bits[k / 64] |= 1 << (k % 64);
                }
            }
        }
        Some(mask)
    }

    /// Whether cell (x, y) is set (false outside).
    pub fn get(&self, x: u32, y: u32) -> bool {
        if x >= self.w || y >= self.h {
            return false;
        }
        let k = y as usize * self.w as usize + x as usize;
        self.bits.get(k / 64).is_some_and(|b| (b >> (k % 64)) & 1 == 1)
    }

    /// Whether a point at normalised device coordinates (x right, y up, [−1, 1]² on screen) of
    /// the view falls on a set cell.
    #[inline]
    pub fn covers(&self, ndc: glam::DVec2) -> bool {
        if !(ndc.x.abs() <= 1.0 && ndc.y.abs() <= 1.0) {
            return false;
        }
        let x = (((ndc.x + 1.0) * 0.5 * f64::from(self.w)) as u32).min(self.w - 1);
        let y = (((1.0 - ndc.y) * 0.5 * f64::from(self.h)) as u32).min(self.h - 1);
        self.get(x, y)
    }

    /// Number of set cells.
    pub fn count(&self) -> u32 {
        self.bits.iter().map(|b| b.count_ones()).sum()
    }
}

/// A dependency: `from` should be shown before `to`, with weight ω ∈ [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Edge {
    /// Predecessor (node index).
    pub from: usize,
    /// Dependent node (node index).
    pub to: usize,
    /// ω: 1 mandatory, 0.8 strong, 0.2 weak in the paper's dataset.
    pub weight: f64,
}

/// A validated information graph.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InfoGraph {
    /// Language used when a text lacks the visitor's.
    pub default_lang: String,
    /// Nodes.
    pub nodes: Vec<Node>,
    /// Edges.
    pub edges: Vec<Edge>,
}

/// Reads a file named by the graph: `Ok(Some((w, h)))` for an image, `Ok(None)` for another
/// existing file, `Err(reason)` when unusable. Supplied by the shell (the core opens no file).
pub type FileProbe<'a> = dyn Fn(&str) -> Result<Option<(u32, u32)>, String> + 'a;

impl Node {
    /// A node with a view and nothing else: importance 1, no texts, media or region of interest.
    pub fn new(id: impl Into<String>, view: Camera) -> Self {
        Self {
            id: id.into(),
            view,
            light: None,
            importance: 1.0,
            title: PerLanguage::default(),
            text: PerLanguage::default(),
            overlay: PerLanguage::default(),
            narration: PerLanguage::default(),
            thumbnail: None,
            roi_mask: None,
            roi_bbox: None,
            roi_bitmap: None,
        }
    }
}

/// A problem found while loading or validating, naming the node when there is one.
#[derive(Clone, Debug, PartialEq, Eq, Serialize)]
pub struct Problem {
    /// Node id concerned, if any.
    pub node: Option<String>,
    /// What is wrong.
    pub msg: String,
    /// Whether the item was dropped (error) or kept (warning).
    pub dropped: bool,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.node {
            Some(n) => write!(f, "node '{n}': {}", self.msg),
            None => write!(f, "{}", self.msg),
        }
    }
}

/// Why a graph cannot be read at all.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GraphError {
    /// Not well-formed XML or not an `<infograph>`.
    #[error("not a valid information graph: {0}")]
    Xml(String),
    /// Written by another version.
    #[error("information graph version {found}, this build reads version {GRAPH_VERSION}")]
    Version {
        /// Version in the file.
        found: u32,
    },
}

// ---- The XML as written: parse, then validate. ----

#[derive(Debug, Serialize, Deserialize)]
#[serde(rename = "infograph")]
struct RawGraph {
    #[serde(rename = "@version")]
    version: u32,
    #[serde(rename = "@default-lang", default = "default_lang")]
    default_lang: String,
    #[serde(rename = "node", default)]
    nodes: Vec<RawNode>,
    #[serde(rename = "edge", default)]
    edges: Vec<RawEdge>,
}

fn default_lang() -> String {
    "en".into()
}

fn one() -> String {
    "1".into()
}

#[derive(Debug, Serialize, Deserialize)]
struct RawNode {
    #[serde(rename = "@id", default)]
    id: String,
    /// Read as text so that a bad value is that node's problem, not the whole file's.
    #[serde(rename = "@importance", default = "one")]
    importance: String,
    /// Held once; read as a list so that a second is that node's problem, not the whole file's
    /// (as are the thumbnail and the region of interest).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    view: Vec<RawView>,
    #[serde(rename = "title", default, skip_serializing_if = "Vec::is_empty")]
    titles: Vec<RawText>,
    #[serde(rename = "text", default, skip_serializing_if = "Vec::is_empty")]
    texts: Vec<RawText>,
    #[serde(rename = "overlay", default, skip_serializing_if = "Vec::is_empty")]
    overlays: Vec<RawFile>,
    #[serde(rename = "narration", default, skip_serializing_if = "Vec::is_empty")]
    narrations: Vec<RawFile>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    thumbnail: Vec<RawFile>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    roi: Vec<RawRoi>,
}

#[derive(Debug, Serialize, Deserialize)]
struct RawView {
    #[serde(rename = "@eye", default)]
    eye: String,
    #[serde(rename = "@target", default)]
    target: String,
    #[serde(rename = "@up", default)]
    up: String,
    #[serde(rename = "@fov", default)]
    fov: String,
    #[serde(rename = "@light", default, skip_serializing_if = "Option::is_none")]
    light: Option<String>,
}

#[derive(Debug, Serialize, Deserialize)]
struct RawText {
    #[serde(rename = "@lang", default, skip_serializing_if = "Option::is_none")]
    lang: Option<String>,
    #[serde(rename = "$text", default)]
    text: String,
}

#[derive(Debug, Serialize, Deserialize)]
struct RawFile {
    #[serde(rename = "@lang", default, skip_serializing_if = "Option::is_none")]
    lang: Option<String>,
    #[serde(rename = "@src", default)]
    src: String,
}

#[derive(Debug, Serialize, Deserialize)]
struct RawRoi {
    #[serde(rename = "@mask", default, skip_serializing_if = "Option::is_none")]
    mask: Option<String>,
    #[serde(rename = "@min", default, skip_serializing_if = "Option::is_none")]
    min: Option<String>,
    #[serde(rename = "@max", default, skip_serializing_if = "Option::is_none")]
    max: Option<String>,
}

#[derive(Debug, Serialize, Deserialize)]
struct RawEdge {
    #[serde(rename = "@from", default)]
    from: String,
    #[serde(rename = "@to", default)]
    to: String,
    #[serde(rename = "@weight", default)]
    weight: String,
}

/// An element of the format: its name, its attributes and the elements it holds.
type Element = (&'static str, &'static [&'static str], &'static [&'static str]);

/// The format's elements.
const SCHEMA: &[Element] = &[
    ("infograph", &["version", "default-lang"], &["node", "edge"]),
    ("node", &["id", "importance"], &["view", "title", "text", "overlay", "narration", "thumbnail", "roi"]),
    ("view", &["eye", "target", "up", "fov", "light"], &[]),
    ("title", &["lang"], &[]),
    ("text", &["lang"], &[]),
    ("overlay", &["lang", "src"], &[]),
    ("narration", &["lang", "src"], &[]),
    ("thumbnail", &["lang", "src"], &[]),
    ("roi", &["mask", "min", "max"], &[]),
    ("edge", &["from", "to", "weight"], &[]),
];

/// Adds to `problems` every element and attribute that the format does not have, with its line
/// (the reader skips them, so a misspelt `<titel>` or `importence` would be lost without a
/// word); fails with the line where the document is not well-formed XML.
fn check_names(text: &str, problems: &mut Vec<Problem>) -> Result<(), GraphError> {
    use quick_xml::events::Event;
    // The reader skips a byte-order mark without counting it in its positions.
    let body = text.strip_prefix('\u{feff}').unwrap_or(text);
    let line = |at: u64| {
        body.as_bytes()[..(at as usize).min(body.len())].iter().filter(|&&b| b == b'\n').count() + 1
    };
    let list = |names: &[&str]| names.join(", ");
    let mut reader = quick_xml::Reader::from_str(body);
    // The schema entries of the open elements (`None`: an unknown one, whose content is skipped).
    let mut open: Vec<Option<&Element>> = Vec::new();
    let mut node: Option<String> = None;
    loop {
        let at = reader.buffer_position();
        let event = reader
            .read_event()
            .map_err(|e| GraphError::Xml(format!("line {}: {e}", line(reader.error_position()))))?;
        let (e, empty) = match &event {
            Event::Start(e) => (e, false),
            Event::Empty(e) => (e, true),
            Event::End(e) => {
                if e.name().as_ref() == "node" && open.len() == 2 {
                    node = None;
                }
                open.pop();
                continue;
            }
            Event::Eof => return Ok(()),
            // An entity XML does not know (`&eacute;`, from HTML) would fail the whole story
            // later with a place in its text alone: said here with its line.
            Event::GeneralRef(r) => {
                let name = r.xml10_content();
                let known = if r.is_char_ref() {
                    r.resolve_char_ref().is_ok_and(|c| c.is_some())
                } else {
                    quick_xml::escape::resolve_predefined_entity(&name).is_some()
                };
                if !known {
                    return Err(GraphError::Xml(format!(
                        "line {}: &{name}; is not an XML entity (XML has &lt; &gt; &amp; &apos; &quot; and \
                         &#…; numbers): write the character itself, the file is UTF-8",
                        line(at)
                    )));
                }
                continue;
            }
            _ => continue,
        };
        let name = e.name().as_ref().to_string();
        if name == "node" && open.len() == 1 {
            node = attribute(e, "id");
        }
        let mut say = |msg: String| {
            problems.push(Problem {
                node: node.clone(),
                msg: format!("line {}: {msg}", line(at)),
                dropped: false,
            })
        };
        let entry = match open.last() {
            // The root: read as the graph whatever its name.
            None => {
                if name != "infograph" {
                    say(format!("the root element is <{name}>; a story's is <infograph>"));
                }
                Some(&SCHEMA[0])
            }
            Some(None) => None,
            Some(Some((parent, _, children))) => {
                if children.contains(&name.as_str()) {
                    SCHEMA.iter().find(|(n, ..)| *n == name)
                } else if children.is_empty() {
                    say(format!("<{parent}> holds no elements, not <{name}>; ignored"));
                    None
                } else {
                    say(format!(
                        "unknown element <{name}> in <{parent}> (it holds {}); ignored",
                        list(children)
                    ));
                    None
                }
            }
        };
        if let Some((element, attributes, _)) = entry {
            for a in e.attributes().flatten() {
                let key = a.key.as_ref().to_string();
                if !attributes.contains(&key.as_str())
                    && !key.starts_with("xmlns")
                    && !key.starts_with("xml:")
                {
                    say(format!(
                        "unknown attribute {key} on <{element}> (it takes {}); ignored",
                        list(attributes)
                    ));
                }
            }
        }
        if !empty {
            open.push(entry);
        } else if open.len() == 1 {
            node = None;
        }
    }
}

/// The value of an element's attribute, trimmed.
fn attribute(e: &quick_xml::events::BytesStart<'_>, name: &str) -> Option<String> {
    e.attributes()
        .flatten()
        .find(|a| a.key.as_ref() == name)
        .and_then(|a| a.normalized_value(quick_xml::XmlVersion::Implicit1_0).ok())
        .map(|v| v.trim().to_string())
}

fn vec3(s: &str) -> Option<DVec3> {
    let v: Vec<f64> = s.split_whitespace().map(str::parse).collect::<Result<_, _>>().ok()?;
    (v.len() == 3 && v.iter().all(|x| x.is_finite())).then(|| DVec3::new(v[0], v[1], v[2]))
}

fn fmt3(v: DVec3) -> String {
    format!("{} {} {}", v.x, v.y, v.z)
}

/// A language code as the kiosk matches it: trimmed, its language in lower case (`IT` → `it`),
/// a region as written (`de-CH`).
fn lang_code(l: &str) -> String {
    let l = l.trim();
    match l.split_once('-') {
        Some((language, region)) => format!("{}-{region}", language.to_ascii_lowercase()),
        None => l.to_ascii_lowercase(),
    }
}

/// `what`'s items by language (one without a language stands for `default`), the first of each
/// kept, and what to say of them: a code written in capitals or with spaces (`IT`) is read as
/// the kiosk's (`it`), one that is no code at all (`""`, `italiano`) is said (it shows only as a
/// last resort), and a second item for a language is ignored.
fn per_language(
    what: &str,
    items: impl Iterator<Item = (Option<String>, String)>,
    default: &str,
) -> (PerLanguage, Vec<String>) {
    let (mut out, mut said) = (BTreeMap::new(), Vec::new());
    for (l, v) in items {
        let code = match l {
            None => default.to_string(),
            Some(l) => {
                let code = lang_code(&l);
                if code != l {
                    said.push(format!("{what} lang=\"{l}\" read as \"{code}\""));
                }
                code
            }
        };
        let letters =
            code.split('-').all(|part| !part.is_empty() && part.chars().all(|c| c.is_ascii_alphanumeric()));
        if !letters || code.split('-').next().is_none_or(|first| !(2..=3).contains(&first.len())) {
            said.push(format!(
                "{what} lang=\"{code}\" is not a language code (en, it, de-CH, …): shown only in a language \
                 the node has no {what} for"
            ));
        }
        if out.contains_key(&code) {
            said.push(format!(
                "a second {what} for language '{code}' (one without lang stands for '{default}'); ignored"
            ));
            continue;
        }
        out.insert(code, v);
    }
    (PerLanguage(out), said)
}

/// Longest node id, in bytes.
pub const MAX_ID_LEN: usize = 64;
/// Longest media path, in bytes.
pub const MAX_PATH_LEN: usize = 512;
/// Longest title or text, in bytes (a text longer than this is cut, with a warning).
pub const MAX_TEXT_LEN: usize = 64 * 1024;

/// Whether `id` may name a node: 1 to [`MAX_ID_LEN`] ASCII letters, digits, `-`, `_` or `.`, not
/// starting with `.`. Ids name files (`thumbs/ID.png`), so nothing else is allowed.
pub fn check_id(id: &str) -> Result<(), String> {
    if id.is_empty() {
        return Err("an id may not be empty".into());
    }
    if id.len() > MAX_ID_LEN {
        return Err(format!("an id may have at most {MAX_ID_LEN} characters (this one has {})", id.len()));
    }
    if id.starts_with('.') || !id.bytes().all(|b| b.is_ascii_alphanumeric() || b"-_.".contains(&b)) {
        return Err(format!(
            "id {:?} may hold only ASCII letters (a–z, A–Z, no accents), digits, '-', '_' and '.', and \
             may not start with '.'",
            id.chars().take(MAX_ID_LEN).collect::<String>()
        ));
    }
    Ok(())
}

/// Whether `path` may name a media file of an exhibit: relative, with `/` between non-empty
/// names, none of them `.` or `..`, no `\`, `:` or control character, at most
/// [`MAX_PATH_LEN`] bytes. The shell also checks that the file it names, links resolved, lies
/// inside the exhibit and is a regular file.
pub fn check_media_path(path: &str) -> Result<(), String> {
    let shown = || path.chars().take(80).collect::<String>();
    if path.len() > MAX_PATH_LEN {
        return Err(format!("path {:?}… is longer than {MAX_PATH_LEN} bytes", shown()));
    }
    if path.starts_with('/') || path.chars().any(|c| c == '\\' || c == ':' || c.is_control()) {
        return Err(format!("path {:?} must be relative to the exhibit, with '/' between names", shown()));
    }
    if path.split('/').any(|c| c.is_empty() || c == "." || c == "..") {
        return Err(format!("path {:?} may not contain empty, '.' or '..' names", shown()));
    }
    Ok(())
}

fn number(s: &str) -> Option<f64> {
    s.trim().parse::<f64>().ok()
}

impl InfoGraph {
    /// Reads a graph, keeping every valid node and edge; the problems list what was dropped.
    pub fn from_xml(text: &str) -> Result<(Self, Vec<Problem>), GraphError> {
        let mut problems = Vec::new();
        check_names(text, &mut problems)?;
        let raw: RawGraph = quick_xml::de::from_str(text).map_err(|e| GraphError::Xml(e.to_string()))?;
        if raw.version != GRAPH_VERSION {
            return Err(GraphError::Version { found: raw.version });
        }
        let mut bad = |node: Option<&str>, msg: String, dropped: bool| {
            problems.push(Problem { node: node.map(str::to_string), msg, dropped })
        };
        let lang = lang_code(&raw.default_lang);
        let mut nodes: Vec<Node> = Vec::new();
        let mut seen = BTreeSet::new();
        for n in raw.nodes {
            let id = n.id.trim().to_string();
            if id.is_empty() {
                bad(None, "a node has an empty id; dropped".into(), true);
                continue;
            }
            if let Err(e) = check_id(&id) {
                bad(None, format!("a node's {e}; dropped"), true);
                continue;
            }
            if !seen.insert(id.clone()) {
                bad(Some(&id), "duplicate id; the later node is dropped".into(), true);
                continue;
            }
            for (what, count) in
                [("view", n.view.len()), ("thumbnail", n.thumbnail.len()), ("roi", n.roi.len())]
            {
                if count > 1 {
                    bad(
                        Some(&id),
                        format!("{count} <{what}> elements; the first is kept, the others ignored"),
                        false,
                    );
                }
            }
            let Some(v) = n.view.into_iter().next() else {
                bad(Some(&id), "no <view>; dropped".into(), true);
                continue;
            };
            let (Some(eye), Some(target), Some(up)) = (vec3(&v.eye), vec3(&v.target), vec3(&v.up)) else {
                bad(Some(&id), "view eye/target/up must be three finite numbers each; dropped".into(), true);
                continue;
            };
            let Some(fov) = number(&v.fov) else {
                bad(Some(&id), format!("view fov {:?} is not a number; dropped", v.fov), true);
                continue;
            };
            if (target - eye).length() <= 0.0 {
                bad(Some(&id), format!("view has eye = target ({}); dropped", fmt3(eye)), true);
                continue;
            }
            // The range the kiosk's own field of view takes (`fov_deg`): wider, the model is a
            // dot in the middle; narrower, a view nobody could recognise, and neither shows.
            let (lo, hi) = (1f64.to_radians(), 170f64.to_radians());
            if !(lo..=hi).contains(&fov) {
                let degrees = if (1.0..=170.0).contains(&fov) {
                    format!("; {fov} degrees would be {:.3}", fov.to_radians())
                } else {
                    String::new()
                };
                bad(
                    Some(&id),
                    format!("view fov {fov} radians is outside 1°–170° ({lo:.3}–{hi:.3}){degrees}; dropped"),
                    true,
                );
                continue;
            }
            let mut view = Camera { eye, target, up, fov_y: fov };
            // Keep an orthonormal up exactly as written (round trips), repair any other.
            if (up.length() - 1.0).abs() > 1e-9 || up.dot(view.forward()).abs() > 1e-9 {
                view.up = orthonormal_up(view.forward(), up, DVec3::Y);
            }
            // A bad light is the light's problem only: the node keeps its view without one.
            let light = v.light.as_deref().and_then(|l| {
                let d = vec3(l).and_then(crate::light::unit);
                if d.is_none() {
                    bad(
                        Some(&id),
                        format!(
                            "view light {:?} must be three finite numbers, not all zero; ignored",
                            l.chars().take(80).collect::<String>()
                        ),
                        false,
                    );
                }
                d
            });
            let mut importance = number(&n.importance).unwrap_or_else(|| {
                bad(
                    Some(&id),
                    format!("importance {:?} is not a number in [0, 1]; 1 used", n.importance),
                    false,
                );
                1.0
            });
            if !(0.0..=1.0).contains(&importance) {
                bad(Some(&id), format!("importance {importance} outside [0, 1]; clamped"), false);
                importance = if importance.is_nan() { 0.0 } else { importance.clamp(0.0, 1.0) };
            }
            let roi_bbox = match n
                .roi
                .first()
                .map(|r| (r.min.as_deref().map(vec3), r.max.as_deref().map(vec3)))
            {
                Some((Some(Some(a)), Some(Some(b)))) => Some((a.min(b), a.max(b))),
                Some((None, None)) | None => None,
                Some(_) => {
                    bad(Some(&id), "roi min/max must both be three finite numbers; ignored".into(), false);
                    None
                }
            };
            // Media paths must stay inside the exhibit; a bad one is left out (the node stays).
            let mut media = |what: &str, src: String| match check_media_path(&src) {
                Ok(()) => Some(src),
                Err(_) if src.is_empty() => {
                    bad(
                        Some(&id),
                        format!("{what} without a src attribute (the file to show); ignored"),
                        false,
                    );
                    None
                }
                Err(e) => {
                    bad(Some(&id), format!("{what}: {e}; ignored"), false);
                    None
                }
            };
            let files =
                |what: &str, list: Vec<RawFile>, media: &mut dyn FnMut(&str, String) -> Option<String>| {
                    let items: Vec<_> =
                        list.into_iter().filter_map(|f| Some((f.lang, media(what, f.src)?))).collect();
                    per_language(what, items.into_iter(), &lang)
                };
            let (overlay, said_overlays) = files("overlay", n.overlays, &mut media);
            let (narration, said_narrations) = files("narration", n.narrations, &mut media);
            let thumbnail = n.thumbnail.into_iter().next().and_then(|f| media("thumbnail", f.src));
            let roi_mask = n.roi.into_iter().next().and_then(|r| r.mask).and_then(|m| media("roi mask", m));
            for msg in said_overlays.into_iter().chain(said_narrations) {
                bad(Some(&id), msg, false);
            }
            let mut text = |what: &str, list: Vec<RawText>| {
                let items: Vec<_> = list
                    .into_iter()
                    .map(|t| {
                        let mut v = t.text.trim().to_string();
                        if v.len() > MAX_TEXT_LEN {
                            let mut end = MAX_TEXT_LEN;
                            while !v.is_char_boundary(end) {
                                end -= 1;
                            }
                            v.truncate(end);
                            bad(Some(&id), format!("{what} longer than {MAX_TEXT_LEN} bytes; cut"), false);
                        }
                        (t.lang, v)
                    })
                    .collect();
                let (texts, said) = per_language(what, items.into_iter(), &lang);
                for msg in said {
                    bad(Some(&id), msg, false);
                }
                texts
            };
            let title = text("title", n.titles);
            let text = text("text", n.texts);
            nodes.push(Node {
                id,
                view,
                light,
                importance,
                title,
                text,
                overlay,
                narration,
                thumbnail,
                roi_mask,
                roi_bbox,
                roi_bitmap: None,
            });
        }
        let index: BTreeMap<&str, usize> =
            nodes.iter().enumerate().map(|(i, n)| (n.id.as_str(), i)).collect();
        let mut edges = Vec::new();
        let mut pairs = BTreeSet::new();
        for e in raw.edges {
            // Ids are trimmed as the nodes' are.
            let (Some(&from), Some(&to)) = (index.get(e.from.trim()), index.get(e.to.trim())) else {
                let (from, to) = (e.from.trim(), e.to.trim());
                let (unknown, other) = if index.contains_key(from) { (to, from) } else { (from, to) };
                if seen.contains(unknown) {
                    bad(
                        Some(unknown),
                        format!("edge {} → {} names a node dropped above; dropped", e.from, e.to),
                        true,
                    );
                    continue;
                }
                // No node by that name: the problem goes to the node at the edge's other end, if
                // there is one (the authoring tool selects it).
                let at = index.contains_key(other).then_some(other);
                bad(
                    at,
                    format!("edge {} → {} names an unknown node '{unknown}'; dropped", e.from, e.to),
                    true,
                );
                continue;
            };
            let weight = number(&e.weight).unwrap_or(f64::NAN);
            if !(0.0..=1.0).contains(&weight) {
                bad(
                    Some(&e.to),
                    format!(
                        "edge {} → {} has weight {:?}, not a number in [0, 1]; dropped",
                        e.from, e.to, e.weight
                    ),
                    true,
                );
                continue;
            }
            if from == to {
                bad(Some(&e.to), "a node cannot depend on itself; edge dropped".into(), true);
                continue;
            }
            if !pairs.insert((from, to)) {
                bad(Some(&e.to), format!("duplicate edge {} → {}; the later is dropped", e.from, e.to), true);
                continue;
            }
            edges.push(Edge { from, to, weight });
        }
        let graph = Self { default_lang: lang, nodes, edges };
        problems.extend(graph.check_structure());
        Ok((graph, problems))
    }

    /// Structural checks that do not drop anything: nodes that can never be shown because of a
    /// cycle of mandatory dependencies (or a mandatory predecessor in such a cycle).
    pub fn check_structure(&self) -> Vec<Problem> {
        let never = self.never_shown();
        never
            .into_iter()
            .map(|i| Problem {
                node: Some(self.nodes[i].id.clone()),
                msg: "can never be shown: it depends, through mandatory edges, on a cycle of mandatory edges"
                    .into(),
                dropped: false,
            })
            .collect()
    }

    /// Nodes unreachable through mandatory dependencies (Kahn's algorithm on mandatory edges).
    pub fn never_shown(&self) -> Vec<usize> {
        let n = self.nodes.len();
        let mut indeg = vec![0usize; n];
        let mut out: Vec<Vec<usize>> = vec![Vec::new(); n];
        for e in self.edges.iter().filter(|e| e.weight >= MANDATORY) {
            indeg[e.to] += 1;
            out[e.from].push(e.to);
        }
        let mut queue: Vec<usize> = (0..n).filter(|&i| indeg[i] == 0).collect();
        let mut reached = vec![false; n];
        while let Some(i) = queue.pop() {
            reached[i] = true;
            for &j in &out[i] {
                indeg[j] -= 1;
                if indeg[j] == 0 {
                    queue.push(j);
                }
            }
        }
        (0..n).filter(|&i| !reached[i]).collect()
    }

    /// Index of a node by id.
    pub fn index_of(&self, id: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.id == id)
    }

    /// Checks the files a graph names, with `probe(path) → Ok(Some((w, h)))` for an image,
    /// `Ok(None)` for an existing non-image and `Err(reason)` when unusable (the shell reads the
    /// files; the core stays pure). Overlays must have the projection's aspect ratio `aspect`.
    pub fn check_files(&self, aspect: f64, probe: &FileProbe<'_>) -> Vec<Problem> {
        let mut out = Vec::new();
        for n in &self.nodes {
            let mut check = |what: &str, path: &str, is_overlay: bool| match probe(path) {
                Err(e) => out.push(Problem {
                    node: Some(n.id.clone()),
                    msg: format!("{what} {path}: {e}"),
                    dropped: false,
                }),
                Ok(Some((w, h))) if is_overlay && h > 0 => {
                    let a = f64::from(w) / f64::from(h);
                    if (a - aspect).abs() > 0.01 * aspect {
                        out.push(Problem {
                            node: Some(n.id.clone()),
                            msg: format!(
                                "{what} {path} is {w}×{h} (aspect {a:.3}), the view's aspect is {aspect:.3}"
                            ),
                            dropped: false,
                        });
                    }
                }
                Ok(_) => {}
            };
            for p in n.overlay.0.values() {
                check("overlay", p, true);
            }
            for p in n.narration.0.values() {
                check("narration", p, false);
            }
            for p in n.thumbnail.iter().chain(&n.roi_mask) {
                check("image", p, false);
            }
        }
        out
    }

    fn raw_node(&self, n: &Node) -> RawNode {
        let texts = |p: &PerLanguage| {
            p.0.iter().map(|(l, t)| RawText { lang: Some(l.clone()), text: t.clone() }).collect()
        };
        let files = |p: &PerLanguage| {
            p.0.iter().map(|(l, s)| RawFile { lang: Some(l.clone()), src: s.clone() }).collect()
        };
        RawNode {
            id: n.id.clone(),
            importance: n.importance.to_string(),
            view: vec![RawView {
                eye: fmt3(n.view.eye),
                target: fmt3(n.view.target),
                up: fmt3(n.view.up),
                fov: n.view.fov_y.to_string(),
                light: n.light.map(fmt3),
            }],
            titles: texts(&n.title),
            texts: texts(&n.text),
            overlays: files(&n.overlay),
            narrations: files(&n.narration),
            thumbnail: n.thumbnail.clone().map(|src| RawFile { lang: None, src }).into_iter().collect(),
            roi: (n.roi_mask.is_some() || n.roi_bbox.is_some())
                .then(|| RawRoi {
                    mask: n.roi_mask.clone(),
                    min: n.roi_bbox.map(|b| fmt3(b.0)),
                    max: n.roi_bbox.map(|b| fmt3(b.1)),
                })
                .into_iter()
                .collect(),
        }
    }

    fn raw_edge(&self, e: &Edge) -> RawEdge {
        RawEdge {
            from: self.nodes[e.from].id.clone(),
            to: self.nodes[e.to].id.clone(),
            weight: e.weight.to_string(),
        }
    }

    /// One node or edge as XML, indented for its place under `<infograph>`.
    fn element_xml<T: Serialize>(root: &str, raw: &T) -> String {
        let mut out = String::new();
        let written = quick_xml::se::Serializer::with_root(&mut out, Some(root)).and_then(|mut ser| {
            ser.indent(' ', 2);
            raw.serialize(ser)
        });
        if let Err(e) = written {
            // Serialising our own structs cannot fail short of a bug; say so in the output.
            return format!("<!-- serialisation failed: {e} -->");
        }
        out.replace('\n', "\n  ")
    }

    /// Writes the graph over `original`, the file it was read from, changing only what was
    /// edited: comments, unknown elements and attributes, and every node or edge the loader
    /// could not read (dropped with a problem) are kept as they were; a node or edge that is
    /// unchanged is copied byte for byte; an edited one is written anew (its unknown attributes
    /// are not kept); a deleted one is removed; new ones are added at the end.
    pub fn to_xml_over(&self, original: &str) -> Result<String, GraphError> {
        use quick_xml::events::Event;
        let (loaded, _) = Self::from_xml(original)?;
        // The reader skips a byte-order mark without counting it in its positions: set it aside.
        let bom = if original.starts_with('\u{feff}') { "\u{feff}" } else { "" };
        let original = &original[bom.len()..];
        let xml_err = |e: &dyn std::fmt::Display| GraphError::Xml(e.to_string());
        let loaded_edge = |from: &str, to: &str| -> Option<&Edge> {
            let (f, t) = (loaded.index_of(from)?, loaded.index_of(to)?);
            loaded.edges.iter().find(|e| e.from == f && e.to == t)
        };
        let mut written_nodes = vec![false; self.nodes.len()];
        let mut written_edges = vec![false; self.edges.len()];
        let mut claimed_nodes = BTreeSet::new();
        let mut claimed_edges = BTreeSet::new();
        let mut out = String::from(bom);
        let mut reader = quick_xml::Reader::from_str(original);
        let mut depth = 0usize;
        let mut item_start = 0usize;
        // Whitespace before an item, held until we know whether the item is kept.
        let mut pending_space = String::new();
        let mut tail_start = None;
        loop {
            let before = reader.buffer_position() as usize;
            let event = reader.read_event().map_err(|e| xml_err(&e))?;
            let after = reader.buffer_position() as usize;
            let raw = &original[before..after];
            match &event {
                Event::Eof => break,
                Event::Start(_) | Event::Empty(_) if depth == 0 => {
                    // Everything up to and including the root's start tag, as it was.
                    out.push_str(&original[..after]);
                    if matches!(event, Event::Start(_)) {
                        depth = 1;
                    } else {
                        tail_start = Some(after);
                        break;
                    }
                    continue;
                }
                _ if depth == 0 => continue,
                Event::End(_) if depth == 1 => {
                    // New nodes and edges go before the root's end tag.
                    for (n, _) in self.nodes.iter().zip(&written_nodes).filter(|(_, w)| !**w) {
                        out.push_str("\n  ");
                        out.push_str(&Self::element_xml("node", &self.raw_node(n)));
                    }
                    for (e, _) in self.edges.iter().zip(&written_edges).filter(|(_, w)| !**w) {
                        out.push_str("\n  ");
                        out.push_str(&Self::element_xml("edge", &self.raw_edge(e)));
                    }
                    out.push_str(&pending_space);
                    tail_start = Some(before);
                    break;
                }
                Event::Text(t) if depth == 1 && t.trim().is_empty() => {
                    pending_space.push_str(raw);
                    continue;
                }
                _ => {}
            }
            // A child of the root (or part of one): find its whole span.
            if depth == 1 {
                item_start = before;
            }
            match &event {
                Event::Start(_) => depth += 1,
                Event::End(_) => depth -= 1,
                _ => {}
            }
            if depth != 1 {
                continue;
            }
            let item = &original[item_start..after];
            let start_tag = match &event {
                Event::Empty(e) => Some(e.clone().into_owned()),
                Event::End(_) => {
                    let mut r = quick_xml::Reader::from_str(item);
                    match r.read_event() {
                        Ok(Event::Start(e)) => Some(e.into_owned()),
                        _ => None,
                    }
                }
                _ => None,
            };
            let replacement: Option<Option<String>> = match &start_tag {
                Some(e) if e.name().as_ref() == "node" => attribute(e, "id").and_then(|id| {
                    let old = loaded.index_of(&id).filter(|_| claimed_nodes.insert(id.clone()))?;
                    Some(self.index_of(&id).map(|i| {
                        written_nodes[i] = true;
                        if self.nodes[i] == loaded.nodes[old] {
                            item.to_string()
                        } else {
                            Self::element_xml("node", &self.raw_node(&self.nodes[i]))
                        }
                    }))
                }),
                Some(e) if e.name().as_ref() == "edge" => match (attribute(e, "from"), attribute(e, "to")) {
                    (Some(from), Some(to)) => loaded_edge(&from, &to)
                        .filter(|_| claimed_edges.insert((from.clone(), to.clone())))
                        .map(|old| {
                            let now = self
                                .edges
                                .iter()
                                .position(|x| self.nodes[x.from].id == from && self.nodes[x.to].id == to);
                            now.map(|i| {
                                written_edges[i] = true;
                                if self.edges[i].weight == old.weight {
                                    item.to_string()
                                } else {
                                    Self::element_xml("edge", &self.raw_edge(&self.edges[i]))
                                }
                            })
                        }),
                    _ => None,
                },
                _ => None,
            };
            match replacement {
                // Not something the loader read (a comment, an unknown element, a node or edge
                // it dropped): kept as it was.
                None => {
                    out.push_str(&pending_space);
                    out.push_str(item);
                }
                Some(Some(text)) => {
                    out.push_str(&pending_space);
                    out.push_str(&text);
                }
                // Deleted by the curator, with the whitespace before it.
                Some(None) => {}
            }
            pending_space.clear();
        }
        if let Some(t) = tail_start {
            out.push_str(&original[t..]);
        }
        Ok(out)
    }

    /// Writes the graph as XML (version 1).
    pub fn to_xml(&self) -> String {
        let raw = RawGraph {
            version: GRAPH_VERSION,
            default_lang: self.default_lang.clone(),
            nodes: self.nodes.iter().map(|n| self.raw_node(n)).collect(),
            edges: self.edges.iter().map(|e| self.raw_edge(e)).collect(),
        };
        let mut out = String::from("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
        let mut ser = quick_xml::se::Serializer::new(&mut out);
        ser.indent(' ', 2);
        if let Err(e) = raw.serialize(ser) {
            // Serialising our own structs cannot fail short of a bug; say so in the output.
            return format!("<!-- serialisation failed: {e} -->");
        }
        out.push('\n');
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXAMPLE: &str = r#"<?xml version="1.0"?>
<infograph version="1" default-lang="en">
  <node id="intro" importance="1.0">
    <view eye="0 1 3" target="0 1 0" up="0 1 0" fov="0.8"/>
    <title lang="en">The bust</title>
    <title lang="it">Il busto</title>
    <text>Demosthenes, Athenian orator &amp; statesman.</text>
    <overlay lang="en" src="overlays/intro.png"/>
    <narration lang="en" src="audio/intro-en.ogg"/>
    <thumbnail src="thumbs/intro.png"/>
    <roi mask="roi/intro.png" min="-0.2 0.8 -0.1" max="0.2 1.2 0.2"/>
  </node>
  <node id="beard" importance="0.6">
    <view eye="0.5 1 2" target="0 1 0" up="0 1 0" fov="0.6"/>
    <title>The beard</title>
  </node>
  <edge from="intro" to="beard" weight="1"/>
</infograph>"#;

    #[test]
    fn example_loads_and_round_trips() {
        let (g, problems) = InfoGraph::from_xml(EXAMPLE).expect("valid");
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(g.nodes.len(), 2);
        assert_eq!(g.nodes[0].title.get("it", "en"), Some("Il busto"));
        assert_eq!(g.nodes[0].title.get("fr", "en"), Some("The bust"));
        assert_eq!(g.nodes[0].text.get("en", "en"), Some("Demosthenes, Athenian orator & statesman."));
        assert_eq!(g.edges, vec![Edge { from: 0, to: 1, weight: 1.0 }]);
        let xml = g.to_xml();
        let (again, p2) = InfoGraph::from_xml(&xml).expect("own output");
        assert!(p2.is_empty());
        assert_eq!(again, g);
    }

    #[test]
    fn a_value_that_is_not_a_number_is_that_nodes_problem() {
        let xml = r#"<infograph version="1">
  <node id="a" importance="high"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="b"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="wide"/></node>
  <node id="c"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <edge from="a" to="c" weight="strong"/>
</infograph>"#;
        let (g, problems) = InfoGraph::from_xml(xml).expect("one bad value does not drop the story");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        let has = |s: &str| text.iter().any(|t| t.contains(s));
        assert_eq!(g.nodes.iter().map(|n| n.id.as_str()).collect::<Vec<_>>(), ["a", "c"], "{text:?}");
        assert!(has("node 'a': importance \"high\" is not a number"), "{text:?}");
        assert_eq!(g.nodes[0].importance, 1.0);
        assert!(has("node 'b': view fov \"wide\" is not a number; dropped"), "{text:?}");
        assert!(has("edge a → c has weight \"strong\""), "{text:?}");
        assert!(g.edges.is_empty());
    }

    #[test]
    fn misspelt_elements_and_attributes_are_named_with_their_line() {
        let xml = r#"<infograf version="1">
  <node id="a" importence="0.6">
    <view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/>
    <titel lang="en">Lost</titel>
    <title lang="en">Kept</title>
    <overlay lang="en" scr="overlays/a.png"/>
  </node>
  <nde id="b"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></nde>
  <node id="c"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"><title>in a view</title></view></node>
  <egde from="a" to="c" weight="1"/>
</infograf>"#;
        let (g, problems) = InfoGraph::from_xml(xml).expect("typos do not drop the story");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        for expect in [
            "line 1: the root element is <infograf>; a story's is <infograph>",
            "node 'a': line 2: unknown attribute importence on <node> (it takes id, importance); ignored",
            "node 'a': line 4: unknown element <titel> in <node> (it holds view, title, text, overlay, \
             narration, thumbnail, roi); ignored",
            "node 'a': line 6: unknown attribute scr on <overlay> (it takes lang, src); ignored",
            "node 'a': overlay without a src attribute (the file to show); ignored",
            "line 8: unknown element <nde> in <infograph> (it holds node, edge); ignored",
            "node 'c': line 9: <view> holds no elements, not <title>; ignored",
            "line 10: unknown element <egde> in <infograph> (it holds node, edge); ignored",
        ] {
            assert!(text.iter().any(|t| t == expect), "missing {expect:?} in {text:#?}");
        }
        assert_eq!(text.len(), 8, "{text:#?}");
        // The rest is read as written.
        assert_eq!(g.nodes.iter().map(|n| n.id.as_str()).collect::<Vec<_>>(), ["a", "c"]);
        assert_eq!(g.nodes[0].title.get("en", "en"), Some("Kept"));
        assert!(g.nodes[0].overlay.get("en", "en").is_none());
        // A document that is not well-formed names the line.
        let e = InfoGraph::from_xml("<infograph version=\"1\">\n  <node id=\"a\">\n  </nod>\n</infograph>")
            .expect_err("mismatched tag");
        assert!(e.to_string().contains("line 3: "), "{e}");
    }

    #[test]
    fn ids_and_media_paths_stay_inside_the_exhibit() {
        let long = "x".repeat(1 << 20);
        let xml = format!(
            r#"<infograph version="1">
  <node id="../../escaped"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="{long}"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="ok">
    <view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/>
    <overlay lang="en" src="/tmp/x.png"/>
    <overlay lang="it" src="overlays/ok it.png"/>
    <narration src="../../../etc/shadow"/>
    <thumbnail src="thumbs/./ok.png"/>
    <roi mask="C:\\roi.png"/>
  </node>
</infograph>"#
        );
        let (g, problems) = InfoGraph::from_xml(&xml).expect("readable");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        assert_eq!(g.nodes.len(), 1, "{text:?}");
        let n = &g.nodes[0];
        assert_eq!(n.id, "ok");
        assert_eq!(n.overlay.0.len(), 1, "only the relative overlay is kept");
        assert_eq!(n.overlay.0["it"], "overlays/ok it.png");
        assert!(n.narration.is_empty() && n.thumbnail.is_none() && n.roi_mask.is_none(), "{n:?}");
        assert_eq!(problems.iter().filter(|p| p.dropped).count(), 2, "{text:?}");
        assert!(text.iter().all(|t| t.len() < 400), "problems stay short: {text:?}");
        assert!(check_id("view-1.b_2").is_ok());
        for bad in ["", ".hidden", "a/b", "a b", "é"] {
            assert!(check_id(bad).is_err(), "{bad:?}");
        }
        for bad in ["/abs", "a//b", "a/../b", "..", "a\\b", "c:x", "a\nb", "a/"] {
            assert!(check_media_path(bad).is_err(), "{bad:?}");
        }
    }

    /// A curator's file: comments, an unknown attribute and element, a node and an edge the
    /// loader cannot read.
    const CURATED: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<!-- Exhibit of the Louvre bust; ask Anna before changing the intro. -->
<infograph version="1" default-lang="en" curator="anna">
  <!-- the first view -->
  <node id="intro" importance="1" colour="gold">
    <view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8"/>
    <title lang="en">The bust</title>
  </node>
  <node id="wide" importance="0.5">
    <view eye="0 0 3" target="0 0 0" up="0 1 0" fov="32"/>
    <title lang="en">Too wide</title>
    <text lang="en">Written by hand; the fov is in degrees by mistake.</text>
  </node>
  <node id="beard">
    <view eye="1 0 3" target="0 0 0" up="0 1 0" fov="0.6"/>
    <title lang="en">The beard</title>
  </node>
  <draft note="ideas for later"/>
  <edge from="intro" to="beard" weight="1"/>
  <edge from="intro" to="wide" weight="0.5"/>
</infograph>
"#;

    #[test]
    fn saving_over_the_original_keeps_what_the_loader_could_not_read() {
        let (g, problems) = InfoGraph::from_xml(CURATED).expect("readable");
        assert_eq!(g.nodes.len(), 2, "{problems:?}");
        assert!(problems.iter().any(|p| p.node.as_deref() == Some("wide") && p.dropped));
        // No edit: the file is written back byte for byte.
        assert_eq!(g.to_xml_over(CURATED).expect("save"), CURATED);
        // One edit: only that node changes; the rest, comments and all, stays.
        let mut edited = g.clone();
        edited.nodes[1].title.0.insert("en".into(), "The curly beard".into());
        let xml = edited.to_xml_over(CURATED).expect("save");
        assert!(xml.contains("The curly beard"), "{xml}");
        for kept in [
            "<!-- Exhibit of the Louvre bust; ask Anna before changing the intro. -->",
            r#"curator="anna""#,
            "<!-- the first view -->",
            r#"<node id="intro" importance="1" colour="gold">"#,
            r#"fov="32""#,
            "the fov is in degrees by mistake",
            r#"<draft note="ideas for later"/>"#,
            r#"<edge from="intro" to="wide" weight="0.5"/>"#,
            r#"<edge from="intro" to="beard" weight="1"/>"#,
        ] {
            assert!(xml.contains(kept), "lost {kept}:\n{xml}");
        }
        let (again, p2) = InfoGraph::from_xml(&xml).expect("own output");
        assert_eq!(again, edited);
        assert_eq!(p2, problems, "the same problems, nothing new and nothing lost");
        // A node deleted and one added, an edge added: the unreadable node stays.
        let mut edited = g.clone();
        edited.edges.clear();
        edited.nodes.remove(1);
        let mut added = edited.nodes[0].clone();
        added.id = "hair".into();
        edited.nodes.push(added);
        edited.edges.push(Edge { from: 0, to: 1, weight: 0.2 });
        let xml = edited.to_xml_over(CURATED).expect("save");
        assert!(!xml.contains("The beard") && !xml.contains(r#"to="beard""#), "{xml}");
        assert!(
            xml.contains(r#"fov="32""#) && xml.contains(r#"<edge from="intro" to="wide" weight="0.5"/>"#)
        );
        let (again, _) = InfoGraph::from_xml(&xml).expect("own output");
        assert_eq!(again, edited, "{xml}");
    }

    #[test]
    fn a_views_light_is_read_normalised_checked_and_saved() {
        let xml = r#"<infograph version="1">
  <!-- lights -->
  <node id="raking"><view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8" light="-2 0 0.5"/></node>
  <node id="unit"><view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8" light="0.6 0.8 0"/></node>
  <node id="zero"><view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8" light="0 0 0"/></node>
  <node id="nan"><view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8" light="NaN 1 0"/></node>
  <node id="short"><view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8" light="1 2"/></node>
  <node id="none"><view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8"/></node>
</infograph>
"#;
        let (g, problems) = InfoGraph::from_xml(xml).expect("readable");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        // A bad light is that node's problem: the node stays, without a light.
        assert_eq!(g.nodes.len(), 6, "{text:?}");
        for id in ["zero", "nan", "short"] {
            assert!(
                text.iter()
                    .any(|t| t.starts_with(&format!("node '{id}': view light")) && t.contains("ignored")),
                "{id}: {text:?}"
            );
            assert_eq!(g.nodes[g.index_of(id).expect("kept")].light, None, "{id}");
        }
        assert!(problems.iter().all(|p| !p.dropped), "{text:?}");
        assert_eq!(problems.len(), 3, "{text:?}");
        let raking = g.nodes[0].light.expect("light");
        assert!((raking - DVec3::new(-2.0, 0.0, 0.5).normalize_or_zero()).length() < 1e-15, "{raking}");
        assert!((raking.length() - 1.0).abs() < 1e-12);
        assert_eq!(g.nodes[1].light, Some(DVec3::new(0.6, 0.8, 0.0)), "a unit light is kept as written");
        assert_eq!(g.nodes[5].light, None);
        // Written and read back: the same lights, exactly.
        let (again, _) = InfoGraph::from_xml(&g.to_xml()).expect("own output");
        assert_eq!(again, g);
        // Saved over the file: untouched nodes stay byte for byte (the bad lights too); a node
        // given a light gets the attribute, one whose light is removed loses it.
        assert_eq!(g.to_xml_over(xml).expect("save"), xml);
        let mut edited = g.clone();
        edited.nodes[5].light = Some(DVec3::new(0.0, 0.0, -1.0));
        edited.nodes[1].light = None;
        let over = edited.to_xml_over(xml).expect("save");
        for kept in ["<!-- lights -->", r#"light="-2 0 0.5""#, r#"light="0 0 0""#, r#"light="NaN 1 0""#] {
            assert!(over.contains(kept), "lost {kept}:\n{over}");
        }
        assert!(over.contains(r#"light="0 0 -1""#) && !over.contains(r#"light="0.6 0.8 0""#), "{over}");
        let (back, _) = InfoGraph::from_xml(&over).expect("own output");
        assert_eq!(back, edited);
    }

    #[test]
    fn the_readmes_example_graph_loads_with_its_light() {
        let readme = include_str!("../../../README.md");
        let start = readme.find("```xml\n").expect("an XML example in the README") + 7;
        let end = start + readme[start..].find("```").expect("its end");
        let (g, problems) = InfoGraph::from_xml(&readme[start..end]).expect("README's graph.xml");
        assert!(problems.is_empty(), "{problems:?}");
        let beard = &g.nodes[g.index_of("beard").expect("beard")];
        let light = beard.light.expect("the example's light");
        assert!((light.length() - 1.0).abs() < 1e-12 && light.x < 0.0, "{light}");
    }

    /// Inputs the fuzzer found (fuzz/run graph_xml): a file that loads can be saved over.
    #[test]
    fn fuzzed_files_that_load_can_be_saved_over() {
        const FUZZED: &[&str] = &[include_str!("../../../tests/data/fuzz/graph-save-over-1.xml")];
        for text in FUZZED {
            let (g, _) = InfoGraph::from_xml(text).expect("loads");
            let over = g.to_xml_over(text).unwrap_or_else(|e| panic!("{e}"));
            let (again, _) = InfoGraph::from_xml(&over).expect("reads back");
            assert_eq!(again, g);
        }
    }

    #[test]
    fn problems_name_the_node_and_keep_the_rest() {
        let xml = r#"<infograph version="1">
  <node id="a"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="a"><view eye="0 0 2" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="b" importance="3"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="c"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="d"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="e"><view eye="x" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <edge from="a" to="zzz" weight="1"/>
  <edge from="a" to="b" weight="1.5"/>
  <edge from="c" to="d" weight="1"/>
  <edge from="d" to="c" weight="1"/>
</infograph>"#;
        let (g, problems) = InfoGraph::from_xml(xml).expect("readable");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        assert_eq!(g.nodes.len(), 4, "{text:?}");
        let has = |s: &str| text.iter().any(|t| t.contains(s));
        assert!(has("node 'a': duplicate id"));
        assert!(has("node 'b': importance 3 outside [0, 1]"));
        assert!(has("node 'e': view eye/target/up"));
        assert!(has("node 'a': edge a → zzz names an unknown node 'zzz'"));
        assert!(!has("names a node dropped above"), "{text:?}");
        // An edge to a node that was dropped says so, rather than calling it unknown.
        let xml =
            xml.replace(r#"<edge from="c" to="d" weight="1"/>"#, r#"<edge from="c" to="e" weight="1"/>"#);
        let (_, problems) = InfoGraph::from_xml(&xml).expect("readable");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        assert!(
            text.iter().any(|t| t == "node 'e': edge c → e names a node dropped above; dropped"),
            "{text:?}"
        );
        assert!(has("node 'b': edge a → b has weight \"1.5\", not a number in [0, 1]"), "{text:?}");
        assert!(has("node 'c': can never be shown"));
        assert!(has("node 'd': can never be shown"));
        let err = InfoGraph::from_xml("<nope/>").map(|_| ()).expect_err("not a graph");
        assert!(err.to_string().starts_with("not a valid"), "{err}");
        assert_eq!(
            InfoGraph::from_xml(r#"<infograph version="7"/>"#).map(|_| ()),
            Err(GraphError::Version { found: 7 })
        );
    }

    #[test]
    fn files_are_checked_through_the_probe() {
        let (g, _) = InfoGraph::from_xml(EXAMPLE).expect("valid");
        let probe = |p: &str| match p {
            "overlays/intro.png" => Ok(Some((1000, 1000))),
            "audio/intro-en.ogg" => Err("missing".to_string()),
            _ => Ok(None),
        };
        let problems: Vec<String> =
            g.check_files(16.0 / 9.0, &probe).iter().map(ToString::to_string).collect();
        assert!(problems.iter().any(|p| p.contains("node 'intro': overlay overlays/intro.png is 1000×1000")));
        assert!(problems.iter().any(|p| p.contains("node 'intro': narration audio/intro-en.ogg: missing")));
    }
    #[test]
    fn an_html_entity_and_a_field_of_view_in_degrees_are_named_with_their_place() {
        let xml = "<infograph version=\"1\" default-lang=\"en\">\n<node id=\"a\">\
                   <view eye=\"0 0 1\" target=\"0 0 0\" up=\"0 1 0\" fov=\"70\"/>\n\
                   <title>Caf&eacute;</title></node>\n</infograph>";
        let e = InfoGraph::from_xml(xml).expect_err("an entity XML does not know");
        assert!(e.to_string().contains("line 3: &eacute; is not an XML entity"), "{e}");
        let (_, problems) = InfoGraph::from_xml(&xml.replace("&eacute;", "&#233;&amp;")).expect("readable");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        let fov = "node 'a': view fov 70 radians is outside 1°–170° (0.017–2.967); 70 degrees would be 1.222; dropped";
        assert!(text.iter().any(|t| t == fov), "{text:?}");
    }

    #[test]
    fn language_codes_written_otherwise_are_read_or_said_and_a_second_text_is_said() {
        let xml = r#"<infograph version="1" default-lang="en">
  <node id="a"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/>
    <title lang="en">Bust</title><title>Bust (default)</title><title lang="IT">Busto</title>
    <text lang="italiano">Un busto</text><text lang="de-CH">Eine Büste</text></node>
</infograph>"#;
        let (g, problems) = InfoGraph::from_xml(xml).expect("readable");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        assert_eq!(g.nodes[0].title.get("en", "en"), Some("Bust"), "the first is kept");
        assert_eq!(g.nodes[0].title.get("it", "en"), Some("Busto"), "IT read as it");
        assert_eq!(g.nodes[0].text.get("de-CH", "en"), Some("Eine Büste"), "a region as written");
        assert!(!text.iter().any(|t| t.contains("lang=\"de-CH\"")), "{text:?}");
        for said in [
            "node 'a': title lang=\"IT\" read as \"it\"",
            "node 'a': a second title for language 'en' (one without lang stands for 'en'); ignored",
            "node 'a': text lang=\"italiano\" is not a language code (en, it, de-CH, …): shown only in a language \
             the node has no text for",
        ] {
            assert!(text.iter().any(|t| t == said), "{said}: {text:?}");
        }
    }

    #[test]
    fn an_element_a_node_holds_once_given_twice_keeps_the_first_and_the_story() {
        let xml = r#"<infograph version="1" default-lang="en">
  <node id="a"><view eye="0 0 1" target="0 0 0" up="0 1 0" fov="0.8"/>
    <thumbnail lang="en" src="thumbs/a-en.png"/><thumbnail lang="it" src="thumbs/a-it.png"/>
    <view eye="0 0 2" target="0 0 0" up="0 1 0" fov="0.8"/></node>
  <node id="b"><view eye="0 0 3" target="0 0 0" up="0 1 0" fov="0.8"/></node>
</infograph>"#;
        let (g, problems) = InfoGraph::from_xml(xml).expect("the story stays");
        let text: Vec<String> = problems.iter().map(ToString::to_string).collect();
        assert_eq!(g.nodes.len(), 2, "{text:?}");
        assert_eq!(g.nodes[0].view.eye, DVec3::new(0.0, 0.0, 1.0));
        assert_eq!(g.nodes[0].thumbnail.as_deref(), Some("thumbs/a-en.png"));
        for what in ["view", "thumbnail"] {
            let said = format!("node 'a': 2 <{what}> elements; the first is kept, the others ignored");
            assert!(text.contains(&said), "{said}: {text:?}");
        }
    }
}
