//! What each window shows, drawn with egui shapes in points of a 720-point-high layout.

use egui::{Align2, Color32, FontId, Pos2, Rect, Stroke, TextureHandle, pos2, vec2};
use kiosk_core::kiosk::{Button, ButtonKind, Mode, buttons};

/// Words of the interface in a language (English for languages without a table).
pub struct Words {
    /// Back button.
    pub back: &'static str,
    /// Help button.
    pub help: &'static str,
    /// Explore button.
    pub explore: &'static str,
    /// Gallery hint.
    pub gallery_hint: &'static str,
    /// Minimal help while exploring.
    pub help_text: &'static str,
    /// Hint while exploring.
    pub explore_hint: &'static str,
    /// Attract loop call.
    pub touch_to_explore: &'static str,
    /// Countdown to the reset ("{s}" is replaced by seconds).
    pub countdown: &'static str,
    /// Under the suggestion inset.
    pub inset_hint: &'static str,
    /// Light button.
    pub light: &'static str,
    /// Hint while the light button is on.
    pub light_hint: &'static str,
    /// While the exhibits load, before the gallery opens.
    pub preparing: &'static str,
    /// When none could be loaded (the kiosk tries again).
    pub closed: &'static str,
}

/// The interface words of a language.
pub fn words(lang: &str) -> &'static Words {
    match lang {
        "it" => &Words {
            back: "Galleria",
            help: "?",
            explore: "Esplora",
            gallery_hint: "Scorri per sfogliare, tocca per esplorare",
            help_text: "Trascina un dito per girare intorno all'opera.\nAvvicina o allontana due dita per lo zoom.\nTieni premuto per i punti vicini.\nLuce: trascina dal pulsante, o toccalo e trascina un dito, per spostare la luce; portala di lato per far risaltare i rilievi. Tocca di nuovo Luce per muoverti.\nCon il mouse: la barra a sinistra fa lo zoom (clic su + o −, o scorri).",
            explore_hint: "Trascina per muoverti · tieni premuto per i punti vicini",
            touch_to_explore: "Tocca per esplorare",
            countdown: "Ritorno alla galleria tra {s} s",
            inset_hint: "Tieni premuto per andarci",
            light: "Luce",
            light_hint: "Trascina per spostare la luce · di lato fa risaltare i rilievi",
            preparing: "La mostra si sta preparando. Un momento, per favore.",
            closed: "La mostra è chiusa per il momento. Ci scusiamo.",
        },
        _ => &Words {
            back: "Gallery",
            help: "?",
            explore: "Explore",
            gallery_hint: "Swipe to browse, tap to explore",
            help_text: "Drag one finger to glide around the object.\nPinch with two fingers to come closer or step back.\nHold your finger still for nearby places.\nLight: drag from the button, or tap it and drag one finger, to move the light; take it to the side to bring out the relief of the surface. Tap Light again to move on.\nWith a mouse: the bar on the left edge zooms (click + or −, or slide).",
            explore_hint: "Drag to move · hold for nearby places",
            touch_to_explore: "Touch to explore",
            countdown: "Back to the gallery in {s} s",
            inset_hint: "Hold to go there",
            light: "Light",
            light_hint: "Drag to move the light · from the side it brings out the relief",
            preparing: "The exhibition is being prepared. One moment, please.",
            closed: "The exhibition is closed for the moment. We are sorry.",
        },
    }
}

const PANEL: Color32 = Color32::from_rgba_premultiplied(12, 14, 20, 200);
const ACCENT: Color32 = Color32::from_rgb(236, 190, 90);

fn rect_of(b: &Button, screen: Rect) -> Rect {
    Rect::from_min_max(
        pos2(screen.width() * b.rect[0] as f32, screen.height() * b.rect[1] as f32),
        pos2(screen.width() * b.rect[2] as f32, screen.height() * b.rect[3] as f32),
    )
    .shrink(6.0)
}

fn wrapped(
    p: &egui::Painter,
    text: &str,
    size: f32,
    width: f32,
    color: Color32,
) -> std::sync::Arc<egui::Galley> {
    p.layout(text.to_string(), FontId::proportional(size), color, width)
}

/// `text` at the largest of `sizes` that fits `width` on one line, else at the smallest in at
/// most `rows` rows of `width`, the rest cut with an ellipsis (a curator's title can be long).
fn fitted(
    p: &egui::Painter,
    text: &str,
    sizes: &[f32],
    width: f32,
    rows: usize,
    color: Color32,
) -> std::sync::Arc<egui::Galley> {
    for &size in sizes {
        let g = p.layout_no_wrap(text.to_string(), FontId::proportional(size), color);
        if g.size().x <= width && g.rows.len() <= rows {
            return g;
        }
    }
    let size = sizes.last().copied().unwrap_or(20.0);
    let mut job = egui::text::LayoutJob::simple(text.to_string(), FontId::proportional(size), color, width);
    job.wrap.max_rows = rows;
    job.wrap.overflow_character = Some('…');
    p.layout_job(job)
}

/// The height of one row of text at `size`.
fn row_height(p: &egui::Painter, size: f32) -> f32 {
    p.layout_no_wrap("Ág".into(), FontId::proportional(size), Color32::WHITE).size().y
}

/// What both windows show while the exhibits load ([`super::preparing`]), or when none could be.
pub struct PreparingView<'a> {
    /// The kiosk's languages: the words are said in each.
    pub languages: &'a [String],
    /// Whether no exhibit could be loaded: the exhibition is closed, still (no pulse).
    pub closed: bool,
    /// Seconds since loading started (the pulse moves with them).
    pub t: f64,
    /// Small print for the technician (the controller only): which exhibit, how long, the
    /// import's last line.
    pub detail: Option<&'a str>,
}

/// Draws the preparing screen: the words in every language, a pulse of three dots, and on the
/// controller the small print; or, closed, the words that say so and the small print.
pub fn preparing(ctx: &egui::Context, v: &PreparingView<'_>) {
    let screen = ctx.content_rect();
    let p = ctx.layer_painter(egui::LayerId::background());
    p.rect_filled(screen, 0.0, Color32::from_rgb(18, 20, 26));
    let width = screen.width() * 0.8;
    let mut y = screen.height() * 0.36;
    // Each language once: one without a table of its own would repeat the English.
    let mut said: Vec<&str> = Vec::new();
    for lang in v.languages {
        let w = words(lang);
        let text = if v.closed { w.closed } else { w.preparing };
        if said.contains(&text) {
            continue;
        }
        let (size, color) =
            if said.is_empty() { (34.0, Color32::WHITE) } else { (26.0, Color32::from_gray(170)) };
        said.push(text);
        let g = wrapped(&p, text, size, width, color);
        let h = g.size().y;
        p.galley(pos2(screen.center().x - g.size().x / 2.0, y), g, color);
        y += h + 18.0;
    }
    // Three dots, one bright at a time, a step a second: the kiosk is alive.
    let lit = v.t.floor().rem_euclid(3.0) as usize;
    for k in (0..3).filter(|_| !v.closed) {
        let c = pos2(screen.center().x + (k as f32 - 1.0) * 28.0, y + 30.0);
        p.circle_filled(c, 7.0, if k == lit { ACCENT } else { Color32::from_gray(70) });
    }
    if let Some(detail) = v.detail {
        let g = wrapped(&p, detail, 18.0, screen.width() * 0.9, Color32::from_gray(150));
        let at = pos2(screen.center().x - g.size().x / 2.0, screen.height() * 0.94 - g.size().y);
        p.galley(at, g, Color32::from_gray(150));
    }
}

/// What the controller window shows.
pub struct ControllerView<'a> {
    /// Mode.
    pub mode: Mode,
    /// Language code and the languages offered.
    pub lang: &'a str,
    /// Languages.
    pub languages: &'a [String],
    /// Whether the help is open.
    pub help: bool,
    /// Seconds before the reset (attract loop).
    pub countdown: Option<f64>,
    /// Gallery: (title, thumbnail) of the current model, its index, and the count.
    pub card: (&'a str, Option<&'a TextureHandle>),
    /// Index of the model and number of models.
    pub page: (usize, usize),
    /// Captions of the narration playing (title, text).
    pub caption: Option<(&'a str, &'a str)>,
    /// The zoom bar, `[x0, y0, x1, y1]` normalised (where the gestures take it).
    pub zoom_bar: [f64; 4],
    /// Whether the light button is on.
    pub light_on: bool,
    /// While a finger steers the light (or the light is on): where the light is on its pad
    /// (centre: from the eye, rim: grazing; x right, y up).
    pub light_pad: Option<(f64, f64)>,
}

/// Draws the controller window (no model content: the visitor looks at the wall; thesis
/// requirement R8).
pub fn controller(ctx: &egui::Context, v: &ControllerView<'_>) {
    let screen = ctx.content_rect();
    let p = ctx.layer_painter(egui::LayerId::background());
    let w = words(v.lang);
    p.rect_filled(screen, 0.0, Color32::from_rgb(18, 20, 26));
    let label = |kind: ButtonKind| -> String {
        match kind {
            ButtonKind::Back => w.back.into(),
            ButtonKind::Help => w.help.into(),
            ButtonKind::Language => v
                .languages
                .iter()
                .map(|l| if l == v.lang { l.to_uppercase() } else { l.clone() })
                .collect::<Vec<_>>()
                .join(" · "),
            ButtonKind::Previous | ButtonKind::Next => String::new(),
            ButtonKind::Explore => w.explore.into(),
            ButtonKind::Light => w.light.into(),
        }
    };
    match v.mode {
        Mode::Gallery => {
            let (title, thumb) = v.card;
            let area = Rect::from_center_size(
                pos2(screen.center().x, screen.height() * 0.46),
                vec2(screen.width() * 0.66, screen.height() * 0.56),
            );
            match thumb {
                Some(t) => {
                    let s = t.size_vec2();
                    let scale = (area.width() / s.x).min(area.height() / s.y);
                    let r = Rect::from_center_size(area.center(), s * scale);
                    p.image(t.id(), r, Rect::from_min_max(Pos2::ZERO, pos2(1.0, 1.0)), Color32::WHITE);
                    p.rect_stroke(
                        r,
                        4.0,
                        Stroke::new(1.0, Color32::from_gray(90)),
                        egui::StrokeKind::Outside,
                    );
                }
                None => {
                    p.rect_filled(area, 6.0, Color32::from_gray(40));
                }
            }
            // Centred between the buttons beside it (the language switch), in at most two rows.
            let half = buttons(v.mode)
                .iter()
                .filter(|b| b.rect[1] < 0.16)
                .map(|b| if b.rect[0] >= 0.5 { b.rect[0] - 0.5 } else { 0.5 - b.rect[2] })
                .fold(0.45, f64::min) as f32
                * screen.width()
                - 10.0;
            let g = fitted(&p, title, &[40.0, 34.0, 28.0, 24.0], 2.0 * half, 2, Color32::WHITE);
            let at = pos2(screen.center().x - g.size().x / 2.0, screen.height() * 0.1 - g.size().y / 2.0);
            p.galley(at.max(pos2(0.0, 2.0)), g, Color32::WHITE);
            p.text(
                pos2(screen.center().x, screen.height() * 0.77),
                Align2::CENTER_CENTER,
                w.gallery_hint,
                FontId::proportional(20.0),
                Color32::from_gray(170),
            );
            let (i, n) = v.page;
            for k in 0..n {
                let c = pos2(
                    screen.center().x + (k as f32 - (n as f32 - 1.0) / 2.0) * 22.0,
                    screen.height() * 0.97,
                );
                p.circle_filled(c, 5.0, if k == i { ACCENT } else { Color32::from_gray(80) });
            }
        }
        Mode::Explore => {
            let r = v.zoom_bar;
            let bar = Rect::from_min_max(
                pos2(screen.width() * r[0] as f32, screen.height() * r[1] as f32),
                pos2(screen.width() * r[2] as f32, screen.height() * r[3] as f32),
            );
            p.rect_filled(bar, 0.0, Color32::from_gray(30));
            p.text(
                pos2(bar.center().x, bar.top() + 24.0),
                Align2::CENTER_CENTER,
                "+",
                FontId::proportional(28.0),
                Color32::from_gray(150),
            );
            p.text(
                pos2(bar.center().x, bar.bottom() - 24.0),
                Align2::CENTER_CENTER,
                "−",
                FontId::proportional(28.0),
                Color32::from_gray(150),
            );
            if v.help {
                let g = wrapped(&p, w.help_text, 26.0, screen.width() * 0.7, Color32::WHITE);
                let r = Rect::from_center_size(screen.center(), g.size() + vec2(48.0, 40.0));
                p.rect_filled(r, 10.0, PANEL);
                p.galley(r.min + vec2(24.0, 20.0), g, Color32::WHITE);
            } else if let Some((x, y)) = v.light_pad {
                // The light's pad: the rim is a grazing light, the dot where the light is.
                let c = screen.center();
                let r = screen.height() * 0.22;
                p.circle_stroke(c, r, Stroke::new(2.0, Color32::from_gray(90)));
                p.circle_filled(c, 4.0, Color32::from_gray(90));
                p.circle_filled(c + r * vec2(x as f32, -y as f32), 12.0, ACCENT);
                p.text(
                    pos2(c.x, c.y + r + 28.0),
                    Align2::CENTER_CENTER,
                    w.light_hint,
                    FontId::proportional(20.0),
                    Color32::from_gray(150),
                );
            } else {
                p.text(
                    screen.center(),
                    Align2::CENTER_CENTER,
                    w.explore_hint,
                    FontId::proportional(22.0),
                    Color32::from_gray(110),
                );
            }
            if let Some((title, text)) = v.caption {
                // At most 6 rows: a long text must not cover the controller's buttons.
                let g = fitted(&p, text, &[22.0], screen.width() * 0.8, 6, Color32::WHITE);
                let t = fitted(&p, title, &[24.0], screen.width() * 0.8, 2, ACCENT);
                let extra = (t.size().y - row_height(&p, 24.0)).max(0.0);
                let top = screen.bottom() - g.size().y - 70.0 - extra;
                let r = Rect::from_min_max(
                    pos2(screen.width() * 0.08, top),
                    pos2(screen.width() * 0.92, screen.bottom() - 12.0),
                );
                p.rect_filled(r, 8.0, PANEL);
                let below = r.min + vec2(16.0, 44.0 + extra);
                p.galley(r.min + vec2(16.0, 10.0), t, ACCENT);
                p.galley(below, g, Color32::WHITE);
            }
        }
        Mode::Attract => {
            let pulse = 0.75 + 0.25 * (ctx.input(|i| i.time) * 2.0).sin() as f32;
            p.text(
                screen.center() - vec2(0.0, 30.0),
                Align2::CENTER_CENTER,
                w.touch_to_explore,
                FontId::proportional(56.0),
                Color32::WHITE.gamma_multiply(pulse),
            );
            if let Some(s) = v.countdown {
                let text = w.countdown.replace("{s}", &format!("{:.0}", s.ceil()));
                p.text(
                    screen.center() + vec2(0.0, 50.0),
                    Align2::CENTER_CENTER,
                    text,
                    FontId::proportional(24.0),
                    Color32::from_gray(160),
                );
            }
        }
    }
    for b in buttons(v.mode) {
        let r = rect_of(b, screen);
        let on = b.kind == ButtonKind::Light && v.light_on;
        p.rect_filled(r, 10.0, if on { ACCENT } else { Color32::from_gray(48) });
        // The bundled fonts have no arrows: draw them.
        let arrow = |at: Pos2, size: f32, left: bool| {
            let d = if left { -size } else { size };
            let pts = vec![at + vec2(d, 0.0), at + vec2(-d * 0.6, -size), at + vec2(-d * 0.6, size)];
            p.add(egui::Shape::convex_polygon(pts, Color32::WHITE, Stroke::NONE));
        };
        match b.kind {
            ButtonKind::Previous => arrow(r.center(), 14.0, true),
            ButtonKind::Next => arrow(r.center(), 14.0, false),
            ButtonKind::Back => arrow(pos2(r.left() + 20.0, r.center().y), 8.0, true),
            _ => {}
        }
        let shift = if b.kind == ButtonKind::Back { vec2(10.0, 0.0) } else { egui::Vec2::ZERO };
        p.text(
            r.center() + shift,
            Align2::CENTER_CENTER,
            label(b.kind),
            FontId::proportional(if b.kind == ButtonKind::Language { 20.0 } else { 26.0 }),
            if on { Color32::BLACK } else { Color32::WHITE },
        );
    }
}

/// An overlay drawing at the view's aspect: full height, centred (the vertical field of view is
/// the view's, so the drawing lines up with the model whatever the window's width).
pub fn overlay(p: &egui::Painter, screen: Rect, t: &TextureHandle, alpha: f32) {
    let s = t.size_vec2();
    let h = screen.height();
    let r = Rect::from_center_size(screen.center(), vec2(h * s.x / s.y.max(1.0), h));
    p.image(t.id(), r, Rect::from_min_max(Pos2::ZERO, pos2(1.0, 1.0)), Color32::WHITE.gamma_multiply(alpha));
}

/// A title and text panel at the bottom of the projection.
pub fn caption(p: &egui::Painter, screen: Rect, title: &str, text: Option<&str>, alpha: f32) {
    let width = screen.width() * 0.6;
    // At most 10 rows (a third of the wall): the model stays in view whatever a text's length.
    let g = text.map(|t| fitted(p, t, &[20.0], width, 10, Color32::WHITE.gamma_multiply(alpha)));
    let t = fitted(p, title, &[30.0], width, 2, ACCENT.gamma_multiply(alpha));
    // What a title longer than one row adds to the panel.
    let extra = (t.size().y - row_height(p, 30.0)).max(0.0);
    let h = 54.0 + extra + g.as_ref().map_or(0.0, |g| g.size().y + 8.0);
    let r = Rect::from_min_size(pos2(24.0, screen.bottom() - h - 24.0), vec2(width + 32.0, h));
    p.rect_filled(r, 8.0, PANEL.gamma_multiply(alpha));
    let below = r.min + vec2(16.0, 50.0 + extra);
    p.galley(r.min + vec2(16.0, 10.0), t, ACCENT.gamma_multiply(alpha));
    if let Some(g) = g {
        p.galley(below, g, Color32::WHITE);
    }
}

/// The suggestion inset as drawn.
pub struct Inset {
    /// The inset's render.
    pub id: egui::TextureId,
    /// Its aspect ratio.
    pub aspect: f32,
    /// Opacity (fade in/out).
    pub alpha: f32,
    /// Size factor (zooms in as it appears).
    pub scale: f32,
    /// The proposed node's title.
    pub title: String,
}

/// The suggestion inset (thesis 11.4.2) in the top-right corner.
pub fn inset(p: &egui::Painter, screen: Rect, inset: &Inset, hint: &str) {
    let Inset { id, aspect, alpha, scale, ref title } = *inset;
    let w = screen.width() * 0.3 * scale;
    let size = vec2(w, w / aspect);
    let r = Rect::from_min_size(pos2(screen.right() - size.x - 24.0, 24.0), size);
    p.rect_filled(r.expand(3.0), 4.0, ACCENT.gamma_multiply(alpha));
    p.image(id, r, Rect::from_min_max(Pos2::ZERO, pos2(1.0, 1.0)), Color32::WHITE.gamma_multiply(alpha));
    p.text(
        pos2(r.left(), r.bottom() + 8.0),
        Align2::LEFT_TOP,
        title,
        FontId::proportional(22.0),
        Color32::WHITE.gamma_multiply(alpha),
    );
    p.text(
        pos2(r.left(), r.bottom() + 36.0),
        Align2::LEFT_TOP,
        hint,
        FontId::proportional(16.0),
        Color32::from_gray(200).gamma_multiply(alpha),
    );
}

/// Opacity of a node's overlay and caption while the radial menu is open over them: the menu's
/// labels would otherwise cross the overlay's.
pub const UNDER_MENU: f32 = 0.2;

/// Where the radial menu puts candidate `i` of `n`: clockwise from the top around the centre.
pub fn slot_rect(screen: Rect, i: usize, n: usize) -> Rect {
    let a = i as f32 * std::f32::consts::TAU / n.max(1) as f32;
    let at = screen.center() + screen.height() * 0.3 * vec2(a.sin(), -a.cos());
    Rect::from_center_size(at, vec2(screen.height() * 0.22, screen.height() * 0.22 * 9.0 / 16.0))
}

/// The radial menu of nearby views: thumbnails clockwise from the top, the pointed one
/// highlighted.
pub fn radial(
    p: &egui::Painter,
    screen: Rect,
    items: &[(Option<TextureHandle>, String)],
    pointed: Option<usize>,
) {
    let c = screen.center();
    let radius = screen.height() * 0.3;
    p.circle_filled(c, 10.0, Color32::from_white_alpha(160));
    if items.is_empty() {
        p.circle_stroke(c, radius * 0.4, Stroke::new(2.0, Color32::from_white_alpha(120)));
        return;
    }
    let n = items.len();
    for (i, (thumb, title)) in items.iter().enumerate() {
        let r = slot_rect(screen, i, n);
        let (at, size) = (r.center(), r.size());
        let on = pointed == Some(i);
        p.line_segment(
            [c, at],
            Stroke::new(if on { 3.0 } else { 1.0 }, Color32::from_white_alpha(if on { 220 } else { 90 })),
        );
        p.rect_filled(
            r.expand(if on { 5.0 } else { 2.0 }),
            4.0,
            if on { ACCENT } else { Color32::from_gray(200) },
        );
        match thumb {
            Some(t) => {
                p.image(t.id(), r, Rect::from_min_max(Pos2::ZERO, pos2(1.0, 1.0)), Color32::WHITE);
            }
            None => {
                p.rect_filled(r, 0.0, Color32::from_gray(40));
            }
        }
        let tr = Rect::from_center_size(pos2(at.x, r.bottom() + 18.0), vec2(size.x + 20.0, 26.0));
        p.rect_filled(tr, 4.0, PANEL);
        p.text(
            tr.center(),
            Align2::CENTER_CENTER,
            title,
            FontId::proportional(17.0),
            if on { ACCENT } else { Color32::WHITE },
        );
    }
}

/// A small banner at the top of the projection (e.g. during the attract loop).
pub fn banner(p: &egui::Painter, screen: Rect, text: &str) {
    let g = p.layout_no_wrap(text.to_string(), FontId::proportional(22.0), Color32::WHITE);
    let r = Rect::from_center_size(pos2(screen.center().x, 36.0), g.size() + vec2(28.0, 14.0));
    p.rect_filled(r, 14.0, PANEL);
    p.galley(r.min + vec2(14.0, 7.0), g, Color32::WHITE);
}
