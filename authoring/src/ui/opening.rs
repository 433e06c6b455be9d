//! Before the tool's window has a project: the exhibit opens on a thread of its own while the
//! window says what it is doing. A new or changed scan is imported into the cache first (minutes
//! for a large one); a curator launching the tool from a desktop icon would otherwise see no
//! window at all and no log. The window shows the exhibit, the time taken and the line the
//! import last logged, or why the exhibit cannot be opened.

use crate::Project;
use kiosk_core::graph::Problem;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// How often the window looks at what the opening thread said.
pub const POLL: Duration = Duration::from_millis(250);

/// What the opening thread says.
enum Message {
    Line(String),
    Done(Box<anyhow::Result<(Project, Vec<Problem>)>>),
}

/// An exhibit opening on its thread.
pub struct Opening {
    dir: PathBuf,
    rx: mpsc::Receiver<Message>,
    /// The last line its import logged.
    line: String,
    since: Instant,
    /// Why it cannot be opened, once the thread said so.
    failed: Option<String>,
}

impl Opening {
    /// Starts opening the exhibit `dir`, its scan imported into `cache` if needed.
    pub fn spawn(dir: &Path, cache: &Path) -> std::io::Result<Self> {
        let (tx, rx) = mpsc::channel();
        let (d, cache) = (dir.to_path_buf(), cache.to_path_buf());
        std::thread::Builder::new().name("opening".into()).spawn(move || {
            let opened =
                Project::open_reporting(&d, &cache, &mut |line| drop(tx.send(Message::Line(line.into()))));
            drop(tx.send(Message::Done(Box::new(opened))));
        })?;
        Ok(Self { dir: dir.to_path_buf(), rx, line: String::new(), since: Instant::now(), failed: None })
    }

    /// Takes in what the thread said: the project once it is open (an error stays on the window,
    /// [`Opening::failed`]).
    pub fn poll(&mut self) -> Option<(Project, Vec<Problem>)> {
        loop {
            match self.rx.try_recv() {
                Ok(Message::Line(line)) => self.line = line,
                Ok(Message::Done(done)) => match *done {
                    Ok(opened) => return Some(opened),
                    Err(e) => {
                        tracing::error!("cannot open {}: {e:#}", self.dir.display());
                        self.failed = Some(format!("{e:#}"));
                    }
                },
                Err(mpsc::TryRecvError::Empty) => return None,
                Err(mpsc::TryRecvError::Disconnected) => {
                    if self.failed.is_none() {
                        self.failed = Some("the thread opening the exhibit ended without a word".into());
                    }
                    return None;
                }
            }
        }
    }

    /// The last line the import logged ("" if none).
    pub fn line(&self) -> &str {
        &self.line
    }

    /// Why the exhibit cannot be opened, if the thread said so.
    pub fn failed(&self) -> Option<&str> {
        self.failed.as_deref()
    }

    /// Draws what the opening is doing, or why it failed.
    pub fn ui(&self, ui: &mut egui::Ui) {
        ui.vertical_centered(|ui| {
            ui.add_space(ui.available_height() * 0.3);
            match &self.failed {
                Some(why) => {
                    ui.heading(format!("Cannot open {}", self.dir.display()));
                    ui.add_space(8.0);
                    ui.label(why);
                    ui.add_space(8.0);
                    ui.label("Fix the exhibit (`kiosk check` lists its problems) and open it again.");
                }
                None => {
                    ui.heading(format!("Opening {}", self.dir.display()));
                    ui.add_space(8.0);
                    ui.spinner();
                    ui.add_space(8.0);
                    let secs = self.since.elapsed().as_secs();
                    ui.label(format!(
                        "A new or changed scan is imported into the cache first: a large one takes minutes. \
                         {} min {} s so far.",
                        secs / 60,
                        secs % 60
                    ));
                    if !self.line.is_empty() {
                        ui.label(&self.line);
                    }
                }
            }
        });
    }
}
