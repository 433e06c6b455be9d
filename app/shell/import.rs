//! `kiosk import`: scan file → store, with a progress bar and a summary.

use anyhow::Context;
use indicatif::{ProgressBar, ProgressStyle};
use kiosk_import::{BuildParams, BuildSummary, Builder, ReadOptions, Stage, source};
use std::path::Path;
use std::time::Instant;

/// Options of an import.
#[derive(Clone, Debug, Default)]
pub struct ImportOptions {
    /// Builder settings.
    pub build: BuildParams,
    /// Reader settings.
    pub read: ReadOptions,
    /// Show a progress bar on the terminal.
    pub progress: bool,
}

/// What an import did.
#[derive(Clone, Debug)]
pub struct ImportReport {
    /// Builder summary.
    pub build: BuildSummary,
    /// Reader warnings.
    pub warnings: Vec<String>,
    /// Wall time in seconds.
    pub seconds: f64,
}

impl std::fmt::Display for ImportReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let b = &self.build;
        write!(
            f,
            "{} input points → {} distinct samples; {} nodes, {} levels, {} samples in all levels; \
             {:.1} MB; {:.2} s; {:.0} points/s",
            b.input_points,
            b.leaf_points,
            b.nodes,
            b.levels,
            b.total_points,
            b.bytes as f64 / 1e6,
            self.seconds,
            b.input_points as f64 / self.seconds.max(1e-9)
        )
    }
}

fn bar(progress: bool) -> ProgressBar {
    if !progress {
        return ProgressBar::hidden();
    }
    let pb = ProgressBar::new(0);
    pb.set_style(
        ProgressStyle::with_template("{msg:>10} [{bar:40}] {pos}/{len} {per_sec} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    pb
}

/// Imports a scan file into a store.
pub fn import(scan: &Path, out: &Path, opts: &ImportOptions) -> anyhow::Result<ImportReport> {
    let start = Instant::now();
    let tmp_dir = out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    let mut builder = Builder::new(opts.build, tmp_dir)?;
    let pb = bar(opts.progress);
    pb.set_message("reading");
    let report = source::read_file(scan, &opts.read, &mut Feed { builder: &mut builder, pb: &pb, read: 0 })
        .with_context(|| format!("{}", scan.display()))?;
    let summary = build(builder, out, &pb)?;
    pb.finish_and_clear();
    Ok(ImportReport { build: summary, warnings: report.warnings, seconds: start.elapsed().as_secs_f64() })
}

/// The builder fed by a reader, with the points read on the progress bar.
struct Feed<'a> {
    builder: &'a mut Builder,
    pb: &'a ProgressBar,
    read: u64,
}

impl source::Sink for Feed<'_> {
    fn point(&mut self, p: source::InputPoint) -> Result<(), String> {
        self.read += 1;
        if self.read.is_multiple_of(65536) {
            self.pb.set_position(self.read);
        }
        source::Sink::point(self.builder, p)
    }

    fn points(&mut self, points: Vec<source::InputPoint>) -> Result<(), String> {
        self.read += points.len() as u64;
        self.pb.set_position(self.read);
        source::Sink::points(self.builder, points)
    }
}

/// Runs the builder with a progress bar.
pub fn build(builder: Builder, out: &Path, pb: &ProgressBar) -> anyhow::Result<BuildSummary> {
    let summary = builder
        .finish(out, &mut |stage| match stage {
            Stage::Distribute(done, total) => {
                pb.set_message("sorting");
                pb.set_length(total);
                pb.set_position(done);
            }
            Stage::Build(done, total) => {
                pb.set_message("building");
                pb.set_length(total);
                pb.set_position(done);
            }
        })
        .with_context(|| format!("building {}", out.display()))?;
    Ok(summary)
}
