//! Maps taken from images: a scalar from one channel or luminance, a direction from two.

use super::error::{check_size, MapError};
use super::render::{map_values, normalize_field};
use crate::raster::Image;

/// Which value of a multi-channel image becomes the scalar map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelSel {
    /// Rec. 709 luma of channels 0..3 (applied to the stored values as they are, linear or
    /// not). 1-channel images pass through; 2-channel images use channel 0, since their
    /// second channel is usually alpha.
    Luminance,
    /// One channel, by index.
    Index(usize),
}

/// Rec. 709 luma weights.
const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Extracts a 1-channel map from `img`.
pub fn from_image_scalar(img: &Image, channel: ChannelSel) -> Result<Image, MapError> {
    check_size(img.width, img.height, 1)?;
    let index = match channel {
        ChannelSel::Index(i) => i,
        ChannelSel::Luminance if img.channels >= 3 => return Ok(luminance(img)),
        ChannelSel::Luminance => 0,
    };
    if index >= img.channels {
        return Err(MapError::Channel { wanted: index, channels: img.channels });
    }
    Ok(Image { width: img.width, height: img.height, channels: 1, data: img.plane(index).to_vec() })
}

fn luminance(img: &Image) -> Image {
    let (r, g, b) = (img.plane(0), img.plane(1), img.plane(2));
    let data = r.iter().zip(g).zip(b).map(|((r, g), b)| LUMA[0] * r + LUMA[1] * g + LUMA[2] * b).collect();
    Image { width: img.width, height: img.height, channels: 1, data }
}

/// Reads an orientation field from channels 0 and 1 (e.g. a painted flow map or the xy of
/// a normal map): each is mapped from `[0, 1]` to `[-1, 1]` and the pair normalised to unit
/// length; (near-)zero vectors become `(1, 0)`.
pub fn from_image_vector(img: &Image) -> Result<Image, MapError> {
    check_size(img.width, img.height, 2)?;
    if img.channels < 2 {
        return Err(MapError::Channel { wanted: 1, channels: img.channels });
    }
    let two =
        Image { width: img.width, height: img.height, channels: 2, data: img.data[..2 * img.plane_len()].to_vec() };
    let mut field = map_values(&two, |v| 2.0 * v - 1.0);
    normalize_field(&mut field);
    Ok(field)
}

#[cfg(test)]
mod tests {
    use super::super::fields::assert_unit_field;
    use super::*;

    fn rgb(values: [f32; 3]) -> Image {
        Image::from_fn(3, 2, 3, |_, _, c| values[c])
    }

    #[test]
    fn luminance_uses_rec709() {
        let img = from_image_scalar(&rgb([1.0, 0.0, 0.0]), ChannelSel::Luminance).unwrap();
        assert_eq!(img.channels, 1);
        assert!((img.get(1, 1, 0) - 0.2126).abs() < 1e-6);
        let white = from_image_scalar(&rgb([1.0; 3]), ChannelSel::Luminance).unwrap();
        assert!((white.get(0, 0, 0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn luminance_passes_one_and_two_channel_images() {
        let one = Image::from_fn(4, 4, 1, |x, y, _| (x + y) as f32 / 8.0);
        assert_eq!(from_image_scalar(&one, ChannelSel::Luminance).unwrap(), one);
        let two = Image::from_fn(4, 4, 2, |x, _, c| if c == 0 { x as f32 } else { 9.0 });
        let l = from_image_scalar(&two, ChannelSel::Luminance).unwrap();
        assert_eq!(l.data, two.plane(0));
    }

    #[test]
    fn index_selects_and_rejects_out_of_range() {
        let img = rgb([0.1, 0.2, 0.3]);
        let g = from_image_scalar(&img, ChannelSel::Index(2)).unwrap();
        assert!(g.data.iter().all(|&v| v == 0.3));
        assert_eq!(from_image_scalar(&img, ChannelSel::Index(3)), Err(MapError::Channel { wanted: 3, channels: 3 }));
    }

    #[test]
    fn vector_maps_and_normalises() {
        // (1, 0.5) -> (1, 0) ; (0.5, 0.5) -> zero -> (1, 0) ; (0.5, 0) -> (0, -1).
        let img = Image::from_fn(3, 1, 3, |x, _, c| match (x, c) {
            (0, 0) => 1.0,
            (2, 1) => 0.0,
            (_, 2) => 0.7,
            _ => 0.5,
        });
        let f = from_image_vector(&img).unwrap();
        assert_unit_field(&f);
        assert_eq!((f.get(0, 0, 0), f.get(0, 0, 1)), (1.0, 0.0));
        assert_eq!((f.get(1, 0, 0), f.get(1, 0, 1)), (1.0, 0.0));
        assert_eq!((f.get(2, 0, 0), f.get(2, 0, 1)), (0.0, -1.0));
        assert!(from_image_vector(&Image::new(2, 2, 1)).is_err());
    }
}
