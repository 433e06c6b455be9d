//! `kiosk bench`: the scene benchmarks (see the README for the figures).

/// Arguments of `kiosk bench`.
#[derive(Clone, Debug, clap::Args)]
pub struct BenchArgs {}

/// Runs the benchmarks.
pub fn run(_args: &BenchArgs) -> anyhow::Result<()> {
    anyhow::bail!("not yet")
}
