//! The out-of-core hierarchy builder (balsa12 §4).
//!
//! 1. [`Builder::push`] takes samples one by one ([`Builder::push_all`] many at once: a mesh's
//!    vertices, taken over whole when they fit): it keeps the bounding box and the samples
//!    themselves in memory up to `chunk_points`. When the input outgrows that, a kd-tree chosen
//!    on a seeded random sample of those samples splits space into cells of about
//!    1/32 of half a chunk (as the input seen so far is spread), and from then on every sample
//!    goes straight to its cell's temporary file.
//! 2. [`Builder::finish`] chooses the model origin (the centre of the bounding box, in `f64`) and
//!    makes a region of every maximal subtree of cells holding at most half a chunk in all. A
//!    cell that alone holds more (the input seen first did not show where the rest would go: a
//!    scan read in sweep order) is split again on a sample of its own and distributed to new cells.
//! 3. Each region is processed in memory: duplicates are merged, normals and spacings estimated
//!    (when missing), the kd-tree continues down to leaves of at most `node_points` samples with
//!    split planes chosen for compactness among balanced (median) candidates, and inner nodes are
//!    built bottom-up by simplifying the union of their two children down to as many samples as
//!    the larger child holds (at most `node_points`).
//! 4. The region roots are joined by the same simplification up to the root.
//!
//! Memory is bounded by about `chunk_points` samples plus the cells' buffers, whatever the input size
//! and order (a region holds at most half a chunk, unless all its samples share one position).
//!
//! Each region is sorted once, in the order the hierarchy is cut (the kd-tree's median splits,
//! then inside each leaf node its implicit box hierarchy): the neighbour search runs on that order
//! and the subtree is cut from it without moving a sample again. Simplification (bettio09 §3,
//! balsa12 §4) collapses nearest pairs with compatible normals, shortest first; pairs longer than
//! a few splat radii are merged only where short pairs run out above M, so an isolated sample is
//! not merged into a disc as large as the gap. Each node is written to the store as soon as the
//! nodes before it are ([`crate::writer`]); regions are read one at a time. A region's buffers are
//! kept for the next one (fresh pages cost a fault and a zeroed page per 4 KiB); a build that
//! fits in one region frees its input samples as soon as they are taken, so that the nodes reuse
//! those pages.
//!
//! The stages are modules of their own, run in turn by [`Builder`]:
//! - `spill` (1, and the partition of the cells into regions of 2): the cell files, and the plan
//!   by which the regions join;
//! - `region` (3 and 4): each region's samples made into nodes, sent to [`crate::writer`] as they
//!   are made, and the region roots joined up to the root;
//! - `simplify` (3 and 4): an inner node's samples from its two children's.

use crate::source::InputPoint;
use crate::writer::{NodeSink, StoreWriter};
use glam::DVec3;
use kiosk_core::scene::boxtree;
use rayon::prelude::*;
use std::path::Path;

mod region;
mod simplify;
mod spill;

use region::{Ctx, Regions, Scratch};
use spill::{CELLS_PER_REGION, Cell, CellWriter, Plan, Selection, TopTree};

/// Settings of the builder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildParams {
    /// Target samples per node (M).
    pub node_points: usize,
    /// Samples processed in memory at once (bounds memory).
    pub chunk_points: usize,
    /// Neighbours for normal and spacing estimation.
    pub knn: usize,
    /// Samples with a normal of their own and no spacing (a point cloud's; a mesh's vertices
    /// bring theirs from the faces) search their neighbours for a spacing one in this many per
    /// leaf of 8–15 neighbouring samples; the others take the spacing of the nearest that did
    /// (1: every sample searches; see [`crate::estimate::estimate`]). A leaf that also holds a
    /// sample without a normal goes by `normal_stride` instead.
    pub spacing_stride: usize,
    /// Samples without a normal (a bare point cloud's) search their neighbours one in this many
    /// per leaf of 8–15 neighbouring samples; where the normals found agree within
    /// `normal_spread_deg`, the others take the normal and spacing of the nearest that searched,
    /// elsewhere they search too (1: every sample searches; at most [`MAX_NORMAL_STRIDE`]; see
    /// [`crate::estimate::Strides`]).
    pub normal_stride: usize,
    /// The largest angle in degrees (0 to 90) between the normals found in a leaf for its other
    /// samples to share them.
    pub normal_spread_deg: f32,
    /// Splat radius = `radius_factor` × local spacing, where the input brings the spacing (a
    /// mesh's vertices, from their faces, whose circumradius bounds the radius from below).
    pub radius_factor: f32,
    /// Splat radius = `cloud_radius_factor` × local spacing, where the spacing is estimated from
    /// the nearest neighbours (point clouds): their samples lie irregularly, so discs of 0.8
    /// spacings leave holes between them that a mesh's would not (figures in docs/performance.md).
    pub cloud_radius_factor: f32,
    /// Cosine of the largest angle between normals of samples that may be merged.
    pub merge_normal_cos: f32,
    /// Size of the random samples that choose the top-level splits (of the samples in memory
    /// when the input outgrows it, and of a cell that is split again).
    pub sample_size: usize,
    /// Seed of every random choice (builds are reproducible).
    pub seed: u64,
}

impl Default for BuildParams {
    fn default() -> Self {
        Self {
            node_points: 8192,
            chunk_points: 4_000_000,
            knn: 12,
            spacing_stride: 8,
            normal_stride: 4,
            normal_spread_deg: 4.0,
            radius_factor: 0.8,
            cloud_radius_factor: 1.4,
            merge_normal_cos: 0.5,
            sample_size: 1_000_000,
            seed: 0x15_0c_a3,
        }
    }
}

/// The largest [`BuildParams::normal_stride`]: the leaves hold 8–15 samples, so that every leaf
/// finds two normals at least to compare.
pub const MAX_NORMAL_STRIDE: usize = boxtree::LEAF_POINTS / 2 - 1;

/// Why a build failed.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// File system failure.
    #[error("I/O error: {0}")]
    Io(std::io::Error),
    /// The input cannot make a model.
    #[error("{0}")]
    Degenerate(String),
    /// Invalid settings.
    #[error("invalid build settings: {0}")]
    Params(String),
}

// The message is in the variant's own, so the I/O error is not also a source (see
// `kiosk_import::ReadError`).
impl From<std::io::Error> for BuildError {
    fn from(e: std::io::Error) -> Self {
        Self::Io(e)
    }
}

/// What a build produced.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildSummary {
    /// Samples pushed.
    pub input_points: u64,
    /// Distinct samples at full resolution.
    pub leaf_points: u64,
    /// Samples over all nodes.
    pub total_points: u64,
    /// Nodes.
    pub nodes: u64,
    /// Levels.
    pub levels: u32,
    /// Bytes of the store.
    pub bytes: u64,
    /// Regions processed out of core (1: everything fitted in memory).
    pub chunks: usize,
    /// Samples of the largest region processed in memory at once.
    pub largest_region: u64,
    /// Where the time of [`Builder::finish`] went.
    pub timings: Timings,
}

/// Wall time of each stage of [`Builder::finish`], summed over regions.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timings {
    /// Closing the cell files, splitting cells that outgrew a region and reading each region
    /// back (out-of-core builds only).
    pub distribute: std::time::Duration,
    /// Merging duplicates.
    pub merge: std::time::Duration,
    /// Sorting each region in the order of the hierarchy.
    pub order: std::time::Duration,
    /// Neighbour search for spacings and normals.
    pub estimate: std::time::Duration,
    /// Leaves, simplification of inner nodes, writing them.
    pub nodes: std::time::Duration,
    /// After the last node is written: the index and header, the final sync, the rename into
    /// place.
    pub finish: std::time::Duration,
}

/// Time since `clock`, which restarts.
fn lap(clock: &mut std::time::Instant) -> std::time::Duration {
    let now = std::time::Instant::now();
    let d = now - *clock;
    *clock = now;
    d
}

/// Progress of a build, for a progress bar.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Splitting a cell that outgrew a region into new cells: (done, total samples of the cell).
    Distribute(u64, u64),
    /// Building nodes: (samples done, total samples).
    Build(u64, u64),
}

enum Spill {
    /// The samples as pushed (a mesh's vertices are taken over whole, see [`Builder::push_all`]).
    Memory(Vec<InputPoint>),
    Cells(CellWriter),
}

/// The builder.
pub struct Builder {
    params: BuildParams,
    spill: Spill,
    count: u64,
    min: DVec3,
    max: DVec3,
    tmp_dir: std::path::PathBuf,
}

impl Builder {
    /// A builder that spills to `tmp_dir` when needed.
    pub fn new(params: BuildParams, tmp_dir: &Path) -> Result<Self, BuildError> {
        if params.node_points < 16 || params.chunk_points < 4 * params.node_points {
            return Err(BuildError::Params(format!(
                "node_points must be ≥ 16 and chunk_points ≥ 4 × node_points (got {} and {})",
                params.node_points, params.chunk_points
            )));
        }
        // A normal stride finds two normals at least in every leaf (8–15 samples) to compare.
        for (name, stride, most) in [
            ("spacing_stride", params.spacing_stride, boxtree::LEAF_POINTS),
            ("normal_stride", params.normal_stride, MAX_NORMAL_STRIDE),
        ] {
            if !(1..=most).contains(&stride) {
                return Err(BuildError::Params(format!("{name} must be 1 to {most} (got {stride})")));
            }
        }
        if !(0.0..=90.0).contains(&params.normal_spread_deg) {
            return Err(BuildError::Params(format!(
                "normal_spread_deg must be 0 to 90 (got {})",
                params.normal_spread_deg
            )));
        }
        Ok(Self {
            params,
            // Address space only: pages are touched as samples arrive.
            spill: Spill::Memory(Vec::with_capacity(params.chunk_points + 1)),
            count: 0,
            min: DVec3::INFINITY,
            max: DVec3::NEG_INFINITY,
            tmp_dir: tmp_dir.to_path_buf(),
        })
    }

    /// Adds a sample (its position must be finite; the readers guarantee it).
    pub fn push(&mut self, p: InputPoint) -> Result<(), BuildError> {
        self.count_in(p.pos)?;
        match &mut self.spill {
            Spill::Memory(v) => {
                v.push(p);
                if v.len() > self.params.chunk_points {
                    self.start_cells()?;
                }
            }
            Spill::Cells(w) => w.push(&p)?,
        }
        Ok(())
    }

    /// Memory is full: from now on samples go to the cells of a kd-tree chosen on those seen so
    /// far, fine enough that regions can be assembled from whole subtrees of cells (cells that
    /// overflow are split again at the end).
    fn start_cells(&mut self) -> Result<(), BuildError> {
        let Spill::Memory(v) = &mut self.spill else {
            return Ok(());
        };
        let first = std::mem::take(v);
        let mut selection = Selection::new(self.params.sample_size, first.len() as u64, self.params.seed);
        selection.take(&first, |p| p.pos);
        let cell = (self.params.chunk_points / 2 / CELLS_PER_REGION).max(1);
        let tree = TopTree::build(&selection.sample, self.count, cell);
        let mut cells = CellWriter::start(&self.tmp_dir, tree)?;
        cells.push_all(&first)?;
        drop(first);
        self.spill = Spill::Cells(cells);
        Ok(())
    }

    /// Adds samples as [`Builder::push`] adds them one by one, and to the same effect (the same
    /// store), a batch at a time. Taken over whole (no copy) when they are the first and fit in
    /// memory: the vertices of a mesh, read before its faces are applied.
    pub fn push_all(&mut self, points: Vec<InputPoint>) -> Result<(), BuildError> {
        let chunk = self.params.chunk_points;
        if matches!(&self.spill, Spill::Memory(v) if v.is_empty()) && points.len() <= chunk {
            self.count_all(&points)?;
            self.spill = Spill::Memory(points);
            return Ok(());
        }
        let mut rest = points.as_slice();
        while !rest.is_empty() {
            match &mut self.spill {
                Spill::Memory(v) => {
                    // As many as one by one would take before memory is full (it holds at most
                    // `chunk` here), then the cells start on the same samples.
                    let (now, later) = rest.split_at((chunk + 1 - v.len()).min(rest.len()));
                    if v.capacity() < chunk + 1 {
                        // Address space only, as at the start (a first batch taken over whole
                        // came with its own capacity).
                        v.reserve_exact(chunk + 1 - v.len());
                    }
                    // On the pool: the copy, and the first touch of fresh pages.
                    v.par_extend(now.par_iter().copied());
                    self.count_all(now)?;
                    if matches!(&self.spill, Spill::Memory(v) if v.len() > chunk) {
                        self.start_cells()?;
                    }
                    rest = later;
                }
                Spill::Cells(w) => {
                    w.push_all(rest)?;
                    self.count_all(rest)?;
                    rest = &[];
                }
            }
        }
        Ok(())
    }

    /// Counts samples in and widens the bounds to them, on the pool (min and max are exact in
    /// any order); the first non-finite position is the error [`Builder::push`] would give.
    fn count_all(&mut self, points: &[InputPoint]) -> Result<(), BuildError> {
        if let Some(i) = points.par_iter().position_first(|p| !p.pos.is_finite()) {
            self.count += i as u64;
            return self.count_in(points[i].pos);
        }
        let (min, max) = points
            .par_iter()
            .fold(|| (DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), p| (lo.min(p.pos), hi.max(p.pos)))
            .reduce(|| (DVec3::INFINITY, DVec3::NEG_INFINITY), |a, b| (a.0.min(b.0), a.1.max(b.1)));
        self.count += points.len() as u64;
        self.min = self.min.min(min);
        self.max = self.max.max(max);
        Ok(())
    }

    /// Counts a sample in and widens the bounds to it (its position must be finite).
    fn count_in(&mut self, pos: DVec3) -> Result<(), BuildError> {
        if !pos.is_finite() {
            return Err(BuildError::Degenerate(format!(
                "sample {} has a non-finite position",
                self.count + 1
            )));
        }
        self.count += 1;
        self.min = self.min.min(pos);
        self.max = self.max.max(pos);
        Ok(())
    }

    /// Samples pushed so far.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// Builds the hierarchy and writes the store to `out`.
    pub fn finish(self, out: &Path, progress: &mut dyn FnMut(Stage)) -> Result<BuildSummary, BuildError> {
        if self.count == 0 {
            return Err(BuildError::Degenerate("the model has no samples".into()));
        }
        let origin = (self.min + self.max) * 0.5;
        // A store keeps f32 coordinates relative to an f64 origin, within bounds that tell a real
        // model from a corrupted store: a model beyond them cannot be stored.
        let half = (self.max - self.min) * 0.5;
        let (max_local, max_origin) =
            (f64::from(kiosk_core::scene::store::MAX_LOCAL), kiosk_core::scene::store::MAX_ORIGIN);
        if half.max_element() > max_local || origin.abs().max_element() > max_origin {
            let at = |p: DVec3| {
                p.to_array()
                    .map(|c| {
                        // Seven digits are plenty to see what is wrong.
                        let short = c as f32;
                        if short == 0.0 || (1e-3..1e7).contains(&short.abs()) {
                            format!("{short}")
                        } else if short.is_finite() {
                            format!("{short:e}")
                        } else {
                            format!("{c:.6e}")
                        }
                    })
                    .join(", ")
            };
            return Err(BuildError::Degenerate(format!(
                "the samples reach from ({}) to ({}); a store holds a model at most {:e} units across, within \
                 {max_origin:e} units of the origin (a wrong scale, or stray points?)",
                at(self.min),
                at(self.max),
                2.0 * max_local,
            )));
        }
        let params = self.params;
        let mut ctx = Ctx {
            params,
            scratch: Scratch::default(),
            // The only region of a build in memory frees its samples and buffers as soon as
            // they are used, so that the nodes and the writer's queue take their pages instead
            // of fresh ones (the peak memory of the build, not only of the region).
            keep_scratch: matches!(self.spill, Spill::Cells(_)),
            sink: NodeSink::start(StoreWriter::create(out)?),
            done: 0,
            total: self.count,
            progress,
            timings: Timings::default(),
            largest_region: 0,
        };
        let (root, chunks) = match self.spill {
            Spill::Memory(v) => {
                (ctx.progress)(Stage::Build(0, ctx.total));
                let root = ctx.region(v, origin, drop)?;
                (root, 1)
            }
            Spill::Cells(w) => {
                let mut clock = std::time::Instant::now();
                let (tree, cells) = w.finish()?;
                let mut cells: Vec<Option<Cell>> = cells.into_iter().map(Some).collect();
                let mut regions = Vec::new();
                let limit = (params.chunk_points / 2) as u64;
                let plan =
                    Plan::new(&tree, &mut cells, limit, &params, &self.tmp_dir, ctx.progress, &mut regions)?;
                let chunks = regions.len();
                ctx.timings.distribute += lap(&mut clock);
                (ctx.progress)(Stage::Build(0, ctx.total));
                // Each region is read when its turn comes (each cell file is deleted once read),
                // into the buffer of the region before.
                let mut regions = Regions::new(regions);
                let root = ctx.top(&plan, &mut regions, origin)?;
                (root.ok_or_else(|| BuildError::Degenerate("no samples reached any region".into()))?, chunks)
            }
        };
        // Every sample is in the tree (duplicates merged: the count built falls short of the
        // count read by as many).
        (ctx.progress)(Stage::Build(ctx.total, ctx.total));
        let clock = std::time::Instant::now();
        let mut timings = ctx.timings;
        let largest_region = ctx.largest_region;
        // Freed before the index is written.
        drop(std::mem::take(&mut ctx.scratch));
        let writer = ctx.sink.finish()?;
        let root = root.id;
        let levels = writer.node(root).height + 1;
        let nodes = u64::from(root) + 1;
        let leaf = writer_counts(&writer, root);
        let bytes = writer.finish(origin.to_array(), self.count, params.node_points as u32)?;
        timings.finish = clock.elapsed();
        Ok(BuildSummary {
            input_points: self.count,
            leaf_points: leaf.0,
            total_points: leaf.1,
            nodes,
            levels,
            bytes,
            chunks,
            largest_region,
            timings,
        })
    }
}

fn writer_counts(w: &StoreWriter, root: u32) -> (u64, u64) {
    let (mut leaf, mut total) = (0, 0);
    for id in 0..=root {
        let n = w.node(id);
        total += u64::from(n.point_count);
        if n.is_leaf() {
            leaf += u64::from(n.point_count);
        }
    }
    (leaf, total)
}

/// The builder takes a mesh's vertices over whole, and a survey reader's batches a batch at a time.
impl crate::source::Sink for Builder {
    type Error = crate::BuildError;

    fn point(&mut self, p: InputPoint) -> Result<(), Self::Error> {
        self.push(p)
    }

    fn points(&mut self, points: Vec<InputPoint>) -> Result<(), Self::Error> {
        self.push_all(points)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use rand::{Rng, SeedableRng};

    #[test]
    fn settings_out_of_range_are_an_error_that_names_them() {
        let tmp = std::env::temp_dir();
        let dir = tmp.as_path();
        for (params, name) in [
            (BuildParams { node_points: 8, ..Default::default() }, "node_points"),
            (BuildParams { chunk_points: 1000, ..Default::default() }, "chunk_points"),
            (BuildParams { spacing_stride: 0, ..Default::default() }, "spacing_stride"),
            (BuildParams { spacing_stride: 17, ..Default::default() }, "spacing_stride"),
            (BuildParams { normal_stride: 0, ..Default::default() }, "normal_stride"),
            (BuildParams { normal_stride: 8, ..Default::default() }, "normal_stride"),
            (BuildParams { normal_spread_deg: f32::NAN, ..Default::default() }, "normal_spread_deg"),
            (BuildParams { normal_spread_deg: -1.0, ..Default::default() }, "normal_spread_deg"),
        ] {
            match Builder::new(params, dir) {
                Err(BuildError::Params(msg)) => assert!(msg.contains(name), "{msg}"),
                other => panic!("{params:?}: {:?}", other.map(|_| ())),
            }
        }
        assert!(
            Builder::new(BuildParams { spacing_stride: 16, normal_stride: 7, ..Default::default() }, dir)
                .is_ok()
        );
    }

    #[test]
    fn a_spill_directory_that_cannot_be_written_is_an_error() {
        let params = BuildParams { node_points: 16, chunk_points: 64, ..Default::default() };
        let mut b = Builder::new(params, Path::new("/nonexistent/spill-dir")).expect("valid settings");
        let err = (0..1000)
            .map(|i| {
                b.push(InputPoint {
                    pos: DVec3::new(f64::from(i), 0.0, 0.0),
                    normal: Vec3::ZERO,
                    color: [0; 4],
                    radius: 0.0,
                    spacing: 0.0,
                })
            })
            .find_map(Result::err);
        assert!(matches!(err, Some(BuildError::Io(_))), "{err:?}");
    }

    fn build_points(
        points: impl Iterator<Item = DVec3>,
        params: BuildParams,
    ) -> Result<BuildSummary, BuildError> {
        let dir = tempfile::tempdir()?;
        let mut b = Builder::new(params, dir.path())?;
        for pos in points {
            b.push(InputPoint { pos, normal: Vec3::Z, color: [0; 4], radius: 0.0, spacing: 0.0 })?;
        }
        b.finish(&dir.path().join("m.kstore"), &mut |_| {})
    }

    #[test]
    fn input_in_sweep_order_still_makes_regions_of_at_most_half_a_chunk() {
        // Sorted along x: when memory runs out, the samples seen span a tenth of the model, so
        // nearly every later sample lands in the last cells, which must be split again.
        let params = BuildParams { node_points: 64, chunk_points: 2000, ..Default::default() };
        let grid = |i: u32| DVec3::new(f64::from(i / 100) * 0.01, f64::from(i % 100) * 0.01, 0.0);
        let s = build_points((0..20_000).map(grid), params).expect("builds");
        assert_eq!(s.leaf_points, 20_000);
        assert!(s.largest_region <= 1000, "a region of {} samples", s.largest_region);
        assert!(s.chunks >= 20, "{} regions", s.chunks);
        // Random order: the first cells already fit.
        let mut order: Vec<u32> = (0..20_000).collect();
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        for i in (1..order.len()).rev() {
            order.swap(i, rng.random_range(0..=i));
        }
        let r = build_points(order.into_iter().map(grid), params).expect("builds");
        assert_eq!(r.leaf_points, 20_000);
        assert!(r.largest_region <= 1000, "a region of {} samples", r.largest_region);
    }

    #[test]
    fn samples_pushed_all_at_once_make_the_store_pushing_them_one_by_one_makes() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let points: Vec<InputPoint> = (0..6000)
            .map(|_| InputPoint {
                pos: DVec3::new(rng.random(), rng.random(), rng.random::<f64>() * 0.1),
                normal: Vec3::Z,
                color: [rng.random(), 7, 9, 255],
                radius: rng.random::<f32>() * 0.01,
                spacing: 0.0,
            })
            .collect();
        let dir = tempfile::tempdir().expect("temp dir");
        let store = |name: &str, params: BuildParams, whole: usize| -> Vec<u8> {
            let mut b = Builder::new(params, dir.path()).expect("valid settings");
            // The first `whole` at once (taken over when they fit in memory), the rest one by one.
            b.push_all(points[..whole].to_vec()).expect("pushed");
            for &p in &points[whole..] {
                b.push(p).expect("pushed");
            }
            let path = dir.path().join(name);
            b.finish(&path, &mut |_| {}).expect("builds");
            std::fs::read(path).expect("store")
        };
        // In memory, and past the memory of 4000 samples (spilled to cells).
        for chunk_points in [10_000, 4000] {
            let params = BuildParams { node_points: 64, chunk_points, ..Default::default() };
            let one_by_one = store("a.kstore", params, 0);
            for whole in [6000, 3000] {
                assert!(
                    store("b.kstore", params, whole) == one_by_one,
                    "chunk {chunk_points}, {whole} at once"
                );
            }
            // In batches (as the survey readers hand them), across the point where memory is full.
            for batch in [1, 777, 4001] {
                let mut b = Builder::new(params, dir.path()).expect("valid settings");
                for part in points.chunks(batch) {
                    b.push_all(part.to_vec()).expect("pushed");
                }
                let path = dir.path().join("c.kstore");
                b.finish(&path, &mut |_| {}).expect("builds");
                assert!(
                    std::fs::read(path).expect("store") == one_by_one,
                    "chunk {chunk_points}, batches of {batch}"
                );
            }
        }
        let mut bad = points.clone();
        bad[4321].pos.y = f64::NAN;
        // Taken over, or one by one after a first sample, or in batches after memory is full:
        // the error names the sample.
        for (before, nth, chunk_points) in [(0, 4322, 4_000_000), (1, 4323, 4_000_000), (1, 4323, 1000)] {
            let params = BuildParams { node_points: 64, chunk_points, ..Default::default() };
            let mut b = Builder::new(params, dir.path()).expect("valid settings");
            points[..before].iter().for_each(|&p| b.push(p).expect("pushed"));
            let err = b.push_all(bad.clone()).expect_err("a NaN");
            assert!(err.to_string().contains(&format!("sample {nth} has a non-finite position")), "{err}");
        }
    }

    #[test]
    fn stores_are_identical_whatever_the_number_of_threads() {
        // Several regions (nodes streamed to the writer as they are made, in any order).
        let params = BuildParams { node_points: 64, chunk_points: 4000, ..Default::default() };
        let mut rng = rand_pcg::Pcg64::seed_from_u64(9);
        let points: Vec<DVec3> = (0..12_000).map(|_| DVec3::new(rng.random(), rng.random(), 0.0)).collect();
        let dir = tempfile::tempdir().expect("temp dir");
        let store = |threads: usize| -> Vec<u8> {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
            let path = dir.path().join(format!("t{threads}.kstore"));
            pool.install(|| {
                let mut b = Builder::new(params, dir.path()).expect("valid settings");
                for &pos in &points {
                    b.push(InputPoint { pos, normal: Vec3::Z, color: [0; 4], radius: 0.0, spacing: 0.0 })
                        .expect("pushed");
                }
                let s = b.finish(&path, &mut |_| {}).expect("builds");
                assert!(s.chunks >= 2, "{} regions", s.chunks);
            });
            std::fs::read(path).expect("store")
        };
        let one = store(1);
        assert!(store(2) == one && store(5) == one);
    }

    #[test]
    fn out_of_core_input_at_one_position_is_an_error_not_a_loop() {
        let params = BuildParams { node_points: 16, chunk_points: 64, ..Default::default() };
        let err = build_points(std::iter::repeat_n(DVec3::new(1.0, 2.0, 3.0), 1000), params);
        assert!(matches!(&err, Err(BuildError::Degenerate(m)) if m.contains("same position")), "{err:?}");
    }
}
