//! The curator's actions on an exhibit, as a headless API. The `author` window ([`ui`], egui)
//! drives exactly these; tests drive them directly.
//!
//! An exhibit is a directory with a model (store or scan) and `graph.xml`; media live beside it
//! (`thumbs/`, `overlays/`, `roi/`, paths relative to the graph). Every edit of the graph is
//! undoable; saving is atomic (write a temporary file, sync, rename), so a crash mid-save never
//! loses the previous file.

use anyhow::Context;
use glam::DVec3;
use kiosk_content::MappedStore;
use kiosk_core::camera::Camera;
use kiosk_core::graph::{Edge, InfoGraph, Node, PerLanguage, Problem};
use kiosk_core::{Cut, CutParams};
use kiosk_render::{Gpu, RenderSettings, Renderer};
use std::io::Write;
use std::path::{Path, PathBuf};

pub mod preview;
pub mod ui;

/// Aspect ratio of the projection the views are authored for.
pub const VIEW_ASPECT: f64 = 16.0 / 9.0;
/// Size of rendered thumbnails.
pub const THUMB_SIZE: (u32, u32) = (320, 180);

/// An open exhibit being authored.
pub struct Project {
    dir: PathBuf,
    /// The model.
    pub store: MappedStore,
    /// The information graph being edited.
    pub graph: InfoGraph,
    undo: Vec<InfoGraph>,
    redo: Vec<InfoGraph>,
    saved: InfoGraph,
    /// The text of graph.xml as last read or written: saving writes over it, keeping what the
    /// loader could not read (see [`InfoGraph::to_xml_over`]).
    original: Option<String>,
    /// How the model stands: its up direction and the side the kiosk shows first (`exhibit.toml`;
    /// without one, the default up of its scan: +Z for a survey scan, else +Y).
    pub pose: ModelPose,
}

pub use kiosk_content::exhibit::{ModelPose, UP_AXES};

impl Project {
    /// Opens an exhibit directory (creating an empty graph when it has none), its scan imported
    /// into the user's cache when needed.
    pub fn open(dir: &Path) -> anyhow::Result<(Self, Vec<Problem>)> {
        Self::open_in(dir, &kiosk_content::exhibit::cache_dir())
    }

    /// [`Project::open`] with the import cache in `cache`. The problems include what the reader
    /// warned of when it imported the scan (now or before), as warnings.
    pub fn open_in(dir: &Path, cache: &Path) -> anyhow::Result<(Self, Vec<Problem>)> {
        Self::open_reporting(dir, cache, &mut |_| {})
    }

    /// [`Project::open_in`], giving `progress` each line the import of the scan logs, if it is
    /// imported (the window shows the last: [`ui::opening`]).
    pub fn open_reporting(
        dir: &Path,
        cache: &Path,
        progress: &mut dyn FnMut(&str),
    ) -> anyhow::Result<(Self, Vec<Problem>)> {
        let (store, warnings) = kiosk_content::exhibit::open_model_warned(dir, cache, progress)?;
        let read_problems =
            warnings.into_iter().map(|w| Problem { node: None, msg: format!("model {w}"), dropped: false });
        let graph_file = dir.join("graph.xml");
        let original = match std::fs::read_to_string(&graph_file) {
            Ok(text) => Some(text),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => None,
            Err(e) => return Err(e).with_context(|| format!("cannot read {}", graph_file.display())),
        };
        // What exhibit.toml could give: a key it could not take is left at its default.
        let settings = kiosk_content::exhibit::exhibit_settings(dir);
        let pose = settings.pose;
        let up_problems =
            settings.messages().into_iter().map(|msg| Problem { node: None, msg, dropped: false });
        let (graph, mut problems) = match kiosk_content::exhibit::open_graph(dir)? {
            Some((g, p)) => (g, p),
            None => (InfoGraph { default_lang: "en".into(), ..InfoGraph::default() }, Vec::new()),
        };
        problems.extend(read_problems.chain(up_problems));
        Ok((
            Self {
                dir: dir.to_path_buf(),
                store,
                saved: graph.clone(),
                graph,
                undo: Vec::new(),
                redo: Vec::new(),
                original,
                pose,
            },
            problems,
        ))
    }

    /// The exhibit directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Whether the graph differs from the last saved one.
    pub fn dirty(&self) -> bool {
        self.graph != self.saved
    }

    fn edit<T>(&mut self, f: impl FnOnce(&mut InfoGraph) -> anyhow::Result<T>) -> anyhow::Result<T> {
        let before = self.graph.clone();
        match f(&mut self.graph) {
            Ok(v) => {
                self.undo.push(before);
                self.redo.clear();
                Ok(v)
            }
            Err(e) => {
                self.graph = before;
                Err(e)
            }
        }
    }

    /// Undoes the last edit; false when there is none.
    pub fn undo(&mut self) -> bool {
        match self.undo.pop() {
            Some(g) => {
                self.redo.push(std::mem::replace(&mut self.graph, g));
                true
            }
            None => false,
        }
    }

    /// Redoes the last undone edit; false when there is none.
    pub fn redo(&mut self) -> bool {
        match self.redo.pop() {
            Some(g) => {
                self.undo.push(std::mem::replace(&mut self.graph, g));
                true
            }
            None => false,
        }
    }

    fn index(&self, id: &str) -> anyhow::Result<usize> {
        self.graph.index_of(id).with_context(|| format!("no node '{id}'"))
    }

    /// Captures `camera` as a new node `id` (a fresh id when `None`); with a GPU, renders its
    /// thumbnail into `thumbs/ID.png`. Returns the id.
    pub fn capture(
        &mut self,
        camera: Camera,
        id: Option<&str>,
        gpu: Option<(&Gpu, &mut Renderer)>,
    ) -> anyhow::Result<String> {
        anyhow::ensure!(camera.is_finite(), "the camera is not finite");
        let id = match id {
            Some(i) => i.trim().to_string(),
            None => (1..)
                .map(|k| format!("view-{k}"))
                .find(|c| self.graph.index_of(c).is_none())
                .unwrap_or_default(),
        };
        kiosk_core::graph::check_id(&id).map_err(|e| anyhow::anyhow!("node {e}"))?;
        anyhow::ensure!(self.graph.index_of(&id).is_none(), "a node '{id}' already exists");
        let thumbnail = match gpu {
            Some((gpu, renderer)) => {
                let img = kiosk_content::snapshot::snapshot(
                    gpu,
                    renderer,
                    &self.store,
                    &camera,
                    THUMB_SIZE,
                    1.0,
                    &RenderSettings::default(),
                )?;
                let rel = format!("thumbs/{id}.png");
                let path = self.dir.join(&rel);
                std::fs::create_dir_all(path.parent().unwrap_or(&self.dir))?;
                img.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
                Some(rel)
            }
            None => None,
        };
        let lang = self.graph.default_lang.clone();
        self.edit(|g| {
            let mut title = PerLanguage::default();
            title.0.insert(lang, id.clone());
            g.nodes.push(Node { title, thumbnail, ..Node::new(id.clone(), camera) });
            Ok(id.clone())
        })
    }

    /// Sets a node's title and text in a language.
    pub fn set_text(&mut self, id: &str, lang: &str, title: &str, text: &str) -> anyhow::Result<()> {
        let i = self.index(id)?;
        let lang = lang.to_string();
        self.edit(|g| {
            g.nodes[i].title.0.insert(lang.clone(), title.to_string());
            g.nodes[i].text.0.insert(lang, text.to_string());
            Ok(())
        })
    }

    /// Attaches a narration file (relative to the exhibit) in a language.
    pub fn set_narration(&mut self, id: &str, lang: &str, rel: &str) -> anyhow::Result<()> {
        let i = self.index(id)?;
        kiosk_content::media::resolve(&self.dir, rel).map_err(|e| anyhow::anyhow!("narration {rel}: {e}"))?;
        let (lang, rel) = (lang.to_string(), rel.to_string());
        self.edit(|g| {
            g.nodes[i].narration.0.insert(lang, rel);
            Ok(())
        })
    }

    /// Sets a node's importance γ (clamped to [0, 1]).
    pub fn set_importance(&mut self, id: &str, importance: f64) -> anyhow::Result<()> {
        anyhow::ensure!(importance.is_finite(), "importance must be a number");
        let i = self.index(id)?;
        self.edit(|g| {
            g.nodes[i].importance = importance.clamp(0.0, 1.0);
            Ok(())
        })
    }

    /// Attaches an overlay image (PNG with alpha, or SVG) in a language: copies it into `overlays/`.
    /// Returns a warning when its aspect ratio differs from the view's.
    pub fn attach_overlay(&mut self, id: &str, lang: &str, source: &Path) -> anyhow::Result<Option<String>> {
        let i = self.index(id)?;
        kiosk_core::graph::check_id(lang).map_err(|e| anyhow::anyhow!("language {e}"))?;
        let (w, h) = if kiosk_content::media::is_svg(source) {
            // An SVG is drawn at the view's size; it must draw.
            let data = std::fs::read(source).with_context(|| format!("cannot read {}", source.display()))?;
            kiosk_content::media::svg_to_rgba(&data)
                .map_err(|e| anyhow::anyhow!("{}: not a readable SVG: {e}", source.display()))?
                .dimensions()
        } else {
            image::image_dimensions(source)
                .with_context(|| format!("{}: not a readable image", source.display()))?
        };
        let ext = source.extension().and_then(|e| e.to_str()).unwrap_or("png").to_ascii_lowercase();
        let rel = format!("overlays/{id}-{lang}.{ext}");
        let dest = self.dir.join(&rel);
        std::fs::create_dir_all(dest.parent().unwrap_or(&self.dir))?;
        std::fs::copy(source, &dest)
            .with_context(|| format!("cannot copy {} to {}", source.display(), dest.display()))?;
        let lang = lang.to_string();
        self.edit(|g| {
            g.nodes[i].overlay.0.insert(lang, rel);
            Ok(())
        })?;
        let aspect = f64::from(w) / f64::from(h.max(1));
        Ok(((aspect - VIEW_ASPECT).abs() > 0.01 * VIEW_ASPECT).then(|| {
            format!(
                "overlay {}×{} (aspect {aspect:.3}) differs from the view's aspect {VIEW_ASPECT:.3}",
                w, h
            )
        }))
    }

    /// Sets a node's region of interest from a mask painted over its view (any size; set where
    /// luminance > 127): saves the mask into `roi/ID.png`, keeps its bitmap for the engine and
    /// computes the ROI bounding box from
    /// the model points that project under it and are visible from the view (the first hit of
    /// a ray cast). Returns the box, or an error when no model point is under the mask.
    pub fn paint_roi(&mut self, id: &str, mask: &image::GrayImage) -> anyhow::Result<(DVec3, DVec3)> {
        let i = self.index(id)?;
        let view = self.graph.nodes[i].view;
        let bbox = roi_bbox(&self.store, &view, mask)
            .with_context(|| format!("node '{id}': no model point under the mask"))?;
        let rel = format!("roi/{id}.png");
        let path = self.dir.join(&rel);
        std::fs::create_dir_all(path.parent().unwrap_or(&self.dir))?;
        mask.save(&path).with_context(|| format!("cannot write {}", path.display()))?;
        // The bitmap the engine ranks with, as the kiosk reads it from the file.
        let bitmap = kiosk_core::graph::RoiMask::from_fn(mask.width(), mask.height(), VIEW_ASPECT, |x, y| {
            mask.get_pixel(x, y)[0] > 127
        });
        self.edit(|g| {
            g.nodes[i].roi_mask = Some(rel);
            g.nodes[i].roi_bbox = Some(bbox);
            g.nodes[i].roi_bitmap = bitmap;
            Ok(())
        })?;
        Ok(bbox)
    }

    /// Sets (or replaces) the dependency `from` → `to` with weight ω ∈ [0, 1]; ω = 0 removes it.
    pub fn set_dependency(&mut self, from: &str, to: &str, weight: f64) -> anyhow::Result<()> {
        anyhow::ensure!((0.0..=1.0).contains(&weight), "weight {weight} outside [0, 1]");
        let (f, t) = (self.index(from)?, self.index(to)?);
        anyhow::ensure!(f != t, "a node cannot depend on itself");
        self.edit(|g| {
            g.edges.retain(|e| !(e.from == f && e.to == t));
            if weight > 0.0 {
                g.edges.push(Edge { from: f, to: t, weight });
            }
            Ok(())
        })
    }

    /// Moves a node's view to `camera` (its thumbnail is not re-rendered).
    pub fn set_view(&mut self, id: &str, camera: Camera) -> anyhow::Result<()> {
        anyhow::ensure!(camera.is_finite(), "the camera is not finite");
        let i = self.index(id)?;
        self.edit(|g| {
            g.nodes[i].view = camera;
            Ok(())
        })
    }

    /// Stores a light in a node's view (`None` removes it): a direction toward the user light in
    /// model axes, any length; zero or not finite is refused. A go-to to the node turns the
    /// kiosk's light to it.
    pub fn set_light(&mut self, id: &str, light: Option<DVec3>) -> anyhow::Result<()> {
        let light = match light {
            Some(l) => Some(
                kiosk_core::light::unit(l)
                    .with_context(|| format!("node '{id}': light {l} must be finite and not zero"))?,
            ),
            None => None,
        };
        let i = self.index(id)?;
        self.edit(|g| {
            g.nodes[i].light = light;
            Ok(())
        })
    }

    /// Replaces the whole graph (e.g. restoring an autosave), as one undoable edit.
    pub fn replace_graph(&mut self, graph: InfoGraph) -> anyhow::Result<()> {
        self.edit(|g| {
            *g = graph;
            Ok(())
        })
    }

    /// Removes a node and its edges.
    pub fn remove_node(&mut self, id: &str) -> anyhow::Result<()> {
        let i = self.index(id)?;
        self.edit(|g| {
            g.nodes.remove(i);
            g.edges.retain(|e| e.from != i && e.to != i);
            for e in &mut g.edges {
                e.from -= usize::from(e.from > i);
                e.to -= usize::from(e.to > i);
            }
            Ok(())
        })
    }

    /// Every problem of the graph: structure and files.
    pub fn validate(&self) -> Vec<Problem> {
        let mut p = self.graph.check_structure();
        p.extend(
            self.graph
                .check_files(VIEW_ASPECT, &|rel: &str| kiosk_content::exhibit::probe_media(&self.dir, rel)),
        );
        p
    }

    /// Turns the model upright: sets its up direction (one of [`UP_AXES`] or any direction, made
    /// unit) and writes it to `exhibit.toml` at once (atomically), so the kiosk shows the model
    /// the same way. A front that lies along the new up direction is dropped (the default front
    /// is used); another is levelled to it.
    pub fn set_up(&mut self, up: DVec3) -> anyhow::Result<()> {
        let up = ModelPose::unit_up(up).with_context(|| format!("up = {up}: not a direction"))?;
        let front = self.pose.front.and_then(|f| ModelPose::level(up, f));
        self.write_pose(ModelPose { up, front })
    }

    /// Tilts the model: turns its whole pose (up and front) by `angle` radians about `axis`, for a
    /// scan that stands a few degrees off an axis in its file (the authoring tool turns it about
    /// the live view's direction or its horizontal). Written to `exhibit.toml` at once; the turn
    /// is returned (for a view to turn with the pose).
    pub fn tilt(&mut self, axis: DVec3, angle: f64) -> anyhow::Result<glam::DQuat> {
        let axis = axis.try_normalize().with_context(|| format!("tilt axis {axis}: not a direction"))?;
        anyhow::ensure!(angle.is_finite(), "tilt angle {angle}: not a number");
        let turn = glam::DQuat::from_axis_angle(axis, angle);
        let up = ModelPose::unit_up(turn * self.pose.up).context("the tilted up")?;
        let front = self.pose.front.map(|f| turn * f).and_then(|f| ModelPose::level(up, f));
        self.write_pose(ModelPose { up, front })?;
        Ok(turn)
    }

    /// Turns the model about its up axis: the kiosk's start view will look at the side `front`
    /// points to (levelled to the up axis), e.g. the direction from the model to the live view's
    /// eye. Written to `exhibit.toml` at once.
    pub fn set_front(&mut self, front: DVec3) -> anyhow::Result<()> {
        let f =
            ModelPose::level(self.pose.up, front).context("that direction is along the model's up axis")?;
        self.write_pose(ModelPose { front: Some(f), ..self.pose })
    }

    /// Writes `exhibit.toml` atomically and takes the pose.
    fn write_pose(&mut self, pose: ModelPose) -> anyhow::Result<()> {
        let path = self.dir.join("exhibit.toml");
        let tmp = self.dir.join(".exhibit.toml.saving");
        std::fs::write(&tmp, kiosk_content::exhibit::exhibit_toml(&self.dir, &pose))
            .and_then(|()| std::fs::rename(&tmp, &path))
            .with_context(|| format!("cannot write {}", path.display()))?;
        self.pose = pose;
        Ok(())
    }

    /// The graph as it would be saved: over the file it was read from, so that comments,
    /// unknown attributes and content the loader could not read are kept.
    pub fn to_xml(&self) -> String {
        match &self.original {
            Some(original) => self.graph.to_xml_over(original).unwrap_or_else(|_| self.graph.to_xml()),
            None => self.graph.to_xml(),
        }
    }

    /// Saves `graph.xml` atomically: a temporary file beside it, synced, renamed over it.
    pub fn save(&mut self) -> anyhow::Result<()> {
        let path = self.dir.join("graph.xml");
        let tmp = self.dir.join(".graph.xml.saving");
        let xml = self.to_xml();
        {
            let mut f =
                std::fs::File::create(&tmp).with_context(|| format!("cannot write {}", tmp.display()))?;
            f.write_all(xml.as_bytes())?;
            f.sync_all()?;
        }
        std::fs::rename(&tmp, &path).with_context(|| format!("cannot replace {}", path.display()))?;
        self.saved = self.graph.clone();
        self.original = Some(xml);
        Ok(())
    }
}

/// The bounding box of the model points visible from `view` whose projection falls on a set
/// pixel of `mask` (stretched over the view at [`VIEW_ASPECT`]).
pub fn roi_bbox(store: &MappedStore, view: &Camera, mask: &image::GrayImage) -> Option<(DVec3, DVec3)> {
    let (mw, mh) = mask.dimensions();
    if mw == 0 || mh == 0 {
        return None;
    }
    let size = (1280, 720);
    let params = view.view_params(store, size)?;
    let mut cut = Cut::root(store);
    cut.update(store, &params, &CutParams { max_changes: usize::MAX, ..CutParams::default() });
    let diag = f64::from(store.bbox().diagonal());
    let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for id in cut.visible_nodes(store, &params) {
        for s in store.splats(id) {
            let p = store.to_model(s.position());
            let Some((x, y, _)) = view.ndc(p, VIEW_ASPECT) else { continue };
            if x.abs() > 1.0 || y.abs() > 1.0 {
                continue;
            }
            let px = (((x + 1.0) * 0.5 * f64::from(mw)) as u32).min(mw - 1);
            let py = (((1.0 - y) * 0.5 * f64::from(mh)) as u32).min(mh - 1);
            if mask.get_pixel(px, py)[0] <= 127 {
                continue;
            }
            // Visible: nothing in front of it along the ray from the eye.
            let d = p - view.eye;
            let len = d.length();
            let hit = store.ray_cast(kiosk_core::Level::Cut(&cut), view.eye, d, len);
            if hit.is_some_and(|h| h.t < len - f64::from(s.radius) * 2.0 - 1e-9 * diag) {
                continue;
            }
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    (lo.x <= hi.x).then_some((lo, hi))
}

#[cfg(test)]
mod tests;
