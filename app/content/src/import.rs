//! `kiosk import`: scan file → store, with progress reports and a summary.
//!
//! An import works in a directory of its own beside the output (`.NAME.import-PID/`: the
//! builder's spill files and the partial store), under an exclusive lock on `.NAME.lock`: a second
//! import to the same output (another `kiosk import`, or two kiosks filling the same cache) waits
//! for the first and never shares its files. The directory is renamed into place and removed when
//! the store is done and removed on an error; a program that ends on a signal removes the running
//! imports' directories with [`remove_work_dirs`] (`kiosk import` does, on Ctrl+C and SIGTERM);
//! one left by a killed process is removed by the next import to that output, which holds the lock.

use anyhow::Context;
use kiosk_import::{BuildParams, BuildSummary, Builder, ReadOptions, Stage, source};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

/// Options of an import.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// Builder settings.
    pub build: BuildParams,
    /// Reader settings.
    pub read: ReadOptions,
}

/// The phases an import reports its progress in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Phase {
    /// The scan is read (done: samples read; total: samples the file says it holds, or a mesh's
    /// vertices passed on plus the samples its surface makes, once its triangles are read; 0
    /// when not known).
    Reading,
    /// A cell that outgrew a region is split again (done and total: that cell's samples; each
    /// cell split starts again from 0).
    Sorting,
    /// The hierarchy is built (done and total: samples).
    Building,
}

impl Phase {
    /// The phase's name as shown to the user.
    pub fn name(self) -> &'static str {
        match self {
            Self::Reading => "reading",
            Self::Sorting => "sorting",
            Self::Building => "building",
        }
    }
}

/// Where an import reports how far it is: the phase, done and total.
pub type Progress<'a> = dyn FnMut(Phase, u64, u64) + 'a;

/// A [`Progress`] that shows nothing.
pub fn quiet(_: Phase, _: u64, _: u64) {}

/// A [`Progress`] for the log, where no terminal shows a bar (a kiosk filling its cache at
/// start, its windows saying it prepares): a line at each phase's start and end (done = total,
/// or the last report before the next phase) and at most one every `every` within it, each
/// starting with `label`, and each also given to `also` (the kiosk's windows show the last).
pub fn logged<'a>(
    label: String,
    every: std::time::Duration,
    also: &'a mut dyn FnMut(&str),
) -> impl FnMut(Phase, u64, u64) + 'a {
    progress_lines(label, every, Instant::now, move |line| {
        tracing::info!("{line}");
        also(&line);
    })
}

/// [`logged`] with its clock `now` and where its lines go, `emit`.
fn progress_lines(
    label: String,
    every: std::time::Duration,
    now: impl Fn() -> Instant,
    mut emit: impl FnMut(String),
) -> impl FnMut(Phase, u64, u64) {
    let line = move |phase: Phase, done: u64, total: u64| {
        let name = phase.name();
        if phase == Phase::Sorting {
            format!("{label}: {name}: splitting a cell of {total} samples, {done} done")
        } else if total > 0 {
            // Whole percents, rounded down: 100 % only at the end.
            let share = (done.min(total) as u128 * 100 / total as u128) as u64;
            format!("{label}: {name} {done} of {total} samples ({share} %)")
        } else if done > 0 {
            format!("{label}: {name} {done} samples")
        } else {
            format!("{label}: {name}")
        }
    };
    // The last report said (phase, when, done, total), and the last one held back.
    let mut said: Option<(Phase, Instant, u64, u64)> = None;
    let mut held: Option<(Phase, u64, u64)> = None;
    move |phase, done, total| {
        let t = now();
        if let Some((p, d, n)) = held.take_if(|(p, ..)| *p != phase) {
            // The phase ended between reports: its last state, before the next phase's.
            emit(line(p, d, n));
        }
        // Within a phase: nothing new, or not the end and too soon after the last line.
        let (again, soon) = match said {
            Some((p, at, d, n)) if p == phase => {
                ((d, n) == (done, total), done != total && t.duration_since(at) < every)
            }
            _ => (false, false),
        };
        if again {
            return;
        }
        if soon {
            held = Some((phase, done, total));
            return;
        }
        held = None;
        said = Some((phase, t, done, total));
        emit(line(phase, done, total));
    }
}

/// What an import did.
#[derive(Clone, Debug)]
pub struct ImportReport {
    /// Builder summary.
    pub build: BuildSummary,
    /// Reader warnings.
    pub warnings: Vec<String>,
    /// The other files the scan names (see [`kiosk_import::ReadReport::inputs`]).
    pub inputs: Vec<PathBuf>,
    /// Wall time in seconds.
    pub seconds: f64,
}

impl std::fmt::Display for ImportReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let b = &self.build;
        write!(
            f,
            "{} samples read → {} distinct; {} node{}, {} level{}, {} samples in all levels; \
             {:.1} MB; {:.2} s; {:.0} samples/s",
            b.input_points,
            b.leaf_points,
            b.nodes,
            if b.nodes == 1 { "" } else { "s" },
            b.levels,
            if b.levels == 1 { "" } else { "s" },
            b.total_points,
            b.bytes as f64 / 1e6,
            self.seconds,
            b.input_points as f64 / self.seconds.max(1e-9)
        )
    }
}

/// Imports a scan file into a store (waiting for any other import to the same output), reporting
/// its progress to `progress` ([`quiet`] for none).
pub fn import(
    scan: &Path,
    out: &Path,
    opts: &ImportOptions,
    progress: &mut Progress<'_>,
) -> anyhow::Result<ImportReport> {
    check_input(scan, out)?;
    check_replaceable(out)?;
    let lock = OutputLock::acquire(out)?;
    build(scan, &lock, opts, progress)
}

/// Imports a scan file into the output that `lock` holds.
pub fn import_locked(
    scan: &Path,
    lock: &OutputLock,
    opts: &ImportOptions,
    progress: &mut Progress<'_>,
) -> anyhow::Result<ImportReport> {
    check_input(scan, &lock.out)?;
    build(scan, lock, opts, progress)
}

/// The import itself, once its output is checked and locked.
fn build(
    scan: &Path,
    lock: &OutputLock,
    opts: &ImportOptions,
    progress: &mut Progress<'_>,
) -> anyhow::Result<ImportReport> {
    let start = Instant::now();
    let work = WorkDir::create(&lock.out)?;
    let mut builder = Builder::new(opts.build, &work.path)?;
    progress(Phase::Reading, 0, 0);
    let mut feed = Feed { builder: &mut builder, progress: &mut *progress, read: 0, expected: 0 };
    let report = kiosk_import::read_file(scan, &opts.read, &mut feed)
        .map_err(|e| anyhow::Error::new(e).context(scan.display().to_string()))?;
    let staged = work.path.join("store.kstore");
    let summary = builder
        .finish(&staged, &mut |stage| match stage {
            Stage::Distribute(done, total) => progress(Phase::Sorting, done, total),
            Stage::Build(done, total) => progress(Phase::Building, done, total),
        })
        .map_err(|e| {
            // What the reader dropped or tolerated may be why too little was left to build.
            let read = match e {
                kiosk_import::BuildError::Degenerate(_) if !report.warnings.is_empty() => {
                    format!(" (the reading: {})", report.warnings.join("; "))
                }
                _ => String::new(),
            };
            anyhow::Error::new(e).context(format!(
                "{}: building {}{read}",
                scan.display(),
                lock.out.display()
            ))
        })?;
    std::fs::rename(&staged, &lock.out).with_context(|| format!("cannot write {}", lock.out.display()))?;
    drop(work);
    Ok(ImportReport {
        build: summary,
        warnings: report.warnings,
        inputs: report.inputs,
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// Refuses an import that would overwrite its own input.
fn check_input(scan: &Path, out: &Path) -> anyhow::Result<()> {
    if let (Ok(a), Ok(b)) = (scan.canonicalize(), out.canonicalize()) {
        anyhow::ensure!(a != b, "{}: the output is the input; choose another output file", out.display());
    }
    // A store given as the scan is told apart by the readers' format detection.
    Ok(())
}

/// Refuses an output that exists and is not a store: an `-o` naming a scan or a document by
/// mistake must not destroy it. (The kiosk's cache, through [`import_locked`], replaces its own
/// files, damaged ones too.)
fn check_replaceable(out: &Path) -> anyhow::Result<()> {
    use std::io::Read;
    let meta = match std::fs::metadata(out) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(e).with_context(|| format!("cannot inspect {}", out.display())),
    };
    let refuse = |what: &str| {
        anyhow::anyhow!(
            "{}: {what}; it is not replaced (remove it first, or choose another output file)",
            out.display()
        )
    };
    if !meta.is_file() {
        return Err(refuse("exists and is not a file"));
    }
    if meta.len() == 0 {
        // Nothing to lose (a file made by `mktemp` or `touch` for the store).
        return Ok(());
    }
    let mut head = Vec::with_capacity(kiosk_core::scene::store::MAGIC.len());
    std::fs::File::open(out)
        .and_then(|f| f.take(kiosk_core::scene::store::MAGIC.len() as u64).read_to_end(&mut head))
        .with_context(|| {
            format!("{}: cannot read it to check that it is a store before replacing it", out.display())
        })?;
    if head != kiosk_core::scene::store::MAGIC {
        return Err(refuse("exists and is not an IsoKiosk store"));
    }
    Ok(())
}

/// An exclusive lock on an output file (on `.NAME.lock` beside it), held until dropped.
pub struct OutputLock {
    out: PathBuf,
    lock: PathBuf,
    _file: std::fs::File,
}

impl OutputLock {
    /// Locks `out`, waiting (with a message in the log) while another process holds it, then
    /// removes what interrupted imports to it left behind.
    pub fn acquire(out: &Path) -> anyhow::Result<Self> {
        Self::lock(out, true)?.with_context(|| format!("{}: the lock was not taken", out.display()))
    }

    /// Locks `out` if no other process holds it (`None` if one does), without waiting.
    pub fn try_acquire(out: &Path) -> anyhow::Result<Option<Self>> {
        Self::lock(out, false)
    }

    fn lock(out: &Path, wait: bool) -> anyhow::Result<Option<Self>> {
        let (dir, name) = split(out)?;
        std::fs::create_dir_all(&dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let path = dir.join(format!(".{name}.lock"));
        let file = match std::fs::OpenOptions::new().create(true).truncate(false).write(true).open(&path) {
            Ok(file) => file,
            // A lock file another user left (imports leave theirs) is locked through a handle
            // that only reads: a lock needs no write access.
            Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && path.is_file() => {
                std::fs::File::open(&path)
                    .with_context(|| format!("cannot open the lock {}", path.display()))?
            }
            Err(e) => return Err(cannot_write_in(&dir, &path, e)),
        };
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) if !wait => return Ok(None),
            Err(std::fs::TryLockError::WouldBlock) => {
                tracing::info!("{}: another import is writing it; waiting", out.display());
                file.lock().with_context(|| format!("cannot lock {}", path.display()))?;
            }
            Err(std::fs::TryLockError::Error(e)) => {
                return Err(e).with_context(|| format!("cannot lock {}", path.display()));
            }
        }
        // Holding the lock, nobody else is importing to `out`: any work directory is stale.
        let prefix = format!(".{name}.import-");
        for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let stale = entry.file_name().to_str().is_some_and(|n| n.starts_with(&prefix));
            if stale && std::fs::remove_dir_all(entry.path()).is_ok() {
                tracing::info!("removed {}, left by an interrupted import", entry.path().display());
            }
        }
        Ok(Some(Self { out: out.to_path_buf(), lock: path, _file: file }))
    }

    /// The output it locks.
    pub fn path(&self) -> &Path {
        &self.out
    }

    /// Its lock file (`.NAME.lock` beside the output).
    pub fn lock_file(&self) -> &Path {
        &self.lock
    }
}

/// An output's directory and file name.
fn split(out: &Path) -> anyhow::Result<(PathBuf, String)> {
    let name = out
        .file_name()
        .and_then(|n| n.to_str())
        .with_context(|| format!("{}: not a file name", out.display()))?;
    let dir = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    Ok((dir.to_path_buf(), name.to_string()))
}

/// An import's files (its lock, its work directory) cannot be made in the output's directory.
fn cannot_write_in(dir: &Path, file: &Path, e: std::io::Error) -> anyhow::Error {
    let name = file.file_name().map_or(file.as_os_str(), |n| n).to_string_lossy();
    anyhow::anyhow!(
        "cannot write in {}, the output's directory: {e} (an import makes {name} there beside the store)",
        dir.display()
    )
}

/// The imports running in this process (see [`remove_work_dirs`]).
struct Active {
    /// Whether [`remove_work_dirs`] ran: no import starts after it.
    closing: bool,
    /// Their work directories.
    dirs: Vec<PathBuf>,
}

static ACTIVE: Mutex<Active> = Mutex::new(Active { closing: false, dirs: Vec::new() });

/// Removes the work directories of the imports running in this process, and keeps any other
/// from starting: for a program that ends before its imports do (on a signal, or closed while
/// importing on another thread), whose imports' own cleanup does not run then.
pub fn remove_work_dirs() {
    let mut active = ACTIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    active.closing = true;
    for dir in &active.dirs {
        let _ = std::fs::remove_dir_all(dir);
    }
}

/// The directory an import works in; removed with everything in it when dropped.
struct WorkDir {
    path: PathBuf,
}

impl WorkDir {
    fn create(out: &Path) -> anyhow::Result<Self> {
        let (dir, name) = split(out)?;
        let path = dir.join(format!(".{name}.import-{}", std::process::id()));
        // Made and noted under the lock, so that a removal never misses it.
        let mut active = ACTIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        anyhow::ensure!(!active.closing, "not imported: the program is closing");
        std::fs::create_dir_all(&path).map_err(|e| cannot_write_in(&dir, &path, e))?;
        active.dirs.push(path.clone());
        Ok(Self { path })
    }
}

impl Drop for WorkDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.path);
        ACTIVE.lock().unwrap_or_else(std::sync::PoisonError::into_inner).dirs.retain(|p| p != &self.path);
    }
}

/// The builder fed by a reader, reporting the samples read.
struct Feed<'a, 'p> {
    builder: &'a mut Builder,
    progress: &'a mut Progress<'p>,
    read: u64,
    expected: u64,
}

impl source::Sink for Feed<'_, '_> {
    type Error = kiosk_import::BuildError;

    fn expect(&mut self, points: u64) {
        // The points to come: a mesh's surface samples follow the vertices already passed on.
        self.expected = self.read.saturating_add(points);
        (self.progress)(Phase::Reading, self.read, self.expected);
    }

    fn point(&mut self, p: source::InputPoint) -> Result<(), Self::Error> {
        self.read += 1;
        if self.read.is_multiple_of(65536) {
            (self.progress)(Phase::Reading, self.read, self.expected);
        }
        source::Sink::point(self.builder, p)
    }

    fn points(&mut self, points: Vec<source::InputPoint>) -> Result<(), Self::Error> {
        self.read += points.len() as u64;
        (self.progress)(Phase::Reading, self.read, self.expected);
        source::Sink::points(self.builder, points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::{Cell, RefCell};
    use std::time::Duration;

    #[test]
    fn logged_progress_says_each_phase_its_end_and_at_most_one_line_every_interval() {
        let start = Instant::now();
        let seconds = Cell::new(0u64);
        let lines = RefCell::new(Vec::new());
        let mut progress = progress_lines(
            "scan".into(),
            Duration::from_secs(10),
            || start + Duration::from_secs(seconds.get()),
            |l| lines.borrow_mut().push(l),
        );
        for (at, phase, done, total) in [
            (0, Phase::Reading, 0, 0),
            (4, Phase::Reading, 100, 0),
            (10, Phase::Reading, 200, 0),
            (12, Phase::Reading, 300, 1000),
            (20, Phase::Reading, 999, 1000),
            (25, Phase::Reading, 1000, 1000),
            (26, Phase::Sorting, 0, 400),
            (27, Phase::Building, 0, 990),
            (28, Phase::Building, 500, 990),
            (29, Phase::Building, 990, 990),
            (29, Phase::Building, 990, 990),
        ] {
            seconds.set(at);
            progress(phase, done, total);
        }
        assert_eq!(
            *lines.borrow(),
            [
                "scan: reading",
                "scan: reading 200 samples",
                "scan: reading 999 of 1000 samples (99 %)",
                "scan: reading 1000 of 1000 samples (100 %)",
                "scan: sorting: splitting a cell of 400 samples, 0 done",
                "scan: building 0 of 990 samples (0 %)",
                "scan: building 990 of 990 samples (100 %)",
            ]
        );
        // A total never known (a point cloud's PLY): the reading's last count is said when the
        // next phase starts.
        lines.borrow_mut().clear();
        let mut progress = progress_lines(
            "cloud".into(),
            Duration::from_secs(10),
            || start + Duration::from_secs(seconds.get()),
            |l| lines.borrow_mut().push(l),
        );
        for (at, phase, done, total) in
            [(0, Phase::Reading, 0, 0), (3, Phase::Reading, 700, 0), (5, Phase::Building, 0, 700)]
        {
            seconds.set(at);
            progress(phase, done, total);
        }
        assert_eq!(
            *lines.borrow(),
            ["cloud: reading", "cloud: reading 700 samples", "cloud: building 0 of 700 samples (0 %)"]
        );
    }
}
