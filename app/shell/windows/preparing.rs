//! Before the gallery: the windows open at once and say that the kiosk is preparing while the
//! exhibits load on a thread of their own. A new or changed scan is imported into the cache
//! first, a quarter of an hour for a billion points here; a dark wall for that long looks
//! broken to a visitor and hung to a technician. The exhibits that open at once (stores, scans
//! already cached) are loaded first: when there are some, the gallery opens with them and the
//! others are imported behind it, joining the gallery once imported, at the first moment nobody
//! is at the kiosk (the gallery idle for `reset_after_secs`: the reset's own condition), so that
//! no visitor sees the gallery change under a finger (a session recorded meanwhile replays on the
//! gallery it ends with). A gallery only of new scans waits for all of them. The projection says it in the kiosk's
//! languages with a pulse that moves; the controller says the same, with the exhibit loading, the
//! time taken and the line its import last logged (which scan, the phase, how far).
//!
//! The screen is drawn once a second (the pulse steps with it): on lavapipe a frame of both
//! windows costs 70–110 ms of CPU, so the screen takes about a tenth of a core from the import
//! (four frames a second took a quarter; measured as the rasteriser threads' CPU time over 6 s
//! of a 10 M-point import). The loading thread is asked four times a second, so the kiosk starts
//! within a quarter of a second of the exhibits being loaded. The first frame is drawn as soon as the windows are open, even
//! when the exhibits are already there, and saved beside the session's screenshots when there
//! are any.
//!
//! When no exhibit can be loaded (the content directory empty, missing or not mounted yet, every
//! exhibit broken), the kiosk does not end: a service would restart it into the same failure, and
//! the wall would show a desktop. The windows say the exhibition is closed, in each language, the
//! controller's small print gives the reason. The kiosk looks at the content every
//! `retry_after_secs` (a minute by default) and tries the exhibits again when it changed
//! ([`content_fingerprint`]), so content that comes opens the gallery without a restart and a
//! broken scan is not imported again and again. The reason is logged as an error once for as
//! long as it stays the same. Closed, the screen is drawn only when it changes: a kiosk may wait
//! for its content for days. Content that comes in parts is taken as it is when the gallery
//! opens; what is still missing then needs a restart.

use super::config::Config;
use super::exhibits::{Exhibit, Status, gallery_places, load_places};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Time between two frames of the preparing screen.
pub(super) const FRAME: Duration = Duration::from_secs(1);

/// Time between two looks at what the loading thread said.
pub(super) const POLL: Duration = Duration::from_millis(250);

/// While trying the exhibits again after they could not be loaded, the closed screen stays
/// unless the loading takes this long (an import, a slow disk): then the screen says the
/// exhibition is being prepared. An empty content directory answers at once; the wall does not
/// flicker every minute.
pub(super) const SAY_PREPARING: f64 = 1.0;

/// No exhibit could be loaded: why, and when they are tried again.
pub(super) struct Closed {
    reason: String,
    retry_secs: f64,
    /// When the content is looked at again; `None` while the exhibits are tried.
    retry_at: Option<Instant>,
    /// What the content held when they were last tried ([`content_fingerprint`]).
    fingerprint: u64,
}

impl Closed {
    /// Closed for `reason` (the exhibits tried on content of `fingerprint`), the content looked
    /// at again in `retry_secs` seconds.
    pub fn new(reason: String, retry_secs: f64, fingerprint: u64) -> Self {
        let retry_at = Some(Instant::now() + Duration::from_secs_f64(retry_secs));
        Self { reason, retry_secs, retry_at, fingerprint }
    }

    /// The content is looked at again in `retry_secs`, nothing having changed.
    pub fn wait_again(&mut self) {
        self.retry_at = Some(Instant::now() + Duration::from_secs_f64(self.retry_secs));
    }

    /// What the content held when the exhibits were last tried.
    pub fn fingerprint(&self) -> u64 {
        self.fingerprint
    }

    pub fn reason(&self) -> &str {
        &self.reason
    }

    /// Whether the exhibits are to be tried again now.
    pub fn due(&self) -> bool {
        self.retry_at.is_some_and(|at| Instant::now() >= at)
    }

    /// The exhibits are being tried again.
    pub fn retrying(&mut self) {
        self.retry_at = None;
    }

    pub fn is_retrying(&self) -> bool {
        self.retry_at.is_none()
    }

    /// The controller's small print: the reason and how often the kiosk tries again.
    pub fn detail(&self) -> String {
        format!(
            "{}\nthe exhibits are tried again when the content changes (looked at every {} s)",
            self.reason, self.retry_secs
        )
    }
}

/// What the content directory holds, as a number: the name, size and modification time of each
/// entry and of each entry of its sub-directories (the exhibits' files), or that it cannot be
/// read. The exhibits are tried again only when it changes: a scan whose import fails after
/// minutes is not imported again every minute, nor its error logged again.
pub(super) fn content_fingerprint(config: &Config) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    let entries = |dir: &std::path::Path| -> Vec<std::fs::DirEntry> {
        let mut v: Vec<_> = std::fs::read_dir(dir).map(|r| r.flatten().collect()).unwrap_or_default();
        v.sort_by_key(std::fs::DirEntry::file_name);
        v
    };
    config.content.is_dir().hash(&mut h);
    for e in entries(&config.content) {
        e.file_name().hash(&mut h);
        let is_dir = e.file_type().is_ok_and(|t| t.is_dir());
        for f in if is_dir { entries(&e.path()) } else { vec![e] } {
            f.file_name().hash(&mut h);
            if let Ok(m) = f.metadata() {
                m.len().hash(&mut h);
                m.modified().ok().hash(&mut h);
            }
        }
    }
    h.finish()
}

/// What the loading thread says.
enum Message {
    Status(Status),
    /// The exhibits the gallery opens with, or why none loads.
    Gallery(anyhow::Result<Gallery>),
    /// Exhibits imported after the gallery opened (those that could be).
    More(Vec<Exhibit>),
}

/// The exhibits the gallery opens with.
pub(super) struct Gallery {
    /// In the gallery's order.
    pub exhibits: Vec<Exhibit>,
    /// How many wait for their scan's import, behind the gallery ([`Loader::more`]).
    pub waiting: usize,
}

/// The exhibits loading on their thread, and what it last said.
pub(super) struct Loader {
    /// The thread's messages; `None` once it has said all it will.
    rx: Option<mpsc::Receiver<Message>>,
    /// Whether it gave the gallery's exhibits.
    opened: bool,
    /// How many exhibits it is importing behind the gallery.
    waiting: usize,
    /// Exhibit i (from 0) of n loading.
    exhibit: Option<(usize, usize)>,
    /// The last line its import logged.
    line: String,
    since: Instant,
    /// What the content held when it started ([`content_fingerprint`]).
    pub fingerprint: u64,
}

impl Loader {
    /// Starts loading the exhibits of `config` on a thread of their own: those that open at
    /// once (stores, scans cached and up to date) first. When some do and others must be
    /// imported, the gallery opens with the first and the others follow ([`Loader::more`]),
    /// if `split`; otherwise they all come together (a played session or a soak run needs the
    /// whole gallery from its start).
    pub fn spawn(config: Config, split: bool) -> anyhow::Result<Self> {
        let fingerprint = content_fingerprint(&config);
        let (tx, rx) = mpsc::channel();
        std::thread::Builder::new().name("exhibits".into()).spawn(move || {
            let mut status = |s: Status| drop(tx.send(Message::Status(s)));
            let places = match gallery_places(&config) {
                Ok(places) => places,
                Err(e) => return drop(tx.send(Message::Gallery(Err(e)))),
            };
            let n = places.len();
            let (mut ready, waiting) = load_places(places, n, false, &mut status);
            if !split || ready.is_empty() || waiting.is_empty() {
                let (more, _) = load_places(waiting, n, true, &mut status);
                ready.extend(more);
                ready.sort_by_key(|e| e.place);
                let gallery = if ready.is_empty() {
                    Err(anyhow::anyhow!("no exhibit could be loaded from {}", config.content.display()))
                } else {
                    Ok(Gallery { exhibits: ready, waiting: 0 })
                };
                return drop(tx.send(Message::Gallery(gallery)));
            }
            let count = waiting.len();
            drop(tx.send(Message::Gallery(Ok(Gallery { exhibits: ready, waiting: count }))));
            let (more, _) = load_places(waiting, n, true, &mut status);
            drop(tx.send(Message::More(more)));
        })?;
        Ok(Self {
            rx: Some(rx),
            opened: false,
            waiting: 0,
            exhibit: None,
            line: String::new(),
            since: Instant::now(),
            fingerprint,
        })
    }

    /// Takes in what the thread said: the gallery's exhibits (or why none loads) once they are
    /// loaded, once.
    pub fn poll(&mut self) -> Option<anyhow::Result<Gallery>> {
        if self.opened {
            return None;
        }
        match self.next()? {
            Ok(Message::Gallery(gallery)) => {
                self.opened = true;
                self.waiting = gallery.as_ref().map_or(0, |g| g.waiting);
                Some(gallery)
            }
            Ok(_) => None,
            Err(()) => Some(Err(anyhow::anyhow!("the thread loading the exhibits ended without a word"))),
        }
    }

    /// After the gallery opened: the exhibits imported behind it, once they are.
    pub fn more(&mut self) -> Option<Vec<Exhibit>> {
        if !self.opened {
            return None;
        }
        match self.next()? {
            Ok(Message::More(more)) => {
                self.rx = None;
                Some(more)
            }
            Ok(_) => None,
            // Done, with nothing behind the gallery: nothing to say.
            Err(()) if self.waiting == 0 => None,
            Err(()) => {
                tracing::error!(
                    "the import of the exhibits behind the gallery ended without a word; they are not shown \
                     until the kiosk starts again"
                );
                None
            }
        }
    }

    /// The thread's next message that is not a status (statuses are taken in on the way):
    /// `None` while there is none, `Err` once the thread ended without it.
    fn next(&mut self) -> Option<Result<Message, ()>> {
        let rx = self.rx.as_ref()?;
        loop {
            match rx.try_recv() {
                Ok(Message::Status(Status::Exhibit(i, n))) => {
                    self.exhibit = Some((i, n));
                    self.line.clear();
                }
                Ok(Message::Status(Status::Line(line))) => self.line = line,
                Ok(message) => return Some(Ok(message)),
                Err(mpsc::TryRecvError::Empty) => return None,
                Err(mpsc::TryRecvError::Disconnected) => {
                    self.rx = None;
                    return Some(Err(()));
                }
            }
        }
    }

    /// Seconds since loading started.
    pub fn elapsed(&self) -> f64 {
        self.since.elapsed().as_secs_f64()
    }

    /// The controller's small print: the exhibit loading, the time taken and the last line its
    /// import logged.
    pub fn detail(&self) -> String {
        let secs = self.since.elapsed().as_secs();
        let taken =
            if secs >= 60 { format!("{} min {} s", secs / 60, secs % 60) } else { format!("{secs} s") };
        let head = match self.exhibit {
            Some((i, n)) => format!("exhibit {} of {n} · {taken}", i + 1),
            None => taken,
        };
        if self.line.is_empty() { head } else { format!("{head}\n{}", self.line) }
    }
}
