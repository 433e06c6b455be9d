//! The authoring tool's window (egui): the curator navigates the model with IsoCam in a live
//! render, captures views as nodes, writes titles and texts per language, attaches overlays (PNG,
//! or SVG rendered with resvg) and narration, paints regions of interest, sets dependencies with
//! presets, sets a view's light (the Light tool steers the live view's light as the kiosk's
//! visitors do; "Set light from live view" stores it), sees the graph and the validation
//! problems, previews the walk the engine would take and replays recorded kiosk sessions. Every
//! action goes through [`crate::Project`], so undo, redo and atomic saving cover them; an
//! autosave file guards against crashes.
//!
//! This module holds [`AuthorApp`]'s state and its actions (what a click does, callable from
//! tests by name); `panels` draws the window and calls them; `graph_view` draws the story graph;
//! `opening` is the window while the exhibit opens (its scan imported into the cache first).

pub mod graph_view;
pub mod opening;
mod panels;

use crate::{Project, preview};
use egui::TextureHandle;
use kiosk_core::camera::{Camera, Controller, Intent, SceneRef};
use kiosk_core::camera::{ControllerKind, make_controller, start_camera};
use kiosk_core::graph::Problem;
use kiosk_core::{Cut, CutParams};
use kiosk_render::{Gpu, Renderer};
use rand::SeedableRng;
use std::path::{Path, PathBuf};

/// Size of the live view's render.
pub const LIVE_SIZE: (u32, u32) = (640, 360);
/// Size of a painted ROI mask.
pub const MASK_SIZE: (u32, u32) = (320, 180);
/// Seconds between autosaves of a changed graph.
pub const AUTOSAVE_SECS: f64 = 30.0;

/// What a drag on the live view does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tool {
    /// Moves the camera (IsoCam: drag = hover, wheel = zoom).
    Navigate,
    /// Paints the selected node's region of interest.
    Paint,
    /// Erases it.
    Erase,
    /// Steers the live view's light (a drag sweeps it around the view, as on the kiosk).
    Light,
}

/// How the toolbar tilts a crooked model ([`AuthorApp::tilt`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tilt {
    /// Turns it on the screen, about the view direction.
    Lean,
    /// Tips its top away from the viewer, about the view's horizontal.
    Tip,
}

/// Weight presets of dependencies.
pub const PRESETS: [(&str, f64); 3] = [("Mandatory", 1.0), ("Strong", 0.8), ("Weak", 0.2)];

/// The side panel's editing buffers: what the curator types or chooses before applying it.
#[derive(Clone, Debug, Default)]
pub struct EditBuffers {
    /// Id of the node to add.
    pub new_id: String,
    /// Title being edited.
    pub title: String,
    /// Text being edited.
    pub text: String,
    /// Overlay file to attach (PNG or SVG).
    pub overlay_file: String,
    /// Narration file to attach.
    pub narration_file: String,
    /// Recorded session to replay.
    pub session_file: String,
    /// Predecessor chosen for a new dependency.
    pub dep_from: Option<String>,
    /// Custom weight of a new dependency.
    pub custom_weight: f64,
}

/// The authoring tool's state.
pub struct AuthorApp {
    /// The exhibit being edited.
    pub project: Project,
    gpu: Option<(Gpu, Renderer)>,
    cut: Cut,
    controller: Controller,
    rng: rand_pcg::Pcg64,
    live: Option<TextureHandle>,
    live_dirty: bool,
    /// The live view's light (as the kiosk would show it).
    pub light: kiosk_core::light::Light,
    light_pad: Option<kiosk_core::light::LightPad>,
    /// The selected node's id.
    pub selected: Option<String>,
    /// The language being edited.
    pub lang: String,
    /// What the curator is typing or choosing in the side panel.
    pub edit: EditBuffers,
    /// Current tool.
    pub tool: Tool,
    mask: Option<image::GrayImage>,
    mask_tex: Option<TextureHandle>,
    overlay_preview: Option<(PathBuf, TextureHandle)>,
    /// Messages for the curator (newest last).
    pub log: Vec<String>,
    /// Problems of the last validation.
    pub problems: Vec<Problem>,
    /// Seed of the walk preview.
    pub walk_seed: u64,
    /// The last walk preview.
    pub walk: Vec<String>,
    /// The last session preview.
    pub replayed: Option<preview::SessionPreview>,
    last_autosave: f64,
    narrator: Option<kiosk_content::audio::Narrator>,
    /// What the kiosk's visitors did with this exhibit's views (its statistics file), shown as a
    /// heat colour per view and a few figures for the selected one.
    pub visitor_stats: kiosk_core::stats::ExhibitStats,
}

/// Where autosaves go, beside the graph.
pub fn autosave_path(dir: &Path) -> PathBuf {
    dir.join(".graph.autosave.xml")
}

/// Where the autosave of a session that ended without saving (a crash) is kept when the tool
/// opens, so that this session's autosaves never overwrite it before the curator has chosen.
pub fn recovered_path(dir: &Path) -> PathBuf {
    dir.join(".graph.recovered.xml")
}

impl AuthorApp {
    /// Opens a project; `gpu` renders the live view and thumbnails (none: no picture, still editable).
    pub fn new(project: Project, problems: Vec<Problem>, gpu: Option<(Gpu, Renderer)>) -> Self {
        let store = &project.store;
        let up = project.pose.up;
        let cam = start_camera(store, 0.8, up, project.pose.front);
        let mut cut = Cut::root(store);
        if let Some(v) = cam.view_params(store, LIVE_SIZE) {
            cut.update(store, &v, &CutParams { max_changes: usize::MAX, ..CutParams::default() });
        }
        let diag = f64::from(store.bbox().diagonal());
        let controller = make_controller(
            SceneRef { store, cut: &cut },
            cam,
            ControllerKind::IsoCam,
            0.01 * diag,
            up,
            f64::from(LIVE_SIZE.0) / f64::from(LIVE_SIZE.1.max(1)),
        );
        let lang = project.graph.default_lang.clone();
        let mut log: Vec<String> = problems.iter().map(|p| format!("on open: {p}")).collect();
        if problems.iter().any(|p| p.dropped) {
            log.push(
                "some content could not be read (above): it is kept in graph.xml as it is when you save; \
                 fix it there or remove it"
                    .into(),
            );
        }
        let (autosave, recovered) = (autosave_path(project.dir()), recovered_path(project.dir()));
        if autosave.exists() {
            // Set aside before this session autosaves anything of its own.
            if let Err(e) = std::fs::rename(&autosave, &recovered) {
                log.push(format!("cannot set aside the autosave {}: {e}", autosave.display()));
            }
        }
        if recovered.exists() {
            log.push(
                "an autosave from a session that ended without saving exists: \"Restore autosave\" brings it back"
                    .into(),
            );
        }
        Self {
            project,
            gpu,
            cut,
            controller,
            rng: rand_pcg::Pcg64::seed_from_u64(0),
            live: None,
            live_dirty: true,
            light: kiosk_content::snapshot::start_light(&cam),
            light_pad: None,
            selected: None,
            lang,
            edit: EditBuffers { custom_weight: 0.5, ..EditBuffers::default() },
            tool: Tool::Navigate,
            mask: None,
            mask_tex: None,
            overlay_preview: None,
            log,
            problems,
            walk_seed: 1,
            walk: Vec::new(),
            replayed: None,
            last_autosave: 0.0,
            narrator: None,
            visitor_stats: kiosk_core::stats::ExhibitStats::default(),
        }
    }

    /// The camera of the live view.
    pub fn camera(&self) -> Camera {
        self.controller.camera()
    }

    fn say(&mut self, msg: impl Into<String>) {
        let msg = msg.into();
        tracing::info!("{msg}");
        self.log.push(msg);
        if self.log.len() > 200 {
            self.log.remove(0);
        }
    }

    fn report<T>(&mut self, what: &str, r: anyhow::Result<T>) -> Option<T> {
        match r {
            Ok(v) => Some(v),
            Err(e) => {
                self.say(format!("{what}: {e:#}"));
                None
            }
        }
    }

    /// Selects a node (or none) and loads its texts into the editors.
    pub fn select(&mut self, id: Option<String>) {
        self.selected = id;
        self.mask = None;
        self.mask_tex = None;
        self.overlay_preview = None;
        self.load_texts();
    }

    fn load_texts(&mut self) {
        let g = &self.project.graph;
        let node = self.selected.as_deref().and_then(|id| g.index_of(id)).map(|i| &g.nodes[i]);
        self.edit.title = node.and_then(|n| n.title.0.get(&self.lang).cloned()).unwrap_or_default();
        self.edit.text = node.and_then(|n| n.text.0.get(&self.lang).cloned()).unwrap_or_default();
    }

    /// Turns the model upright: its up direction is saved in `exhibit.toml` and the live view starts
    /// again from the upright framing.
    pub fn set_up(&mut self, up: glam::DVec3) {
        let r = self.project.set_up(up);
        if self.report("model up", r).is_none() {
            return;
        }
        self.restart_live_view();
        self.say(format!("model up: {up}; saved in exhibit.toml"));
    }

    /// Makes the side of the model the live view looks at its front: the kiosk's start view
    /// and gallery card will show it (saved in `exhibit.toml`); the live view starts again from it.
    pub fn set_front_from_view(&mut self) {
        let cam = self.camera();
        let r = self.project.set_front(cam.eye - cam.target);
        if self.report("model front", r).is_none() {
            return;
        }
        self.restart_live_view();
        self.say("the side in view is the model's front; saved in exhibit.toml");
    }

    /// Tilts the model by `degrees` as seen in the live view: `Lean` turns it on the screen
    /// (counter-clockwise for a positive angle), `Tip` tips its top away from the viewer. For a
    /// scan that stands crooked in its file: the pose is saved in `exhibit.toml`, and the live
    /// view turns with the pose about the point it looks at, so the model is seen tilted.
    pub fn tilt(&mut self, how: Tilt, degrees: f64) {
        let cam = self.camera();
        let forward = cam.forward();
        // The pose turned about the view direction toward the view's right (or about the view's
        // right, toward the viewer), and the view with it: the model is seen turned the other way.
        let axis = match how {
            Tilt::Lean => forward,
            Tilt::Tip => forward.cross(cam.up),
        };
        let r = self.project.tilt(axis, degrees.to_radians());
        let Some(turn) = self.report("model tilt", r) else { return };
        let up = self.project.pose.up;
        let eye = cam.target + turn * (cam.eye - cam.target);
        let turned = Camera { eye, up: turn * cam.up, ..cam };
        self.live_view_from(Camera {
            up: kiosk_core::camera::orthonormal_up(turned.forward(), up, turned.up),
            ..turned
        });
        let tilt = up.dot(self.nearest_axis()).clamp(-1.0, 1.0).acos().to_degrees();
        self.say(format!("model tilted: {tilt:.1}° off its axis; saved in exhibit.toml"));
    }

    /// The named axis nearest the model's up.
    fn nearest_axis(&self) -> glam::DVec3 {
        let up = self.project.pose.up;
        crate::UP_AXES.iter().map(|(_, a)| *a).max_by(|a, b| a.dot(up).total_cmp(&b.dot(up))).unwrap_or(up)
    }

    /// The live view from the kiosk's start view of the model as it now stands.
    fn restart_live_view(&mut self) {
        let store = &self.project.store;
        let cam = start_camera(store, 0.8, self.project.pose.up, self.project.pose.front);
        self.live_view_from(cam);
    }

    /// The live view from `cam`, upright on the model's up.
    fn live_view_from(&mut self, cam: Camera) {
        let store = &self.project.store;
        let up = self.project.pose.up;
        self.cut = Cut::root(store);
        if let Some(v) = cam.view_params(store, LIVE_SIZE) {
            self.cut.update(store, &v, &CutParams { max_changes: usize::MAX, ..CutParams::default() });
        }
        self.controller = make_controller(
            SceneRef { store, cut: &self.cut },
            cam,
            ControllerKind::IsoCam,
            0.01 * f64::from(store.bbox().diagonal()),
            up,
            f64::from(LIVE_SIZE.0) / f64::from(LIVE_SIZE.1.max(1)),
        );
        self.live_dirty = true;
    }

    /// Steers the live view's light by a drag of `(dx, dy)` (view widths and heights, y down),
    /// as a kiosk visitor does; the user light then dominates.
    pub fn steer_light(&mut self, dx: f64, dy: f64) {
        let cam = self.camera();
        let pad =
            self.light_pad.get_or_insert_with(|| kiosk_core::light::LightPad::start(&cam, self.light.dir));
        let aspect = f64::from(LIVE_SIZE.0) / f64::from(LIVE_SIZE.1.max(1));
        self.light.dir = pad.drag(&cam, dx, dy, aspect);
        self.light.mix = kiosk_core::light::ACTIVE_MIX;
        self.live_dirty = true;
    }

    /// Stores the live view's light in the selected node's view.
    pub fn set_light_from_live(&mut self) {
        let Some(id) = self.selected.clone() else { return };
        let r = self.project.set_light(&id, Some(self.light.dir));
        if self.report("set light", r).is_some() {
            let d = self.light.dir;
            self.say(format!("light of '{id}': {:.3} {:.3} {:.3}", d.x, d.y, d.z));
        }
    }

    /// Moves the live camera (the IsoCam controller keeps it off the surface).
    pub fn set_camera(&mut self, cam: Camera) {
        let scene = SceneRef { store: &self.project.store, cut: &self.cut };
        self.controller.set_camera(scene, cam);
        self.update_cut();
    }

    /// Applies a navigation intent to the live camera.
    pub fn navigate(&mut self, intent: &Intent) {
        let scene = SceneRef { store: &self.project.store, cut: &self.cut };
        self.controller.apply(scene, intent, &mut self.rng);
        self.update_cut();
    }

    fn update_cut(&mut self) {
        let store = &self.project.store;
        if let Some(v) = self.controller.camera().view_params(store, LIVE_SIZE) {
            self.cut.update(store, &v, &CutParams { max_changes: usize::MAX, ..CutParams::default() });
        }
        self.live_dirty = true;
    }

    /// Captures the live view as a node (with the id typed, or a fresh one) and selects it.
    pub fn capture(&mut self) {
        let id = (!self.edit.new_id.trim().is_empty()).then(|| self.edit.new_id.trim().to_string());
        let cam = self.camera();
        let gpu = self.gpu.as_mut().map(|(g, r)| (&*g, r));
        let r = self.project.capture(cam, id.as_deref(), gpu);
        if let Some(id) = self.report("capture", r) {
            self.say(format!("captured the view as '{id}'"));
            self.edit.new_id.clear();
            self.select(Some(id));
        }
    }

    /// Attaches `self.edit.overlay_file` to the selected node in the current language; an SVG is
    /// rendered at the view's size first.
    pub fn attach_overlay(&mut self) {
        let Some(id) = self.selected.clone() else { return };
        let source = PathBuf::from(self.edit.overlay_file.trim());
        let is_svg = source.extension().is_some_and(|e| e.eq_ignore_ascii_case("svg"));
        let r = if is_svg {
            svg_to_png(&source).and_then(|png| {
                let tmp = tempfile::Builder::new().suffix(".png").tempfile()?;
                png.save(tmp.path())?;
                self.project.attach_overlay(&id, &self.lang, tmp.path())
            })
        } else {
            self.project.attach_overlay(&id, &self.lang, &source)
        };
        if let Some(warning) = self.report("attach overlay", r) {
            self.say(format!("overlay attached to '{id}' ({})", self.lang));
            if let Some(w) = warning {
                self.say(format!("warning: {w}"));
            }
            self.overlay_preview = None;
        }
    }

    /// Copies `self.edit.narration_file` into `audio/` and attaches it in the current language.
    pub fn attach_narration(&mut self) {
        let Some(id) = self.selected.clone() else { return };
        if let Err(e) = kiosk_core::graph::check_id(&self.lang) {
            self.say(format!("error: language {e}"));
            return;
        }
        let source = PathBuf::from(self.edit.narration_file.trim());
        let ext = source.extension().and_then(|e| e.to_str()).unwrap_or("wav").to_ascii_lowercase();
        let rel = format!("audio/{id}-{}.{ext}", self.lang);
        let dest = self.project.dir().join(&rel);
        let r = std::fs::create_dir_all(dest.parent().unwrap_or(Path::new(".")))
            .and_then(|()| std::fs::copy(&source, &dest))
            .map_err(|e| anyhow::anyhow!("cannot copy {}: {e}", source.display()))
            .and_then(|_| self.project.set_narration(&id, &self.lang, &rel));
        if self.report("attach narration", r).is_some() {
            self.say(format!("narration attached to '{id}' ({})", self.lang));
        }
    }

    fn play_narration(&mut self) {
        let Some(i) = self.selected.as_deref().and_then(|id| self.project.graph.index_of(id)) else { return };
        let Some(rel) = self.project.graph.nodes[i].narration.0.get(&self.lang).cloned() else {
            self.say("no narration in this language");
            return;
        };
        let path = self.project.dir().join(rel);
        let narrator = self.narrator.get_or_insert_with(|| kiosk_content::audio::Narrator::new(1.0, false));
        match narrator.play(&path) {
            Ok(()) if narrator.audible() => self.say(format!("playing {}", path.display())),
            Ok(()) => self.say(format!("{} decodes; no audio device, so it is not heard", path.display())),
            Err(e) => self.say(format!("error: {e}")),
        }
    }

    /// Applies the edited title and text.
    pub fn apply_texts(&mut self) {
        let Some(id) = self.selected.clone() else { return };
        let (title, text) = (self.edit.title.clone(), self.edit.text.clone());
        let r = self.project.set_text(&id, &self.lang, &title, &text);
        if self.report("texts", r).is_some() {
            self.say(format!("texts of '{id}' ({}) set", self.lang));
        }
    }

    /// Sets the dependency from `self.edit.dep_from` to the selected node.
    pub fn add_dependency(&mut self, weight: f64) {
        let (Some(from), Some(to)) = (self.edit.dep_from.clone(), self.selected.clone()) else {
            self.say("pick a predecessor first");
            return;
        };
        let r = self.project.set_dependency(&from, &to, weight);
        if self.report("dependency", r).is_some() {
            self.say(format!("{from} -> {to}: {weight}"));
        }
    }

    /// Paints (or erases) a disc of the ROI mask at a point of the view (normalised).
    pub fn brush(&mut self, u: f32, v: f32, radius: f32, on: bool) {
        let mask = self.mask.get_or_insert_with(|| image::GrayImage::new(MASK_SIZE.0, MASK_SIZE.1));
        let (cx, cy) = (u * MASK_SIZE.0 as f32, v * MASK_SIZE.1 as f32);
        let r = radius * MASK_SIZE.1 as f32;
        for y in ((cy - r).floor().max(0.0) as u32)..((cy + r).ceil().min(MASK_SIZE.1 as f32) as u32) {
            for x in ((cx - r).floor().max(0.0) as u32)..((cx + r).ceil().min(MASK_SIZE.0 as f32) as u32) {
                if (x as f32 + 0.5 - cx).hypot(y as f32 + 0.5 - cy) <= r {
                    mask.put_pixel(x, y, image::Luma([if on { 255 } else { 0 }]));
                }
            }
        }
        self.mask_tex = None;
    }

    /// Computes the selected node's ROI from the painted mask.
    pub fn apply_roi(&mut self) {
        let (Some(id), Some(mask)) = (self.selected.clone(), self.mask.clone()) else {
            self.say("paint the region over the node's view first");
            return;
        };
        let r = self.project.paint_roi(&id, &mask);
        if let Some((lo, hi)) = self.report("region of interest", r) {
            self.say(format!("ROI of '{id}': {:.3?} – {:.3?}", lo.to_array(), hi.to_array()));
        }
    }

    /// Saves atomically and removes the autosave.
    pub fn save(&mut self) {
        let r = self.project.save();
        if self.report("save", r).is_some() {
            let _ = std::fs::remove_file(autosave_path(self.project.dir()));
            self.say("saved");
        }
    }

    /// Writes the autosave file (atomically) when the graph changed since the last save.
    pub fn autosave(&mut self) {
        if !self.project.dirty() {
            return;
        }
        let path = autosave_path(self.project.dir());
        let tmp = path.with_extension("saving");
        let r = std::fs::write(&tmp, self.project.to_xml()).and_then(|()| std::fs::rename(&tmp, &path));
        if let Err(e) = r {
            self.say(format!("autosave failed: {e}"));
        }
    }

    /// Loads the autosave of the session that ended without saving as an edit (undoable); the
    /// file is removed once restored (this session's autosaves take over).
    pub fn restore_autosave(&mut self) {
        let path = recovered_path(self.project.dir());
        let r = std::fs::read_to_string(&path)
            .map_err(anyhow::Error::from)
            .and_then(|t| Ok(kiosk_core::graph::InfoGraph::from_xml(&t)?.0))
            .and_then(|g| self.project.replace_graph(g));
        if self.report("restore autosave", r).is_some() {
            let _ = std::fs::remove_file(&path);
            self.say("autosave restored (undo to go back)");
            self.load_texts();
        }
    }

    /// Runs the validation and keeps its problems.
    pub fn validate(&mut self) {
        self.problems = self.project.validate();
        let n = self.problems.len();
        self.say(if n == 0 { "no problems".to_string() } else { format!("{n} problem(s)") });
    }

    /// Simulates a visitor-less walk with the seed.
    pub fn preview_walk(&mut self) {
        self.walk = preview::simulate_walk(
            &self.project.store,
            &self.project.graph,
            self.project.pose,
            self.walk_seed,
            600.0,
        );
        self.say(format!("walk with seed {}: {}", self.walk_seed, self.walk.join(" -> ")));
    }

    /// Replays the session file against the current graph.
    pub fn replay(&mut self) {
        let path = PathBuf::from(self.edit.session_file.trim());
        let r = std::fs::read_to_string(&path)
            .map_err(|e| anyhow::anyhow!("cannot read {}: {e}", path.display()))
            .and_then(|t| Ok(kiosk_core::session::Session::parse(&t)?));
        if let Some(s) = self.report("replay", r) {
            let p = preview::replay_session(&self.project.store, &self.project.graph, self.project.pose, &s);
            self.say(format!("replayed {:.0} s: displayed {}", p.duration, p.displayed.join(", ")));
            self.replayed = Some(p);
        }
    }

    /// Undo (reloads the editors).
    pub fn undo(&mut self) {
        if self.project.undo() {
            self.say("undone");
            self.load_texts();
        }
    }

    /// Redo.
    pub fn redo(&mut self) {
        if self.project.redo() {
            self.say("redone");
            self.load_texts();
        }
    }

    /// Selects a node and moves the live camera to its view.
    pub fn jump_to(&mut self, id: &str) {
        if let Some(i) = self.project.graph.index_of(id) {
            let view = self.project.graph.nodes[i].view;
            self.select(Some(id.to_string()));
            self.set_camera(view);
            self.take_node_light(i);
        }
    }

    /// The live light becomes node `i`'s stored light, if it has one (else it stays).
    fn take_node_light(&mut self, i: usize) {
        if let Some(dir) = self.project.graph.nodes[i].light {
            self.light = kiosk_core::light::Light { dir, mix: kiosk_core::light::ACTIVE_MIX };
            self.live_dirty = true;
        }
    }
}

/// Renders an SVG drawing (curators draw overlays in vector tools) to an RGBA image at the
/// view's size (1280×720), fitted and centred, reading no other file.
pub fn svg_to_png(path: &Path) -> anyhow::Result<image::RgbaImage> {
    kiosk_content::media::read_image(path).map_err(anyhow::Error::msg)
}
