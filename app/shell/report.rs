//! `kiosk stats`: the curators' view of the visit statistics — a table per node and SVG plots
//! (visits per day, dwell per node, acceptance rate per node).
//!
//! Without `--since` the table comes from the exhibit's long-run statistics (`stats.json`, every
//! visit since the kiosk started counting); with it, from the visit log's records since that
//! day (the log keeps the latest visits only, see [`kiosk_content::stats::LogLimits`]). Dates are UTC.

use anyhow::Context as _;
use kiosk_content::stats::{read_visits, stats_path};
use kiosk_core::stats::{ExhibitStats, NodeTotals, VisitRecord};
use plotters::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Days since 1970-01-01 of a civil date (proleptic Gregorian, UTC).
pub fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let mp = (i64::from(m) + 9) % 12;
    let doy = (153 * mp + 2) / 5 + i64::from(d) - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The civil date of a day since 1970-01-01.
pub fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { yoe + era * 400 + 1 } else { yoe + era * 400 }, m, d)
}

/// Parses `YYYY-MM-DD` to Unix seconds at its midnight (UTC).
pub fn parse_date(s: &str) -> anyhow::Result<f64> {
    let bad = || anyhow::anyhow!("--since {s}: expected a date YYYY-MM-DD");
    let mut it = s.trim().splitn(3, '-');
    let y: i64 = it.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    let m: u32 = it.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    let d: u32 = it.next().and_then(|x| x.parse().ok()).ok_or_else(bad)?;
    anyhow::ensure!((1..=12).contains(&m) && (1..=31).contains(&d), bad());
    Ok(days_from_civil(y, m, d) as f64 * 86_400.0)
}

fn date(day: i64) -> String {
    let (y, m, d) = civil_from_days(day);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The per-node counts of an exhibit from visit records.
pub fn totals_from_visits(visits: &[VisitRecord], exhibit: &str) -> ExhibitStats {
    let mut s = ExhibitStats::default();
    for v in visits {
        for m in v.models.iter().filter(|m| m.exhibit == exhibit) {
            s.visits += 1;
            let mut node =
                |id: &str, f: &mut dyn FnMut(&mut NodeTotals)| f(s.nodes.entry(id.into()).or_default());
            for d in &m.displayed {
                node(&d.node, &mut |t| {
                    t.displays += 1;
                    t.dwell_secs += d.dwell_secs;
                });
            }
            for id in &m.accepted {
                node(id, &mut |t| {
                    t.proposals += 1;
                    t.accepted += 1;
                });
            }
            for id in &m.refused {
                node(id, &mut |t| {
                    t.proposals += 1;
                    t.refusals += 1;
                });
            }
            for id in &m.by_attraction {
                node(id, &mut |t| t.by_attraction += 1);
            }
            for id in &m.menu_picks {
                node(id, &mut |t| t.menu_picks += 1);
            }
        }
    }
    s
}

/// The table printed by `kiosk stats`.
pub fn table(stats: &ExhibitStats) -> String {
    let mut out = format!(
        "{:<24} {:>8} {:>10} {:>9} {:>10} {:>10}\n",
        "node", "displays", "mean dwell", "proposals", "acceptance", "menu picks"
    );
    for (id, t) in &stats.nodes {
        out += &format!(
            "{:<24} {:>8} {:>9.1}s {:>9} {:>10} {:>10}\n",
            id,
            t.displays,
            t.mean_dwell().unwrap_or(0.0),
            t.proposals,
            t.acceptance().map_or_else(|| "-".into(), |a| format!("{:.0} %", 100.0 * a)),
            t.menu_picks
        );
    }
    out
}

/// Options of `kiosk stats`.
#[derive(Clone, Debug)]
pub struct StatsOptions {
    /// The exhibit's name (its directory's).
    pub exhibit: String,
    /// Only visits since this Unix time (from the log).
    pub since: Option<f64>,
    /// Where the plots go.
    pub out: PathBuf,
    /// The state directory.
    pub state: PathBuf,
}

/// Prints the table and writes the plots; returns the table.
pub fn run(opts: &StatsOptions) -> anyhow::Result<String> {
    let visits: Vec<VisitRecord> = read_visits(&opts.state)
        .into_iter()
        .filter(|v| v.models.iter().any(|m| m.exhibit == opts.exhibit))
        .filter(|v| opts.since.is_none_or(|s| v.wall_start.is_some_and(|w| w >= s)))
        .collect();
    let stats = match opts.since {
        Some(_) => totals_from_visits(&visits, &opts.exhibit),
        None => {
            let path = stats_path(&opts.state, &opts.exhibit);
            anyhow::ensure!(
                path.exists() || !visits.is_empty(),
                "no statistics for exhibit '{}' in {}",
                opts.exhibit,
                opts.state.display()
            );
            kiosk_content::stats::read_stats(&path)?
        }
    };
    let mut text = format!("{}: {} visits\n", opts.exhibit, stats.visits);
    text += &table(&stats);
    std::fs::create_dir_all(&opts.out).with_context(|| format!("cannot create {}", opts.out.display()))?;
    let mut per_day: BTreeMap<i64, u32> = BTreeMap::new();
    for v in &visits {
        if let Some(w) = v.wall_start {
            *per_day.entry((w / 86_400.0).floor() as i64).or_default() += 1;
        }
    }
    let days: Vec<(String, f64)> = per_day.iter().map(|(&d, &n)| (date(d), f64::from(n))).collect();
    bars(&opts.out.join("visits-per-day.svg"), "Visits per day", "visits", &days)?;
    let dwell: Vec<(String, f64)> =
        stats.nodes.iter().map(|(id, t)| (id.clone(), t.mean_dwell().unwrap_or(0.0))).collect();
    bars(&opts.out.join("dwell-per-node.svg"), "Mean dwell per node", "seconds", &dwell)?;
    let acc: Vec<(String, f64)> =
        stats.nodes.iter().filter_map(|(id, t)| t.acceptance().map(|a| (id.clone(), 100.0 * a))).collect();
    bars(&opts.out.join("acceptance-per-node.svg"), "Acceptance rate of proposals", "%", &acc)?;
    text += &format!("plots in {}\n", opts.out.display());
    Ok(text)
}

/// A bar chart of labelled values as SVG.
fn bars(path: &Path, title: &str, unit: &str, data: &[(String, f64)]) -> anyhow::Result<()> {
    let width = (160 + 28 * data.len() as u32).clamp(480, 4000);
    let root = SVGBackend::new(path, (width, 420)).into_drawing_area();
    let draw = || -> Result<(), Box<dyn std::error::Error + '_>> {
        root.fill(&WHITE)?;
        let top = data.iter().map(|d| d.1).fold(0.0f64, f64::max).max(1.0) * 1.1;
        let n = data.len().max(1);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(10)
            .x_label_area_size(90)
            .y_label_area_size(50)
            .build_cartesian_2d(0.0..n as f64, 0.0..top)?;
        chart
            .configure_mesh()
            .disable_x_mesh()
            .y_desc(unit)
            .x_labels(n)
            .x_label_formatter(&|x| {
                let i = x.floor() as usize;
                data.get(i).map_or_else(String::new, |d| d.0.clone())
            })
            .x_label_style(("sans-serif", 11).into_font().transform(FontTransform::Rotate90))
            .draw()?;
        chart.draw_series(data.iter().enumerate().map(|(i, (_, v))| {
            Rectangle::new([(i as f64 + 0.15, 0.0), (i as f64 + 0.85, *v)], BLUE.mix(0.7).filled())
        }))?;
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use kiosk_content::stats::*;
    use kiosk_core::camera::Camera;
    use kiosk_core::graph::{InfoGraph, Node};
    use kiosk_core::recommend::{RecEvent, RecSettings, RecState, Recommender, ViewContext};
    use kiosk_core::stats::ExhibitStats;
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
        let since = super::parse_date("2024-03-20").expect("date");
        let text = super::run(&super::StatsOptions {
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
        let text = super::run(&super::StatsOptions {
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
    fn a_report_on_damaged_statistics_says_so_and_leaves_them_for_the_kiosk() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = stats_path(dir.path(), "bust");
        std::fs::create_dir_all(path.parent().expect("dir")).expect("mkdir");
        std::fs::write(&path, b"{\"visits\": 3, \"nod").expect("write");
        let opts = StatsOptions {
            exhibit: "bust".into(),
            since: None,
            out: dir.path().join("out"),
            state: dir.path().into(),
        };
        let e = run(&opts).expect_err("damaged");
        assert!(e.to_string().contains(&format!("the statistics {} are damaged", path.display())), "{e:#}");
        assert_eq!(std::fs::read(&path).expect("still there"), b"{\"visits\": 3, \"nod");
    }

    #[test]
    fn civil_dates_round_trip() {
        assert_eq!(days_from_civil(1970, 1, 1), 0);
        assert_eq!(days_from_civil(2000, 3, 1), 11_017);
        for z in [-1000, 0, 59, 10_000, 19_000, 30_000] {
            let (y, m, d) = civil_from_days(z);
            assert_eq!(days_from_civil(y, m, d), z);
        }
        assert_eq!(parse_date("2024-02-29").expect("date"), 19_782.0 * 86_400.0);
        assert!(parse_date("yesterday").is_err());
    }
}
