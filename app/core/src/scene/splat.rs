//! One surface sample as stored on disk and uploaded to the GPU.
//!
//! Needs to be kept in sync with the splat shader (`shaders/splat.wgsl`) and the vertex layout
//! the renderer declares for it (`app/render/src/lib.rs`).

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

/// A surface sample: an oriented disc. 24 bytes, little endian, 4-byte aligned.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Splat {
    /// Position relative to the model origin (metres of the input file's units).
    pub pos: [f32; 3],
    /// Radius of the disc that covers the surface around the sample.
    pub radius: f32,
    /// Unit normal, octahedral encoding in two signed 16-bit integers.
    pub normal_oct: [i16; 2],
    /// sRGB colour and alpha (alpha 0 means "the scan had no colour").
    pub color: [u8; 4],
}

impl Splat {
    /// Builds a splat from a position, a unit normal (zero: unknown), a radius and a colour.
    pub fn new(pos: Vec3, normal: Vec3, radius: f32, color: [u8; 4]) -> Self {
        Self { pos: pos.to_array(), radius, normal_oct: oct_encode(normal), color }
    }

    /// Position as a vector.
    #[inline]
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.pos)
    }

    /// Decoded unit normal.
    pub fn normal(&self) -> Vec3 {
        oct_decode(self.normal_oct)
    }
}

/// Encodes a unit vector with the octahedral mapping (error below 0.01° at 16 bits).
/// A zero or non-finite vector encodes as +Z.
pub fn oct_encode(n: Vec3) -> [i16; 2] {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if l1.is_nan() || l1 <= 0.0 || !l1.is_finite() {
        return [0, 0];
    }
    let mut x = n.x / l1;
    let mut y = n.y / l1;
    if n.z < 0.0 {
        let (ox, oy) = (x, y);
        x = (1.0 - oy.abs()) * sign_not_zero(ox);
        y = (1.0 - ox.abs()) * sign_not_zero(oy);
    }
    let q = |v: f32| (v.clamp(-1.0, 1.0) * 32767.0).round() as i16;
    [q(x), q(y)]
}

/// Decodes [`oct_encode`]; always returns a unit vector.
pub fn oct_decode(e: [i16; 2]) -> Vec3 {
    let x = f32::from(e[0]) / 32767.0;
    let y = f32::from(e[1]) / 32767.0;
    let z = 1.0 - x.abs() - y.abs();
    let (x, y) = if z < 0.0 {
        ((1.0 - y.abs()) * sign_not_zero(x), (1.0 - x.abs()) * sign_not_zero(y))
    } else {
        (x, y)
    };
    Vec3::new(x, y, z).try_normalize().unwrap_or(Vec3::Z)
}

fn sign_not_zero(v: f32) -> f32 {
    if v >= 0.0 { 1.0 } else { -1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn octahedral_round_trip_is_accurate_everywhere() {
        let mut worst: f32 = 1.0;
        for i in 0..60 {
            for j in 0..120 {
                let th = std::f32::consts::PI * (i as f32 + 0.5) / 60.0;
                let ph = std::f32::consts::TAU * j as f32 / 120.0;
                let n = Vec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                worst = worst.min(oct_decode(oct_encode(n)).dot(n));
            }
        }
        // cos(0.01°) = 0.999_999_98: f32 cannot resolve that, so check 0.05°.
        assert!(worst > (0.05f32).to_radians().cos(), "worst dot {worst}");
        assert_eq!(oct_decode(oct_encode(Vec3::NEG_Z)), Vec3::NEG_Z);
        assert_eq!(oct_decode(oct_encode(Vec3::ZERO)), Vec3::Z);
        assert_eq!(oct_decode(oct_encode(Vec3::NAN)), Vec3::Z);
    }
}
