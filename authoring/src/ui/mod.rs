//! The authoring tool's window (egui): the curator navigates the model with IsoCam in a live
//! render, captures views as nodes, writes titles and texts per language, attaches overlays (PNG,
//! or SVG rendered with resvg) and narration, paints regions of interest, sets dependencies with
//! presets, sets a view's light (the Light tool steers the live view's light as the kiosk's
//! visitors do; "Set light from live view" stores it), sees the graph and the validation problems, previews the walk the engine would take
//! and replays recorded kiosk sessions. Every action goes through [`crate::Project`], so undo,
//! redo and atomic saving cover them; an autosave file guards against crashes.

pub mod graph_view;

use crate::{Project, VIEW_ASPECT, preview};
use egui::{Color32, ColorImage, Pos2, Rect, Sense, TextureHandle, TextureOptions, vec2};
use kiosk_core::camera::{Camera, Controller, Intent, SceneRef};
use kiosk_core::camera::{ControllerKind, make_controller, start_camera};
use kiosk_core::graph::Problem;
use kiosk_core::{Cut, CutParams};
use kiosk_render::{Gpu, RenderSettings, Renderer};
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

    fn refresh_live(&mut self, ctx: &egui::Context) {
        if !self.live_dirty && self.live.is_some() {
            return;
        }
        self.live_dirty = false;
        let Some((gpu, renderer)) = self.gpu.as_mut() else { return };
        let store = &self.project.store;
        let cam = self.controller.camera();
        let Some(v) = cam.view_params(store, LIVE_SIZE) else { return };
        let nodes = self.cut.visible_nodes(store, &v);
        let settings = kiosk_content::snapshot::lit(RenderSettings::default(), self.light);
        match renderer.render_image(gpu, store, &nodes, &cam, LIVE_SIZE, &settings) {
            Ok((img, _)) => {
                let color = ColorImage::from_rgba_unmultiplied(
                    [img.width() as usize, img.height() as usize],
                    img.as_raw(),
                );
                match &mut self.live {
                    Some(t) => t.set(color, TextureOptions::LINEAR),
                    None => self.live = Some(ctx.load_texture("live view", color, TextureOptions::LINEAR)),
                }
            }
            Err(e) => self.say(format!("render: {e}")),
        }
    }

    /// The whole window.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        let ctx = ui.ctx().clone();
        let now = ctx.input(|i| i.time);
        if now - self.last_autosave >= AUTOSAVE_SECS {
            self.last_autosave = now;
            self.autosave();
        }
        if self.project.dirty() {
            // egui draws only on input: wake up for the next autosave even if nobody touches
            // anything after an edit.
            let left = (self.last_autosave + AUTOSAVE_SECS - now).max(0.05);
            ctx.request_repaint_after(std::time::Duration::from_secs_f64(left));
        }
        let (undo, redo, save) = ctx.input_mut(|i| {
            (
                i.consume_key(egui::Modifiers::COMMAND, egui::Key::Z),
                i.consume_key(egui::Modifiers::COMMAND, egui::Key::Y),
                i.consume_key(egui::Modifiers::COMMAND, egui::Key::S),
            )
        });
        if undo {
            self.undo();
        }
        if redo {
            self.redo();
        }
        if save {
            self.save();
        }
        self.refresh_live(&ctx);
        egui::Panel::top("toolbar").show(ui, |ui| self.toolbar(ui));
        egui::Panel::bottom("log").resizable(true).show(ui, |ui| self.log_panel(ui));
        egui::Panel::left("nodes").resizable(true).default_size(230.0).show(ui, |ui| self.nodes_panel(ui));
        egui::Panel::right("node").resizable(true).default_size(360.0).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| self.node_panel(ui));
        });
        egui::CentralPanel::default().show(ui, |ui| {
            self.live_view(ui);
            ui.separator();
            let sel = self.selected.as_deref().and_then(|id| self.project.graph.index_of(id));
            ui.label("Story graph (click a node)");
            let depth = graph_view::levels(&self.project.graph).into_iter().max().unwrap_or(0) + 1;
            let height = (depth as f32 * 52.0 + 24.0).max(160.0);
            if let Some(i) = egui::ScrollArea::vertical()
                .id_salt("graph")
                .show(ui, |ui| graph_view::show(ui, &self.project.graph, sel, height))
                .inner
            {
                let id = self.project.graph.nodes[i].id.clone();
                self.select(Some(id));
            }
        });
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

    fn toolbar(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.strong(format!("Exhibit: {}", self.project.dir().display()));
            if ui.button("Save").clicked() {
                self.save();
            }
            if ui.add_enabled(true, egui::Button::new("Undo")).clicked() {
                self.undo();
            }
            if ui.button("Redo").clicked() {
                self.redo();
            }
            if recovered_path(self.project.dir()).exists() && ui.button("Restore autosave").clicked() {
                self.restore_autosave();
            }
            ui.separator();
            ui.label("Model up");
            let current = self.project.pose.up;
            for (name, axis) in crate::UP_AXES {
                let label = ui.selectable_label(current == axis, name);
                let label = if current == axis {
                    label
                } else {
                    label.on_hover_text(
                        "Stands the model on this axis (a tilt made with Lean and Tip is undone)",
                    )
                };
                if label.clicked() && current != axis {
                    self.set_up(axis);
                }
            }
            let hover =
                "For a scan that stands crooked in its file: tilts the model 1° as seen in the live view";
            for (label, how, degrees) in [
                ("Lean left", Tilt::Lean, 1.0),
                ("Lean right", Tilt::Lean, -1.0),
                ("Tip back", Tilt::Tip, 1.0),
                ("Tip forward", Tilt::Tip, -1.0),
            ] {
                if ui.button(label).on_hover_text(hover).clicked() {
                    self.tilt(how, degrees);
                }
            }
            if ui
                .button("Front from view")
                .on_hover_text(
                    "The side of the model you are looking at becomes its front: the kiosk starts there",
                )
                .clicked()
            {
                self.set_front_from_view();
            }
            ui.separator();
            ui.label("Language");
            let langs = self.languages();
            for l in langs {
                if ui.selectable_label(self.lang == l, &l).clicked() {
                    self.lang = l;
                    self.load_texts();
                    self.overlay_preview = None;
                }
            }
            ui.separator();
            if self.project.dirty() {
                ui.colored_label(Color32::from_rgb(230, 170, 60), "unsaved changes");
            }
        });
    }

    /// Languages in use (the default first), plus English and Italian to start with.
    fn languages(&self) -> Vec<String> {
        let mut v = vec![self.project.graph.default_lang.clone()];
        for n in &self.project.graph.nodes {
            for l in n.title.0.keys().chain(n.text.0.keys()) {
                if !v.contains(l) {
                    v.push(l.clone());
                }
            }
        }
        for l in ["en", "it"] {
            if !v.iter().any(|x| x == l) {
                v.push(l.into());
            }
        }
        v
    }

    fn log_panel(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.strong("Validation");
            if ui.button("Validate").clicked() {
                self.validate();
            }
        });
        let mut jump = None;
        egui::ScrollArea::vertical().id_salt("problems").max_height(90.0).show(ui, |ui| {
            for p in &self.problems {
                let text = format!("! {p}");
                if ui.link(text).clicked() {
                    jump = p.node.clone();
                }
            }
        });
        if let Some(id) = jump {
            self.jump_to(&id);
        }
        ui.separator();
        egui::ScrollArea::vertical().id_salt("log").max_height(80.0).stick_to_bottom(true).show(ui, |ui| {
            for l in &self.log {
                ui.label(l);
            }
        });
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

    fn nodes_panel(&mut self, ui: &mut egui::Ui) {
        ui.heading("Views");
        ui.horizontal(|ui| {
            let l = ui.label("New id");
            ui.add(egui::TextEdit::singleline(&mut self.edit.new_id).desired_width(100.0)).labelled_by(l.id);
        });
        if ui.button("Capture view").clicked() {
            self.capture();
        }
        ui.separator();
        let mut pick = None;
        let heat = kiosk_core::stats::popularity(&self.project.graph, &self.visitor_stats);
        let seen = self.visitor_stats.visits > 0;
        egui::ScrollArea::vertical().show(ui, |ui| {
            for (n, p) in self.project.graph.nodes.iter().zip(&heat) {
                let title = n.title.get(&self.lang, &self.project.graph.default_lang).unwrap_or("");
                let label = if title.is_empty() { n.id.clone() } else { format!("{} — {title}", n.id) };
                ui.horizontal(|ui| {
                    // Popularity with the visitors: blue (ignored) to red (popular); grey before
                    // any visit.
                    let (rect, _) = ui.allocate_exact_size(egui::vec2(10.0, 10.0), egui::Sense::hover());
                    let colour = if seen { heat_colour(*p) } else { egui::Color32::GRAY };
                    ui.painter().circle_filled(rect.center(), 5.0, colour);
                    if ui.selectable_label(self.selected.as_deref() == Some(n.id.as_str()), label).clicked() {
                        pick = Some(n.id.clone());
                    }
                });
            }
        });
        if let Some(id) = pick {
            self.jump_to(&id);
        }
        ui.separator();
        ui.heading("Preview");
        ui.horizontal(|ui| {
            let l = ui.label("Seed");
            ui.add(egui::DragValue::new(&mut self.walk_seed)).labelled_by(l.id);
            if ui.button("Simulate walk").clicked() {
                self.preview_walk();
            }
        });
        if !self.walk.is_empty() {
            ui.label(self.walk.join(" -> "));
        }
        ui.horizontal(|ui| {
            let l = ui.label("Session");
            ui.add(egui::TextEdit::singleline(&mut self.edit.session_file).desired_width(120.0))
                .labelled_by(l.id);
        });
        if ui.button("Replay session").clicked() {
            self.replay();
        }
        if let Some(p) = &self.replayed {
            ui.label(format!("{:.0} s, displayed: {}", p.duration, p.displayed.join(", ")));
        }
    }

    fn node_panel(&mut self, ui: &mut egui::Ui) {
        let Some(id) = self.selected.clone() else {
            ui.label("Select a view on the left, or capture one.");
            return;
        };
        let Some(i) = self.project.graph.index_of(&id) else {
            self.selected = None;
            return;
        };
        ui.heading(format!("View '{id}'"));
        ui.label(visitor_figures(&self.visitor_stats, &id));
        ui.horizontal(|ui| {
            if ui.button("Go to view").clicked() {
                self.set_camera(self.project.graph.nodes[i].view);
                self.take_node_light(i);
            }
            if ui.button("Set to current view").clicked() {
                let cam = self.camera();
                let r = self.project.set_view(&id, cam);
                self.report("set view", r);
            }
            if ui.button("Remove").clicked() {
                let r = self.project.remove_node(&id);
                if self.report("remove", r).is_some() {
                    self.select(None);
                }
            }
        });
        if self.selected.is_none() {
            return;
        }
        ui.horizontal(|ui| {
            let light = self.project.graph.nodes[i].light;
            ui.label(match light {
                Some(d) => format!("Light {:.2} {:.2} {:.2}", d.x, d.y, d.z),
                None => "Light: the visitor's".to_string(),
            });
            ui.selectable_value(&mut self.tool, Tool::Light, "Steer light");
            if ui.button("Set light from live view").clicked() {
                self.set_light_from_live();
            }
            if light.is_some() && ui.button("Remove light").clicked() {
                let r = self.project.set_light(&id, None);
                self.report("remove light", r);
            }
        });
        let mut importance = self.project.graph.nodes[i].importance;
        let r = ui.add(egui::Slider::new(&mut importance, 0.0..=1.0).text("Importance"));
        if r.drag_stopped() || (r.changed() && !r.dragged()) {
            let res = self.project.set_importance(&id, importance);
            self.report("importance", res);
        }
        ui.separator();
        ui.strong(format!("Texts ({})", self.lang));
        ui.horizontal(|ui| {
            let l = ui.label("Title");
            ui.text_edit_singleline(&mut self.edit.title).labelled_by(l.id);
        });
        let l = ui.label("Text");
        ui.add(
            egui::TextEdit::multiline(&mut self.edit.text).desired_rows(4).hint_text("Text shown and spoken"),
        )
        .labelled_by(l.id);
        if ui.button("Apply texts").clicked() {
            self.apply_texts();
        }
        ui.separator();
        ui.strong(format!("Overlay ({})", self.lang));
        ui.horizontal(|ui| {
            let l = ui.label("Overlay file");
            ui.add(egui::TextEdit::singleline(&mut self.edit.overlay_file).hint_text("drawing.png or .svg"))
                .labelled_by(l.id);
        });
        ui.horizontal(|ui| {
            if ui.button("Attach overlay").clicked() {
                self.attach_overlay();
            }
            if ui.button("Preview overlay").clicked() {
                self.preview_overlay(ui.ctx());
            }
        });
        ui.separator();
        ui.strong(format!("Narration ({})", self.lang));
        ui.horizontal(|ui| {
            let l = ui.label("Narration file");
            ui.add(
                egui::TextEdit::singleline(&mut self.edit.narration_file)
                    .hint_text("voice.wav / .ogg / .mp3"),
            )
            .labelled_by(l.id);
        });
        ui.horizontal(|ui| {
            if ui.button("Attach narration").clicked() {
                self.attach_narration();
            }
            if ui.button("Play").clicked() {
                self.play_narration();
            }
            if ui.button("Stop").clicked()
                && let Some(n) = self.narrator.as_mut()
            {
                n.stop();
            }
        });
        ui.separator();
        ui.strong("Region of interest");
        ui.horizontal(|ui| {
            ui.selectable_value(&mut self.tool, Tool::Navigate, "Navigate");
            ui.selectable_value(&mut self.tool, Tool::Paint, "Paint");
            ui.selectable_value(&mut self.tool, Tool::Erase, "Erase");
            if ui.button("Apply region").clicked() {
                self.apply_roi();
            }
        });
        if let Some((lo, hi)) = self.project.graph.nodes[i].roi_bbox {
            ui.label(format!("box {:.2?} – {:.2?}", lo.to_array(), hi.to_array()));
        }
        ui.separator();
        ui.strong("Depends on");
        let preds: Vec<(String, f64)> = self
            .project
            .graph
            .edges
            .iter()
            .filter(|e| e.to == i)
            .map(|e| (self.project.graph.nodes[e.from].id.clone(), e.weight))
            .collect();
        for (from, w) in preds {
            ui.horizontal(|ui| {
                ui.label(format!("{from} ({w:.2})"));
                if ui.small_button("x").on_hover_text("remove this dependency").clicked() {
                    let r = self.project.set_dependency(&from, &id, 0.0);
                    self.report("dependency", r);
                }
            });
        }
        let others: Vec<String> =
            self.project.graph.nodes.iter().map(|n| n.id.clone()).filter(|n| *n != id).collect();
        egui::ComboBox::from_label("Predecessor")
            .selected_text(self.edit.dep_from.clone().unwrap_or_else(|| "choose…".into()))
            .show_ui(ui, |ui| {
                for o in others {
                    ui.selectable_value(&mut self.edit.dep_from, Some(o.clone()), o);
                }
            });
        ui.horizontal(|ui| {
            for (name, w) in PRESETS {
                if ui.button(format!("{name} {w}")).clicked() {
                    self.add_dependency(w);
                }
            }
        });
        ui.horizontal(|ui| {
            ui.add(egui::Slider::new(&mut self.edit.custom_weight, 0.01..=1.0).text("weight"));
            if ui.button("Custom").clicked() {
                self.add_dependency(self.edit.custom_weight);
            }
        });
    }

    fn preview_overlay(&mut self, ctx: &egui::Context) {
        let Some(i) = self.selected.as_deref().and_then(|id| self.project.graph.index_of(id)) else { return };
        let node = &self.project.graph.nodes[i];
        let view = node.view;
        let Some(rel) = node.overlay.0.get(&self.lang).cloned() else {
            self.say("no overlay in this language");
            return;
        };
        let path = self.project.dir().join(rel);
        match image::open(&path) {
            Ok(img) => {
                let img = img.to_rgba8();
                let aspect = f64::from(img.width()) / f64::from(img.height().max(1));
                if (aspect - VIEW_ASPECT).abs() > 0.01 * VIEW_ASPECT {
                    self.say(format!(
                        "warning: the overlay's aspect {aspect:.3} differs from the view's {VIEW_ASPECT:.3}"
                    ));
                }
                let color = ColorImage::from_rgba_unmultiplied(
                    [img.width() as usize, img.height() as usize],
                    img.as_raw(),
                );
                let tex = ctx.load_texture(path.display().to_string(), color, TextureOptions::LINEAR);
                self.overlay_preview = Some((path, tex));
                self.set_camera(view);
            }
            Err(e) => self.say(format!("overlay {}: {e}", path.display())),
        }
    }

    fn live_view(&mut self, ui: &mut egui::Ui) {
        let w = ui.available_width().min(ui.available_height().max(200.0) * 16.0 / 9.0);
        let size = vec2(w, w * 9.0 / 16.0);
        let (rect, response) = ui.allocate_exact_size(size, Sense::click_and_drag());
        response.widget_info(|| egui::WidgetInfo::labeled(egui::Role::Image, true, "Live view"));
        let p = ui.painter_at(rect);
        let uv = Rect::from_min_max(Pos2::ZERO, egui::pos2(1.0, 1.0));
        match &self.live {
            Some(t) => {
                p.image(t.id(), rect, uv, Color32::WHITE);
            }
            None => {
                p.rect_filled(rect, 0.0, Color32::from_gray(30));
                p.text(
                    rect.center(),
                    egui::Align2::CENTER_CENTER,
                    "no GPU: no live view",
                    egui::FontId::proportional(16.0),
                    Color32::GRAY,
                );
            }
        }
        if let Some((_, t)) = &self.overlay_preview {
            p.image(t.id(), rect, uv, Color32::WHITE);
        }
        if self.mask.is_some() && self.mask_tex.is_none() {
            let m = self.mask.as_ref().map(|m| {
                let rgba: Vec<u8> =
                    m.pixels().flat_map(|px| [255, 60, 60, if px[0] > 127 { 110 } else { 0 }]).collect();
                ColorImage::from_rgba_unmultiplied([m.width() as usize, m.height() as usize], &rgba)
            });
            if let Some(m) = m {
                self.mask_tex = Some(ui.ctx().load_texture("roi mask", m, TextureOptions::LINEAR));
            }
        }
        if let Some(t) = &self.mask_tex {
            p.image(t.id(), rect, uv, Color32::WHITE);
        }
        let pointer = response.interact_pointer_pos();
        match self.tool {
            Tool::Navigate => {
                if response.dragged() {
                    let d = response.drag_delta();
                    // Drag = hover (thesis 9.5.2 with a mouse), in viewport heights, y up.
                    let intent = Intent {
                        hover: (f64::from(d.x / rect.height()) * 2.0, -f64::from(d.y / rect.height()) * 2.0),
                        ..Intent::default()
                    };
                    self.navigate(&intent);
                    self.overlay_preview = None;
                }
                let scroll = ui.input(|i| i.smooth_scroll_delta.y);
                if response.hovered() && scroll != 0.0 {
                    self.navigate(&Intent { zoom: f64::from(scroll) * 0.002, ..Intent::default() });
                }
            }
            Tool::Light => {
                if response.dragged() {
                    let d = response.drag_delta();
                    self.steer_light(f64::from(d.x / rect.width()), f64::from(d.y / rect.height()));
                }
                if response.drag_stopped() {
                    self.light_pad = None;
                }
            }
            Tool::Paint | Tool::Erase => {
                if let (Some(q), true) = (pointer, response.dragged() || response.clicked()) {
                    let u = (q.x - rect.left()) / rect.width();
                    let v = (q.y - rect.top()) / rect.height();
                    self.brush(u, v, 0.06, self.tool == Tool::Paint);
                }
            }
        }
        ui.label(match self.tool {
            Tool::Navigate => "Drag to glide over the model, wheel to come closer.",
            Tool::Paint => "Paint the region of interest over the view (then Apply region).",
            Tool::Erase => "Erase parts of the painted region.",
            Tool::Light => "Drag to move the light (to the rim of the view: raking light).",
        });
    }
}

/// Renders an SVG drawing (curators draw overlays in vector tools) to an RGBA image at the
/// view's size (1280×720), fitted and centred, reading no other file.
pub fn svg_to_png(path: &Path) -> anyhow::Result<image::RgbaImage> {
    kiosk_content::media::read_image(path).map_err(anyhow::Error::msg)
}

/// Blue (0) through purple to red (1).
fn heat_colour(p: f64) -> egui::Color32 {
    let p = p.clamp(0.0, 1.0);
    egui::Color32::from_rgb((40.0 + 215.0 * p) as u8, 60, (255.0 - 215.0 * p) as u8)
}

/// What visitors did with one view, in a line.
pub fn visitor_figures(stats: &kiosk_core::stats::ExhibitStats, id: &str) -> String {
    if stats.visits == 0 {
        return "Visitors: no visits recorded yet".into();
    }
    let t = stats.get(id);
    let pct = |r: Option<f64>| r.map_or("–".to_string(), |r| format!("{:.0} %", 100.0 * r));
    format!(
        "Visitors ({} visits): shown {} times, {:.0} s each on average, proposals accepted {}, picked in the menu {} times",
        stats.visits,
        t.displays,
        t.mean_dwell().unwrap_or(0.0),
        pct(t.acceptance()),
        t.menu_picks
    )
}
