//! `kiosk`: the IsoKiosk command line.

use anyhow::Context;
use clap::{Parser, Subcommand};
use kiosk::import::{ImportOptions, import};
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "kiosk", version, about = "IsoKiosk: explore huge 3D scans in a museum")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Import a scan (PLY in any encoding, .ply.gz, OBJ) into a multiresolution store.
    Import {
        /// The scan file.
        scan: PathBuf,
        /// The store to write.
        #[arg(short, long)]
        output: PathBuf,
        /// Target samples per node (M).
        #[arg(long, default_value_t = kiosk_import::BuildParams::default().node_points)]
        node_points: usize,
        /// Skip samples with NaN/∞ coordinates instead of failing.
        #[arg(long)]
        drop_invalid: bool,
        /// No progress bar.
        #[arg(long, short)]
        quiet: bool,
    },
    /// Check a store: header, index and every node's checksum.
    Verify {
        /// The store file.
        store: PathBuf,
    },
    /// Run a benchmark and print its table (see the README).
    Bench(kiosk::bench::BenchArgs),
}

fn main() -> anyhow::Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Import { scan, output, node_points, drop_invalid, quiet } => {
            let mut opts = ImportOptions { progress: !quiet, ..Default::default() };
            opts.build.node_points = node_points;
            opts.read.drop_invalid = drop_invalid;
            let report = import(&scan, &output, &opts)?;
            for w in &report.warnings {
                eprintln!("warning: {}: {w}", scan.display());
            }
            println!("{}: {report}", output.display());
        }
        Command::Verify { store } => {
            let s = kiosk::open_store(&store)?;
            for id in 0..s.nodes().len() as u32 {
                s.verify_node(id).with_context(|| format!("{}", store.display()))?;
            }
            let h = s.header();
            println!(
                "{}: ok — {} nodes, {} levels, {} samples at full resolution, origin {:?}",
                store.display(),
                h.node_count,
                s.levels(),
                h.leaf_point_count,
                h.origin
            );
        }
        Command::Bench(args) => kiosk::bench::run(&args)?,
    }
    Ok(())
}
