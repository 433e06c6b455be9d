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

/// Share of the pixels inside `mask` (true: the model covers the pixel) whose colour steps by
/// more than `step` (0–255, any channel) to their right or lower neighbour inside the mask: the
/// visible edges of the image, e.g. the rims of overlapping discs on a smooth surface.
pub fn edge_share(img: &image::RgbaImage, mask: &[bool], step: u8) -> f64 {
    let (w, h) = img.dimensions();
    let inside = |x: u32, y: u32| mask[(y * w + x) as usize];
    let differs = |a: &image::Rgba<u8>, b: &image::Rgba<u8>| (0..3).any(|c| a[c].abs_diff(b[c]) > step);
    let (mut edges, mut total) = (0u64, 0u64);
    for y in 0..h {
        for x in 0..w {
            if !inside(x, y) {
                continue;
            }
            total += 1;
            let p = img.get_pixel(x, y);
            let right = x + 1 < w && inside(x + 1, y) && differs(p, img.get_pixel(x + 1, y));
            let down = y + 1 < h && inside(x, y + 1) && differs(p, img.get_pixel(x, y + 1));
            if right || down {
                edges += 1;
            }
        }
    }
    if total == 0 { 0.0 } else { edges as f64 / total as f64 }
}

/// Share of the pixels inside `mask` where `img` steps (as [`edge_share`] counts) but `reference`
/// has no step within `margin` pixels: edges the surface does not have, e.g. disc rims.
pub fn extra_edge_share(
    img: &image::RgbaImage,
    reference: &image::RgbaImage,
    mask: &[bool],
    step: u8,
    margin: u32,
) -> f64 {
    let (w, h) = img.dimensions();
    let steps = |im: &image::RgbaImage| -> Vec<bool> {
        let differs = |a: &image::Rgba<u8>, b: &image::Rgba<u8>| (0..3).any(|c| a[c].abs_diff(b[c]) > step);
        (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .map(|(x, y)| {
                let i = (y * w + x) as usize;
                let p = im.get_pixel(x, y);
                mask[i]
                    && ((x + 1 < w && mask[i + 1] && differs(p, im.get_pixel(x + 1, y)))
                        || (y + 1 < h && mask[i + w as usize] && differs(p, im.get_pixel(x, y + 1))))
            })
            .collect()
    };
    let (mine, theirs) = (steps(img), steps(reference));
    let m = i64::from(margin);
    let near_reference_edge = |x: i64, y: i64| {
        (-m..=m).any(|dy| {
            (-m..=m).any(|dx| {
                let (u, v) = (x + dx, y + dy);
                u >= 0
                    && v >= 0
                    && u < i64::from(w)
                    && v < i64::from(h)
                    && theirs[(v * i64::from(w) + u) as usize]
            })
        })
    };
    let total = mask.iter().filter(|m| **m).count();
    let extra = (0..i64::from(h))
        .flat_map(|y| (0..i64::from(w)).map(move |x| (x, y)))
        .filter(|&(x, y)| mine[(y * i64::from(w) + x) as usize] && !near_reference_edge(x, y))
        .count();
    if total == 0 { 0.0 } else { extra as f64 / total as f64 }
}

/// The pixels of `img` that are not `background` (an sRGB RGBA8 colour, ±2 per channel).
pub fn coverage(img: &image::RgbaImage, background: [u8; 3]) -> Vec<bool> {
    img.pixels().map(|p| (0..3).any(|c| p[c].abs_diff(background[c]) > 2)).collect()
}

/// The inside of a model seen in two images: the pixels both cover, `margin` pixels away from
/// either one's silhouette (where two renderings of one surface differ by a pixel or two and
/// every step is the silhouette's).
pub fn interior(a: &[bool], b: &[bool], (w, h): (u32, u32), margin: u32) -> Vec<bool> {
    let both: Vec<bool> = a.iter().zip(b).map(|(x, y)| *x && *y).collect();
    let m = margin as i64;
    (0..h as i64)
        .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
        .map(|(x, y)| {
            (-m..=m).all(|dy| {
                (-m..=m).all(|dx| {
                    let (u, v) = (x + dx, y + dy);
                    u >= 0 && v >= 0 && u < w as i64 && v < h as i64 && both[(v * w as i64 + u) as usize]
                })
            })
        })
        .collect()
}

/// CIE L*a*b* (D65) of an sRGB colour.
fn lab([r, g, b]: [u8; 3]) -> [f64; 3] {
    let lin = |c: u8| {
        let c = f64::from(c) / 255.0;
        if c <= 0.040_45 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
    };
    let (r, g, b) = (lin(r), lin(g), lin(b));
    let x = (0.412_456_4 * r + 0.357_576_1 * g + 0.180_437_5 * b) / 0.950_47;
    let y = 0.212_672_9 * r + 0.715_152_2 * g + 0.072_175_0 * b;
    let z = (0.019_333_9 * r + 0.119_192_0 * g + 0.950_304_1 * b) / 1.088_83;
    let f = |t: f64| if t > 216.0 / 24389.0 { t.cbrt() } else { (24389.0 / 27.0 * t + 16.0) / 116.0 };
    let (fx, fy, fz) = (f(x), f(y), f(z));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// The mean colour difference ΔE (CIE76: distance in L*a*b*; about 2.3 is just noticeable)
/// between two images over the pixels of `mask`; 0 when the mask is empty.
pub fn delta_e(a: &image::RgbaImage, b: &image::RgbaImage, mask: &[bool]) -> f64 {
    let (mut sum, mut n) = (0.0, 0usize);
    for ((p, q), &m) in a.pixels().zip(b.pixels()).zip(mask) {
        if m {
            let (x, y) = (lab([p[0], p[1], p[2]]), lab([q[0], q[1], q[2]]));
            sum += ((x[0] - y[0]).powi(2) + (x[1] - y[1]).powi(2) + (x[2] - y[2]).powi(2)).sqrt();
            n += 1;
        }
    }
    if n == 0 { 0.0 } else { sum / n as f64 }
}

/// The sRGB RGBA8 encoding of a linear colour (as an sRGB render target stores it).
pub fn srgb8(linear: [f64; 4]) -> [u8; 3] {
    let e = |c: f64| {
        let c = c.clamp(0.0, 1.0);
        (255.0 * if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }).round() as u8
    };
    [e(linear[0]), e(linear[1]), e(linear[2])]
}

#[cfg(test)]
mod tests {
    #[test]
    fn delta_e_is_zero_for_equal_images_and_about_100_from_black_to_white() {
        let black = image::RgbaImage::from_pixel(4, 4, image::Rgba([0, 0, 0, 255]));
        let white = image::RgbaImage::from_pixel(4, 4, image::Rgba([255, 255, 255, 255]));
        let mask = vec![true; 16];
        assert_eq!(super::delta_e(&black, &black, &mask), 0.0);
        assert!((super::delta_e(&black, &white, &mask) - 100.0).abs() < 0.1);
        assert_eq!(super::delta_e(&black, &white, &[false; 16]), 0.0);
    }

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

    #[test]
    fn edges_are_steps_inside_the_mask_away_from_silhouettes() {
        // A smooth ramp has no edges; a disc's rim on it does; background around is not counted.
        let bg = srgb8([0.02, 0.02, 0.025, 1.0]);
        let smooth = image::RgbaImage::from_fn(40, 40, |x, y| {
            if (5..35).contains(&x) && (5..35).contains(&y) {
                image::Rgba([100 + x as u8, 100, 100, 255])
            } else {
                image::Rgba([bg[0], bg[1], bg[2], 255])
            }
        });
        let mut disc = smooth.clone();
        for (x, y, p) in disc.enumerate_pixels_mut() {
            if (x as i32 - 20).pow(2) + (y as i32 - 20).pow(2) < 64 {
                p[1] = 140;
            }
        }
        let mask = interior(&coverage(&smooth, bg), &coverage(&disc, bg), (40, 40), 2);
        assert!(mask[20 * 40 + 20] && !mask[5 * 40 + 5] && !mask[0]);
        assert_eq!(edge_share(&smooth, &mask, 12), 0.0);
        let e = edge_share(&disc, &mask, 12);
        assert!(e > 0.02 && e < 0.2, "{e}");
    }
}
