//! Writes a store file sequentially: nodes as they are completed (children before parents), then
//! the index, then the header at offset 0. The file is written under a temporary name and
//! renamed into place at the end, so an interrupted import never leaves a half store behind.
//!
//! [`NodeSink`] shares the writer between the threads that build: nodes get their ids before
//! they are made, are sent from any thread as they are completed and are written in id order.
//! The bytes go through an ordinary buffered file (the page cache); the store is synced once, at
//! the end.

use kiosk_core::scene::boxtree::box_count;
use kiosk_core::scene::store::{self, NONE, NodeRecord, StoreHeader};
use kiosk_core::{Aabb, Splat};
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// A store being written.
pub struct StoreWriter {
    out: BufWriter<std::fs::File>,
    tmp_path: PathBuf,
    final_path: PathBuf,
    offset: u64,
    nodes: Vec<NodeRecord>,
    points: u64,
    leaf_points: u64,
    /// Set once the store is in place; otherwise dropping removes the partial file.
    finished: bool,
}

impl Drop for StoreWriter {
    fn drop(&mut self) {
        if !self.finished {
            // A build that failed or was interrupted leaves nothing behind.
            let _ = std::fs::remove_file(&self.tmp_path);
        }
    }
}

/// Statistics of one node's samples, for its index record.
pub struct NodeStats {
    /// Average sample spacing.
    pub spacing: f32,
    /// [`store::node_data_crc`] of the node's splats and boxes (computed by the caller, which
    /// builds nodes in parallel).
    pub data_crc: u32,
}

impl StoreWriter {
    /// Creates `path` (through a temporary file beside it).
    pub fn create(path: &Path) -> std::io::Result<Self> {
        let mut tmp = path.as_os_str().to_owned();
        tmp.push(".partial");
        let tmp_path = PathBuf::from(tmp);
        let mut out = BufWriter::new(std::fs::File::create(&tmp_path)?);
        out.write_all(&[0u8; StoreHeader::LEN])?;
        Ok(Self {
            out,
            tmp_path,
            final_path: path.to_path_buf(),
            offset: StoreHeader::LEN as u64,
            nodes: Vec::new(),
            points: 0,
            leaf_points: 0,
            finished: false,
        })
    }

    /// Bytes written so far.
    pub fn bytes_written(&self) -> u64 {
        self.offset
    }

    /// Appends a node. `splats` must be spatially sorted and `boxes` built from them.
    /// Returns the node id.
    pub fn add_node(
        &mut self,
        splats: &[Splat],
        boxes: &[Aabb],
        children: Option<[u32; 2]>,
        stats: NodeStats,
    ) -> std::io::Result<u32> {
        debug_assert_eq!(boxes.len(), box_count(splats.len()));
        debug_assert_eq!(stats.data_crc, store::node_data_crc(splats, boxes));
        let id = self.nodes.len() as u32;
        if let Some(c) = children.into_iter().flatten().find(|&c| c >= id) {
            return Err(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("node {id} names child {c}, which is not written"),
            ));
        }
        let points_offset = self.offset;
        self.out.write_all(bytemuck::cast_slice(splats))?;
        self.offset += std::mem::size_of_val(splats) as u64;
        let boxes_offset = self.offset;
        self.out.write_all(bytemuck::cast_slice(boxes))?;
        self.offset += std::mem::size_of_val(boxes) as u64;
        let mut bbox = boxes.first().copied().unwrap_or(Aabb::EMPTY);
        let (mut rmin, mut rmax, mut rsum) = (f32::INFINITY, 0.0f32, 0.0f64);
        for s in splats {
            rmin = rmin.min(s.radius);
            rmax = rmax.max(s.radius);
            rsum += f64::from(s.radius);
        }
        let mut subtree_radius_max = rmax;
        let height = match children {
            Some([a, b]) => {
                for c in [a, b] {
                    let child = &mut self.nodes[c as usize];
                    child.parent = id;
                    bbox = bbox.union(child.bbox());
                    subtree_radius_max = subtree_radius_max.max(child.subtree_radius_max);
                }
                1 + self.nodes[a as usize].height.max(self.nodes[b as usize].height)
            }
            None => 0,
        };
        self.nodes.push(NodeRecord {
            points_offset,
            boxes_offset,
            bbox_min: bbox.min.to_array(),
            bbox_max: bbox.max.to_array(),
            children: children.unwrap_or([NONE, NONE]),
            parent: NONE,
            point_count: splats.len() as u32,
            height,
            radius_min: rmin,
            radius_avg: (rsum / splats.len().max(1) as f64) as f32,
            radius_max: rmax,
            spacing: stats.spacing,
            data_crc: stats.data_crc,
            subtree_radius_max,
            reserved: 0,
        });
        self.points += splats.len() as u64;
        if children.is_none() {
            self.leaf_points += splats.len() as u64;
        }
        Ok(id)
    }

    /// Nodes written so far (the id of the next node).
    pub fn node_count(&self) -> u32 {
        self.nodes.len() as u32
    }

    /// A node already written.
    pub fn node(&self, id: u32) -> &NodeRecord {
        &self.nodes[id as usize]
    }

    /// Writes the index and the header and moves the file into place. The last node added is
    /// the root.
    pub fn finish(mut self, origin: [f64; 3], input_points: u64, node_points: u32) -> std::io::Result<u64> {
        let pad = (8 - self.offset % 8) % 8;
        self.out.write_all(&[0u8; 8][..pad as usize])?;
        self.offset += pad;
        let index_offset = self.offset;
        let index: &[u8] = bytemuck::cast_slice(&self.nodes);
        self.out.write_all(index)?;
        self.offset += index.len() as u64;
        let header = StoreHeader {
            magic: store::MAGIC,
            version: store::VERSION,
            header_len: StoreHeader::LEN as u32,
            origin,
            node_count: self.nodes.len() as u64,
            point_count: self.points,
            leaf_point_count: self.leaf_points,
            input_point_count: input_points,
            index_offset,
            file_len: self.offset,
            root: self.nodes.len() as u32 - 1,
            node_points,
            index_crc: store::crc(index),
            header_crc: 0,
        }
        .seal();
        self.out.flush()?;
        let file = self.out.get_mut();
        file.seek(SeekFrom::Start(0))?;
        file.write_all(bytemuck::bytes_of(&header))?;
        file.sync_all()?;
        std::fs::rename(&self.tmp_path, &self.final_path)?;
        self.finished = true;
        Ok(self.offset)
    }
}

/// A node for [`NodeSink::send`] or [`NodeSender::send`].
pub struct PendingNode {
    /// Spatially sorted splats.
    pub splats: Vec<Splat>,
    /// Their boxes.
    pub boxes: Vec<Aabb>,
    /// Children (lower ids).
    pub children: Option<[u32; 2]>,
    /// Statistics for the index record.
    pub stats: NodeStats,
}

/// A [`StoreWriter`] shared by the threads that build nodes. Nodes get their ids before they
/// are made ([`NodeSink::reserve`]: a subtree's ids follow from its sample count), are sent from
/// any thread in any order as they are made ([`NodeSender`]), and are written in id order: a
/// node waits in memory only for the nodes of lower ids still being built. (A thread of its own
/// for the writer gained 1–2 % side by side: docs/performance.md, speed devices.)
pub struct NodeSink {
    next_id: u32,
    queue: std::sync::Arc<std::sync::Mutex<Queue>>,
}

/// The writer, the nodes that came before the ones below them, and the first error.
struct Queue {
    writer: StoreWriter,
    waiting: std::collections::BTreeMap<u32, PendingNode>,
    failed: Option<std::io::Error>,
}

impl Queue {
    /// Takes node `id` and writes every node it completes the run of; after an error, nothing.
    fn take(&mut self, id: u32, node: PendingNode) {
        if self.failed.is_some() {
            return;
        }
        self.waiting.insert(id, node);
        while let Some(n) = self.waiting.remove(&self.writer.node_count()) {
            if let Err(e) = self.writer.add_node(&n.splats, &n.boxes, n.children, n.stats) {
                self.failed = Some(e);
                self.waiting.clear();
                return;
            }
        }
    }

    /// The first error, again (an error cannot be cloned: its kind and text).
    fn failure(&self) -> Option<std::io::Error> {
        self.failed.as_ref().map(|e| std::io::Error::new(e.kind(), e.to_string()))
    }
}

fn lock(queue: &std::sync::Mutex<Queue>) -> std::sync::MutexGuard<'_, Queue> {
    queue.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Sends nodes with reserved ids to a [`NodeSink`], from any thread.
#[derive(Clone)]
pub struct NodeSender(std::sync::Arc<std::sync::Mutex<Queue>>);

impl NodeSender {
    /// Sends node `id` (reserved). After a write failed, nodes are dropped: the error comes from
    /// [`NodeSink::sender`], [`NodeSink::send`] or [`NodeSink::finish`].
    pub fn send(&self, id: u32, node: PendingNode) {
        lock(&self.0).take(id, node);
    }
}

impl NodeSink {
    /// Starts with `writer`.
    pub fn start(writer: StoreWriter) -> Self {
        let next_id = writer.node_count();
        let queue = Queue { writer, waiting: Default::default(), failed: None };
        Self { next_id, queue: std::sync::Arc::new(std::sync::Mutex::new(queue)) }
    }

    /// Reserves the ids of `n` nodes; returns the first.
    pub fn reserve(&mut self, n: u32) -> u32 {
        self.next_id += n;
        self.next_id - n
    }

    /// The error of a write that failed, if one did.
    pub fn check(&self) -> std::io::Result<()> {
        lock(&self.queue).failure().map_or(Ok(()), Err)
    }

    /// A sender of nodes with reserved ids; the error of a write that failed.
    pub fn sender(&self) -> std::io::Result<NodeSender> {
        self.check()?;
        Ok(NodeSender(self.queue.clone()))
    }

    /// Sends `node` with the next id, and returns it.
    pub fn send(&mut self, node: PendingNode) -> std::io::Result<u32> {
        let sender = self.sender()?;
        let id = self.reserve(1);
        sender.send(id, node);
        Ok(id)
    }

    /// The writer, once every node reserved is written (senders must be gone).
    pub fn finish(self) -> std::io::Result<StoreWriter> {
        let queue = std::sync::Arc::into_inner(self.queue)
            .ok_or_else(|| std::io::Error::other("a node sender outlived the build"))?
            .into_inner()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(e) = queue.failed {
            return Err(e);
        }
        let next = queue.writer.node_count();
        if let Some(id) = queue.waiting.keys().next() {
            return Err(std::io::Error::other(format!(
                "node {id} came without the nodes before it (the next to write is {next})"
            )));
        }
        if next < self.next_id {
            return Err(std::io::Error::other(format!(
                "nodes {next} to {} were reserved, never sent",
                self.next_id - 1
            )));
        }
        Ok(queue.writer)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn node(k: u32, children: Option<[u32; 2]>) -> PendingNode {
        let splats: Vec<Splat> = (0..20)
            .map(|i| Splat::new(Vec3::new(i as f32, k as f32, 0.5), Vec3::Z, 0.1, [k as u8, 0, 0, 255]))
            .collect();
        let boxes = kiosk_core::scene::boxtree::build_boxes(&splats);
        let data_crc = store::node_data_crc(&splats, &boxes);
        PendingNode { splats, boxes, children, stats: NodeStats { spacing: 0.2, data_crc } }
    }

    /// The store of two leaves and their parent, sent in `order` of ids.
    fn store(dir: &Path, name: &str, order: [u32; 3]) -> std::io::Result<Vec<u8>> {
        let path = dir.join(name);
        let mut sink = NodeSink::start(StoreWriter::create(&path)?);
        let base = sink.reserve(3);
        let sender = sink.sender()?;
        for id in order {
            sender.send(base + id, node(id, (id == 2).then_some([base, base + 1])));
        }
        drop(sender);
        sink.finish()?.finish([0.0; 3], 60, 32)?;
        std::fs::read(path)
    }

    #[test]
    fn nodes_sent_in_any_order_are_written_in_id_order() {
        let dir = tempfile::tempdir().expect("temp dir");
        let in_order = store(dir.path(), "a.kstore", [0, 1, 2]).expect("written");
        for order in [[2, 1, 0], [1, 2, 0], [0, 2, 1]] {
            assert!(store(dir.path(), "b.kstore", order).expect("written") == in_order, "{order:?}");
        }
    }

    #[test]
    fn a_node_whose_children_are_not_written_is_an_error() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("d.kstore");
        let mut sink = NodeSink::start(StoreWriter::create(&path).expect("created"));
        let base = sink.reserve(2);
        sink.sender().expect("sender").send(base, node(0, Some([98, 99])));
        let e = sink.sender().err().expect("the write failed");
        assert_eq!(e.to_string(), "node 0 names child 98, which is not written");
        assert!(sink.finish().is_err());
        assert!(!path.exists());
    }

    #[test]
    fn a_reserved_node_never_sent_is_an_error_not_a_hang() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("c.kstore");
        let mut sink = NodeSink::start(StoreWriter::create(&path).expect("created"));
        let base = sink.reserve(2);
        sink.sender().expect("sender").send(base + 1, node(1, None));
        let e = sink.finish().err().expect("node 0 is missing");
        assert!(e.to_string().contains("came without the nodes before it"), "{e}");
        assert!(!path.exists());
    }
}
