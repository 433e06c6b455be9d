//! Image comparison for golden-image tests and the renderer's speed/accuracy benchmark.

/// Luminance (Rec. 601 weights) of every pixel.
fn luminance(img: &image::RgbaImage) -> Vec<f64> {
    img.pixels()
        .map(|p| 0.299 * f64::from(p[0]) + 0.587 * f64::from(p[1]) + 0.114 * f64::from(p[2]))
        .collect()
}

/// Mean SSIM (Wang et al. 2004 constants, 8-bit range) over 8×8 windows of the luminance, every
/// 4 pixels. 1 for identical images; images of different sizes score 0.
pub fn ssim(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    if a.dimensions() != b.dimensions() {
        return 0.0;
    }
    let (w, h) = a.dimensions();
    let (la, lb) = (luminance(a), luminance(b));
    let (c1, c2) = ((0.01f64 * 255.0).powi(2), (0.03f64 * 255.0).powi(2));
    let (mut total, mut n) = (0.0, 0u32);
    for by in (0..h.saturating_sub(7)).step_by(4) {
        for bx in (0..w.saturating_sub(7)).step_by(4) {
            let idx = |x: u32, y: u32| ((by + y) * w + bx + x) as usize;
            let (mut ma, mut mb) = (0.0, 0.0);
            for y in 0..8 {
                for x in 0..8 {
                    ma += la[idx(x, y)];
                    mb += lb[idx(x, y)];
                }
            }
            ma /= 64.0;
            mb /= 64.0;
            let (mut va, mut vb, mut cov) = (0.0, 0.0, 0.0);
            for y in 0..8 {
                for x in 0..8 {
                    let (da, db) = (la[idx(x, y)] - ma, lb[idx(x, y)] - mb);
                    va += da * da;
                    vb += db * db;
                    cov += da * db;
                }
            }
            let (va, vb, cov) = (va / 63.0, vb / 63.0, cov / 63.0);
            total += ((2.0 * ma * mb + c1) * (2.0 * cov + c2)) / ((ma * ma + mb * mb + c1) * (va + vb + c2));
            n += 1;
        }
    }
    if n == 0 { 1.0 } else { total / f64::from(n) }
}

/// Peak signal-to-noise ratio in dB over the RGB channels (∞ for identical images).
pub fn psnr(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    let n = 3.0 * f64::from(a.width() * a.height()).max(1.0);
    let mse: f64 = a
        .pixels()
        .zip(b.pixels())
        .map(|(p, q)| (0..3).map(|c| (f64::from(p[c]) - f64::from(q[c])).powi(2)).sum::<f64>())
        .sum::<f64>()
        / n;
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0f64 * 255.0 / mse).log10() }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_score_one_and_noise_lowers_the_score() {
        let a =
            image::RgbaImage::from_fn(64, 48, |x, y| image::Rgba([(x * 4) as u8, (y * 5) as u8, 90, 255]));
        assert_eq!(ssim(&a, &a), 1.0);
        assert_eq!(psnr(&a, &a), f64::INFINITY);
        let b = image::RgbaImage::from_fn(64, 48, |x, y| {
            let n = if (x * 7 + y * 13) % 5 == 0 { 60 } else { 0 };
            image::Rgba([((x * 4) as u8).saturating_add(n), (y * 5) as u8, 90, 255])
        });
        assert!(ssim(&a, &b) < 0.95);
        assert!(psnr(&a, &b) < 40.0);
    }
}
