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
    use glam::DVec3;
    use kiosk_core::camera::Camera;
    use kiosk_core::graph::{InfoGraph, Node};
    use kiosk_core::recommend::{RecEvent, RecSettings, RecState, Recommender, ViewContext};
    use kiosk_core::stats::{ModelVisit, Observer, PopularitySettings, VisitEnd, adjusted_importance};
    use rand::{Rng, SeedableRng};

    fn graph(n: usize) -> InfoGraph {
        let nodes = (0..n)
            .map(|i| {
                let a = i as f64 * 0.7;
                Node {
                    importance: 0.6,
                    ..Node::new(
                        format!("node-{i}"),
                        Camera {
                            eye: DVec3::new(a.cos() * 3.0, 0.1 * a, a.sin() * 3.0),
                            target: DVec3::ZERO,
                            up: DVec3::Y,
                            fov_y: 0.8,
                        },
                    )
                }
            })
            .collect();
        InfoGraph { default_lang: "en".into(), nodes, edges: vec![] }
    }

    /// One simulated two-minute visit through the core's engine and observer.
    fn visit(g: &InfoGraph, stats: &mut ExhibitStats, seed: u64, start: f64) -> VisitRecord {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let mut rec = Recommender::new(g, RecSettings::default(), start);
        let on = PopularitySettings { enabled: true, ..PopularitySettings::default() };
        if let Some(gamma) = adjusted_importance(g, stats, &on) {
            rec.set_gamma(gamma);
        }
        let camera = Camera { eye: DVec3::new(0.0, 0.0, 4.0), target: DVec3::ZERO, up: DVec3::Y, fov_y: 0.8 };
        let ctx = ViewContext { camera, aspect: 16.0 / 9.0, samples: &[], diagonal: 4.0, moving: false };
        let mut obs = Observer::default();
        let mut mv = ModelVisit { exhibit: "demo".into(), ..ModelVisit::default() };
        let mut now = start;
        while now < start + 120.0 {
            now += 0.5;
            let before = rec.state;
            let ev = match before {
                RecState::Propose { node, .. } if rng.random_bool(0.2 + 0.05 * (node % 10) as f64) => {
                    RecEvent::LongPress
                }
                _ => RecEvent::Tick,
            };
            rec.step(g, &ctx, ev, now, &mut rng);
            obs.step(g, (before, rec.state), now, true, stats, Some(&mut mv));
        }
        obs.close(g, now, stats, Some(&mut mv));
        stats.visits += 1;
        let mut v = VisitRecord::new(start, "en");
        v.end = now;
        v.last_touch = now - 30.0;
        v.ended = VisitEnd::Reset;
        v.models.push(mv);
        v
    }

    #[test]
    fn a_month_of_visits_keeps_the_statistics_and_the_log_bounded() {
        let dir = tempfile::tempdir().expect("temp dir");
        let state = dir.path();
        let g = graph(12);
        let limits = LogLimits { max_bytes: 64 << 10, keep: 4 };
        let path = stats_path(state, "demo");
        let day0 = 19_800.0 * 86_400.0;
        let (per_day, days) = (80, 30);
        let mut size_after_day1 = 0;
        let mut largest_log = 0;
        let mut last = None;
        for day in 0..days {
            for k in 0..per_day {
                // As the kiosk does: statistics loaded at start (here: every visit), the visit's
                // line appended and the statistics written when it ends.
                let mut stats = load_stats(&path);
                let seed = (day * per_day + k) as u64;
                let mut v = visit(&g, &mut stats, seed, seed as f64 * 200.0);
                v.wall_start = Some(day0 + day as f64 * 86_400.0 + k as f64 * 300.0);
                v.wall_end = v.wall_start.map(|w| w + 120.0);
                append_visit(state, &v, limits).expect("append");
                save_stats(&path, &stats).expect("save");
                largest_log = largest_log.max(std::fs::metadata(log_path(state, 0)).expect("log").len());
                last = Some(v);
            }
            if day == 0 {
                size_after_day1 = std::fs::metadata(&path).expect("stats").len();
            }
        }
        let stats = load_stats(&path);
        assert_eq!(stats.visits, (per_day * days) as u64);
        assert_eq!(stats.nodes.len(), 12);
        // The statistics file: one entry per node whatever the number of visits.
        let size = std::fs::metadata(&path).expect("stats").len();
        assert!(
            size < 4096 && size < 2 * size_after_day1,
            "{size} bytes after a month, {size_after_day1} after a day"
        );
        // The log: rotated, at most keep + 1 files, each within the limit.
        assert!(largest_log <= limits.max_bytes, "{largest_log}");
        assert!(log_path(state, limits.keep).exists(), "rotated {} times at least", limits.keep);
        assert!(!log_path(state, limits.keep + 1).exists());
        let total: u64 = (0..=limits.keep + 1)
            .filter_map(|k| std::fs::metadata(log_path(state, k)).ok())
            .map(|m| m.len())
            .sum();
        assert!(total <= (limits.keep as u64 + 1) * limits.max_bytes, "{total} bytes of log");
        // What is kept is the latest visits, oldest first, complete.
        let kept = read_visits(state);
        assert!(kept.len() < per_day * days && kept.len() > per_day, "{} visits kept", kept.len());
        assert_eq!(kept.last(), last.as_ref());
        assert!(kept.windows(2).all(|w| w[0].start < w[1].start));
        // No temporary file is left behind; nothing else was written.
        let names: Vec<String> = std::fs::read_dir(state.join("demo"))
            .expect("dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, [STATS_FILE]);
        // `kiosk stats` on it: the table and three plots.
        let out = dir.path().join("plots");
        let since = crate::report::parse_date("2024-03-20").expect("date");
        let text = crate::report::run(&crate::report::StatsOptions {
            exhibit: "demo".into(),
            since: None,
            out: out.clone(),
            state: state.to_path_buf(),
        })
        .expect("report");
        assert!(text.contains("node-11") && text.contains(&format!("{} visits", per_day * days)), "{text}");
        for f in ["visits-per-day.svg", "dwell-per-node.svg", "acceptance-per-node.svg"] {
            let svg = std::fs::read_to_string(out.join(f)).expect("plot");
            assert!(svg.contains("<svg") && svg.contains("<rect"), "{f}");
        }
        // --since: only the logged visits of those days (2024-03-20 is day 19 802).
        let text = crate::report::run(&crate::report::StatsOptions {
            exhibit: "demo".into(),
            since: Some(since),
            out,
            state: state.to_path_buf(),
        })
        .expect("report since");
        let recent = kept.iter().filter(|v| v.wall_start.is_some_and(|w| w >= since)).count();
        assert!(text.starts_with(&format!("demo: {recent} visits")), "{text}");
    }

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
