//! Two-colour diff images for line art and label images: what the golden had and the output
//! lost, and what the output drew that the golden did not, over a faded copy of the golden.

use super::compare::sample_diff;
use super::diff::gray;
use crate::raster::{check_layout, Image};

/// Marked where only the golden has ink: the output removed it.
pub const REMOVED: [f32; 3] = [0.9, 0.0, 0.0];
/// Marked where only the output has ink: the output added it.
pub const ADDED: [f32; 3] = [0.0, 0.35, 1.0];
/// Marked where both have ink (or the same boundary state) but the values differ.
pub const CHANGED: [f32; 3] = [1.0, 0.6, 0.0];
/// Contrast the golden keeps underneath (the rest is faded towards white).
const FADED_CONTRAST: f32 = 0.25;
/// A channel within this distance of 0 or 1 counts as black or white.
const BINARY_SLACK: f32 = 0.02;
/// Share of pixels that must be black or white in every channel for an image to be line art.
const BINARY_SHARE: f64 = 0.95;

/// What counts as ink when comparing two images.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marks {
    /// Line art: a pixel is ink when its gray level is on the other side of ½ from the
    /// golden's background (the gray side most of the golden's pixels are on).
    Lines,
    /// Label images (identities): a pixel is ink when it lies on a region boundary, i.e. its
    /// value differs from its right or lower neighbour's.
    Boundaries,
}

/// Whether `img` is line art, the rule for drawing its diff with [`two_colour_diff`]: at least
/// 95 % of its pixels are black or white (every channel within 0.02 of 0 or 1). Edges,
/// seams and outlines drawn on a plain ground are; photographs, maps and gradients are not.
pub fn is_line_art(img: &Image) -> bool {
    let n = img.width * img.height;
    if n == 0 || check_layout(img).is_err() {
        return false;
    }
    let binary = |v: f32| v.abs() <= BINARY_SLACK || (1.0 - v).abs() <= BINARY_SLACK;
    let count = (0..img.height)
        .flat_map(|y| (0..img.width).map(move |x| (x, y)))
        .filter(|&(x, y)| (0..img.channels).all(|c| binary(img.get(x, y, c))))
        .count();
    count as f64 >= BINARY_SHARE * n as f64
}

/// An RGB picture of how `actual` departs from `golden`, for line art and label images:
///
/// * background: the golden's gray level at 25 % contrast, faded towards white;
/// * [`REMOVED`] (red): ink in the golden only;
/// * [`ADDED`] (blue): ink in the output only;
/// * [`CHANGED`] (orange): ink in both (or, for labels, no boundary moved) but the values
///   differ.
///
/// What ink is depends on `marks`. On a canvas of the larger width and height (top-left
/// corners aligned), a pixel outside one image counts as having no ink there; a pixel
/// outside both is black. With different channel counts only the common ones are compared.
pub fn two_colour_diff(actual: &Image, golden: &Image, marks: Marks) -> Image {
    let a = Inked::new(actual, marks, background_is_light(golden));
    let g = Inked::new(golden, marks, background_is_light(golden));
    let (w, h) = (a.width.max(g.width), a.height.max(g.height));
    let common = actual.channels.min(golden.channels);
    let mut out = Image::new(w, h, 3);
    for y in 0..h {
        for x in 0..w {
            let rgb = match (a.ink(x, y), g.ink(x, y)) {
                (None, None) => [0.0; 3],
                (Some(false) | None, Some(true)) => REMOVED,
                (Some(true), Some(false) | None) => ADDED,
                (Some(_), Some(_)) if differs(actual, golden, common, x, y) => CHANGED,
                _ => faded(g.gray(x, y)),
            };
            for (c, v) in rgb.into_iter().enumerate() {
                out.set(x, y, c, v);
            }
        }
    }
    out
}

/// An image with its ink rule; malformed images (data inconsistent with the header) are empty.
struct Inked<'a> {
    img: &'a Image,
    width: usize,
    height: usize,
    marks: Marks,
    light_ground: bool,
}

impl<'a> Inked<'a> {
    fn new(img: &'a Image, marks: Marks, light_ground: bool) -> Self {
        let (width, height) = if check_layout(img).is_ok() { (img.width, img.height) } else { (0, 0) };
        Inked { img, width, height, marks, light_ground }
    }

    /// Whether the pixel is ink; `None` outside the image.
    fn ink(&self, x: usize, y: usize) -> Option<bool> {
        if x >= self.width || y >= self.height {
            return None;
        }
        Some(match self.marks {
            Marks::Lines => (gray(self.img, x, y) > 0.5) != self.light_ground,
            Marks::Boundaries => {
                let other = |nx: usize, ny: usize| {
                    nx < self.width
                        && ny < self.height
                        && (0..self.img.channels)
                            .any(|c| sample_diff(self.img.get(x, y, c), self.img.get(nx, ny, c)) > 0.0)
                };
                other(x + 1, y) || other(x, y + 1)
            }
        })
    }

    fn gray(&self, x: usize, y: usize) -> f32 {
        if x < self.width && y < self.height {
            gray(self.img, x, y)
        } else {
            1.0
        }
    }
}

/// Whether most of the golden's pixels are light (its ink is then dark).
fn background_is_light(golden: &Image) -> bool {
    if check_layout(golden).is_err() {
        return true;
    }
    let n = golden.width * golden.height;
    let light = (0..golden.height)
        .flat_map(|y| (0..golden.width).map(move |x| (x, y)))
        .filter(|&(x, y)| gray(golden, x, y) > 0.5)
        .count();
    2 * light >= n
}

fn differs(a: &Image, g: &Image, channels: usize, x: usize, y: usize) -> bool {
    (0..channels).any(|c| sample_diff(a.get(x, y, c), g.get(x, y, c)) > 0.0)
}

/// A gray level at [`FADED_CONTRAST`], faded towards white.
fn faded(v: f32) -> [f32; 3] {
    let f = 1.0 - FADED_CONTRAST + FADED_CONTRAST * v;
    [f, f, f]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn px(img: &Image, x: usize, y: usize) -> [f32; 3] {
        [img.get(x, y, 0), img.get(x, y, 1), img.get(x, y, 2)]
    }

    /// Black lines on white: a vertical line at `column`.
    fn line_at(column: usize) -> Image {
        Image::from_fn(6, 4, 1, |x, _, _| if x == column { 0.0 } else { 1.0 })
    }

    #[test]
    fn a_moved_line_is_red_where_it_was_and_blue_where_it_is() {
        let d = two_colour_diff(&line_at(3), &line_at(1), Marks::Lines);
        assert_eq!((d.width, d.height, d.channels), (6, 4, 3));
        assert_eq!(px(&d, 1, 2), REMOVED);
        assert_eq!(px(&d, 3, 2), ADDED);
        assert_eq!(px(&d, 0, 0), [1.0; 3], "white stays white");
        assert_ne!(REMOVED, ADDED);
    }

    #[test]
    fn the_golden_shows_faded_where_nothing_changed() {
        let d = two_colour_diff(&line_at(1), &line_at(1), Marks::Lines);
        assert_eq!(px(&d, 1, 0), [0.75; 3], "black at 25 % contrast");
        assert_eq!(px(&d, 2, 0), [1.0; 3]);
    }

    #[test]
    fn white_lines_on_black_are_ink_too() {
        let invert = |img: Image| Image::from_fn(6, 4, 1, |x, y, _| 1.0 - img.get(x, y, 0));
        let d = two_colour_diff(&invert(line_at(4)), &invert(line_at(0)), Marks::Lines);
        assert_eq!(px(&d, 0, 1), REMOVED);
        assert_eq!(px(&d, 4, 1), ADDED);
    }

    #[test]
    fn ink_of_another_colour_is_changed() {
        let golden = Image::from_fn(3, 1, 3, |x, _, _| if x == 1 { 0.0 } else { 1.0 });
        let mut actual = golden.clone();
        actual.set(1, 0, 0, 0.2);
        assert_eq!(px(&two_colour_diff(&actual, &golden, Marks::Lines), 1, 0), CHANGED);
    }

    #[test]
    fn moved_label_boundaries_are_removed_and_added() {
        // Two regions split at x = 2 in the golden, at x = 3 in the output.
        let labels = |split: usize| Image::from_fn(6, 2, 1, move |x, _, _| if x < split { 0.2 } else { 0.6 });
        let d = two_colour_diff(&labels(3), &labels(2), Marks::Boundaries);
        assert_eq!(px(&d, 1, 0), REMOVED);
        assert_eq!(px(&d, 2, 0), ADDED);
        assert_eq!(px(&d, 5, 0), faded(0.6));
        // A region renumbered without moving: changed, not removed or added.
        let d = two_colour_diff(&Image::filled(2, 2, 1, 0.3), &Image::filled(2, 2, 1, 0.4), Marks::Boundaries);
        assert_eq!(px(&d, 0, 0), CHANGED);
    }

    #[test]
    fn sizes_differ_and_malformed_images_draw_without_panicking() {
        let d = two_colour_diff(&Image::filled(2, 1, 1, 0.0), &Image::filled(1, 2, 1, 1.0), Marks::Lines);
        assert_eq!((d.width, d.height), (2, 2));
        assert_eq!(px(&d, 1, 0), ADDED);
        assert_eq!(px(&d, 1, 1), [0.0; 3]);
        let broken = Image { width: 3, height: 3, channels: 1, data: vec![0.0; 2] };
        let d = two_colour_diff(&broken, &line_at(0), Marks::Boundaries);
        assert_eq!((d.width, d.height), (6, 4));
        assert!(!is_line_art(&broken));
    }

    #[test]
    fn line_art_is_nearly_binary() {
        assert!(is_line_art(&line_at(2)));
        let mut soft = line_at(2);
        soft.set(3, 0, 0, 0.5); // one grey pixel of 24: still line art
        assert!(is_line_art(&soft));
        assert!(!is_line_art(&Image::from_fn(8, 8, 1, |x, y, _| (x + y) as f32 / 14.0)));
        assert!(!is_line_art(&Image::new(0, 0, 1)));
    }
}
