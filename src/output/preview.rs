//! The 8-bit sRGB preview PNG. Like pbrt's `imgtool convert` default: clamp to [0, 1] and apply
//! the sRGB transfer curve, nothing else, so the preview shows exactly the radiance the EXR holds
//! (no exposure or tone curve that could hide noise or bias in the comparisons).
use std::path::Path;

use image::{ImageFormat, RgbImage};

use super::OutputError;
use crate::pipeline::frame::Frame;

/// The exact piecewise sRGB OETF (IEC 61966-2-1) of a linear value in [0, 1].
fn srgb_oetf(linear: f32) -> f32 {
    if linear <= 0.003_130_8 {
        12.92 * linear
    } else {
        1.055 * linear.powf(1.0 / 2.4) - 0.055
    }
}

/// Linear RGB to 8-bit sRGB: clamp, OETF, round to nearest. A pixel with any non-finite
/// component is black: a NaN or infinite sample is a bug to see, and showing the finite
/// components alone would give it a plausible-looking colour instead.
pub fn tonemap_srgb8(rgb: [f32; 3]) -> [u8; 3] {
    if !rgb.iter().all(|c| c.is_finite()) {
        return [0; 3];
    }
    // After the clamp the product is in [0, 255.5], so the cast cannot saturate.
    rgb.map(|c| (srgb_oetf(c.clamp(0.0, 1.0)) * 255.0 + 0.5) as u8)
}

/// Writes `frame.color` tone-mapped as an 8-bit sRGB PNG.
pub fn write_preview_png(path: &Path, frame: &Frame) -> Result<(), OutputError> {
    if frame.color.len() != frame.pixel_count() {
        return Err(OutputError::InvalidInput {
            path: path.to_path_buf(),
            reason: format!("colour has {} pixels, expected {}x{}", frame.color.len(), frame.width, frame.height),
        });
    }
    let bytes = frame.color.iter().flat_map(|&c| tonemap_srgb8(c)).collect();
    let image = RgbImage::from_raw(frame.width, frame.height, bytes)
        .expect("buffer length checked against the frame size above");
    save_png(path, &image)
}

/// Saves an RGB image as PNG, mapping errors to `OutputError` with the path. An empty image is
/// an `InvalidInput` error here rather than whatever the encoder would make of it.
pub(super) fn save_png(path: &Path, image: &RgbImage) -> Result<(), OutputError> {
    if image.width() == 0 || image.height() == 0 {
        return Err(OutputError::InvalidInput {
            path: path.to_path_buf(),
            reason: format!("empty {}x{} image", image.width(), image.height()),
        });
    }
    image.save_with_format(path, ImageFormat::Png).map_err(|source| match source {
        image::ImageError::IoError(source) => OutputError::Io { path: path.to_path_buf(), source },
        source => OutputError::Png { path: path.to_path_buf(), source },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::test_util::TempDir;

    #[test]
    fn oetf_endpoints_and_midpoint() {
        assert_eq!(tonemap_srgb8([0.0; 3]), [0; 3]);
        assert_eq!(tonemap_srgb8([1.0; 3]), [255; 3]);
        // 0.5 -> 1.055 * 0.5^(1/2.4) - 0.055 = 0.7354 -> 187.5 -> 188.
        assert_eq!(tonemap_srgb8([0.5; 3]), [188; 3]);
        assert_eq!(tonemap_srgb8([0.0, 0.5, 1.0]), [0, 188, 255]);
    }

    #[test]
    fn oetf_is_continuous_at_the_knee() {
        let knee = 0.003_130_8_f32;
        let linear_side = 12.92 * knee;
        let power_side = 1.055 * knee.powf(1.0 / 2.4) - 0.055;
        assert!((linear_side - power_side).abs() < 1e-6);
        assert!((srgb_oetf(knee) - 0.040_45).abs() < 1e-5);
        // Just above the knee the power branch is used and agrees.
        assert!((srgb_oetf(knee * 1.0001) - linear_side).abs() < 1e-5);
        // 0.04045 * 255 = 10.3.
        assert_eq!(tonemap_srgb8([knee; 3]), [10; 3]);
    }

    #[test]
    fn oetf_is_monotone() {
        let mut previous = 0;
        for i in 0..=4096 {
            let [v, _, _] = tonemap_srgb8([i as f32 / 4096.0, 0.0, 0.0]);
            assert!(v >= previous);
            previous = v;
        }
        assert_eq!(previous, 255);
    }

    #[test]
    fn out_of_range_values_clamp() {
        assert_eq!(tonemap_srgb8([-1.0, 2.0, 1e30]), [0, 255, 255]);
        assert_eq!(tonemap_srgb8([f32::MAX, f32::MIN, -0.0]), [255, 0, 0]);
    }

    #[test]
    fn non_finite_pixels_are_black() {
        assert_eq!(tonemap_srgb8([f32::NAN; 3]), [0; 3]);
        assert_eq!(tonemap_srgb8([f32::INFINITY; 3]), [0; 3]);
        assert_eq!(tonemap_srgb8([1.0, f32::NEG_INFINITY, 1.0]), [0; 3]);
        assert_eq!(tonemap_srgb8([0.5, 0.5, f32::NAN]), [0; 3]);
    }

    #[test]
    fn preview_png_has_frame_size_and_pixels() {
        let dir = TempDir::new("preview");
        let path = dir.path().join("p.png");
        let frame = Frame {
            width: 3,
            height: 2,
            color: vec![[0.0; 3], [1.0; 3], [0.5; 3], [f32::NAN; 3], [2.0, -1.0, 0.0], [0.0, 0.5, 1.0]],
            spp: vec![1.0; 6],
            ..Frame::default()
        };
        write_preview_png(&path, &frame).unwrap();
        let image = image::open(&path).unwrap().into_rgb8();
        assert_eq!(image.dimensions(), (3, 2));
        let pixels: Vec<[u8; 3]> = image.pixels().map(|p| p.0).collect();
        assert_eq!(pixels, [[0; 3], [255; 3], [188; 3], [0; 3], [255, 0, 0], [0, 188, 255]]);
    }

    #[test]
    fn preview_rejects_wrong_buffer_length() {
        let dir = TempDir::new("preview_bad");
        let path = dir.path().join("p.png");
        let frame = Frame { width: 2, height: 2, color: vec![[0.0; 3]; 3], ..Frame::default() };
        let error = write_preview_png(&path, &frame).unwrap_err();
        assert!(matches!(error, OutputError::InvalidInput { .. }));
        assert!(error.to_string().contains("p.png"), "{error}");
        assert!(!path.exists());
    }
}
