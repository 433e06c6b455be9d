//! Stage 1, spilling, and the partition of stage 2: once the input outgrows memory, every sample
//! goes to the temporary file of its cell ([`CellWriter`]), a leaf of a kd-tree ([`TopTree`])
//! chosen on a seeded random sample ([`Selection`]) of the samples seen so far. At the end,
//! [`Plan::new`] partitions the cells into regions of at most half a chunk (a cell that outgrew
//! that is split again, its samples distributed to new cells by [`distribute`]). The region stage
//! gets the plan, which says how the regions join, and reads each region's samples back in the
//! plan's order with [`read_region`].

use super::{BuildError, BuildParams, Stage};
use crate::source::InputPoint;
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use std::fs::File;
use std::io::{BufWriter, Read, Write};
use std::path::Path;

/// A sample as spilled to disk.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct RawRec {
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
pub(super) trait Record: Copy + Send + Sync + 'static {
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

/// Samples read from a cell file at a time.
const READ_BATCH: usize = 1 << 16;

/// Records grouped by cell at once by [`CellWriter::push_all`] (12 MiB of them, besides the
/// input).
const PUSH_WINDOW: usize = 1 << 18;

/// Records one task of [`CellWriter::push_all`] groups by cell.
const PUSH_PART: usize = 1 << 14;

/// One part of a window of [`CellWriter::push_all`]: its records grouped by cell, cell `c`'s at
/// `start[c]..start[c + 1]`.
struct Grouped {
    start: Vec<u32>,
    recs: Vec<RawRec>,
}

/// Cells per expected region when the input first outgrows memory: regions are later made of
/// whole subtrees of cells, so a region can be as small as half a chunk's worth / this.
pub(super) const CELLS_PER_REGION: usize = 32;

/// Sorts samples into the cell files of a kd-tree (chosen on the samples seen when memory ran
/// out), each through a buffer of its own. (A thread of its own for this work gained under 3 %
/// side by side: docs/performance.md, speed devices.)
pub(super) struct CellWriter {
    tree: TopTree,
    cells: Vec<(BufWriter<tempfile::NamedTempFile>, u64)>,
}

/// A kd-tree and its cells (one per leaf, in order).
type Cells = (TopTree, Vec<Cell>);

/// The temporary file of one cell and the samples in it.
pub(super) struct Cell {
    file: tempfile::NamedTempFile,
    count: u64,
}

impl CellWriter {
    /// Starts the (empty) cells of `tree`.
    pub(super) fn start(tmp_dir: &Path, tree: TopTree) -> std::io::Result<Self> {
        let mut cells = Vec::with_capacity(tree.leaves());
        for _ in 0..tree.leaves() {
            cells.push((BufWriter::with_capacity(1 << 16, tempfile::NamedTempFile::new_in(tmp_dir)?), 0u64));
        }
        Ok(Self { tree, cells })
    }

    /// Writes `r` to its cell.
    #[inline]
    pub(super) fn push<R: Record>(&mut self, r: &R) -> std::io::Result<()> {
        let (w, count) = &mut self.cells[self.tree.locate(r.position())];
        w.write_all(bytemuck::bytes_of(&r.spilled()))?;
        *count += 1;
        Ok(())
    }

    /// Writes `recs` to their cells, to the same files as [`CellWriter::push`] one by one (each
    /// cell's records in input order), on the pool: a window at a time, every part of it finds
    /// its records' cells and groups them by cell, then every cell takes its groups, part after
    /// part. One by one, finding each record's cell and copying it into its buffer kept one
    /// core busy while the other waited: the reading of a 5 M-point LAS took 1.22 times as long
    /// (the whole build 1.07; docs/performance.md, speed devices). After an error the cells are
    /// unusable (some may hold more of the window than others): the build stops.
    pub(super) fn push_all<R: Record>(&mut self, recs: &[R]) -> std::io::Result<()> {
        let cells = self.cells.len();
        for window in recs.chunks(PUSH_WINDOW) {
            let parts: Vec<Grouped> = window
                .par_chunks(PUSH_PART)
                .map(|part| {
                    let cell: Vec<u32> = part.iter().map(|r| self.tree.locate(r.position()) as u32).collect();
                    let mut start = vec![0u32; cells + 1];
                    for &c in &cell {
                        start[c as usize + 1] += 1;
                    }
                    for c in 0..cells {
                        start[c + 1] += start[c];
                    }
                    let mut next = start.clone();
                    let mut grouped = vec![RawRec::zeroed(); part.len()];
                    for (r, &c) in part.iter().zip(&cell) {
                        grouped[next[c as usize] as usize] = r.spilled();
                        next[c as usize] += 1;
                    }
                    Grouped { start, recs: grouped }
                })
                .collect();
            self.cells.par_iter_mut().enumerate().try_for_each(|(c, (w, count))| {
                for part in &parts {
                    let group = &part.recs[part.start[c] as usize..part.start[c + 1] as usize];
                    w.write_all(bytemuck::cast_slice(group))?;
                    *count += group.len() as u64;
                }
                Ok::<_, std::io::Error>(())
            })?;
        }
        Ok(())
    }

    /// Flushes the cells and returns the tree and its cells.
    pub(super) fn finish(self) -> std::io::Result<Cells> {
        let cells = self
            .cells
            .into_iter()
            .map(|(w, count)| {
                Ok(Cell { file: w.into_inner().map_err(std::io::IntoInnerError::into_error)?, count })
            })
            .collect::<std::io::Result<_>>()?;
        Ok((self.tree, cells))
    }
}

/// The top of the kd-tree, chosen on a random sample of the samples.
pub(super) enum TopTree {
    Leaf(usize),
    Split { axis: usize, at: f64, children: Box<[TopTree; 2]> },
}

impl TopTree {
    pub(super) fn build(sample: &[DVec3], total: u64, max_expected: usize) -> Self {
        let mut s = sample.to_vec();
        let mut tree = Self::rec(&mut s, total as f64 / sample.len().max(1) as f64, max_expected as f64);
        tree.number(&mut 0);
        tree
    }

    /// The tree over `s` (reordered), both halves of a large split chosen in parallel; its leaves
    /// are numbered by [`TopTree::number`].
    fn rec(s: &mut [DVec3], scale: f64, max_expected: f64) -> Self {
        if (s.len() as f64) * scale <= max_expected || s.len() < 2 {
            return Self::Leaf(0);
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
        let (left, right) = if mid >= 1 << 13 {
            rayon::join(|| Self::rec(l, scale, max_expected), || Self::rec(r, scale, max_expected))
        } else {
            (Self::rec(l, scale, max_expected), Self::rec(r, scale, max_expected))
        };
        Self::Split { axis, at, children: Box::new([left, right]) }
    }

    /// Numbers the leaves left to right from `next`.
    fn number(&mut self, next: &mut usize) {
        match self {
            Self::Leaf(i) => {
                *i = *next;
                *next += 1;
            }
            Self::Split { children, .. } => children.iter_mut().for_each(|c| c.number(next)),
        }
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
pub(super) enum Plan {
    Region,
    Split(Box<[Plan; 2]>),
}

impl Plan {
    /// Makes a region of every maximal subtree of `t` whose cells hold at most `limit` samples
    /// together, appending its cells to `regions`; a single cell over the limit is split again
    /// on a sample of its own and distributed to new cells.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
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
                let sample = sample_file(cell.file.path(), n, params.sample_size, params.seed)?;
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

/// A seeded random sample of `size` of `total` samples (all of them when they are fewer), kept
/// in their order: the indices are chosen first, every subset of that size equally likely
/// (Floyd's algorithm: one random draw per index chosen), then the samples are taken as they are
/// offered in turn ([`Selection::offer`]) or straight from memory ([`Selection::take`]).
/// Selection sampling (Knuth's Algorithm S), one draw per sample offered, took 85 ms of a single
/// core for the 4 M samples of the first chunk; a reservoir before it, which replaces samples at
/// random places of a sample of 24 MB, an eighth of the reading's profile.
pub(super) struct Selection {
    pub(super) sample: Vec<DVec3>,
    /// The indices taken, ascending.
    chosen: Vec<u64>,
    /// Of them, the next to be offered.
    next: usize,
    /// Samples offered so far.
    offered: u64,
}

impl Selection {
    pub(super) fn new(size: usize, total: u64, seed: u64) -> Self {
        let wanted = (size as u64).min(total);
        // Floyd marks the indices in a bitmap of `total` bits where that is at most 8 bytes per
        // index wanted (a chunk in memory), in a hash set otherwise (a cell of a billion samples):
        // the same draws, so the same indices, in memory bounded by the sample either way.
        let chosen = floyd(wanted, total, seed, total <= 64 * wanted);
        Self { sample: Vec::with_capacity(wanted as usize), chosen, next: 0, offered: 0 }
    }

    /// Offers the next sample's position (beyond `total`, none is taken).
    #[inline]
    pub(super) fn offer(&mut self, p: DVec3) {
        if self.chosen.get(self.next) == Some(&self.offered) {
            self.sample.push(p);
            self.next += 1;
        }
        self.offered += 1;
    }

    /// Takes the chosen of `items` (the first `total` samples, all in memory), touching only them.
    pub(super) fn take<T>(&mut self, items: &[T], position: impl Fn(&T) -> DVec3) {
        for &i in &self.chosen[self.next..] {
            match usize::try_from(i).ok().and_then(|i| items.get(i)) {
                Some(item) => self.sample.push(position(item)),
                None => break,
            }
            self.next += 1;
        }
        self.offered += items.len() as u64;
    }
}

/// `wanted` of the indices `0..total`, ascending, every subset equally likely (Floyd: for each j
/// of the last `wanted` indices, a random t ≤ j, or j itself when t is taken already), marked in
/// a bitmap or a hash set (`bitmap`), which draw the same indices.
fn floyd(wanted: u64, total: u64, seed: u64, bitmap: bool) -> Vec<u64> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let draws = (total - wanted..total).map(move |j| (j, rng.random_range(0..=j)));
    if bitmap {
        let mut bits = vec![0u64; total.div_ceil(64) as usize];
        let word = |i: u64| (i / 64) as usize;
        for (j, t) in draws {
            let i = if bits[word(t)] >> (t % 64) & 1 == 1 { j } else { t };
            bits[word(i)] |= 1 << (i % 64);
        }
        let mut chosen = Vec::with_capacity(wanted as usize);
        for (w, &b) in bits.iter().enumerate() {
            let mut b = b;
            while b != 0 {
                chosen.push(w as u64 * 64 + u64::from(b.trailing_zeros()));
                b &= b - 1;
            }
        }
        chosen
    } else {
        let mut set = std::collections::HashSet::with_capacity(wanted as usize);
        for (j, t) in draws {
            if !set.insert(t) {
                set.insert(j);
            }
        }
        let mut chosen: Vec<u64> = set.into_iter().collect();
        chosen.sort_unstable();
        chosen
    }
}

/// Calls `f` with the samples of the file `path`, a batch at a time.
fn for_each_batch(path: &Path, mut f: impl FnMut(&[RawRec]) -> std::io::Result<()>) -> std::io::Result<()> {
    let mut file = File::open(path)?;
    let mut buf = vec![RawRec::zeroed(); READ_BATCH];
    loop {
        let got =
            crate::read_full(&mut file, bytemuck::cast_slice_mut(&mut buf))? / std::mem::size_of::<RawRec>();
        if got == 0 {
            return Ok(());
        }
        f(&buf[..got])?;
    }
}

/// A seeded random sample of at most `size` positions of a cell file of `count` samples.
fn sample_file(path: &Path, count: u64, size: usize, seed: u64) -> std::io::Result<Vec<DVec3>> {
    let mut selection = Selection::new(size, count, seed);
    for_each_batch(path, |batch| {
        batch.iter().for_each(|rec| selection.offer(DVec3::from_array(rec.pos)));
        Ok(())
    })?;
    Ok(selection.sample)
}

/// Distributes the samples of the file `input` (`total` of them) to new cells, one per leaf of
/// `top`.
fn distribute(
    input: &Path,
    top: TopTree,
    total: u64,
    tmp_dir: &Path,
    progress: &mut dyn FnMut(Stage),
) -> Result<Cells, BuildError> {
    let mut writer = CellWriter::start(tmp_dir, top)?;
    let mut done = 0u64;
    for_each_batch(input, |batch| {
        done += batch.len() as u64;
        writer.push_all(batch)?;
        progress(Stage::Distribute(done, total));
        Ok(())
    })?;
    Ok(writer.finish()?)
}

/// The samples of one region: its cells, in order (in `recs`, whose contents are replaced).
pub(super) fn read_region(cells: &[Cell], mut recs: Vec<RawRec>) -> std::io::Result<Vec<RawRec>> {
    recs.clear();
    recs.par_extend(rayon::iter::repeat_n(RawRec::zeroed(), cells.iter().map(|c| c.count as usize).sum()));
    // Each cell into its own part of the buffer, on the pool (the copies from the page cache,
    // one core's work otherwise while the other waits for the region); the first error in the
    // cells' order is the one reported.
    let mut parts = Vec::with_capacity(cells.len());
    let mut rest = recs.as_mut_slice();
    for c in cells {
        let (part, tail) = rest.split_at_mut(c.count as usize);
        parts.push((c, part));
        rest = tail;
    }
    let results: Vec<std::io::Result<()>> = parts
        .into_par_iter()
        .map(|(c, part)| File::open(c.file.path())?.read_exact(bytemuck::cast_slice_mut(part)))
        .collect();
    results.into_iter().collect::<std::io::Result<()>>()?;
    Ok(recs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_selection_takes_as_many_as_asked_each_as_likely_in_the_order_offered() {
        let p = |i: usize| DVec3::new(i as f64, 0.0, 0.0);
        // Fewer than asked: all of them.
        let mut all = Selection::new(10, 4, 1);
        (0..4).for_each(|i| all.offer(p(i)));
        assert_eq!(all.sample, (0..4).map(p).collect::<Vec<_>>());
        // 30 of 100, over 2000 seeds: always 30, increasing, and every position taken about
        // 30 % of the time (binomial: 600 ± 20.5; 6 standard deviations).
        let mut taken = [0u32; 100];
        for seed in 0..2000 {
            let mut s = Selection::new(30, 100, seed);
            (0..100).for_each(|i| s.offer(p(i)));
            assert_eq!(s.sample.len(), 30, "seed {seed}");
            assert!(s.sample.windows(2).all(|w| w[0].x < w[1].x), "seed {seed}: in order");
            s.sample.iter().for_each(|q| taken[q.x as usize] += 1);
        }
        for (i, &n) in taken.iter().enumerate() {
            assert!((477..=723).contains(&n), "position {i} taken {n} times of 2000");
        }
        // More offered than announced: the sample stays as asked.
        let mut over = Selection::new(3, 5, 7);
        (0..50).for_each(|i| over.offer(p(i)));
        assert!(over.sample.len() == 3 && over.sample.iter().all(|q| q.x < 5.0), "{:?}", over.sample);
        // The bitmap and the hash set draw the same indices.
        for (wanted, total, seed) in [(0u64, 0u64, 1u64), (0, 10, 2), (7, 7, 3), (30, 100, 4), (64, 1000, 5)]
        {
            let bits = floyd(wanted, total, seed, true);
            assert_eq!(bits, floyd(wanted, total, seed, false), "{wanted} of {total}");
            assert!(bits.len() as u64 == wanted && bits.windows(2).all(|w| w[0] < w[1]), "{bits:?}");
        }
        // Taken from memory: the same sample as offered one by one, across bitmap words.
        let items: Vec<DVec3> = (0..1000).map(p).collect();
        for (size, seed) in [(1usize, 3u64), (64, 4), (500, 5), (999, 6), (1000, 7), (2000, 8)] {
            let (mut offered, mut taken) =
                (Selection::new(size, 1000, seed), Selection::new(size, 1000, seed));
            items.iter().for_each(|&q| offered.offer(q));
            taken.take(&items, |&q| q);
            assert_eq!(offered.sample, taken.sample, "size {size}, seed {seed}");
            assert_eq!(taken.sample.len(), size.min(1000));
        }
    }

    #[test]
    fn records_pushed_all_at_once_fill_the_cells_pushing_them_one_by_one_fills() {
        // More than a window, in calls that end mid-part and mid-window.
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let recs: Vec<InputPoint> = (0..PUSH_WINDOW + 3 * PUSH_PART + 123)
            .map(|i| {
                let pos = DVec3::new(rng.random(), rng.random::<f64>() * 3.0, rng.random::<f64>() - 0.5);
                InputPoint { spacing: i as f32, ..InputPoint::at(pos, [rng.random(), 1, 2, 255]) }
            })
            .collect();
        let sample: Vec<DVec3> = recs.iter().step_by(7).map(|r| r.pos).collect();
        let tree = || TopTree::build(&sample, recs.len() as u64, recs.len() / 40);
        let dir = tempfile::tempdir().expect("temp dir");
        let mut one = CellWriter::start(dir.path(), tree()).expect("cells");
        recs.iter().try_for_each(|r| one.push(r)).expect("pushed");
        let mut all = CellWriter::start(dir.path(), tree()).expect("cells");
        let (a, b) = recs.split_at(PUSH_PART + 5);
        all.push_all(a).expect("pushed");
        all.push_all(b).expect("pushed");
        let ((_, one), (_, all)) = (one.finish().expect("flushed"), all.finish().expect("flushed"));
        assert!(one.len() >= 32, "{} cells", one.len());
        assert_eq!(one.len(), all.len());
        let read = |c: &Cell| std::fs::read(c.file.path()).expect("cell file");
        for (i, (x, y)) in one.iter().zip(&all).enumerate() {
            assert!(x.count > 0 && x.count == y.count, "cell {i}: {} and {}", x.count, y.count);
            assert!(read(x) == read(y), "cell {i} differs");
        }
        assert_eq!(one.iter().map(|c| c.count).sum::<u64>(), recs.len() as u64);
    }
}
