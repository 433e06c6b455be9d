//! ASTM E57 (with the `e57` crate): every scan of the file, each with its pose applied,
//! Cartesian or spherical coordinates (converted), colour, or intensity as grey when a scan has
//! no colour; points flagged invalid are skipped (counted in a warning). Several scans merge into
//! one model. Normals and spacings are estimated by the builder.

use crate::source::{InputPoint, ReadReport, Sink};
use glam::DVec3;
use std::path::Path;

/// Why an E57 file cannot be read: the reader's own errors, or `E`, the error of the consumer
/// of the points that stopped the reading.
#[derive(Debug, thiserror::Error)]
pub enum E57Error<E = std::convert::Infallible> {
    /// The file's structure (header, XML section, binary sections).
    #[error("{}", message(.0))]
    File(::e57::Error),
    /// A scan's points cannot be decoded.
    #[error(
        "scan {scan}{}{}: {}",
        if name.is_empty() { String::new() } else { format!(" ({name})") },
        .point.map(|p| format!(", point {p}")).unwrap_or_default(),
        message(.cause)
    )]
    Scan {
        /// 1-based scan index.
        scan: usize,
        /// The scan's name, if any.
        name: String,
        /// 1-based index, within the scan, of the point being decoded (`None`: opening it).
        point: Option<u64>,
        /// The decoder's error.
        cause: ::e57::Error,
    },
    /// No scan holds a valid point.
    #[error(
        "{}",
        if *.0 == 0 { "the file holds no point cloud (images only, or nothing)".to_string() }
        else { format!("no valid point in its {} scan(s)", .0) }
    )]
    Empty(usize),
    /// Rejected by the consumer of the points, with its error.
    #[error(transparent)]
    Sink(E),
    /// The decoder gave up on corrupted data.
    #[error("{0}")]
    Corrupt(String),
}

impl<E> E57Error<E> {
    /// The reader's own error, or the consumer's.
    pub(crate) fn split(self) -> Result<E57Error, E> {
        match self {
            Self::File(e) => Ok(E57Error::File(e)),
            Self::Scan { scan, name, point, cause } => Ok(E57Error::Scan { scan, name, point, cause }),
            Self::Empty(n) => Ok(E57Error::Empty(n)),
            Self::Sink(e) => Err(e),
            Self::Corrupt(msg) => Ok(E57Error::Corrupt(msg)),
        }
    }
}

/// Points handed on at a time.
const CHUNK: usize = 1 << 16;

/// The `e57` crate's message, or what a file that ends before the sections its header names
/// means, in a user's words.
fn message(e: &::e57::Error) -> String {
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(e);
    while let Some(c) = cause {
        if c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::UnexpectedEof)
        {
            return super::CUT_SHORT.into();
        }
        cause = c.source();
    }
    e.to_string()
}

/// Reads every scan of an E57 file into `sink`.
pub fn read<E>(path: &Path, sink: &mut dyn Sink<Error = E>) -> Result<ReadReport, E57Error<E>> {
    super::guarded(|| read_guarded(path, sink), E57Error::Corrupt)
}

fn read_guarded<E>(path: &Path, sink: &mut dyn Sink<Error = E>) -> Result<ReadReport, E57Error<E>> {
    let mut reader = ::e57::E57Reader::from_file(path).map_err(E57Error::File)?;
    let clouds = reader.pointclouds();
    let mut report = ReadReport::default();
    let mut invalid = 0u64;
    sink.expect(clouds.iter().map(|pc| pc.records).sum());
    for (i, pc) in clouds.iter().enumerate() {
        let scan_err = |point: Option<u64>| {
            move |cause| E57Error::Scan {
                scan: i + 1,
                name: pc.name.clone().unwrap_or_default(),
                point,
                cause,
            }
        };
        let has_color = pc.has_color();
        report.has_colors |= has_color || pc.has_intensity();
        let mut points = reader.pointcloud_simple(pc).map_err(scan_err(None))?;
        points.spherical_to_cartesian(true);
        points.apply_pose(true);
        points.intensity_to_color(true);
        let mut out = Vec::with_capacity(CHUNK);
        for (k, p) in (1u64..).zip(points) {
            let p = p.map_err(scan_err(Some(k)))?;
            report.rows += 1;
            let ::e57::CartesianCoordinate::Valid { x, y, z } = p.cartesian else {
                invalid += 1;
                continue;
            };
            if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                invalid += 1;
                continue;
            }
            let color = match (&p.color, p.intensity) {
                (Some(c), _) => {
                    let ch = |v: f32| super::to_u8(f64::from(v), 1.0);
                    [ch(c.red), ch(c.green), ch(c.blue), 255]
                }
                (None, Some(g)) => {
                    let g = super::to_u8(f64::from(g), 1.0);
                    [g, g, g, 255]
                }
                (None, None) => [0; 4],
            };
            out.push(InputPoint::at(DVec3::new(x, y, z), color));
            if out.len() == CHUNK {
                report.points += out.len() as u64;
                sink.points(std::mem::replace(&mut out, Vec::with_capacity(CHUNK)))
                    .map_err(E57Error::Sink)?;
            }
        }
        report.points += out.len() as u64;
        sink.points(out).map_err(E57Error::Sink)?;
    }
    if report.points == 0 {
        return Err(E57Error::Empty(clouds.len()));
    }
    if invalid > 0 {
        report.warnings.push(format!("{invalid} points flagged invalid or without coordinates were skipped"));
    }
    Ok(report)
}
