//! False-colour PNGs of scalar maps (spp, filter width), as in the figures of the axis-aligned
//! filtering papers: each value through a colormap on a linear scale from 0 to the map's largest
//! finite value, with a legend strip below saying what the colours mean.
use std::path::Path;

use image::{Rgb, RgbImage};

use super::legend::{Legend, BACKGROUND};
use super::preview::save_png;
use super::OutputError;

/// Viridis rather than the papers' jet/turbo: perceptually uniform and monotone in lightness,
/// so equal steps in spp or width look equal and the map still reads in greyscale print.
const COLORMAP: colorous::Gradient = colorous::VIRIDIS;

/// Colour of NaN and infinite values: black is not in viridis, so they stand out.
const NON_FINITE: Rgb<u8> = Rgb([0, 0, 0]);

/// Writes `values` (row-major, top row first, `width` x `height`) as a false-colour PNG with a
/// legend titled `title`. The canvas is wider than `width` when the legend needs the room.
pub fn write_false_color_png(
    path: &Path,
    values: &[f32],
    width: u32,
    height: u32,
    title: &str,
) -> Result<(), OutputError> {
    // An empty map would still get a legend, which would be a misleading file.
    if values.len() != width as usize * height as usize || values.is_empty() {
        return Err(OutputError::InvalidInput {
            path: path.to_path_buf(),
            reason: format!("{} values for a {width}x{height} map", values.len()),
        });
    }
    save_png(path, &false_color_image(values, width, height, title))
}

/// The image `write_false_color_png` writes: the map, centred, above its legend.
pub(super) fn false_color_image(values: &[f32], width: u32, height: u32, title: &str) -> RgbImage {
    let max = scale_max(values);
    let legend = Legend::new(max, title, width);
    let canvas_width = width.max(legend.min_width());
    let mut canvas = RgbImage::from_pixel(canvas_width, height + legend.height(), BACKGROUND);
    let left = (canvas_width - width) / 2;
    for (i, &value) in values.iter().enumerate() {
        let (x, y) = ((i % width as usize) as u32, (i / width as usize) as u32);
        canvas.put_pixel(left + x, y, map_color(value, max));
    }
    legend.draw(&mut canvas, height, colormap);
    canvas
}

/// The top of the scale: the largest finite value, or 0 if there is none above 0.
fn scale_max(values: &[f32]) -> f32 {
    values.iter().copied().filter(|v| v.is_finite()).fold(0.0, f32::max)
}

/// Colour of `value` on the scale [0, max]; values below 0 get the lowest colour, and so does
/// everything when `max` is 0.
fn map_color(value: f32, max: f32) -> Rgb<u8> {
    if !value.is_finite() {
        return NON_FINITE;
    }
    let t = if max > 0.0 { f64::from(value) / f64::from(max) } else { 0.0 };
    colormap(t)
}

fn colormap(t: f64) -> Rgb<u8> {
    let c = COLORMAP.eval_continuous(t.clamp(0.0, 1.0));
    Rgb([c.r, c.g, c.b])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::test_util::TempDir;

    fn lowest() -> Rgb<u8> {
        colormap(0.0)
    }

    /// The map's own pixels, without the legend or side padding.
    fn map_pixels(image: &RgbImage, width: u32, height: u32) -> Vec<Rgb<u8>> {
        let left = (image.width() - width) / 2;
        (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| *image.get_pixel(left + x, y)).collect()
    }

    #[test]
    fn constant_zero_map_is_uniformly_the_lowest_colour() {
        let image = false_color_image(&[0.0; 12], 4, 3, "spp");
        assert!(map_pixels(&image, 4, 3).iter().all(|&p| p == lowest()));
        // Negative values also clamp to the lowest colour.
        let image = false_color_image(&[-1.0, 0.0], 2, 1, "spp");
        assert!(map_pixels(&image, 2, 1).iter().all(|&p| p == lowest()));
    }

    #[test]
    fn ramp_follows_the_colormap_in_order() {
        let width = 200;
        let ramp: Vec<f32> = (0..width).map(|x| x as f32 * 0.5).collect();
        let max = *ramp.last().unwrap();
        let image = false_color_image(&ramp, width, 1, "spp");
        let pixels = map_pixels(&image, width, 1);
        let table: Vec<Rgb<u8>> = (0..1024).map(|i| colormap(i as f64 / 1023.0)).collect();
        let nearest = |p: Rgb<u8>| {
            let distance = |q: &Rgb<u8>| (0..3).map(|c| (i32::from(p[c]) - i32::from(q[c])).pow(2)).sum::<i32>();
            (0..table.len()).min_by_key(|&i| distance(&table[i])).unwrap()
        };
        let mut previous = 0;
        for (&value, &pixel) in ramp.iter().zip(&pixels) {
            let expected = colorous::VIRIDIS.eval_continuous(f64::from(value / max));
            assert_eq!(pixel.0, [expected.r, expected.g, expected.b], "at {value}");
            let index = nearest(pixel);
            assert!(index >= previous, "colour for {value} goes back along the colormap");
            previous = index;
        }
        assert_eq!(pixels[0], lowest());
        assert_eq!(pixels[width as usize - 1], colormap(1.0));
    }

    #[test]
    fn non_finite_values_are_black_and_do_not_set_the_scale() {
        let values = [f32::NAN, f32::INFINITY, 2.0, 4.0];
        assert_eq!(scale_max(&values), 4.0);
        let image = false_color_image(&values, 4, 1, "spp");
        let pixels = map_pixels(&image, 4, 1);
        assert_eq!(pixels[0], NON_FINITE);
        assert_eq!(pixels[1], NON_FINITE);
        assert_eq!(pixels[2], colormap(0.5));
        assert_eq!(pixels[3], colormap(1.0));
    }

    #[test]
    fn dimensions_include_the_legend() {
        // Small map: the canvas widens to fit the title; the height adds the legend strip.
        let legend = Legend::new(3.0, "filter width (px)", 64);
        let image = false_color_image(&vec![3.0; 64 * 16], 64, 16, "filter width (px)");
        assert!(image.width() > 64);
        assert_eq!(image.width(), legend.min_width());
        assert_eq!(image.height(), 16 + legend.height());
        // Wide map: the canvas keeps the map's width.
        let legend = Legend::new(1.0, "spp", 900);
        let image = false_color_image(&vec![1.0; 900 * 2], 900, 2, "spp");
        assert_eq!(image.dimensions(), (900, 2 + legend.height()));
    }

    #[test]
    fn writes_a_png_of_the_composed_image() {
        let dir = TempDir::new("falsecolor");
        let path = dir.path().join("spp.png");
        let values: Vec<f32> = (0..15).map(|i| i as f32).collect();
        write_false_color_png(&path, &values, 3, 5, "spp").unwrap();
        let written = image::open(&path).unwrap().into_rgb8();
        assert_eq!(written, false_color_image(&values, 3, 5, "spp"));
    }

    #[test]
    fn wrong_value_count_is_an_error_naming_the_file() {
        let dir = TempDir::new("falsecolor_bad");
        let path = dir.path().join("bad.png");
        let error = write_false_color_png(&path, &[1.0; 5], 3, 2, "spp").unwrap_err();
        assert!(matches!(error, OutputError::InvalidInput { .. }));
        assert!(error.to_string().contains("bad.png"), "{error}");
        let error = write_false_color_png(&path, &[], 0, 0, "spp").unwrap_err();
        assert!(matches!(error, OutputError::InvalidInput { .. }));
    }
}
