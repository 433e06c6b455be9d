//! The authoring window's drawing: the toolbar, the views list, the selected view's editor, the
//! live view with its tools, the validation and message log. Each control calls an action of
//! [`AuthorApp`] (in the parent module), which goes through [`crate::Project`].

use super::{AUTOSAVE_SECS, AuthorApp, LIVE_SIZE, PRESETS, Tilt, Tool, graph_view, recovered_path};
use crate::VIEW_ASPECT;
use egui::{Color32, ColorImage, Pos2, Rect, Sense, TextureOptions, vec2};
use kiosk_core::camera::Intent;
use kiosk_render::RenderSettings;

impl AuthorApp {
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

/// Blue (0) through purple to red (1).
fn heat_colour(p: f64) -> egui::Color32 {
    let p = p.clamp(0.0, 1.0);
    egui::Color32::from_rgb((40.0 + 215.0 * p) as u8, 60, (255.0 - 215.0 * p) as u8)
}

/// What visitors did with one view, in a line.
fn visitor_figures(stats: &kiosk_core::stats::ExhibitStats, id: &str) -> String {
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
