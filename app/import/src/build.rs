//! The out-of-core hierarchy builder (balsa12 §4).
//!
//! 1. [`Builder::push`] takes samples one by one ([`Builder::push_all`] many at once: a mesh's
//!    vertices, taken over whole when they fit): it keeps the bounding box and the samples
//!    themselves in memory up to `chunk_points`. When the input outgrows that, a kd-tree chosen
//!    on a seeded random sample of those samples splits space into cells of about
//!    1/32 of half a chunk (as the input seen so far is spread), and from then on every sample
//!    goes straight to its cell's temporary file (written by a thread of its own).
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
//! not merged into a disc as large as the gap. The store is written by a thread of its own while
//! the next region is built ([`crate::writer`]). A region's buffers are kept for the next one
//! (fresh pages cost a fault and a zeroed page per 4 KiB); a build that fits in one region frees
//! its input samples as soon as they are taken, so that the nodes reuse those pages.

use crate::estimate::{self, Estimate};
use crate::source::InputPoint;
use crate::writer::{NodeSink, NodeStats, PendingNode, StoreWriter};
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};
use kiosk_core::scene::boxtree;
use kiosk_core::{Aabb, Splat};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;

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
    /// (1: every sample searches; see [`estimate::estimate`]).
    pub spacing_stride: usize,
    /// Splat radius = `radius_factor` × local spacing.
    pub radius_factor: f32,
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
            radius_factor: 0.8,
            merge_normal_cos: 0.5,
            sample_size: 1_000_000,
            seed: 0x15_0c_a3,
        }
    }
}

/// Why a build failed.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// File system failure.
    #[error("I/O error: {0}")]
    Io(#[from] std::io::Error),
    /// The input cannot make a model.
    #[error("{0}")]
    Degenerate(String),
    /// Invalid settings.
    #[error("invalid build settings: {0}")]
    Params(String),
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
    /// Closing the cell files and splitting cells that outgrew a region (out-of-core builds only).
    pub distribute: std::time::Duration,
    /// Merging duplicates.
    pub merge: std::time::Duration,
    /// Sorting each region in the order of the hierarchy.
    pub order: std::time::Duration,
    /// Neighbour search for spacings and normals.
    pub estimate: std::time::Duration,
    /// Leaves, simplification of inner nodes, writing them.
    pub nodes: std::time::Duration,
    /// After the last node is made: the writer's last blocks, the index and header, the final
    /// sync, the rename into place.
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

/// A sample as spilled to disk.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
struct RawRec {
    pos: [f64; 3],
    normal: [f32; 3],
    color: [u8; 4],
    radius: f32,
    spacing: f32,
}

impl From<InputPoint> for RawRec {
    fn from(p: InputPoint) -> Self {
        Self {
            pos: p.pos.to_array(),
            normal: p.normal.to_array(),
            color: p.color,
            radius: p.radius,
            spacing: p.spacing,
        }
    }
}

/// A sample as the builder holds it: as pushed (in memory) or as spilled (read back from cells).
trait Record: Copy + Send + Sync + 'static {
    fn position(&self) -> DVec3;
    fn spilled(&self) -> RawRec;
    /// Normal, colour, radius and spacing.
    fn attributes(&self) -> (Vec3, [u8; 4], f32, f32);
}

impl Record for InputPoint {
    #[inline]
    fn position(&self) -> DVec3 {
        self.pos
    }
    #[inline]
    fn spilled(&self) -> RawRec {
        RawRec::from(*self)
    }
    #[inline]
    fn attributes(&self) -> (Vec3, [u8; 4], f32, f32) {
        (self.normal, self.color, self.radius, self.spacing)
    }
}

impl Record for RawRec {
    #[inline]
    fn position(&self) -> DVec3 {
        DVec3::from_array(self.pos)
    }
    #[inline]
    fn spilled(&self) -> RawRec {
        *self
    }
    #[inline]
    fn attributes(&self) -> (Vec3, [u8; 4], f32, f32) {
        (Vec3::from_array(self.normal), self.color, self.radius, self.spacing)
    }
}

/// A sample being processed, in local coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Work {
    pos: Vec3,
    normal: Vec3,
    radius: f32,
    color: [u8; 4],
}

impl boxtree::HasPosition for Work {
    #[inline]
    fn position(&self) -> Vec3 {
        self.pos
    }
}

enum Spill {
    /// The samples as pushed (a mesh's vertices are taken over whole, see [`Builder::push_all`]).
    Memory(Vec<InputPoint>),
    Cells(CellWriter<InputPoint>),
}

/// Samples per batch handed to the cell writer.
const SPILL_BATCH: usize = 1 << 16;

/// Cells per expected region when the input first outgrows memory: regions are later made of
/// whole subtrees of cells, so a region can be as small as half a chunk's worth / this.
const CELLS_PER_REGION: usize = 32;

/// Sorts samples into the cell files of a kd-tree (chosen on the samples seen when memory ran
/// out) on a thread of its own, so that reading the input and writing the cells overlap.
/// Batches queue up to a few (memory stays bounded).
struct CellWriter<R> {
    batch: Vec<R>,
    tx: Option<std::sync::mpsc::SyncSender<Vec<R>>>,
    thread: Option<std::thread::JoinHandle<std::io::Result<Cells>>>,
}

/// A kd-tree and its cells (one per leaf, in order).
type Cells = (TopTree, Vec<Cell>);

/// The temporary file of one cell and the samples in it.
struct Cell {
    file: tempfile::NamedTempFile,
    count: u64,
}

impl<R: Record> CellWriter<R> {
    /// Starts the cells of `tree` with `first`.
    fn start(tmp_dir: &Path, tree: TopTree, first: Vec<R>) -> std::io::Result<Self> {
        let mut cells = Vec::with_capacity(tree.leaves());
        for _ in 0..tree.leaves() {
            cells.push((BufWriter::with_capacity(1 << 16, tempfile::NamedTempFile::new_in(tmp_dir)?), 0u64));
        }
        let (tx, rx) = std::sync::mpsc::sync_channel::<Vec<R>>(4);
        let thread = std::thread::Builder::new().name("cells".into()).spawn(move || {
            for batch in rx {
                for rec in &batch {
                    let (w, count) = &mut cells[tree.locate(rec.position())];
                    w.write_all(bytemuck::bytes_of(&rec.spilled()))?;
                    *count += 1;
                }
            }
            let cells = cells
                .into_iter()
                .map(|(w, count)| {
                    Ok(Cell { file: w.into_inner().map_err(std::io::IntoInnerError::into_error)?, count })
                })
                .collect::<std::io::Result<_>>()?;
            Ok((tree, cells))
        })?;
        let mut w = Self { batch: Vec::with_capacity(SPILL_BATCH), tx: Some(tx), thread: Some(thread) };
        w.send(first)?;
        Ok(w)
    }

    fn push(&mut self, r: R) -> std::io::Result<()> {
        self.batch.push(r);
        if self.batch.len() >= SPILL_BATCH {
            let batch = std::mem::replace(&mut self.batch, Vec::with_capacity(SPILL_BATCH));
            self.send(batch)?;
        }
        Ok(())
    }

    fn send(&mut self, batch: Vec<R>) -> std::io::Result<()> {
        match &self.tx {
            Some(tx) if tx.send(batch).is_ok() => Ok(()),
            // The thread stopped: its error says why.
            _ => Err(self.join().err().unwrap_or_else(|| std::io::Error::other("the cell writer stopped"))),
        }
    }

    fn join(&mut self) -> std::io::Result<Cells> {
        self.tx = None;
        match self.thread.take().map(std::thread::JoinHandle::join) {
            Some(Ok(result)) => result,
            Some(Err(_)) => Err(std::io::Error::other("the cell writer panicked")),
            None => Err(std::io::Error::other("the cell writer stopped")),
        }
    }

    /// Writes what is left and returns the tree and its cells.
    fn finish(mut self) -> std::io::Result<Cells> {
        let batch = std::mem::take(&mut self.batch);
        self.send(batch)?;
        self.join()
    }
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
        if !(1..=boxtree::LEAF_POINTS).contains(&params.spacing_stride) {
            return Err(BuildError::Params(format!(
                "spacing_stride must be 1 to {} (got {})",
                boxtree::LEAF_POINTS,
                params.spacing_stride
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
            Spill::Cells(w) => w.push(p)?,
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
        let mut reservoir = Reservoir::new(self.params.sample_size, self.params.seed);
        first.iter().for_each(|p| reservoir.offer(p.pos));
        let cell = (self.params.chunk_points / 2 / CELLS_PER_REGION).max(1);
        let tree = TopTree::build(&reservoir.sample, self.count, cell);
        self.spill = Spill::Cells(CellWriter::start(&self.tmp_dir, tree, first)?);
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
                    v.extend_from_slice(now);
                    self.count_all(now)?;
                    if matches!(&self.spill, Spill::Memory(v) if v.len() > chunk) {
                        self.start_cells()?;
                    }
                    rest = later;
                }
                Spill::Cells(w) => {
                    for &p in rest {
                        w.push(p)?;
                    }
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
        let params = self.params;
        let mut ctx = Ctx {
            params,
            scratch: Scratch::default(),
            // The only region of a build in memory frees its samples and buffers as soon as
            // they are used, so that the nodes and the writer's queue take their pages instead
            // of fresh ones (the peak memory of the build, not only of the region).
            keep_scratch: matches!(self.spill, Spill::Cells(_)),
            sink: NodeSink::start(StoreWriter::create(out)?)?,
            done: 0,
            total: self.count,
            progress,
            timings: Timings::default(),
            largest_region: 0,
        };
        let (root, chunks) = match self.spill {
            Spill::Memory(v) => {
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
                // A reader thread loads the next region while this one is processed (one region
                // ahead: memory stays bounded); each cell file is deleted once read.
                // Region buffers go back to the reader once processed: fresh pages for every
                // region (≈ 100 MB each) would cost a page fault and a zeroed page per 4 KiB.
                let root = std::thread::scope(|scope| {
                    let (tx, rx) = std::sync::mpsc::sync_channel(1);
                    let (back_tx, back_rx) = std::sync::mpsc::channel();
                    scope.spawn(move || {
                        for files in regions {
                            let recs = read_region(&files, back_rx.try_recv().unwrap_or_default());
                            drop(files);
                            if tx.send(recs).is_err() {
                                break;
                            }
                        }
                    });
                    ctx.top(&plan, &Regions { next: rx, back: back_tx }, origin)
                })?;
                (root.ok_or_else(|| BuildError::Degenerate("no samples reached any region".into()))?, chunks)
            }
        };
        let clock = std::time::Instant::now();
        let mut timings = ctx.timings;
        let largest_region = ctx.largest_region;
        // Freed while the writer writes the last nodes, not after.
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

/// The top of the kd-tree, chosen on a random sample of the samples.
enum TopTree {
    Leaf(usize),
    Split { axis: usize, at: f64, children: Box<[TopTree; 2]> },
}

impl TopTree {
    fn build(sample: &[DVec3], total: u64, max_expected: usize) -> Self {
        let mut s = sample.to_vec();
        let mut next = 0;
        Self::rec(&mut s, total as f64 / sample.len().max(1) as f64, max_expected as f64, &mut next)
    }

    fn rec(s: &mut [DVec3], scale: f64, max_expected: f64, next: &mut usize) -> Self {
        if (s.len() as f64) * scale <= max_expected || s.len() < 2 {
            *next += 1;
            return Self::Leaf(*next - 1);
        }
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for p in s.iter() {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let axis = (hi - lo).max_position();
        let mid = s.len() / 2;
        s.select_nth_unstable_by(mid, |a, b| a[axis].total_cmp(&b[axis]));
        let at = s[mid][axis];
        let (l, r) = s.split_at_mut(mid);
        let left = Self::rec(l, scale, max_expected, next);
        let right = Self::rec(r, scale, max_expected, next);
        Self::Split { axis, at, children: Box::new([left, right]) }
    }

    fn leaves(&self) -> usize {
        match self {
            Self::Leaf(i) => i + 1,
            Self::Split { children, .. } => children[1].leaves(),
        }
    }

    /// The leaves under this node: `first..end` (leaves are numbered left to right).
    fn leaf_range(&self) -> (usize, usize) {
        match self {
            Self::Leaf(i) => (*i, i + 1),
            Self::Split { children, .. } => (children[0].leaf_range().0, children[1].leaf_range().1),
        }
    }

    fn locate(&self, p: DVec3) -> usize {
        match self {
            Self::Leaf(i) => *i,
            Self::Split { axis, at, children } => children[usize::from(p[*axis] >= *at)].locate(p),
        }
    }
}

/// How the regions of an out-of-core build join: the kd-tree above them, its leaves the regions
/// in the order [`Plan::new`] lists their files.
enum Plan {
    Region,
    Split(Box<[Plan; 2]>),
}

impl Plan {
    /// Makes a region of every maximal subtree of `t` whose cells hold at most `limit` samples
    /// together, appending its cells to `regions`; a single cell over the limit is split again
    /// on a sample of its own and distributed to new cells.
    #[allow(clippy::too_many_arguments)]
    fn new(
        t: &TopTree,
        cells: &mut [Option<Cell>],
        limit: u64,
        params: &BuildParams,
        tmp_dir: &Path,
        progress: &mut dyn FnMut(Stage),
        regions: &mut Vec<Vec<Cell>>,
    ) -> Result<Self, BuildError> {
        let (first, end) = t.leaf_range();
        let n: u64 = cells[first..end].iter().flatten().map(|c| c.count).sum();
        if n <= limit {
            regions.push(cells[first..end].iter_mut().filter_map(Option::take).collect());
            return Ok(Self::Region);
        }
        match t {
            TopTree::Split { children, .. } => {
                let l = Self::new(&children[0], cells, limit, params, tmp_dir, progress, regions)?;
                let r = Self::new(&children[1], cells, limit, params, tmp_dir, progress, regions)?;
                Ok(Self::Split(Box::new([l, r])))
            }
            TopTree::Leaf(i) => {
                // The samples seen first did not show where the rest would go (a scan read in
                // sweep order): this cell outgrew a region and is split on a sample of its own.
                let cell = cells[*i].take().ok_or_else(|| std::io::Error::other("a cell was read twice"))?;
                let sample = sample_file(cell.file.path(), params.sample_size, params.seed)?;
                let sub = TopTree::build(&sample, n, limit as usize);
                let sub_cells = distribute(cell.file.path(), sub, n, tmp_dir, progress)?;
                drop(cell);
                let (sub, sub_cells) = sub_cells;
                if sub_cells.iter().any(|c| c.count == n) {
                    // Nothing separates these samples (all at one position): one region.
                    regions.push(sub_cells);
                    return Ok(Self::Region);
                }
                let mut sub_cells: Vec<_> = sub_cells.into_iter().map(Some).collect();
                Self::new(&sub, &mut sub_cells, limit, params, tmp_dir, progress, regions)
            }
        }
    }
}

/// A seeded reservoir sample of at most `size` of the positions offered.
struct Reservoir {
    sample: Vec<DVec3>,
    size: usize,
    seen: u64,
    rng: rand_pcg::Pcg64,
}

impl Reservoir {
    fn new(size: usize, seed: u64) -> Self {
        Self { sample: Vec::new(), size, seen: 0, rng: rand_pcg::Pcg64::seed_from_u64(seed) }
    }

    fn offer(&mut self, p: DVec3) {
        self.seen += 1;
        if self.sample.len() < self.size {
            self.sample.push(p);
        } else {
            let j = self.rng.random_range(0..self.seen);
            if (j as usize) < self.size {
                self.sample[j as usize] = p;
            }
        }
    }
}

/// Calls `f` with the samples of the file `path`, a batch at a time.
fn for_each_batch(path: &Path, mut f: impl FnMut(Vec<RawRec>) -> std::io::Result<()>) -> std::io::Result<()> {
    let mut file = File::open(path)?;
    loop {
        let mut buf = vec![RawRec::zeroed(); SPILL_BATCH];
        let got =
            crate::read_full(&mut file, bytemuck::cast_slice_mut(&mut buf))? / std::mem::size_of::<RawRec>();
        if got == 0 {
            return Ok(());
        }
        buf.truncate(got);
        f(buf)?;
    }
}

/// A seeded reservoir sample of at most `size` positions of a cell file.
fn sample_file(path: &Path, size: usize, seed: u64) -> std::io::Result<Vec<DVec3>> {
    let mut reservoir = Reservoir::new(size, seed);
    for_each_batch(path, |batch| {
        batch.iter().for_each(|rec| reservoir.offer(DVec3::from_array(rec.pos)));
        Ok(())
    })?;
    Ok(reservoir.sample)
}

/// Distributes the samples of the file `input` (`total` of them) to new cells, one per leaf of
/// `top`: this thread reads while the cell writer's thread sorts.
fn distribute(
    input: &Path,
    top: TopTree,
    total: u64,
    tmp_dir: &Path,
    progress: &mut dyn FnMut(Stage),
) -> Result<Cells, BuildError> {
    let mut writer = CellWriter::start(tmp_dir, top, Vec::new())?;
    let mut done = 0u64;
    for_each_batch(input, |batch| {
        done += batch.len() as u64;
        writer.send(batch)?;
        progress(Stage::Distribute(done, total));
        Ok(())
    })?;
    Ok(writer.finish()?)
}

/// The samples of one region: its cells, in order (in `recs`, whose contents are replaced).
fn read_region(cells: &[Cell], mut recs: Vec<RawRec>) -> std::io::Result<Vec<RawRec>> {
    recs.clear();
    recs.resize(cells.iter().map(|c| c.count as usize).sum(), RawRec::zeroed());
    let mut at = 0;
    for c in cells {
        let len = c.count as usize;
        File::open(c.file.path())?.read_exact(bytemuck::cast_slice_mut(&mut recs[at..at + len]))?;
        at += len;
    }
    Ok(recs)
}

/// A finished subtree: its root id and the root's samples (for simplification into the parent).
struct Sub {
    id: u32,
    samples: Vec<Work>,
    spacing: f32,
}

/// The regions of an out-of-core build as the reader thread delivers them, and the way back for
/// their buffers.
struct Regions {
    next: std::sync::mpsc::Receiver<std::io::Result<Vec<RawRec>>>,
    back: std::sync::mpsc::Sender<Vec<RawRec>>,
}

/// What a sample of a region brings besides its position: as read, zero where unknown.
#[derive(Clone, Copy, Debug)]
struct Attrs {
    normal: Vec3,
    color: [u8; 4],
    /// The radius it must cover at least.
    min_radius: f32,
    spacing: f32,
}

/// Whether `h` is a spacing (positive and finite; 0 stands for unknown).
#[inline]
fn known_spacing(h: f32) -> bool {
    h > 0.0 && h.is_finite()
}

/// The buffers of [`Ctx::region`], kept from one region to the next (their pages stay mapped).
#[derive(Default)]
struct Scratch {
    pts: Vec<(Vec3, Attrs)>,
    keyed: Vec<Keyed>,
    positions: Vec<Vec3>,
    sorted: Vec<Attrs>,
    work: Vec<Work>,
    h2: Vec<f32>,
}

struct Ctx<'a> {
    params: BuildParams,
    scratch: Scratch,
    /// Whether [`Ctx::scratch`] is kept for a next region (else freed as soon as it is used).
    keep_scratch: bool,
    sink: NodeSink,
    done: u64,
    total: u64,
    progress: &'a mut dyn FnMut(Stage),
    timings: Timings,
    largest_region: u64,
}

impl Ctx<'_> {
    /// Builds the regions under `plan`, in order, from the samples `regions` delivers in the same
    /// order, and joins them.
    fn top(&mut self, plan: &Plan, regions: &Regions, origin: DVec3) -> Result<Option<Sub>, BuildError> {
        match plan {
            Plan::Region => {
                let recs =
                    regions.next.recv().map_err(|_| std::io::Error::other("the region reader stopped"))??;
                // The buffer goes back to the reader as soon as the region has taken its
                // samples; the reader may have finished: then it is simply freed.
                let back = |recs| {
                    let _ = regions.back.send(recs);
                };
                if recs.is_empty() {
                    back(recs);
                    return Ok(None);
                }
                self.region(recs, origin, back).map(Some)
            }
            Plan::Split(children) => {
                let l = self.top(&children[0], regions, origin)?;
                let r = self.top(&children[1], regions, origin)?;
                match (l, r) {
                    (Some(a), Some(b)) => self.join(a, b).map(Some),
                    (a, b) => Ok(a.or(b)),
                }
            }
        }
    }

    /// Processes one in-memory region into a subtree; `recs` is handed to `done` as soon as the
    /// region has taken its samples from it.
    fn region<R: Record>(
        &mut self,
        recs: Vec<R>,
        origin: DVec3,
        done: impl FnOnce(Vec<R>),
    ) -> Result<Sub, BuildError> {
        let mut clock = std::time::Instant::now();
        let n_in = recs.len() as u64;
        self.largest_region = self.largest_region.max(n_in);
        let mut s = std::mem::take(&mut self.scratch);
        let pts = &mut s.pts;
        recs.par_iter()
            .map(|r| {
                let (normal, color, min_radius, spacing) = r.attributes();
                ((r.position() - origin).as_vec3(), Attrs { normal, color, min_radius, spacing })
            })
            .collect_into_vec(pts);
        done(recs);
        // Merge duplicates (identical stored positions): average their normals and colours, keep
        // the largest radius and the area they cover together. A group of duplicates becomes its
        // first sample; the others are dropped. Samples keep their input order.
        let mut groups = Vec::new();
        duplicate_groups(pts.len(), |i| pts[i].0, position_hash, |run| groups.push(run.to_vec()));
        let mut dropped = vec![false; pts.len()];
        for run in &groups {
            let of = |k: usize| pts[k].1;
            let normal = run.iter().fold(Vec3::ZERO, |a, &k| a + of(k).normal).normalize_or_zero();
            let mut c = [0u32; 4];
            for &k in run {
                for (acc, v) in c.iter_mut().zip(of(k).color) {
                    *acc += u32::from(v);
                }
            }
            let n = run.len() as u32;
            let min_radius = run.iter().fold(0.0f32, |a, &k| a.max(of(k).min_radius));
            let spacing = run.iter().map(|&k| of(k).spacing.powi(2)).sum::<f32>().sqrt();
            pts[run[0]].1 = Attrs { normal, color: c.map(|x| (x / n) as u8), min_radius, spacing };
            for &k in &run[1..] {
                dropped[k] = true;
            }
        }
        if dropped.contains(&true) {
            let mut k = 0;
            pts.retain(|_| {
                k += 1;
                !dropped[k - 1]
            });
        }
        let merged = &*pts;
        self.timings.merge += lap(&mut clock);
        if merged.len() < 2 {
            return Err(BuildError::Degenerate(format!(
                "all {n_in} samples are at the same position: a model needs at least 2 distinct points"
            )));
        }
        // One spatial order serves everything below: the splits of the node kd-tree at the top,
        // the implicit box hierarchy of each node under it. Estimation searches the whole region
        // in this order, and the subtree is cut from it without moving a sample again.
        let keyed = &mut s.keyed;
        merged.par_iter().enumerate().map(|(i, p)| Keyed { pos: p.0, idx: i as u32 }).collect_into_vec(keyed);
        hierarchy_sort(keyed, self.params.node_points);
        // A sample's splat from what the input brought (`a`) and, where it brought no normal or
        // spacing, their estimates (`e`).
        let lacks_normal = |a: &Attrs| a.normal == Vec3::ZERO;
        let lacks_spacing = |a: &Attrs| !known_spacing(a.spacing);
        let radius_factor = self.params.radius_factor;
        let splat = |pos: Vec3, a: &Attrs, e: Estimate| {
            let normal = if lacks_normal(a) { e.normal } else { a.normal };
            let spacing = if lacks_spacing(a) { e.spacing } else { a.spacing };
            // A lone point far from the rest still gets a finite, positive radius.
            let h = if known_spacing(spacing) { spacing } else { f32::MIN_POSITIVE };
            let radius = (radius_factor * h).max(a.min_radius);
            (Work { pos, normal, radius, color: a.color }, h * h)
        };
        if !merged.par_iter().any(|(_, a)| lacks_normal(a) || lacks_spacing(a)) {
            // Nothing to estimate (a mesh brings normals and spacings from its faces): the
            // samples go straight into their order.
            let none = Estimate { normal: Vec3::ZERO, spacing: 0.0 };
            keyed
                .par_iter()
                .map(|k| splat(k.pos, &merged[k.idx as usize].1, none))
                .unzip_into_vecs(&mut s.work, &mut s.h2);
            self.timings.order += lap(&mut clock);
        } else {
            let positions = &mut s.positions;
            keyed.par_iter().map(|k| k.pos).collect_into_vec(positions);
            // The rest of each sample follows its position (one gather).
            let sorted = &mut s.sorted;
            keyed.par_iter().map(|k| merged[k.idx as usize].1).collect_into_vec(sorted);
            self.timings.order += lap(&mut clock);
            // Estimation searches the whole region in its spatial order.
            let need_normal = |k: usize| lacks_normal(&sorted[k]);
            let need_spacing = |k: usize| lacks_spacing(&sorted[k]);
            let boxes = boxtree::build_boxes(positions);
            let (k, stride) = (self.params.knn, self.params.spacing_stride);
            let est = estimate::estimate(positions, &boxes, k, stride, &need_normal, &need_spacing)
                .ok_or_else(|| BuildError::Degenerate("fewer than 2 distinct points".into()))?;
            self.timings.estimate += lap(&mut clock);
            positions
                .par_iter()
                .zip(&*sorted)
                .zip(&est)
                .map(|((&pos, a), &e)| splat(pos, a, e))
                .unzip_into_vecs(&mut s.work, &mut s.h2);
        }
        if !self.keep_scratch {
            // Only the samples in their order are left to use.
            (s.pts, s.keyed, s.positions, s.sorted) = Default::default();
        }
        let r = self.split(&mut s.work, &mut s.h2);
        self.timings.nodes += lap(&mut clock);
        self.scratch = s;
        r
    }

    /// Builds the subtree of one region (both halves of every split in parallel), sending each
    /// node to the writer as it is made: ids in post order, known from the sample counts, so
    /// that stores are identical whatever the scheduling.
    fn split(&mut self, work: &mut [Work], h2: &mut [f32]) -> Result<Sub, BuildError> {
        let before = self.sink.next_id();
        let base = self.sink.reserve(subtree_nodes(work.len(), self.params.node_points));
        let sender = self.sink.sender()?;
        let built = build_subtree(work, h2, &self.params, base, &|id, node| sender.send(id, node.into()));
        // The nodes of the regions before this one are written before the next is built: at
        // most this region's nodes wait in memory.
        self.sink.wait_written(before)?;
        self.done += work.len() as u64;
        (self.progress)(Stage::Build(self.done, self.total));
        Ok(Sub { id: built.id, samples: built.samples, spacing: built.spacing })
    }

    /// Makes the parent of two subtrees by simplifying the union of their samples.
    fn join(&mut self, a: Sub, b: Sub) -> Result<Sub, BuildError> {
        let mut parent = parent_of(a.samples, a.spacing, b.samples, b.spacing, &self.params);
        parent.children = Some([a.id, b.id]);
        let (samples, spacing) = (std::mem::take(&mut parent.stored), parent.spacing);
        let id = self.sink.send(parent.into())?;
        Ok(Sub { id, samples, spacing })
    }
}

/// A node ready to be written.
struct NodeOut {
    splats: Vec<Splat>,
    boxes: Vec<Aabb>,
    /// Children as indices into the subtree's node list.
    children: Option<[u32; 2]>,
    spacing: f32,
    /// Checksum of `splats` and `boxes`.
    data_crc: u32,
    /// The samples as stored (quantised normals): what the parent is built from (balsa12 §4);
    /// taken by the parent's builder.
    stored: Vec<Work>,
}

impl From<NodeOut> for PendingNode {
    fn from(n: NodeOut) -> Self {
        Self {
            splats: n.splats,
            boxes: n.boxes,
            children: n.children,
            stats: NodeStats { spacing: n.spacing, data_crc: n.data_crc },
        }
    }
}

/// A subtree built: its root's id and samples.
struct SubtreeOut {
    id: u32,
    samples: Vec<Work>,
    spacing: f32,
}

/// The nodes [`build_subtree`] makes of `n` samples.
fn subtree_nodes(n: usize, node_points: usize) -> u32 {
    if n <= node_points {
        1
    } else {
        1 + subtree_nodes(n / 2, node_points) + subtree_nodes(n - n / 2, node_points)
    }
}

fn make_node(mut w: Vec<Work>, children: Option<[u32; 2]>, spacing: f32) -> NodeOut {
    boxtree::sort_spatially(&mut w);
    node_from_sorted(&w, children, spacing)
}

/// A node from samples already in the order of its implicit box hierarchy.
fn node_from_sorted(w: &[Work], children: Option<[u32; 2]>, spacing: f32) -> NodeOut {
    let boxes = boxtree::build_boxes(w);
    let splats: Vec<Splat> = w.iter().map(|s| Splat::new(s.pos, s.normal, s.radius, s.color)).collect();
    let stored = splats
        .iter()
        .map(|s| Work { pos: s.position(), normal: s.normal(), radius: s.radius, color: s.color })
        .collect();
    let data_crc = kiosk_core::scene::store::node_data_crc(&splats, &boxes);
    NodeOut { splats, boxes, children, spacing, data_crc, stored }
}

/// The parent of two nodes: the union of their samples simplified to as many samples as the
/// larger child holds where that takes only short merges, and to at most M in any case.
/// Leaves are halved ranges of M/2 to M samples, so every node of a region is about as full as
/// its leaves; simplifying to M instead would leave parents of underfull leaves nearly as dense
/// as their children (one level for little coarsening) at the cost of a full simplification
/// pass and a larger store. Its spacing keeps the area the children cover:
/// n_p h_p² = n_a h_a² + n_b h_b².
fn parent_of(a: Vec<Work>, ha: f32, b: Vec<Work>, hb: f32, params: &BuildParams) -> NodeOut {
    let area = a.len() as f64 * f64::from(ha).powi(2) + b.len() as f64 * f64::from(hb).powi(2);
    let soft = params.node_points.min(a.len().max(b.len()));
    let mut all = a;
    all.extend(b);
    let simplified = simplify(all, soft, params.node_points, params.merge_normal_cos);
    let spacing = (area / simplified.len() as f64).sqrt() as f32;
    make_node(simplified, None, spacing)
}

/// Cuts the subtree out of samples in [`hierarchy_sort`] order (leaves of at most M samples),
/// building both halves in parallel, and passes each node to `emit` as it is made, with its id:
/// `base` and on in post order (the root last; [`subtree_nodes`] of them).
fn build_subtree(
    work: &mut [Work],
    h2: &mut [f32],
    params: &BuildParams,
    base: u32,
    emit: &(dyn Fn(u32, NodeOut) + Sync),
) -> SubtreeOut {
    if work.len() <= params.node_points {
        let spacing = (h2.iter().map(|&x| f64::from(x)).sum::<f64>() / h2.len() as f64).sqrt() as f32;
        let mut node = node_from_sorted(work, None, spacing);
        let samples = std::mem::take(&mut node.stored);
        emit(base, node);
        return SubtreeOut { id: base, samples, spacing };
    }
    let mid = work.len() / 2;
    let (wl, wr) = work.split_at_mut(mid);
    let (hl, hr) = h2.split_at_mut(mid);
    let right_base = base + subtree_nodes(mid, params.node_points);
    let (l, r) = rayon::join(
        || build_subtree(wl, hl, params, base, emit),
        || build_subtree(wr, hr, params, right_base, emit),
    );
    let mut parent = parent_of(l.samples, l.spacing, r.samples, r.spacing, params);
    parent.children = Some([l.id, r.id]);
    let id = r.id + 1;
    let samples = std::mem::take(&mut parent.stored);
    let spacing = parent.spacing;
    emit(id, parent);
    SubtreeOut { id, samples, spacing }
}

/// Calls `group` with the indices (ascending) of every set of at least two of the `n` samples at
/// bit-identical positions (sample `i` at `position(i)`). One integer per sample finds them:
/// `hash` of the position above the sample's index, sorted, so that equal positions are
/// contiguous and in input order; a run of equal hashes is then split by position (distinct
/// positions may share a hash).
fn duplicate_groups(
    n: usize,
    position: impl Fn(usize) -> Vec3 + Sync,
    hash: impl Fn(Vec3) -> u64 + Sync,
    mut group: impl FnMut(&[usize]),
) {
    let idx_bits = usize::BITS - (n.max(2) - 1).leading_zeros();
    let mut keys: Vec<u64> =
        (0..n).into_par_iter().map(|i| hash(position(i)) << idx_bits | i as u64).collect();
    keys.par_sort_unstable();
    let index = |k: u64| (k & ((1 << idx_bits) - 1)) as usize;
    let bits = |k: usize| position(k).to_array().map(f32::to_bits);
    let mut i = 0;
    while i < keys.len() {
        let mut j = i + 1;
        while j < keys.len() && keys[j] >> idx_bits == keys[i] >> idx_bits {
            j += 1;
        }
        if j - i > 1 {
            let mut rest: Vec<usize> = keys[i..j].iter().map(|&k| index(k)).collect();
            while let Some(&first) = rest.first() {
                let run: Vec<usize>;
                (run, rest) = rest.iter().partition(|&&k| bits(k) == bits(first));
                if run.len() > 1 {
                    group(&run);
                }
            }
        }
        i = j;
    }
}

/// A hash of a position's bits (equal positions, equal hashes), well mixed in every bit.
#[inline]
fn position_hash(p: Vec3) -> u64 {
    let [x, y, z] = p.to_array().map(|c| u64::from(c.to_bits()));
    // MurmurHash3's 64-bit finaliser over the three coordinates.
    let mut h = (x << 32 | y) ^ z.wrapping_mul(0x9e37_79b9_7f4a_7c15);
    h ^= h >> 33;
    h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
    h ^= h >> 33;
    h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
    h ^ h >> 33
}

/// A position and where it came from, for sorting a region once.
#[derive(Clone, Copy)]
struct Keyed {
    pos: Vec3,
    idx: u32,
}

impl boxtree::HasPosition for Keyed {
    #[inline]
    fn position(&self) -> Vec3 {
        self.pos
    }
}

/// Orders `items` as the hierarchy is cut: ranges of more than `node_points` items are split at
/// their middle index by a median partition along [`choose_axis`] (the node kd-tree); a range
/// of at most `node_points` (a leaf node) is sorted for its implicit box hierarchy.
fn hierarchy_sort<T: boxtree::HasPosition + Send>(items: &mut [T], node_points: usize) {
    if items.len() <= node_points {
        boxtree::sort_spatially(items);
        return;
    }
    let axis = choose_axis(items);
    let mid = items.len() / 2;
    boxtree::partition_along(items, mid, axis);
    let (l, r) = items.split_at_mut(mid);
    rayon::join(|| hierarchy_sort(l, node_points), || hierarchy_sort(r, node_points));
}

/// Split axis (balsa12 §4): candidates are median splits (perfectly balanced) along every axis
/// whose extent is at least half the longest; among them, the one whose children are the most
/// compact (smallest worst ratio between the two largest extents of a child's box). Candidates
/// are judged on an evenly strided sample of at most [`AXIS_SAMPLE`] points: its box, its median
/// and its halves' boxes stand for the range's (the split itself is exact).
fn choose_axis<T: boxtree::HasPosition>(work: &[T]) -> usize {
    let step = work.len().div_ceil(AXIS_SAMPLE).max(1);
    let sample: Vec<Vec3> = work.iter().step_by(step).map(boxtree::HasPosition::position).collect();
    let ext = Aabb::from_points(sample.iter().copied()).extent();
    let longest = ext.max_element();
    let mut best = (f32::INFINITY, ext.max_position());
    for axis in 0..3 {
        if ext[axis] < 0.5 * longest || ext[axis] <= 0.0 {
            continue;
        }
        let mut vals: Vec<f32> = sample.iter().map(|p| p[axis]).collect();
        let mid = vals.len() / 2;
        let (_, &mut at, _) = vals.select_nth_unstable_by(mid, f32::total_cmp);
        let mut worst: f32 = 0.0;
        for side in [false, true] {
            let b = Aabb::from_points(sample.iter().copied().filter(|p| (p[axis] >= at) == side));
            let mut e = b.extent().to_array();
            e.sort_by(f32::total_cmp);
            let ratio = if e[1] > 0.0 { e[2] / e[1] } else { f32::INFINITY };
            worst = worst.max(ratio);
        }
        if worst < best.0 {
            best = (worst, axis);
        }
    }
    best.1
}

/// Most points [`choose_axis`] judges candidate splits on.
const AXIS_SAMPLE: usize = 16_384;

/// A merge is short when its length is at most this many times the larger splat radius of
/// the pair (neighbours on a surface are about 1.25 radii apart, a merged pair stays within 2).
const MERGE_REACH: f32 = 3.0;

/// Which pairs a simplification pass may collapse.
#[derive(Clone, Copy, Debug)]
struct MergeRule {
    /// Cosine of the largest angle between the normals (`None`: any normals).
    normal_cos: Option<f32>,
    /// Longest merge, in multiples of the larger radius of the pair (`None`: any length).
    reach: Option<f32>,
}

/// Reduces `pts` to `soft` samples by collapsing short near pairs with compatible normals
/// (bettio09 §3: shortest edges first; balsa12 §4: nearest neighbour with a compatible normal),
/// then, if short pairs ran out above `hard`, to `hard` by any pairs with compatible normals,
/// and at last by any pairs. The soft target halves a node's samples only where that keeps the
/// surface: an isolated sample (the tip of an ear) is not merged with one far away, which would
/// make a splat as large as the gap.
/// Each pass takes the samples in spatial order; within each leaf of the implicit box hierarchy
/// (fewer than 16 spatially close samples) it matches pairs greedily, shortest first; of the
/// candidate pairs of all leaves, the shortest are collapsed until the target remains. A pass
/// nearly halves the samples, so 2M → M takes one or two passes.
/// Merged sample: midpoint; normal and colour weighted by splat area; radius covering both.
///
/// The input is the concatenation of two nodes, each in the order of its implicit hierarchy (the
/// two halves of a kd split): already a spatial order. A pass keeps it: a merged pair takes the
/// place of its first sample, so later passes need no sort (the caller sorts the result for its
/// box hierarchy).
fn simplify(mut pts: Vec<Work>, soft: usize, hard: usize, normal_cos: f32) -> Vec<Work> {
    let rules = [
        (soft, MergeRule { normal_cos: Some(normal_cos), reach: Some(MERGE_REACH) }),
        (hard, MergeRule { normal_cos: Some(normal_cos), reach: None }),
        (hard, MergeRule { normal_cos: None, reach: None }),
    ];
    for (target, rule) in rules {
        while pts.len() > target {
            match simplify_pass(&pts, target, rule) {
                Some(next) => pts = next,
                None => break,
            }
        }
    }
    pts
}

/// One pass of [`simplify`] towards `target` under `rule`; `None` when no pair qualifies.
fn simplify_pass(pts: &[Work], target: usize, rule: MergeRule) -> Option<Vec<Work>> {
    // (squared length bits << 32 | i, j), in the order of the ranges.
    let pairs_in = |ranges: Vec<(usize, usize)>| -> Vec<(u64, u32)> {
        ranges
            .par_iter()
            .flat_map_iter(|&(lo, hi)| {
                leaf_pairs(&pts[lo..hi], rule, |key| {
                    let (i, j) = pair_ends(key);
                    ((key & !0xffff_ffff) | (lo + i) as u64, (lo + j) as u32)
                })
            })
            .collect()
    };
    let needed = pts.len() - target;
    let depth = boxtree::depth_for(pts.len());
    // A pass that needs few merges (the last few of a halving) matches within the leaves'
    // halves or quarters: a quarter of the pairs to weigh per sample, or less, and still more
    // candidates than it takes. Where those hold too few, it matches within the leaves.
    let finer = (1..=2).take_while(|&d| needed << (d + 1) <= pts.len()).last().unwrap_or(0);
    let mut edges =
        if finer > 0 { pairs_in(boxtree::ranges_at_depth(pts.len(), depth + finer)) } else { Vec::new() };
    if edges.len() < needed {
        edges = pairs_in(boxtree::leaf_ranges(pts.len()));
    }
    if edges.is_empty() {
        return None;
    }
    if edges.len() > needed {
        // The `needed` shortest (keys are distinct: each sample is in one pair at most).
        let mut keys: Vec<u64> = edges.iter().map(|e| e.0).collect();
        let nth = *keys.select_nth_unstable(needed - 1).1;
        edges.retain(|e| e.0 <= nth);
    }
    // partner[i] = j for the first sample of a pair, i for the second (it is dropped).
    let mut partner = vec![u32::MAX; pts.len()];
    for &(key, j) in &edges {
        let i = key as u32;
        partner[i as usize] = j;
        partner[j as usize] = i;
    }
    // Each pair leaves one sample: the size is known, the vector never grows.
    let mut next = Vec::with_capacity(pts.len() - edges.len());
    next.extend(pts.iter().zip(&partner).enumerate().filter_map(|(i, (p, &j))| match j {
        u32::MAX => Some(*p),
        j if j as usize > i => Some(merge(p, &pts[j as usize])),
        _ => None,
    }));
    Some(next)
}

/// The pairs of one leaf (fewer than [`boxtree::LEAF_POINTS`] samples) that greedy matching takes,
/// shortest first, among the pairs `rule` allows, as `pair((squared length bits) << 32 | i << 8 | j)`
/// with i < j.
///
/// Keys are distinct, so greedy matching takes exactly the pairs that are, at some point, the
/// shortest pair of both their samples among the samples still free ("mutual nearest"); rounds
/// of that need no sort of the candidate pairs.
fn leaf_pairs<T>(leaf: &[Work], rule: MergeRule, mut pair: impl FnMut(u64) -> T) -> Vec<T> {
    const N: usize = boxtree::LEAF_POINTS;
    let m = leaf.len().min(N);
    let mut key = [[u64::MAX; N]; N];
    // best[i]: the shortest candidate pair of sample i among the samples still free.
    let mut best = [u64::MAX; N];
    for i in 0..m {
        for j in i + 1..m {
            let d2 = (leaf[i].pos - leaf[j].pos).length_squared();
            let short = rule.reach.is_none_or(|f| d2 <= (f * leaf[i].radius.max(leaf[j].radius)).powi(2));
            if short && rule.normal_cos.is_none_or(|c| compatible(leaf[i].normal, leaf[j].normal, c)) {
                let k = u64::from(d2.to_bits()) << 32 | (i as u64) << 8 | j as u64;
                key[i][j] = k;
                key[j][i] = k;
                best[i] = best[i].min(k);
                best[j] = best[j].min(k);
            }
        }
    }
    let mut out = Vec::with_capacity(m / 2);
    // The samples still free that have a candidate left: `free[..nf]`.
    let mut free: [usize; N] = std::array::from_fn(|i| i);
    let mut nf = m;
    loop {
        let mut taken = [false; N];
        let mut any = false;
        for &i in &free[..nf] {
            let k = best[i];
            let (a, b) = pair_ends(k);
            if k != u64::MAX && a == i && best[b] == k {
                taken[a] = true;
                taken[b] = true;
                any = true;
                out.push(pair(k));
            }
        }
        if !any {
            break;
        }
        // A sample with no candidate left stays unmatched.
        let before = nf;
        nf = 0;
        for f in 0..before {
            let i = free[f];
            if !taken[i] && best[i] != u64::MAX {
                free[nf] = i;
                nf += 1;
            }
        }
        if nf < 2 {
            break;
        }
        // Only a sample whose shortest pair lost its other sample has a new shortest pair: the
        // others' is still among the free ones, and nothing shorter came.
        for f in 0..nf {
            let i = free[f];
            let (a, b) = pair_ends(best[i]);
            if taken[if a == i { b } else { a }] {
                best[i] = free[..nf].iter().fold(u64::MAX, |b, &j| b.min(key[i][j]));
            }
        }
    }
    out
}

/// The two samples (i < j) of a [`leaf_pairs`] key.
#[inline]
fn pair_ends(key: u64) -> (usize, usize) {
    ((key >> 8) as u8 as usize, key as u8 as usize)
}

fn merge(a: &Work, b: &Work) -> Work {
    let (wa, wb) = (a.radius * a.radius, b.radius * b.radius);
    // Normals are oriented only away from their region's centroid: b's is turned to a's side.
    let bn = if a.normal.dot(b.normal) < 0.0 { -b.normal } else { b.normal };
    let normal = (a.normal * wa + bn * wb).try_normalize().unwrap_or(a.normal);
    // Equal colours blend to themselves (the weighted mean of c and c rounds back to c): a scan
    // without colours, or a region of one colour, skips the arithmetic.
    let color = if a.color == b.color { a.color } else { blend(a.color, wa, b.color, wb) };
    Work {
        pos: (a.pos + b.pos) * 0.5,
        normal,
        radius: (a.pos - b.pos).length() * 0.5 + a.radius.max(b.radius),
        color,
    }
}

/// Whether two normals are within the angle of cosine `cos` of each other, whichever way each
/// points: estimated normals are oriented only away from their region's centroid, so a normal
/// and its opposite describe the same surface.
fn compatible(a: Vec3, b: Vec3, cos: f32) -> bool {
    a.dot(b).abs() >= cos
}

/// The mean of colours `a` and `b` weighted by `wa` and `wb`, rounded to the nearest level.
fn blend(a: [u8; 4], wa: f32, b: [u8; 4], wb: f32) -> [u8; 4] {
    let ws = (wa + wb).max(f32::MIN_POSITIVE);
    std::array::from_fn(|k| {
        ((f32::from(a[k]) * wa + f32::from(b[k]) * wb) / ws).round().clamp(0.0, 255.0) as u8
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_pairs_are_the_greedy_matching_shortest_first() {
        // The plain greedy matching: every allowed pair sorted by key, each taken when both of
        // its samples are still free.
        fn greedy(leaf: &[Work], rule: MergeRule) -> Vec<u64> {
            let mut keys = Vec::new();
            for i in 0..leaf.len() {
                for j in i + 1..leaf.len() {
                    let d2 = (leaf[i].pos - leaf[j].pos).length_squared();
                    let r = leaf[i].radius.max(leaf[j].radius);
                    if rule.reach.is_none_or(|f| d2 <= (f * r).powi(2))
                        && rule.normal_cos.is_none_or(|c| leaf[i].normal.dot(leaf[j].normal).abs() >= c)
                    {
                        keys.push(u64::from(d2.to_bits()) << 32 | (i as u64) << 8 | j as u64);
                    }
                }
            }
            keys.sort_unstable();
            let mut used = [false; boxtree::LEAF_POINTS];
            let mut out = Vec::new();
            for k in keys {
                let (i, j) = pair_ends(k);
                if !used[i] && !used[j] {
                    used[i] = true;
                    used[j] = true;
                    out.push(k);
                }
            }
            out.sort_unstable();
            out
        }
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let rules = [
            MergeRule { normal_cos: Some(0.5), reach: Some(MERGE_REACH) },
            MergeRule { normal_cos: Some(0.5), reach: None },
            MergeRule { normal_cos: None, reach: None },
        ];
        let mut pairs = 0;
        for round in 0..3000 {
            let n = 2 + round % (boxtree::LEAF_POINTS - 1);
            // Coarse coordinates: some lengths tie, and ties are broken by the indices.
            let leaf: Vec<Work> = (0..n)
                .map(|_| Work {
                    pos: Vec3::new(
                        rng.random_range(0..8) as f32,
                        rng.random_range(0..8) as f32,
                        rng.random_range(0..3) as f32,
                    ),
                    normal: Vec3::new(
                        rng.random_range(-1.0..1.0),
                        rng.random_range(-1.0..1.0),
                        if rng.random() { 1.0 } else { -1.0 },
                    )
                    .normalize(),
                    radius: rng.random_range(0.2..2.0),
                    color: [0; 4],
                })
                .collect();
            for rule in rules {
                let mut got = leaf_pairs(&leaf, rule, |k| k);
                got.sort_unstable();
                assert_eq!(got, greedy(&leaf, rule), "round {round}, {rule:?}");
                pairs += got.len();
            }
        }
        assert!(pairs > 10_000, "the leaves had pairs to take: {pairs}");
    }

    #[test]
    fn settings_out_of_range_are_an_error_that_names_them() {
        let tmp = std::env::temp_dir();
        let dir = tmp.as_path();
        for (params, name) in [
            (BuildParams { node_points: 8, ..Default::default() }, "node_points"),
            (BuildParams { chunk_points: 1000, ..Default::default() }, "chunk_points"),
            (BuildParams { spacing_stride: 0, ..Default::default() }, "spacing_stride"),
            (BuildParams { spacing_stride: 17, ..Default::default() }, "spacing_stride"),
        ] {
            match Builder::new(params, dir) {
                Err(BuildError::Params(msg)) => assert!(msg.contains(name), "{msg}"),
                other => panic!("{params:?}: {:?}", other.map(|_| ())),
            }
        }
        assert!(Builder::new(BuildParams { spacing_stride: 16, ..Default::default() }, dir).is_ok());
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

    #[test]
    fn duplicates_are_grouped_in_input_order_even_when_distinct_positions_share_a_hash() {
        let p = |x: f32| Vec3::new(x, 1.0, -2.0);
        let positions = [p(1.0), p(2.0), p(1.0), p(3.0), p(2.0), p(1.0), p(-0.0), p(0.0)];
        for hash in [position_hash as fn(Vec3) -> u64, |_| 7, |v: Vec3| u64::from(v.x.to_bits() % 2)] {
            let mut groups = Vec::new();
            duplicate_groups(positions.len(), |i| positions[i], hash, |g| groups.push(g.to_vec()));
            groups.sort();
            assert_eq!(groups, vec![vec![0, 2, 5], vec![1, 4]]);
        }
        let mut none = Vec::new();
        duplicate_groups(1, |_| p(1.0), position_hash, |g| none.push(g.to_vec()));
        assert!(none.is_empty());
    }

    #[test]
    fn a_merged_colour_is_the_area_weighted_mean_and_equal_colours_stay_as_they_are() {
        let at = |x: f32, radius: f32, color: [u8; 4]| Work {
            pos: Vec3::new(x, 0.0, 0.0),
            normal: Vec3::Z,
            radius,
            color,
        };
        // Radii 1 and 3: weights 1 and 9.
        let m = merge(&at(0.0, 1.0, [0, 100, 255, 10]), &at(1.0, 3.0, [100, 0, 255, 20]));
        assert_eq!(m.color, [90, 10, 255, 19]);
        // Equal colours stay as they are, as the weighted mean would leave them, whatever the
        // weights.
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        for _ in 0..10_000 {
            let c: [u8; 4] = std::array::from_fn(|_| rng.random());
            let (ra, rb) = (rng.random_range(1e-6..1e3), rng.random_range(1e-6..1e3));
            let m = merge(&at(0.0, ra, c), &at(1.0, rb, c));
            assert_eq!(m.color, c);
            assert_eq!(
                blend(c, ra * ra, c, rb * rb),
                c,
                "the weighted mean of {c:?} with radii {ra} and {rb}"
            );
        }
        // And with no weights at all (two splats of radius 0).
        assert_eq!(merge(&at(0.0, 0.0, [7; 4]), &at(0.0, 0.0, [7; 4])).color, [7; 4]);
    }

    #[test]
    fn normals_of_opposite_orientation_are_compatible_and_merge_into_one_plane() {
        // Two neighbours on the plane z = 0, their normals oriented either way (away from two
        // region centroids on either side).
        let a = Work { pos: Vec3::ZERO, normal: Vec3::Z, radius: 0.8, color: [0; 4] };
        let b =
            Work { pos: Vec3::X, normal: -Vec3::new(0.1, 0.0, 1.0).normalize(), radius: 0.8, color: [0; 4] };
        let rule = MergeRule { normal_cos: Some(0.5), reach: Some(MERGE_REACH) };
        assert_eq!(leaf_pairs(&[a, b], rule, |k| k).len(), 1, "the pair is compatible");
        // A normal at 80° is not, whichever way it points.
        let c = Work { normal: Vec3::new(1.0, 0.0, 0.18).normalize(), ..b };
        assert!(leaf_pairs(&[a, c], rule, |k| k).is_empty());
        assert!(leaf_pairs(&[a, Work { normal: -c.normal, ..c }], rule, |k| k).is_empty());
        // The merge keeps the plane (not the cancelled sum of opposite normals).
        let m = merge(&a, &b);
        assert!(m.normal.dot(Vec3::Z) > 0.99, "{:?}", m.normal);
        // Simplification merges them.
        assert_eq!(simplify(vec![a, b], 1, 2, 0.5).len(), 1);
    }

    #[test]
    fn simplification_halves_by_short_merges_and_reaches_m_by_any() {
        // A 4 × 4 grid (spacing 1, radius 0.8) and two samples far from it and from each other.
        let sample =
            |x: f32, y: f32| Work { pos: Vec3::new(x, y, 0.0), normal: Vec3::Z, radius: 0.8, color: [9; 4] };
        let mut pts: Vec<Work> = (0..16).map(|i| sample((i % 4) as f32, (i / 4) as f32)).collect();
        pts.extend([sample(100.0, 0.0), sample(200.0, 0.0)]);
        boxtree::sort_spatially(&mut pts);
        let lone = |s: &[Work]| s.iter().filter(|w| w.pos.x >= 100.0 && w.radius == 0.8).count();
        // Soft target 2, M = 18: the grid collapses by short merges into one sample; going
        // further would take a long merge, so the far samples stay as they are and no splat
        // grows past the grid.
        let soft = simplify(pts.clone(), 2, 18, 0.5);
        assert_eq!(lone(&soft), 2);
        assert_eq!(soft.len(), 3);
        assert!(
            soft.iter().all(|w| w.radius < 5.0),
            "{:?}",
            soft.iter().map(|w| w.radius).collect::<Vec<_>>()
        );
        // M = 2: reached, by merging far samples.
        let hard = simplify(pts, 2, 2, 0.5);
        assert_eq!(hard.len(), 2);
        assert!(hard.iter().any(|w| w.radius > 40.0));
    }

    #[test]
    fn a_pass_that_needs_few_merges_matches_in_finer_ranges_or_else_in_the_leaves() {
        // 64 samples on a line, spacing 1 (a little more at every fourth, so lengths differ).
        let line = |normal: &dyn Fn(usize) -> Vec3| -> Vec<Work> {
            (0..64)
                .map(|i| Work {
                    pos: Vec3::new(i as f32 + (i / 4) as f32 * 0.01, 0.0, 0.0),
                    normal: normal(i),
                    radius: 0.8,
                    color: [0; 4],
                })
                .collect()
        };
        let rule = MergeRule { normal_cos: Some(0.5), reach: Some(MERGE_REACH) };
        // 4 merges of 64: ranges of 2 or 3 samples hold enough candidates; the merges are of
        // neighbours (a merged splat covers both: half the spacing plus the radius).
        let out = simplify_pass(&line(&|_| Vec3::Z), 60, rule).expect("pairs");
        assert_eq!(out.len(), 60);
        assert!(
            out.iter().all(|w| w.radius <= 0.5 + 0.8 + 0.01),
            "{:?}",
            out.iter().map(|w| w.radius).collect::<Vec<_>>()
        );
        // Neighbours with perpendicular normals (opposite ones are compatible: normals are
        // oriented only away from a centroid): no pair within those ranges; the leaves have
        // pairs two apart (within 3 radii).
        let out =
            simplify_pass(&line(&|i| if i % 2 == 0 { Vec3::Z } else { Vec3::X }), 60, rule).expect("pairs");
        assert_eq!(out.len(), 60);
        assert!(out.iter().all(|w| w.normal == Vec3::Z || w.normal == Vec3::X));
        assert_eq!(out.iter().filter(|w| w.radius > 1.0 + 0.8 - 0.01).count(), 4);
    }

    #[test]
    fn hierarchy_order_cuts_nodes_at_middles_and_sorts_each_leaf_node() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64::seed_from_u64(5);
        let mut pts: Vec<Vec3> = (0..5000)
            .map(|_| Vec3::new(rng.random(), rng.random::<f32>() * 4.0, rng.random::<f32>() * 0.2))
            .collect();
        let before = pts.clone();
        hierarchy_sort(&mut pts, 1000);
        // A permutation: nothing lost, nothing invented.
        let key = |v: &Vec3| v.to_array().map(f32::to_bits);
        let (mut a, mut b) =
            (before.iter().map(key).collect::<Vec<_>>(), pts.iter().map(key).collect::<Vec<_>>());
        a.sort_unstable();
        b.sort_unstable();
        assert_eq!(a, b);
        // Every cut, of the node kd-tree and of each leaf node's box hierarchy (down to its
        // leaves of < 16 points), is a median split: its halves are separated along one axis.
        fn separated(l: &[Vec3], r: &[Vec3]) -> bool {
            (0..3).any(|axis| {
                let lmax = l.iter().map(|v| v[axis]).fold(f32::NEG_INFINITY, f32::max);
                let rmin = r.iter().map(|v| v[axis]).fold(f32::INFINITY, f32::min);
                lmax <= rmin
            })
        }
        fn boxes(p: &[Vec3], depth_left: u32) {
            if depth_left > 0 {
                let (l, r) = p.split_at(p.len() / 2);
                assert!(separated(l, r), "a box split of {} points does not separate its halves", p.len());
                boxes(l, depth_left - 1);
                boxes(r, depth_left - 1);
            }
        }
        fn check(p: &[Vec3], m: usize) {
            if p.len() <= m {
                boxes(p, boxtree::depth_for(p.len()));
                return;
            }
            let (l, r) = p.split_at(p.len() / 2);
            assert!(separated(l, r), "a node cut of {} points does not separate its halves", p.len());
            check(l, m);
            check(r, m);
        }
        check(&pts, 1000);
    }
}
