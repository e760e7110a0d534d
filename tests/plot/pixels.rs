//! Reading pictures back: pixels, colours near a point, hues.

use super::*;

pub(super) fn decode(p: &Path) -> RgbImage {
    image::open(p)
        .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
        .to_rgb8()
}

pub(super) type Rgb = (u8, u8, u8);

pub(super) fn px(img: &RgbImage, (x, y): (i32, i32)) -> Option<Rgb> {
    if x < 0 || y < 0 || x as u32 >= img.width() || y as u32 >= img.height() {
        return None;
    }
    let p = img.get_pixel(x as u32, y as u32);
    Some((p[0], p[1], p[2]))
}

/// The pixels within `r` (Chebyshev) of `at`.
pub(super) fn around(img: &RgbImage, at: (i32, i32), r: i32) -> Vec<Rgb> {
    let mut v = Vec::new();
    for dy in -r..=r {
        for dx in -r..=r {
            if let Some(p) = px(img, (at.0 + dx, at.1 + dy)) {
                v.push(p);
            }
        }
    }
    v
}

pub(super) fn has(img: &RgbImage, at: (i32, i32), r: i32, colour: Rgb) -> bool {
    around(img, at, r).contains(&colour)
}

pub(super) fn hue_distance(a: f64, b: f64) -> f64 {
    ((a - b + 180.0).rem_euclid(360.0) - 180.0).abs()
}

/// The largest saturation among the pixels near `at` whose hue is within 20 degrees of
/// `hue`.
pub(super) fn saturation_of_hue(img: &RgbImage, at: (i32, i32), r: i32, hue: f64) -> f64 {
    around(img, at, r)
        .into_iter()
        .map(hue_saturation)
        .filter(|(h, s)| *s > 0.05 && hue_distance(*h, hue) < 20.0)
        .map(|(_, s)| s)
        .fold(0.0, f64::max)
}

pub(super) fn count(img: &RgbImage, f: impl Fn(Rgb) -> bool) -> usize {
    img.pixels().filter(|p| f((p[0], p[1], p[2]))).count()
}

pub(super) fn bluish((r, g, b): Rgb) -> bool {
    let (h, s) = hue_saturation((r, g, b));
    s > 0.15 && hue_distance(h, hue_saturation(SAMPLE).0) < 15.0
}
