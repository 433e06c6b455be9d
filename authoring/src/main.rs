//! `author`: the curators' tool. `author content/demosthenes` opens an exhibit (a directory with a
//! scan or store; its graph.xml is created on the first save).

use clap::Parser;
use kiosk_author::ui::AuthorApp;
use kiosk_author::ui::opening::{self, Opening};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "author",
    version,
    about = "IsoKiosk authoring: build an exhibit's story without touching XML"
)]
struct Cli {
    /// The exhibit directory.
    exhibit: PathBuf,
}

fn main() -> anyhow::Result<()> {
    use std::io::IsTerminal;
    tracing_subscriber::fmt()
        .with_ansi(std::io::stdout().is_terminal())
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
            tracing_subscriber::EnvFilter::new("info,wgpu_core=warn,wgpu_hal=warn,naga=warn")
        }))
        .init();
    let cli = Cli::parse();
    // The exhibit opens while the window says so (its scan may be imported first: minutes).
    let mut opening = Opening::spawn(&cli.exhibit, &kiosk_content::exhibit::cache_dir())?;
    let mut gpu = Some(match kiosk_content::snapshot::offscreen() {
        Ok(g) => Some(g),
        Err(e) => {
            tracing::error!("no GPU for the live view and thumbnails: {e:#}");
            None
        }
    });
    // The kiosk's statistics of this exhibit, where the kiosk keeps them (read only).
    let stats = kiosk_content::stats::stats_path(
        &kiosk_content::stats::state_dir(),
        &kiosk_content::stats::exhibit_name(&cli.exhibit),
    );
    let mut app: Option<AuthorApp> = None;
    // Why the exhibit could not be opened, for the exit status once the window is closed.
    let failed = std::rc::Rc::new(std::cell::RefCell::new(None::<String>));
    let failure = failed.clone();
    // The window's device as the kiosk's: no shader debug info, which a debug build would ask
    // for by default and which Debian 12's Vulkan validation layers reject (they predate WGSL as
    // a SPIR-V source language) with an error at every pipeline; validation as WGPU_* says.
    let mut setup = eframe::egui_wgpu::WgpuSetupCreateNew::without_display_handle();
    setup.instance_descriptor.flags = eframe::wgpu::InstanceFlags::empty().with_env();
    let options = eframe::NativeOptions {
        viewport: egui::ViewportBuilder::default()
            .with_inner_size([1400.0, 900.0])
            .with_title("IsoKiosk author"),
        wgpu_options: eframe::egui_wgpu::WgpuConfiguration {
            wgpu_setup: eframe::egui_wgpu::WgpuSetup::CreateNew(setup),
            ..Default::default()
        },
        ..Default::default()
    };
    let ran = eframe::run_ui_native("IsoKiosk author", options, move |ui, _frame| {
        if app.is_none()
            && let Some((project, problems)) = opening.poll()
        {
            let mut opened = AuthorApp::new(project, problems, gpu.take().flatten());
            // The kiosk's file, read only: a damaged one is the kiosk's to set aside.
            opened.visitor_stats = kiosk_content::stats::read_stats(&stats).unwrap_or_else(|e| {
                tracing::error!("{e:#}; the views are shown without visitor statistics");
                Default::default()
            });
            app = Some(opened);
        }
        match app.as_mut() {
            Some(app) => app.ui(ui),
            None => {
                egui::CentralPanel::default().show(ui, |ui| opening.ui(ui));
                match opening.failed() {
                    None => ui.ctx().request_repaint_after(opening::POLL),
                    Some(why) => *failure.borrow_mut() = Some(why.to_string()),
                }
            }
        }
    });
    // Closed while its scan was being imported: the import stops with the process, without its
    // work directory.
    kiosk_content::import::remove_work_dirs();
    ran.map_err(|e| anyhow::anyhow!("{e}"))?;
    match failed.borrow_mut().take() {
        Some(why) => Err(anyhow::anyhow!("cannot open {}: {why}", cli.exhibit.display())),
        None => Ok(()),
    }
}
