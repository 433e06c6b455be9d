//! Visit statistics on disk: each exhibit's long-run counts ([`ExhibitStats`], a small JSON
//! file) and the visit log (`visits.jsonl`, one [`VisitRecord`] a line), in the kiosk's state
//! directory ([`state_dir`]), never inside the content.
//!
//! Layout: `STATE/EXHIBIT/stats.json` and `STATE/visits.jsonl` (rotated by size to
//! `visits.1.jsonl` … `visits.K.jsonl`, oldest last, so the log never fills the disk). The
//! statistics are written atomically (temporary file, fsync, rename, fsync of the directory): a
//! crash or a power cut leaves the old file or the new one, never a broken one. A file that
//! cannot be read anyway is renamed aside (`stats.json.corrupt-N`), logged, and the kiosk starts
//! from empty statistics. Anonymous: counts and times only.

use anyhow::Context as _;
use kiosk_core::stats::{ExhibitStats, VisitRecord};
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Name of an exhibit's statistics file inside its state directory.
pub const STATS_FILE: &str = "stats.json";

/// Where the kiosk keeps its state: `$ISOKIOSK_STATE`, else `$XDG_STATE_HOME/isokiosk`, else
/// `~/.local/state/isokiosk`, else the temporary directory.
pub fn state_dir() -> PathBuf {
    let var = |k: &str| std::env::var_os(k).filter(|v| !v.is_empty()).map(PathBuf::from);
    var("ISOKIOSK_STATE")
        .or_else(|| var("XDG_STATE_HOME").map(|d| d.join("isokiosk")))
        .or_else(|| var("HOME").map(|d| d.join(".local/state/isokiosk")))
        .unwrap_or_else(|| std::env::temp_dir().join("isokiosk-state"))
}

/// An exhibit's name: its directory's.
pub fn exhibit_name(dir: &Path) -> String {
    dir.file_name().map_or_else(|| "exhibit".into(), |n| n.to_string_lossy().into_owned())
}

/// The statistics file of an exhibit.
pub fn stats_path(state: &Path, exhibit: &str) -> PathBuf {
    state.join(exhibit).join(STATS_FILE)
}

/// Reads an exhibit's statistics: missing → empty; unreadable or corrupt → renamed aside
/// (`*.corrupt-N`), logged, empty.
pub fn load_stats(path: &Path) -> ExhibitStats {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return ExhibitStats::default(),
        Err(e) => {
            tracing::error!("statistics {}: {e}; starting from empty statistics", path.display());
            return ExhibitStats::default();
        }
    };
    match serde_json::from_slice::<ExhibitStats>(&bytes) {
        Ok(s) => s,
        Err(e) => {
            let aside = set_aside(path);
            tracing::error!(
                "statistics {}: {e}; moved to {}, starting from empty statistics",
                path.display(),
                aside.as_ref().map_or_else(|e| format!("nowhere ({e})"), |p| p.display().to_string())
            );
            ExhibitStats::default()
        }
    }
}

/// Reads an exhibit's statistics without changing anything (a report, the authoring tool; the
/// kiosk, which owns the file, sets a broken one aside: [`load_stats`]): missing → empty;
/// unreadable or corrupt → an error naming the file.
pub fn read_stats(path: &Path) -> anyhow::Result<ExhibitStats> {
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(ExhibitStats::default()),
        Err(e) => anyhow::bail!("cannot read the statistics {}: {e}", path.display()),
    };
    serde_json::from_slice(&bytes).map_err(|e| {
        anyhow::anyhow!(
            "the statistics {} are damaged: {e} (the kiosk sets them aside at its next start)",
            path.display()
        )
    })
}

/// Renames a broken file to the first free `NAME.corrupt-N`.
fn set_aside(path: &Path) -> std::io::Result<PathBuf> {
    for n in 1.. {
        let mut name = path.as_os_str().to_owned();
        name.push(format!(".corrupt-{n}"));
        let aside = PathBuf::from(name);
        if !aside.exists() {
            std::fs::rename(path, &aside)?;
            return Ok(aside);
        }
    }
    unreachable!("an unbounded range ends only by returning")
}

/// Writes `bytes` to `path` atomically: a temporary file beside it, fsync, rename, fsync of the
/// directory.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let mut tmp_name = path.as_os_str().to_owned();
    tmp_name.push(format!(".tmp-{}", std::process::id()));
    let tmp = PathBuf::from(tmp_name);
    let written = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        drop(f);
        std::fs::rename(&tmp, path)
    })();
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
        return written;
    }
    // The rename itself reaches the disk with the directory's entry.
    if let Ok(d) = std::fs::File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Saves an exhibit's statistics atomically.
pub fn save_stats(path: &Path, stats: &ExhibitStats) -> anyhow::Result<()> {
    let mut json = serde_json::to_vec_pretty(stats)?;
    json.push(b'\n');
    write_atomic(path, &json).with_context(|| format!("cannot write statistics {}", path.display()))
}

/// How large the visit log may grow.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LogLimits {
    /// Size at which `visits.jsonl` is rotated.
    pub max_bytes: u64,
    /// Rotated files kept (`visits.1.jsonl` … `visits.K.jsonl`).
    pub keep: usize,
}

impl Default for LogLimits {
    fn default() -> Self {
        Self { max_bytes: 8 << 20, keep: 4 }
    }
}

/// The visit log's file: `visits.jsonl` (k = 0) or its k-th rotation.
pub fn log_path(state: &Path, k: usize) -> PathBuf {
    if k == 0 { state.join("visits.jsonl") } else { state.join(format!("visits.{k}.jsonl")) }
}

/// Appends one visit to the log, rotating it first if the line would take it past the limit:
/// at most (keep + 1) × max_bytes on disk, plus one line.
pub fn append_visit(state: &Path, record: &VisitRecord, limits: LogLimits) -> anyhow::Result<()> {
    let mut line = serde_json::to_vec(record)?;
    line.push(b'\n');
    std::fs::create_dir_all(state).with_context(|| format!("cannot create {}", state.display()))?;
    let current = log_path(state, 0);
    let size = std::fs::metadata(&current).map_or(0, |m| m.len());
    if size > 0 && size + line.len() as u64 > limits.max_bytes {
        rotate(state, limits.keep).with_context(|| format!("cannot rotate {}", current.display()))?;
    }
    let mut f = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&current)
        .with_context(|| format!("cannot open {}", current.display()))?;
    f.write_all(&line).with_context(|| format!("cannot write {}", current.display()))?;
    Ok(())
}

fn rotate(state: &Path, keep: usize) -> std::io::Result<()> {
    if keep == 0 {
        return std::fs::remove_file(log_path(state, 0));
    }
    match std::fs::remove_file(log_path(state, keep)) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e),
        _ => {}
    }
    for k in (0..keep).rev() {
        let from = log_path(state, k);
        if from.exists() {
            std::fs::rename(&from, log_path(state, k + 1))?;
        }
    }
    Ok(())
}

/// Every visit of the log, oldest first (the rotated files, then the current one). A line that
/// does not parse (a torn last line after a power cut) is skipped.
pub fn read_visits(state: &Path) -> Vec<VisitRecord> {
    let mut files: Vec<PathBuf> = (1..)
        .map(|k| log_path(state, k))
        .take_while(|p| p.exists())
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    files.push(log_path(state, 0));
    let mut out = Vec::new();
    for f in files {
        let Ok(text) = std::fs::read_to_string(&f) else { continue };
        out.extend(text.lines().filter_map(|l| serde_json::from_str::<VisitRecord>(l).ok()));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_corrupt_statistics_file_is_set_aside_and_the_kiosk_starts_empty() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = stats_path(dir.path(), "demo");
        assert_eq!(load_stats(&path), ExhibitStats::default(), "missing: empty");
        let mut s = ExhibitStats { visits: 3, ..Default::default() };
        s.nodes.insert("a".into(), Default::default());
        save_stats(&path, &s).expect("save");
        assert_eq!(load_stats(&path), s);
        // Torn writes of another program, twice: each is kept aside under its own name.
        let torn = b"{\"version\":1,\"visits\":3,\"nod";
        for n in 1..=2 {
            std::fs::write(&path, torn).expect("write");
            assert_eq!(load_stats(&path), ExhibitStats::default());
            assert!(!path.exists());
            let aside = dir.path().join("demo").join(format!("stats.json.corrupt-{n}"));
            assert_eq!(std::fs::read(&aside).expect("aside"), torn);
        }
        // An atomic write over an existing file replaces it whole.
        save_stats(&path, &s).expect("save");
        save_stats(&path, &ExhibitStats::default()).expect("save");
        assert_eq!(load_stats(&path), ExhibitStats::default());
    }
}
