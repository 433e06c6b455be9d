//! The on-disk hierarchy: one file per model, read through a memory map handed in by the shell.
//!
//! Layout (all little endian; version 1):
//! ```text
//! [StoreHeader]                      at 0, 112 bytes
//! (NodeRecord: 88 bytes)
//! per node, in post order (children before parents):
//!   [Splat; point_count]             at NodeRecord::points_offset (4-byte aligned)
//!   [Aabb; box_count(points)]        at NodeRecord::boxes_offset  (4-byte aligned)
//! [NodeRecord; node_count]           at StoreHeader::index_offset (8-byte aligned)
//! ```
//! Point positions and boxes are `f32` relative to the `f64` model origin of the header.
//! Opening checks the header, the index checksum and the tree's structure, so that a truncated or
//! corrupted file is a clear error; node data is checked on demand ([`Store::verify_node`]) so
//! that opening a huge model touches only its index.

use super::boxtree::box_count;
use super::splat::Splat;
use crate::geom::Aabb;
use bytemuck::{Pod, Zeroable};
use glam::{DVec3, Vec3};

/// First bytes of every store file.
/// Largest model origin coordinate accepted (georeferenced coordinates reach ~10⁷ m).
pub const MAX_ORIGIN: f64 = 1e12;
/// Largest local coordinate accepted (f32 relative to the origin; beyond this a store is not
/// a real model: an import centres its points on the origin).
pub const MAX_LOCAL: f32 = 1e9;

pub const MAGIC: [u8; 8] = *b"ISOKSTOR";
/// The store version this build reads and writes.
pub const VERSION: u32 = 1;
/// "No node" in child and parent links.
pub const NONE: u32 = u32::MAX;

/// Identifier of a node: its position in the index.
pub type NodeId = u32;

/// File header.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct StoreHeader {
    /// [`MAGIC`].
    pub magic: [u8; 8],
    /// [`VERSION`].
    pub version: u32,
    /// Size of this header in bytes.
    pub header_len: u32,
    /// Model origin: local coordinates are relative to it.
    pub origin: [f64; 3],
    /// Number of nodes in the index.
    pub node_count: u64,
    /// Total splats over all nodes (every level).
    pub point_count: u64,
    /// Splats at full resolution (sum over leaves), after merging duplicates.
    pub leaf_point_count: u64,
    /// Samples read from the input file.
    pub input_point_count: u64,
    /// Byte offset of the node index.
    pub index_offset: u64,
    /// Length of the whole file.
    pub file_len: u64,
    /// Index of the root node.
    pub root: u32,
    /// Target samples per node (M).
    pub node_points: u32,
    /// CRC-32 of the node index.
    pub index_crc: u32,
    /// CRC-32 of this header with this field zeroed.
    pub header_crc: u32,
}

/// One entry of the node index.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct NodeRecord {
    /// Byte offset of the node's splats.
    pub points_offset: u64,
    /// Byte offset of the node's search boxes.
    pub boxes_offset: u64,
    /// Bounding box of the positions of the node **and all its descendants** (local
    /// coordinates): a valid bound for searches that descend the tree.
    pub bbox_min: [f32; 3],
    /// See `bbox_min`.
    pub bbox_max: [f32; 3],
    /// Children, or [`NONE`] for a leaf.
    pub children: [u32; 2],
    /// Parent, or [`NONE`] for the root.
    pub parent: u32,
    /// Number of splats.
    pub point_count: u32,
    /// 0 for leaves, 1 + the largest child height otherwise.
    pub height: u32,
    /// Smallest splat radius.
    pub radius_min: f32,
    /// Mean splat radius.
    pub radius_avg: f32,
    /// Largest splat radius.
    pub radius_max: f32,
    /// Average distance between neighbouring samples (drives refinement).
    pub spacing: f32,
    /// CRC-32 of the node's splats and boxes.
    pub data_crc: u32,
    /// Largest splat radius in the node's subtree (bounds ray casts that descend the tree).
    pub subtree_radius_max: f32,
    /// Zero.
    pub reserved: u32,
}

impl NodeRecord {
    /// Bounding box of the positions of the node's subtree.
    pub fn bbox(&self) -> Aabb {
        Aabb { min: Vec3::from_array(self.bbox_min), max: Vec3::from_array(self.bbox_max) }
    }

    /// Whether the node has no children.
    pub fn is_leaf(&self) -> bool {
        self.children[0] == NONE
    }
}

/// Why a store cannot be opened or read.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum StoreError {
    /// Not a store at all.
    #[error("not an IsoKiosk store (bad magic bytes; expected \"ISOKSTOR\")")]
    BadMagic,
    /// Written by another version.
    #[error("store version {found}, this build reads version {VERSION}; re-import the scan")]
    Version {
        /// Version in the file.
        found: u32,
    },
    /// Shorter than the header says.
    #[error("store truncated: the header says {expected} bytes, the file has {found}")]
    Truncated {
        /// Bytes announced.
        expected: u64,
        /// Bytes present.
        found: u64,
    },
    /// A checksum does not match.
    #[error("store corrupted: {what} checksum mismatch")]
    Checksum {
        /// Which part.
        what: String,
    },
    /// The index describes an impossible tree or points outside the file.
    #[error("store corrupted: node {node}: {why}")]
    BadNode {
        /// Node id.
        node: u32,
        /// What is wrong.
        why: String,
    },
    /// Other structural problem.
    #[error("store corrupted: {0}")]
    Corrupt(String),
    /// The bytes handed in are not aligned for zero-copy reading.
    #[error("store buffer is not 8-byte aligned (open it through a memory map)")]
    Misaligned,
}

/// CRC-32 of a byte slice.
pub fn crc(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

impl StoreHeader {
    /// Size in bytes.
    pub const LEN: usize = std::mem::size_of::<Self>();

    /// Fills `header_crc` so that the header verifies.
    pub fn seal(mut self) -> Self {
        self.header_crc = 0;
        self.header_crc = crc(bytemuck::bytes_of(&self));
        self
    }

    /// The model origin.
    pub fn origin(&self) -> DVec3 {
        DVec3::from_array(self.origin)
    }
}

/// A hierarchy store over bytes (a memory map or an aligned buffer) owned by `B`.
#[derive(Debug)]
pub struct Store<B> {
    bytes: B,
    header: StoreHeader,
}

impl<B: AsRef<[u8]>> Store<B> {
    /// Opens a store, checking its header, index checksum and tree structure.
    pub fn open(bytes: B) -> Result<Self, StoreError> {
        let b = bytes.as_ref();
        // Not a store, however short (a text file named .kstore): not "truncated".
        let head = b.len().min(MAGIC.len());
        if b[..head] != MAGIC[..head] {
            return Err(StoreError::BadMagic);
        }
        if b.len() < StoreHeader::LEN {
            return Err(StoreError::Truncated { expected: StoreHeader::LEN as u64, found: b.len() as u64 });
        }
        if !(b.as_ptr() as usize).is_multiple_of(8) {
            return Err(StoreError::Misaligned);
        }
        let header: StoreHeader = bytemuck::pod_read_unaligned(&b[..StoreHeader::LEN]);
        if header.version != VERSION {
            return Err(StoreError::Version { found: header.version });
        }
        if header.seal().header_crc != header.header_crc || header.header_len as usize != StoreHeader::LEN {
            return Err(StoreError::Checksum { what: "header".into() });
        }
        if header.file_len != b.len() as u64 {
            return Err(StoreError::Truncated { expected: header.file_len, found: b.len() as u64 });
        }
        let index_len = header
            .node_count
            .checked_mul(std::mem::size_of::<NodeRecord>() as u64)
            .ok_or_else(|| StoreError::Corrupt("node count overflows".into()))?;
        let index_end = header
            .index_offset
            .checked_add(index_len)
            .filter(|e| *e <= header.file_len && header.index_offset.is_multiple_of(8))
            .ok_or_else(|| StoreError::Corrupt("node index lies outside the file".into()))?;
        let index = &b[header.index_offset as usize..index_end as usize];
        if crc(index) != header.index_crc {
            return Err(StoreError::Checksum { what: "node index".into() });
        }
        let store = Self { bytes, header };
        store.check_structure()?;
        Ok(store)
    }

    fn check_structure(&self) -> Result<(), StoreError> {
        let nodes = self.nodes();
        let n = nodes.len() as u64;
        if n == 0 {
            return Err(StoreError::Corrupt("no nodes".into()));
        }
        let origin = self.header.origin();
        if !origin.is_finite() || origin.abs().max_element() > MAX_ORIGIN {
            return Err(StoreError::Corrupt(format!(
                "model origin {:?} is not a finite coordinate within ±{MAX_ORIGIN:e}",
                self.header.origin
            )));
        }
        if u64::from(self.header.root) != n - 1 {
            return Err(StoreError::Corrupt("the root is not the last node".into()));
        }
        let len = self.header.file_len;
        let mut points = 0u64;
        let mut leaf_points = 0u64;
        for (id, node) in nodes.iter().enumerate() {
            let id32 = id as u32;
            let bad = |why: String| StoreError::BadNode { node: id32, why };
            if node.point_count == 0 {
                return Err(bad("has no points".into()));
            }
            let p_len = u64::from(node.point_count) * std::mem::size_of::<Splat>() as u64;
            let b_len = box_count(node.point_count as usize) as u64 * std::mem::size_of::<Aabb>() as u64;
            let in_file =
                |off: u64, l: u64| off.is_multiple_of(4) && off.checked_add(l).is_some_and(|e| e <= len);
            if !in_file(node.points_offset, p_len) || !in_file(node.boxes_offset, b_len) {
                return Err(bad("its data lies outside the file".into()));
            }
            let bbox = node.bbox();
            if !bbox.min.is_finite() || !bbox.max.is_finite() || bbox.is_empty() {
                return Err(bad("invalid bounding box".into()));
            }
            if bbox.min.abs().max(bbox.max.abs()).max_element() > MAX_LOCAL {
                return Err(bad(format!(
                    "bounding box {:?}…{:?} reaches beyond ±{MAX_LOCAL:e} from the origin",
                    node.bbox_min, node.bbox_max
                )));
            }
            if !(node.subtree_radius_max.is_finite() && node.subtree_radius_max >= node.radius_max) {
                return Err(bad("invalid radius bound".into()));
            }
            points += u64::from(node.point_count);
            match node.children {
                [NONE, NONE] => leaf_points += u64::from(node.point_count),
                [a, b] if a < id32 && b < id32 && a != b => {
                    for c in [a, b] {
                        if nodes[c as usize].parent != id32 {
                            return Err(bad(format!("child {c} does not name it as parent")));
                        }
                        let cb = nodes[c as usize].bbox();
                        if !(cb.min.cmpge(bbox.min).all() && cb.max.cmple(bbox.max).all()) {
                            return Err(bad(format!("child {c}'s bounding box is not inside its own")));
                        }
                    }
                }
                _ => return Err(bad("invalid children".into())),
            }
            let root = id32 == self.header.root;
            if root != (node.parent == NONE) || (!root && node.parent as u64 >= n) {
                return Err(bad("invalid parent".into()));
            }
        }
        if points != self.header.point_count || leaf_points != self.header.leaf_point_count {
            return Err(StoreError::Corrupt("point counts disagree with the index".into()));
        }
        Ok(())
    }

    /// The header.
    pub fn header(&self) -> &StoreHeader {
        &self.header
    }

    /// The model origin (f64): model coordinates = origin + local coordinates.
    pub fn origin(&self) -> DVec3 {
        self.header.origin()
    }

    /// The root node.
    pub fn root(&self) -> NodeId {
        self.header.root
    }

    /// The node index.
    pub fn nodes(&self) -> &[NodeRecord] {
        let h = &self.header;
        let start = h.index_offset as usize;
        let end = start + h.node_count as usize * std::mem::size_of::<NodeRecord>();
        // Alignment and bounds were checked at open.
        bytemuck::try_cast_slice(&self.bytes.as_ref()[start..end]).unwrap_or(&[])
    }

    /// One node's record.
    pub fn node(&self, id: NodeId) -> &NodeRecord {
        &self.nodes()[id as usize]
    }

    /// A node's splats, spatially sorted.
    pub fn splats(&self, id: NodeId) -> &[Splat] {
        let n = self.node(id);
        let start = n.points_offset as usize;
        let end = start + n.point_count as usize * std::mem::size_of::<Splat>();
        bytemuck::try_cast_slice(&self.bytes.as_ref()[start..end]).unwrap_or(&[])
    }

    /// A node's search boxes in heap order.
    pub fn boxes(&self, id: NodeId) -> &[Aabb] {
        let n = self.node(id);
        let start = n.boxes_offset as usize;
        let end = start + box_count(n.point_count as usize) * std::mem::size_of::<Aabb>();
        bytemuck::try_cast_slice(&self.bytes.as_ref()[start..end]).unwrap_or(&[])
    }

    /// Checks a node's data against its checksum (reads the whole node).
    pub fn verify_node(&self, id: NodeId) -> Result<(), StoreError> {
        let mut h = crc32fast::Hasher::new();
        h.update(bytemuck::cast_slice(self.splats(id)));
        h.update(bytemuck::cast_slice(self.boxes(id)));
        if h.finalize() != self.node(id).data_crc {
            return Err(StoreError::Checksum { what: format!("node {id} data") });
        }
        let bad_splat = self
            .splats(id)
            .iter()
            .position(|s| !Vec3::from_array(s.pos).is_finite() || !s.radius.is_finite() || s.radius < 0.0);
        if let Some(i) = bad_splat {
            return Err(StoreError::BadNode { node: id, why: format!("splat {i} is not finite") });
        }
        let node = self.node(id);
        let bbox = node.bbox();
        let outside = self.splats(id).iter().position(|s| {
            let p = Vec3::from_array(s.pos);
            !(p.cmpge(bbox.min).all() && p.cmple(bbox.max).all()) || s.radius > node.radius_max
        });
        if let Some(i) = outside {
            return Err(StoreError::BadNode {
                node: id,
                why: format!("splat {i} lies outside the node's bounding box or radius bound"),
            });
        }
        Ok(())
    }

    /// The nodes whose data fail [`Store::verify_node`], in index order, with why (reads every
    /// node it is asked for).
    pub fn failing_nodes(&self) -> impl Iterator<Item = (NodeId, StoreError)> + '_ {
        (0..self.nodes().len() as NodeId).filter_map(|id| self.verify_node(id).err().map(|e| (id, e)))
    }

    /// Total bytes of the store.
    pub fn len_bytes(&self) -> u64 {
        self.header.file_len
    }

    /// Number of levels (height of the root + 1).
    pub fn levels(&self) -> u32 {
        self.node(self.root()).height + 1
    }

    /// Bounding box of the whole model (local coordinates).
    pub fn bbox(&self) -> Aabb {
        self.node(self.root()).bbox()
    }

    /// Converts model coordinates to local `f32` coordinates.
    pub fn to_local(&self, p_model: DVec3) -> Vec3 {
        (p_model - self.origin()).as_vec3()
    }

    /// Converts local coordinates to model coordinates.
    pub fn to_model(&self, p_local: Vec3) -> DVec3 {
        self.origin() + p_local.as_dvec3()
    }
}

/// Computes a node's data checksum as written (used by the builder).
pub fn node_data_crc(splats: &[Splat], boxes: &[Aabb]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(bytemuck::cast_slice(splats));
    h.update(bytemuck::cast_slice(boxes));
    h.finalize()
}
