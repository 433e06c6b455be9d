//! The kiosk: a projection window (the model, overlays, the suggestion inset, the radial menu,
//! titles) and a controller window (touch: help, back, language, gallery, captions), driven by
//! the core's [`Kiosk`] at a fixed 60 Hz clock, with narration through kira.
//!
//! The light: each frame the renderer gets the exploration's light ([`kiosk_core::light`]:
//! direction and weight of the user light); the gallery's turntable gets the light a visit
//! starts with (fixed to the model as it turns), a thumbnail its node's stored light or that
//! start light, the suggestion inset the proposed node's light or the current one.
//!
//! The same touch events that drive the windows are what `--record` writes and what `--session`
//! plays back, so a recorded visit replays through the real windows, and through `kiosk replay`.
//!
//! The windows open first and say the kiosk is preparing while the exhibits load, or that the
//! exhibition is closed while none can be ([`preparing`]);
//! Ctrl+Q, closing a window or a signal (SIGTERM, SIGINT, SIGHUP) ends the kiosk the same way, the
//! visit in progress logged.

pub mod config;
mod draw;
mod drive;
mod exhibits;
mod graphics;
pub mod heap;
mod paint;
mod preparing;
mod surface;
mod visits;

use anyhow::Context as _;
use config::Config;
pub use exhibits::{Exhibit, Status, kiosk_settings};
use graphics::{Graphics, Windows};
use kiosk_content::snapshot::{lit, node_light, start_light};
use kiosk_core::camera::{GoTo, SceneRef};
use kiosk_core::clock::Stepper;
use kiosk_core::gesture::{TouchEvent, TouchKind};
use kiosk_core::kiosk::{Kiosk, KioskEffect, Mode, ModelRef};
use kiosk_core::light::Light;
use kiosk_core::recommend::RecState;
use kiosk_core::session::Session;
use kiosk_core::{Cut, CutParams};
use kiosk_render::{RenderSettings, wgpu};
use std::collections::HashSet;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, MouseButton, TouchPhase, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::window::{Fullscreen, Window, WindowId};

/// Where the projection shows radial-menu candidate `i` of `n` in a canvas of `size` pixels:
/// `[x0, y0, x1, y1]` (for tests that look at screenshots).
pub fn radial_slot_px(size: (u32, u32), i: usize, n: usize) -> [f32; 4] {
    let screen = egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(size.0 as f32, size.1 as f32));
    let r = draw::slot_rect(screen, i, n);
    [r.min.x, r.min.y, r.max.x, r.max.y]
}

/// Size of the suggestion inset's render (pixels).
const INSET_SIZE: (u32, u32) = (384, 216);
/// Phases of the inset (seconds): fade in, path animation, fade out.
const INSET_FADE: f64 = 0.6;
const INSET_PATH: f64 = 2.5;

/// How the kiosk runs.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// Configuration.
    pub config: Config,
    /// Ordinary windows instead of fullscreen.
    pub windowed: bool,
    /// Record the visitors' touches here (JSON Lines session).
    pub record: Option<PathBuf>,
    /// Play this session through the windows and exit when it ends.
    pub session: Option<Session>,
    /// Session times at which to save both windows as PNG.
    pub screenshot_at: Vec<f64>,
    /// Where screenshots go.
    pub screenshot_dir: PathBuf,
    /// Clock speed (1 = real time; larger for accelerated tests).
    pub speed: f64,
    /// Repeat the session until this much kiosk time has passed (soak runs).
    pub run_for: Option<f64>,
    /// Never open an audio device.
    pub silent: bool,
    /// Soak runs: kiosk time after which the RSS is taken as the reference.
    pub warmup: f64,
    /// Write the kiosk's trace here (JSON Lines, one line per 60 Hz frame).
    pub trace: Option<PathBuf>,
}

/// Signals received (SIGINT, SIGTERM or SIGHUP: a service stopped, the machine shutting down).
/// At the first the kiosk closes as on Ctrl+Q, at its next frame (within a quarter of a second
/// while it prepares); a second, when it has not (a frame stuck on the GPU, Ctrl+C pressed
/// again), ends the process at once, without its imports' work directories.
static STOPS: AtomicU32 = AtomicU32::new(0);

/// Runs the kiosk until the window closes (or the session ends, or a signal stops it).
pub fn run(opts: RunOptions) -> anyhow::Result<()> {
    heap::settle();
    let stop = || {
        if STOPS.fetch_add(1, Ordering::SeqCst) > 0 {
            kiosk_content::import::remove_work_dirs();
            std::process::exit(130);
        }
    };
    if let Err(e) = ctrlc::set_handler(stop) {
        tracing::warn!("cannot close cleanly on signals ({e}): a stopped kiosk loses the visit in progress");
    }
    let event_loop = EventLoop::new().context("cannot open the display (is DISPLAY set?)")?;
    // The exhibits load while the windows say so.
    let loader = preparing::Loader::spawn(opts.config.clone(), opts.session.is_none())?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let mut app = App {
        opts,
        loader,
        exhibits: Vec::new(),
        joining: Vec::new(),
        display: None,
        state: None,
        ctrl: false,
        stopping: false,
        closed: None,
        closed_reason: None,
        error: None,
    };
    event_loop.run_app(&mut app)?;
    match app.state.as_mut() {
        // The visit in progress ends with the kiosk; its statistics are kept.
        Some(s) => s.persist(&app.exhibits, true),
        None if app.error.is_some() => {}
        None if app.closed.is_some() => tracing::info!("closed with no exhibit to show"),
        None => tracing::info!("closed while preparing the exhibits"),
    }
    // An import under way (before the gallery, or behind it) stops with the process, without
    // its work directory; the next start imports again.
    kiosk_content::import::remove_work_dirs();
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

struct App {
    opts: RunOptions,
    /// The exhibits loading ([`preparing`]).
    loader: preparing::Loader,
    /// The gallery once loaded, borrowed by the kiosk: each exhibit is kept until the process
    /// ends (the kiosk holds its models while it lives), so leaked when it comes.
    exhibits: Vec<&'static Exhibit>,
    /// Exhibits imported behind the gallery, waiting for nobody to be at the kiosk to join it.
    joining: Vec<Exhibit>,
    /// The windows while the exhibits load.
    display: Option<Display>,
    /// The kiosk, once the exhibits are loaded.
    state: Option<Running<'static>>,
    /// Whether Ctrl is held (for Ctrl+Q).
    ctrl: bool,
    /// Whether a signal's close was logged.
    stopping: bool,
    /// No exhibit could be loaded: the exhibition is closed until they are tried again.
    closed: Option<preparing::Closed>,
    /// Why it was last closed (logged once while it stays the same).
    closed_reason: Option<String>,
    error: Option<anyhow::Error>,
}

/// The windows and the device they draw with, open before the exhibits are loaded.
struct Display {
    /// The device and everything drawn with it, renewed at each reset ([`graphics`]).
    gfx: Graphics,
    instance: wgpu::Instance,
    adapter: wgpu::Adapter,
    /// The second of loading (from 0) the preparing screen was last drawn in.
    drawn: Option<u64>,
    /// Whether the preparing screen must be drawn again now (a window was resized).
    redraw: bool,
    /// Whether the screen saying the exhibition is closed was saved with the screenshots.
    closed_saved: bool,
}

/// Everything that exists once the windows are open and the exhibits loaded.
struct Running<'a> {
    /// The device and everything drawn with it, renewed at each reset ([`graphics`]).
    gfx: Graphics,
    instance: wgpu::Instance,
    adapter: wgpu::Adapter,
    /// Whether a reset asked for the graphics to be renewed after this tick.
    renew: bool,
    kiosk: Kiosk<'a, memmap2::Mmap>,
    narrator: kiosk_content::audio::Narrator,
    start: Instant,
    /// Kiosk time of the last 60 Hz step.
    sim_t: f64,
    /// The core's fixed-clock loop (the one replays step by), with live touches and the
    /// recorded session as its input.
    drive: Stepper<drive::Input>,
    /// The trace, screenshots and soak reports.
    probes: drive::Probes,
    /// The mouse, a finger of its own.
    pointer: drive::Pointer,
    gallery_cut: Option<(usize, Cut)>,
    render_settings: RenderSettings,
    reported: HashSet<String>,
    /// Frames rendered (both windows).
    rendered: u64,
    /// The last frame's submission, waited for before the next frame.
    in_flight: Option<wgpu::SubmissionIndex>,
    /// The statistics and the visit log.
    visits: visits::VisitLog,
}

impl App {
    /// Opens both windows and a device on an adapter that can present to them.
    fn open(&self, el: &ActiveEventLoop) -> anyhow::Result<Display> {
        let cfg = &self.opts.config;
        let monitors: Vec<_> = el.available_monitors().collect();
        let attrs = |title: &str, w: &config::WindowConfig, x: i32| {
            let mut a = Window::default_attributes().with_title(title);
            if self.opts.windowed || !w.fullscreen {
                a = a
                    .with_inner_size(winit::dpi::PhysicalSize::new(w.size[0], w.size[1]))
                    .with_position(winit::dpi::PhysicalPosition::new(x, 0));
            } else {
                let m = monitors.get(w.monitor).or_else(|| {
                    tracing::warn!(
                        "{title}: monitor {} not found ({} present); using the first",
                        w.monitor,
                        monitors.len()
                    );
                    monitors.first()
                });
                if let Some(m) = m {
                    // Without a window manager, fullscreen moves but does not resize: say both.
                    a = a
                        .with_fullscreen(Some(Fullscreen::Borderless(Some(m.clone()))))
                        .with_position(m.position())
                        .with_inner_size(m.size())
                        .with_decorations(false);
                }
            }
            a
        };
        let pw = Arc::new(el.create_window(attrs("IsoKiosk — projection", &cfg.projection, 0))?);
        let cw = Arc::new(el.create_window(attrs(
            "IsoKiosk — controller",
            &cfg.controller,
            cfg.projection.size[0] as i32 + 8,
        ))?);
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN | wgpu::Backends::GL,
            // wgpu validates every call itself; the Vulkan layers stay off in the kiosk (the render
            // tests run with them), set WGPU_VALIDATION=1 to turn them on.
            flags: wgpu::InstanceFlags::empty().with_env(),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        // An adapter that can present to the projection window (the surface only asks).
        let probe = instance.create_surface(pw.clone())?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: Some(&probe),
            apply_limit_buckets: false,
        }))
        .context("no GPU adapter for the windows")?;
        drop(probe);
        let gfx =
            Graphics::new(&instance, &adapter, &Windows { projection: pw, controller: cw, config: cfg })?;
        tracing::info!("GPU: {} ({:?})", gfx.gpu.adapter.name, gfx.gpu.adapter.backend);
        if !self.opts.screenshot_at.is_empty() {
            std::fs::create_dir_all(&self.opts.screenshot_dir)
                .with_context(|| format!("cannot create {}", self.opts.screenshot_dir.display()))?;
        }
        Ok(Display { gfx, instance, adapter, drawn: None, redraw: false, closed_saved: false })
    }

    /// Draws the preparing screen when it is due (its first frame at once, saved with the
    /// screenshots if there are any), and starts the kiosk once the exhibits are loaded. When
    /// none could be, the screen says the exhibition is closed and the exhibits are tried again
    /// after `retry_after_secs` ([`preparing::Closed`]).
    fn prepare(&mut self, el: &ActiveEventLoop) {
        // After an error, the loop is ending: nothing more to draw or start (winit may still
        // call back within this turn).
        if self.error.is_some() {
            return;
        }
        let Some(d) = self.display.as_mut() else { return };
        if let Some(c) = self.closed.as_mut()
            && c.due()
        {
            if preparing::content_fingerprint(&self.opts.config) == c.fingerprint() {
                c.wait_again();
                return;
            }
            tracing::info!("the content changed: trying the exhibits again");
            match preparing::Loader::spawn(self.opts.config.clone(), self.opts.session.is_none()) {
                Ok(loader) => self.loader = loader,
                Err(e) => {
                    self.error = Some(e);
                    el.exit();
                    return;
                }
            }
            c.retrying();
        }
        let mut done = None;
        let mut newly_closed = false;
        if self.closed.as_ref().is_none_or(|c| c.is_retrying()) {
            match self.loader.poll() {
                // A session played or a soak run: a test, not a museum; it ends with the reason.
                Some(Err(e)) if self.opts.session.is_some() || self.opts.run_for.is_some() => {
                    self.error = Some(e);
                    el.exit();
                    return;
                }
                Some(Err(e)) => {
                    let retry = self.opts.config.retry_after_secs;
                    let closed = preparing::Closed::new(format!("{e:#}"), retry, self.loader.fingerprint);
                    // Said (and drawn) once for as long as the reason stays the same: the kiosk
                    // may wait for its content for days.
                    if self.closed_reason.as_deref() != Some(closed.reason()) {
                        tracing::error!(
                            "{}: the exhibition is closed; the exhibits are tried again when the content \
                             changes (looked at every {retry} s)",
                            closed.reason(),
                        );
                        self.closed_reason = Some(closed.reason().to_string());
                        d.redraw = true;
                    }
                    newly_closed = self.closed.is_none();
                    d.redraw |= newly_closed;
                    self.closed = Some(closed);
                }
                Some(Ok(exhibits)) => done = Some(exhibits),
                // Trying again takes long (an import, a slow disk): say so.
                None if self.closed.is_some() && self.loader.elapsed() > preparing::SAY_PREPARING => {
                    self.closed = None;
                    d.redraw = true;
                }
                None => {}
            }
        }
        let first = d.drawn.is_none();
        let second = (self.loader.elapsed() / preparing::FRAME.as_secs_f64()) as u64;
        // Closed, the screen stays still: drawn again only when it changes.
        let tick = self.closed.is_none() && d.drawn != Some(second);
        if first || (done.is_none() && (d.redraw || tick)) {
            d.drawn = Some(second);
            d.redraw = false;
            let detail = match &self.closed {
                Some(c) => c.detail(),
                None => self.loader.detail(),
            };
            let view = draw::PreparingView {
                languages: &self.opts.config.languages,
                closed: self.closed.is_some(),
                t: self.loader.elapsed(),
                detail: Some(&detail),
            };
            d.gfx.draw_preparing(&view);
            if first && self.closed.is_some() {
                tracing::info!("windows open: the exhibition is closed");
            } else if first {
                tracing::info!("windows open: preparing the exhibits");
            }
            // The first frame, and the first that says the exhibition is closed (both, when no
            // exhibit could be loaded before the first).
            let closed_shot = newly_closed && !std::mem::replace(&mut d.closed_saved, true);
            let tags = [first.then_some("preparing"), closed_shot.then_some("closed")];
            if !self.opts.screenshot_at.is_empty()
                && let Err(e) = tags
                    .into_iter()
                    .flatten()
                    .try_for_each(|tag| d.gfx.capture(&self.opts.screenshot_dir, tag))
            {
                self.error = Some(e);
                el.exit();
                return;
            }
        }
        let Some(gallery) = done else {
            el.set_control_flow(ControlFlow::WaitUntil(Instant::now() + preparing::POLL));
            return;
        };
        let later = match gallery.waiting {
            0 => String::new(),
            n => format!("; {n} more join it once imported"),
        };
        tracing::info!(
            "the gallery opens: {} exhibit(s), loaded in {:.1} s{later}",
            gallery.exhibits.len(),
            self.loader.elapsed()
        );
        self.exhibits = gallery.exhibits.into_iter().map(leaked).collect();
        let started = match self.display.take() {
            Some(d) => self.start(d),
            None => return,
        };
        match started {
            Ok(s) => {
                self.state = Some(s);
                el.set_control_flow(ControlFlow::Poll);
            }
            Err(e) => {
                self.error = Some(e);
                el.exit();
            }
        }
    }

    /// The kiosk on the open windows, with the exhibits loaded.
    fn start(&self, d: Display) -> anyhow::Result<Running<'static>> {
        let Display { gfx, instance, adapter, .. } = d;
        let cfg = &self.opts.config;
        let ctrl = gfx.controller.canvas.size;
        let seed = self
            .opts
            .session
            .as_ref()
            .and_then(|s| s.header.as_ref())
            .and_then(|h| h.seed)
            .unwrap_or(cfg.seed);
        let settings = kiosk_settings(
            cfg,
            gfx.projection.canvas.size,
            f64::from(ctrl.0) / f64::from(ctrl.1.max(1)),
            seed,
        );
        let fps = settings.explore.fps;
        let mut kiosk = Kiosk::new(settings, models(&self.exhibits), 0.0);
        let visits = visits::VisitLog::open(cfg.state_dir(), self.opts.speed, &self.exhibits, &mut kiosk);
        let narrator = kiosk_content::audio::Narrator::new(cfg.volume, self.opts.silent);
        let record = match &self.opts.record {
            Some(p) => {
                let f = std::fs::File::create(p).with_context(|| format!("cannot create {}", p.display()))?;
                let mut w = std::io::BufWriter::new(f);
                writeln!(
                    w,
                    "{{\"session\":1,\"exhibit\":{:?},\"seed\":{seed}}}",
                    cfg.content.display().to_string()
                )?;
                w.flush()?;
                Some(w)
            }
            None => None,
        };
        let trace = match &self.opts.trace {
            Some(p) => Some(std::io::BufWriter::new(
                std::fs::File::create(p).with_context(|| format!("cannot create {}", p.display()))?,
            )),
            None => None,
        };
        let input = drive::Input::new(self.opts.session.clone(), self.opts.run_for.is_some(), record);
        let soak = self.opts.run_for.map(|_| self.opts.warmup);
        let probes = drive::Probes::new(trace, self.opts.screenshot_at.clone(), soak, visits.dir());
        Ok(Running {
            gfx,
            instance,
            adapter,
            renew: false,
            kiosk,
            narrator,
            start: Instant::now(),
            sim_t: 0.0,
            drive: Stepper::new(fps, input),
            probes,
            pointer: drive::Pointer::default(),
            gallery_cut: None,
            render_settings: self.opts.config.render_settings(),
            reported: HashSet::new(),
            rendered: 0,
            in_flight: None,
            visits,
        })
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, el: &ActiveEventLoop) {
        if self.state.is_some() || self.display.is_some() {
            return;
        }
        match self.open(el) {
            Ok(d) => {
                self.display = Some(d);
                self.prepare(el);
            }
            Err(e) => {
                self.error = Some(e);
                el.exit();
            }
        }
    }

    fn window_event(&mut self, el: &ActiveEventLoop, id: WindowId, event: WindowEvent) {
        // The windows' own events, while preparing too.
        let gfx = match (&mut self.state, &mut self.display) {
            (Some(s), _) => &mut s.gfx,
            (None, Some(d)) => &mut d.gfx,
            (None, None) => return,
        };
        let on_controller = id == gfx.controller.window.id();
        match event {
            WindowEvent::CloseRequested => {
                el.exit();
                return;
            }
            WindowEvent::Resized(size) => {
                let w = if on_controller { &mut gfx.controller } else { &mut gfx.projection };
                w.resize(&gfx.gpu, (size.width, size.height));
                // A new canvas is blank: the preparing screen is drawn again at once.
                if let Some(d) = self.display.as_mut() {
                    d.redraw = true;
                }
                return;
            }
            WindowEvent::ModifiersChanged(m) => {
                self.ctrl = m.state().control_key();
                return;
            }
            WindowEvent::KeyboardInput { event, .. } => {
                // Ctrl+Q, or Escape in windowed mode, closes the kiosk (technicians, not visitors).
                if event.state == ElementState::Pressed
                    && self.ctrl
                    && let winit::keyboard::Key::Character(c) = &event.logical_key
                    && c.as_str().eq_ignore_ascii_case("q")
                {
                    el.exit();
                }
                if self.opts.windowed
                    && event.logical_key == winit::keyboard::Key::Named(winit::keyboard::NamedKey::Escape)
                {
                    el.exit();
                }
                return;
            }
            _ => {}
        }
        // Touches and the mouse, once the kiosk runs.
        let Some(s) = self.state.as_mut() else { return };
        match event {
            _ if !on_controller || self.opts.session.is_some() => {}
            WindowEvent::Touch(t) => {
                let (x, y) = s.normalised(t.location.x, t.location.y);
                let ev = match t.phase {
                    TouchPhase::Started => TouchKind::Down,
                    TouchPhase::Moved => TouchKind::Move,
                    TouchPhase::Ended => TouchKind::Up,
                    TouchPhase::Cancelled => TouchKind::Cancel,
                };
                s.input(TouchEvent { t: s.kiosk_time(self.opts.speed), ev, id: t.id as i64, x, y });
            }
            WindowEvent::CursorMoved { position, .. } => {
                let size = s.gfx.controller.window.inner_size();
                let inside = (0.0..f64::from(size.width)).contains(&position.x)
                    && (0.0..f64::from(size.height)).contains(&position.y);
                let (x, y) = s.normalised(position.x, position.y);
                if let Some(e) = s.pointer.moved(s.kiosk_time(self.opts.speed), x, y, inside) {
                    s.input(e);
                }
            }
            WindowEvent::CursorLeft { .. } => s.pointer.over_window(false),
            WindowEvent::CursorEntered { .. } => s.pointer.over_window(true),
            WindowEvent::MouseInput { state, button, .. } => {
                let t = s.kiosk_time(self.opts.speed);
                let pressed = state == ElementState::Pressed;
                match button {
                    MouseButton::Left => {
                        if let Some(e) = s.pointer.left(t, pressed) {
                            s.input(e);
                        }
                    }
                    MouseButton::Right if pressed => {
                        let e = s.pointer.right(t);
                        s.input(e);
                    }
                    _ => {}
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, el: &ActiveEventLoop) {
        if STOPS.load(Ordering::SeqCst) > 0 {
            if !self.stopping {
                tracing::info!("a signal asks the kiosk to close: closing");
                self.stopping = true;
            }
            el.exit();
            return;
        }
        let Some(s) = self.state.as_mut() else { return self.prepare(el) };
        match self.loader.more() {
            Some(more) if more.is_empty() => tracing::error!(
                "no exhibit imported behind the gallery could be loaded (see above); the gallery stays as it is"
            ),
            Some(more) => {
                let names: Vec<String> = more.iter().map(|e| e.dir.display().to_string()).collect();
                tracing::info!(
                    "imported behind the gallery: {}; they join it when nobody is at the kiosk",
                    names.join(", ")
                );
                self.joining.extend(more);
            }
            None => {}
        }
        // Nobody at the kiosk: the gallery idle as long as the reset waits.
        if !self.joining.is_empty()
            && s.kiosk.mode() == Mode::Gallery
            && s.kiosk.visit().is_none()
            && s.kiosk.idle_secs() >= s.kiosk.settings.reset_after_secs
        {
            self.exhibits.extend(self.joining.drain(..).map(leaked));
            self.exhibits.sort_by_key(|e| e.place);
            s.regallery(&self.exhibits);
            tracing::info!("the gallery now holds {} exhibits", self.exhibits.len());
        }
        match s.tick(&self.opts, &self.exhibits) {
            Ok(true) if s.renew => {
                if let Some(s) = self.state.take() {
                    match s.renewed(&self.opts.config) {
                        Ok(s) => self.state = Some(s),
                        Err(e) => {
                            self.error = Some(e.context("renewing the GPU device at a reset"));
                            el.exit();
                        }
                    }
                }
            }
            Ok(true) => {}
            Ok(false) => el.exit(),
            Err(e) => {
                self.error = Some(e);
                el.exit();
            }
        }
    }
}

/// An exhibit kept for the rest of the process: the kiosk borrows its model while it lives.
fn leaked(e: Exhibit) -> &'static Exhibit {
    Box::leak(Box::new(e))
}

/// The kiosk's models: the gallery's exhibits, in order.
fn models(exhibits: &[&'static Exhibit]) -> Vec<ModelRef<'static, memmap2::Mmap>> {
    exhibits
        .iter()
        .map(|e| ModelRef { store: &e.store, graph: e.graph.as_ref(), up: e.up, front: e.front })
        .collect()
}

impl Running<'static> {
    /// The kiosk anew on a gallery of other `exhibits` (exhibits imported behind it join), in
    /// the gallery with the same settings at the same time; the statistics and visit log go on.
    fn regallery(&mut self, exhibits: &[&'static Exhibit]) {
        let mut kiosk = Kiosk::new(self.kiosk.settings.clone(), models(exhibits), self.sim_t);
        self.visits.hand_stats(exhibits, &mut kiosk);
        self.kiosk = kiosk;
        self.gallery_cut = None;
    }
}

impl Running<'_> {
    /// The same kiosk on a new device: the old device and all it holds are released first (a
    /// window presents through one surface at a time), then everything is made again.
    fn renewed(mut self, config: &Config) -> anyhow::Result<Self> {
        let windows = Windows {
            projection: self.gfx.projection.window.clone(),
            controller: self.gfx.controller.window.clone(),
            config,
        };
        self.in_flight = None;
        drop(self.gfx);
        heap::trim();
        self.gfx = Graphics::new(&self.instance, &self.adapter, &windows)?;
        self.renew = false;
        tracing::info!("reset: GPU device renewed");
        Ok(self)
    }

    /// Kiosk time now.
    fn kiosk_time(&self, speed: f64) -> f64 {
        self.start.elapsed().as_secs_f64() * speed.max(1e-3)
    }

    fn normalised(&self, x: f64, y: f64) -> (f64, f64) {
        let size = self.gfx.controller.window.inner_size();
        let u = (x / f64::from(size.width.max(1))).clamp(0.0, 1.0);
        let v = (y / f64::from(size.height.max(1))).clamp(0.0, 1.0);
        self.gfx.controller.to_canvas(u, v)
    }

    /// A live touch: recorded (`--record`) and queued for its step.
    fn input(&mut self, e: TouchEvent) {
        if let Err(err) = self.drive.source().push(e) {
            self.report("record", &format!("cannot write the session record; recording stops: {err}"));
        }
    }

    /// Steps the core up to the clock, renders, and takes due screenshots. `false` = done.
    fn tick(&mut self, opts: &RunOptions, exhibits: &[&Exhibit]) -> anyhow::Result<bool> {
        let dt = self.drive.clock().dt();
        let now = self.kiosk_time(opts.speed);
        let end = self.drive.source().end(opts.run_for);
        let mut stepped = false;
        while let Some(t) = self.drive.next(now, &mut self.kiosk) {
            let before = self.kiosk.mode();
            let frame = self.kiosk.step(t);
            if before != Mode::Gallery
                && frame.mode == Mode::Gallery
                && frame.explore.is_none()
                && self.kiosk.idle_secs() >= self.kiosk.settings.reset_after_secs
            {
                // The reset, nobody in front of the kiosk: the device is renewed after this
                // tick ([`graphics`]).
                self.renew = graphics::renewal_wanted();
            }
            for fx in &frame.effects {
                self.effect(fx, exhibits);
            }
            self.persist(exhibits, false);
            self.sim_t = t;
            stepped = true;
            self.probes.stepped(&frame, t, self.drive.clock().steps(), dt)?;
            if let Some(at) = self.probes.screenshot_due(t) {
                self.render(exhibits, t)?;
                self.gfx.capture(&opts.screenshot_dir, &format!("{at:.1}"))?;
            }
            if end.is_some_and(|e| t >= e) {
                break;
            }
        }
        if stepped {
            self.render(exhibits, self.sim_t)?;
        }
        if let Some(e) = end
            && self.sim_t >= e
        {
            self.probes.finish(
                self.sim_t,
                self.start.elapsed().as_secs_f64(),
                self.drive.clock().steps(),
                self.rendered,
            )?;
            return Ok(false);
        }
        Ok(true)
    }

    /// Writes the visits that ended (and, `exit`, the one in progress) to the log, and the
    /// statistics of the exhibits they explored ([`visits`]).
    fn persist(&mut self, exhibits: &[&Exhibit], exit: bool) {
        if exit {
            self.kiosk.end_visit(self.sim_t, kiosk_core::stats::VisitEnd::Exit);
        }
        let reported = &mut self.reported;
        self.visits.persist(&mut self.kiosk, exhibits, exit, &mut |what, e| report_once(reported, what, &e));
    }

    fn effect(&mut self, fx: &KioskEffect, exhibits: &[&Exhibit]) {
        match fx {
            KioskEffect::PlayNarration { model, node, lang } => {
                let Some(ex) = exhibits.get(*model) else { return };
                let Some(g) = ex.graph.as_ref() else { return };
                match g.nodes.get(*node).and_then(|n| n.narration.get(lang, &g.default_lang)) {
                    Some(file) => match media(&mut self.reported, &ex.dir, file) {
                        // A broken file is logged once by the narrator; captions still show.
                        Some(path) => drop(self.narrator.play(&path)),
                        None => self.narrator.stop(),
                    },
                    None => self.narrator.stop(),
                }
            }
            KioskEffect::StopNarration => self.narrator.stop(),
        }
    }

    fn report(&mut self, what: &str, e: &dyn std::fmt::Display) {
        report_once(&mut self.reported, what, e);
    }

    /// Logs, once each, the nodes of `ex`'s model the renderer found corrupt.
    fn report_corrupt(&mut self, ex: &Exhibit) {
        for why in self.gfx.renderer.corrupt_nodes().values() {
            let what = format!("{} (its model)", ex.dir.display());
            report_once(&mut self.reported, &what, &format!("{why}; drawn as its nearest sound ancestor"));
        }
    }

    /// Renders both windows' canvases and presents them.
    fn render(&mut self, exhibits: &[&Exhibit], t: f64) -> anyhow::Result<()> {
        self.rendered += 1;
        // At most one frame in flight: without vsync (Xvfb, some drivers) presenting does not
        // throttle, and frames submitted faster than the GPU draws them pile up in its queue —
        // memory grew without bound in the soak run until this wait.
        if let Some(index) = self.in_flight.take()
            && let Err(e) = self
                .gfx
                .gpu
                .device
                .poll(wgpu::PollType::Wait { submission_index: Some(index), timeout: None })
        {
            self.report("GPU wait", &e);
        }
        self.render_projection(exhibits, t);
        self.render_controller(exhibits, t);
        if let Err(e) = self.gfx.gpu.check() {
            self.report("GPU", &e);
        }
        if let Err(e) = self.gfx.projection.present(&self.gfx.gpu, &self.gfx.blit) {
            self.report("projection window", &e);
        }
        if let Err(e) = self.gfx.controller.present(&self.gfx.gpu, &self.gfx.blit) {
            self.report("controller window", &e);
        }
        self.in_flight = Some(self.gfx.gpu.queue.submit([]));
        Ok(())
    }

    fn render_projection(&mut self, exhibits: &[&Exhibit], t: f64) {
        let size = self.gfx.projection.canvas.size;
        let model = self.kiosk.model();
        let Some(ex) = exhibits.get(model) else { return };
        let store = &ex.store;
        let lang = self.kiosk.lang().to_string();
        // The model: the exploration's camera, cut and light, or the gallery's slow turntable.
        let camera;
        let nodes;
        let mut settings = self.render_settings;
        match self.kiosk.explorer() {
            Some(x) => {
                camera = x.camera();
                settings = lit(settings, x.light());
                nodes = camera
                    .view_params(store, size)
                    .map(|v| x.cut().visible_nodes(store, &v))
                    .unwrap_or_default();
            }
            None => {
                let fov = self.kiosk.settings.explore.fov_y;
                // The gallery's turntable, about the model's own up axis.
                let c0 = ex.start_camera(fov);
                camera = kiosk_core::camera::turntable(c0, ex.up, t);
                settings = lit(settings, start_light(&c0));
                if self.gallery_cut.as_ref().is_none_or(|(m, _)| *m != model) {
                    self.gallery_cut = Some((model, Cut::root(store)));
                }
                let params = CutParams {
                    tolerance_px: self.kiosk.settings.explore.cut.tolerance_px,
                    ..CutParams::default()
                };
                nodes = match (self.gallery_cut.as_mut(), camera.view_params(store, size)) {
                    (Some((_, cut)), Some(v)) => {
                        cut.update(store, &v, &params);
                        cut.visible_nodes(store, &v)
                    }
                    _ => Vec::new(),
                };
            }
        }
        let canvas = &self.gfx.projection.canvas;
        match self.gfx.renderer.render(&self.gfx.gpu, store, &nodes, &camera, &canvas.view, size, &settings) {
            Err(e) => self.report("render", &e),
            Ok(stats) if stats.corrupt > 0 => self.report_corrupt(ex),
            Ok(_) => {}
        }
        // The suggestion inset: fade in, the path from here to the proposed view, hold, fade out.
        let mut inset = None;
        let rec = self.kiosk.explorer().and_then(|x| x.recommender()).map(|r| r.state);
        if let (Some(RecState::Propose { node, since }), Some(g), Some(x)) =
            (rec, ex.graph.as_ref(), self.kiosk.explorer())
        {
            let age = t - since;
            let total = self.kiosk.settings.explore.recommend.propose_secs;
            let alpha = (age / INSET_FADE).min((total - age) / INSET_FADE).clamp(0.0, 1.0);
            let path = GoTo {
                from: x.camera(),
                to: g.nodes[node].view,
                start: since + INSET_FADE,
                duration: INSET_PATH,
            };
            let cam = path.camera_at(t, SceneRef { store, cut: x.cut() }, x.min_distance());
            // The proposed view in its own light, if it has one; else in the current light.
            let light = match g.nodes[node].light {
                Some(dir) => Light { dir, mix: kiosk_core::light::ACTIVE_MIX },
                None => x.light(),
            };
            let inset_settings = lit(self.render_settings, light);
            if let Err(e) = self.gfx.renderer.render(
                &self.gfx.gpu,
                store,
                x.cut().nodes(),
                &cam,
                &self.gfx.inset.view,
                INSET_SIZE,
                &inset_settings,
            ) {
                self.report("inset render", &e);
            }
            let title =
                g.nodes[node].title.get(&lang, &g.default_lang).unwrap_or(&g.nodes[node].id).to_string();
            inset = Some(draw::Inset {
                id: self.gfx.inset_id,
                aspect: INSET_SIZE.0 as f32 / INSET_SIZE.1 as f32,
                alpha: alpha as f32,
                scale: (0.8 + 0.2 * alpha) as f32,
                title,
            });
        }
        // Overlay and caption of the displayed node.
        let mut overlay = None;
        let mut caption = None;
        if let (Some(RecState::Display { node, since, .. }), Some(g)) = (rec, ex.graph.as_ref()) {
            let n = &g.nodes[node];
            let alpha = ((t - since) / 0.5).clamp(0.0, 1.0) as f32;
            if let Some(file) = n.overlay.get(&lang, &g.default_lang) {
                overlay = media(&mut self.reported, &ex.dir, file)
                    .and_then(|path| self.gfx.proj_painter.image(&path))
                    .map(|t| (t, alpha));
            }
            caption = Some((
                n.title.get(&lang, &g.default_lang).unwrap_or(&n.id).to_string(),
                n.text.get(&lang, &g.default_lang).map(str::to_string),
                alpha,
            ));
        }
        // The radial menu with thumbnails.
        let mut radial = None;
        if let (Some(menu), Some(g)) = (self.kiosk.explorer().and_then(|x| x.menu()), ex.graph.as_ref()) {
            let pointed =
                menu.pointing.and_then(|a| kiosk_core::radial::slot_for_angle(a, menu.candidates.len()));
            let candidates = menu.candidates.clone();
            let mut items = Vec::new();
            for i in candidates {
                let n = &g.nodes[i];
                let thumb = self.thumbnail(ex, i);
                items.push((thumb, n.title.get(&lang, &g.default_lang).unwrap_or(&n.id).to_string()));
            }
            radial = Some((items, pointed));
        }
        let mode = self.kiosk.mode();
        let title = ex.title(&lang);
        let words = draw::words(&lang);
        let view = self.gfx.projection.canvas.ui_view.clone();
        self.gfx.proj_painter.paint(&self.gfx.gpu, &view, size, None, t, |ctx| {
            let screen = ctx.content_rect();
            let p = ctx.layer_painter(egui::LayerId::background());
            // Under the open menu the overlay and caption fade back, so that its labels read.
            let dim = if radial.is_some() { draw::UNDER_MENU } else { 1.0 };
            if let Some((tex, alpha)) = &overlay {
                draw::overlay(&p, screen, tex, alpha * dim);
            }
            match &caption {
                Some((title, text, alpha)) => draw::caption(&p, screen, title, text.as_deref(), alpha * dim),
                None => draw::caption(&p, screen, &title, None, 0.85 * dim),
            }
            if let Some(inset) = &inset {
                draw::inset(&p, screen, inset, words.inset_hint);
            }
            if let Some((items, pointed)) = &radial {
                draw::radial(&p, screen, items, *pointed);
            }
            if mode == Mode::Attract {
                draw::banner(&p, screen, words.touch_to_explore);
            }
        });
    }

    /// A node's thumbnail: its file, or (missing file) a render of its view, cached.
    fn thumbnail(&mut self, ex: &Exhibit, node: usize) -> Option<egui::TextureHandle> {
        let g = ex.graph.as_ref()?;
        let n = g.nodes.get(node)?;
        let file = n.thumbnail.as_deref().and_then(|f| media(&mut self.reported, &ex.dir, f));
        if let Some(path) = &file {
            return self.gfx.proj_painter.image(path);
        }
        // No usable file: a render of the node's view, cached under a key no file can have.
        let key = ex.dir.join(format!("#render-{}", n.id));
        if self.gfx.proj_painter.has_image(&key) {
            return self.gfx.proj_painter.image(&key);
        }
        let start = start_light(&ex.start_camera(self.kiosk.settings.explore.fov_y));
        let img = self.still(ex, &n.view, node_light(n, start), (256, 144));
        match img {
            Some(img) => Some(self.gfx.proj_painter.put_image(&key, &img)),
            None => {
                self.report("thumbnail", &format!("node {} of {}", n.id, ex.dir.display()));
                None
            }
        }
    }

    /// The gallery card's picture: the thumbnail of the story's first view, else (no story, no
    /// thumbnail, or one that cannot be used) a render of the start view, made once per device.
    fn card_image(&mut self, ex: &Exhibit) -> Option<egui::TextureHandle> {
        let first = ex.graph.as_ref().and_then(|g| g.nodes.first()?.thumbnail.as_ref());
        if let Some(path) = first.and_then(|f| media(&mut self.reported, &ex.dir, f))
            && let Some(image) = self.gfx.ctrl_painter.image(&path)
        {
            return Some(image);
        }
        // A key no file can have.
        let key = ex.dir.join("#card");
        if self.gfx.ctrl_painter.has_image(&key) {
            return self.gfx.ctrl_painter.image(&key);
        }
        // One that could not be made is not tried again at every frame.
        let failed = format!("#card {}", ex.dir.display());
        if self.reported.contains(&failed) {
            return None;
        }
        let camera = ex.start_camera(self.kiosk.settings.explore.fov_y);
        match self.still(ex, &camera, start_light(&camera), (512, 288)) {
            Some(img) => Some(self.gfx.ctrl_painter.put_image(&key, &img)),
            None => {
                self.reported.insert(failed);
                self.report("card", &format!("the start view of {}", ex.dir.display()));
                None
            }
        }
    }

    /// `camera`'s view of `ex` at `size` in `light` (a thumbnail, the gallery card), on a cut
    /// converged to 2 px; a corrupted node is reported and its ancestors drawn.
    fn still(
        &mut self,
        ex: &Exhibit,
        camera: &kiosk_core::camera::Camera,
        light: Light,
        size: (u32, u32),
    ) -> Option<image::RgbaImage> {
        let v = camera.view_params(&ex.store, size)?;
        let mut cut = Cut::root(&ex.store);
        cut.update(
            &ex.store,
            &v,
            &CutParams { tolerance_px: 2.0, max_changes: usize::MAX, ..CutParams::default() },
        );
        let nodes = cut.visible_nodes(&ex.store, &v);
        let settings = lit(self.render_settings, light);
        let (img, stats) =
            self.gfx.renderer.render_image(&self.gfx.gpu, &ex.store, &nodes, camera, size, &settings).ok()?;
        if stats.corrupt > 0 {
            self.report_corrupt(ex);
        }
        Some(img)
    }

    fn render_controller(&mut self, exhibits: &[&Exhibit], t: f64) {
        let size = self.gfx.controller.canvas.size;
        let lang = self.kiosk.lang().to_string();
        let model = self.kiosk.model();
        let ex = exhibits.get(model);
        let title = ex.map(|e| e.title(&lang)).unwrap_or_default();
        let thumb = ex.filter(|_| self.kiosk.mode() == Mode::Gallery).and_then(|e| self.card_image(e));
        let caption = self.kiosk.narrating().and_then(|(m, node)| {
            let g = exhibits.get(m)?.graph.as_ref()?;
            let n = g.nodes.get(node)?;
            Some((
                n.title.get(&lang, &g.default_lang).unwrap_or(&n.id).to_string(),
                n.text.get(&lang, &g.default_lang).unwrap_or("").to_string(),
            ))
        });
        let view = draw::ControllerView {
            mode: self.kiosk.mode(),
            lang: &lang,
            languages: &self.kiosk.settings.languages,
            help: self.kiosk.help(),
            countdown: self.kiosk.countdown(),
            card: (&title, thumb.as_ref()),
            page: (model, exhibits.len()),
            caption: caption.as_ref().map(|(a, b)| (a.as_str(), b.as_str())),
            zoom_bar: self.kiosk.settings.explore.gestures.zoom_bar_rect(),
            light_on: self.kiosk.light_on(),
            light_pad: self
                .kiosk
                .explorer()
                .filter(|_| self.kiosk.light_active())
                .map(|x| x.light_pad())
                .map(|p| (p.x, p.y)),
        };
        let target = self.gfx.controller.canvas.ui_view.clone();
        self.gfx.ctrl_painter.paint(&self.gfx.gpu, &target, size, Some(wgpu::Color::BLACK), t, |ctx| {
            draw::controller(ctx, &view)
        });
    }
}

/// Logs an error once (a kiosk draws 60 frames a second).
fn report_once(reported: &mut HashSet<String>, what: &str, e: &dyn std::fmt::Display) {
    if reported.insert(format!("{what}: {e}")) {
        tracing::error!("{what}: {e}");
    }
}

/// The file a graph's media path names, confined to the exhibit ([`kiosk_content::media::resolve`]). A
/// path that cannot be used was reported with the graph's problems when it loaded (by the same
/// check), so it is only noted here, once, at debug level; its node's other content still shows.
fn media(reported: &mut HashSet<String>, dir: &Path, rel: &str) -> Option<PathBuf> {
    match kiosk_content::media::resolve(dir, rel) {
        Ok(p) => Some(p),
        Err(e) => {
            if reported.insert(format!("media {}: {rel}: {e}", dir.display())) {
                tracing::debug!("{}: {rel}: {e}; not used", dir.display());
            }
            None
        }
    }
}
