//! FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"), the
//! perceptual error next to RMSE in `wedge bench`, through NVIDIA's reference implementation
//! (the `nv-flip` crate). LDR-FLIP of both images as a viewer sees them: clamped to [0, 1] and
//! encoded as 8-bit sRGB, at FLIP's default 67 pixels per degree (a 0.7 m viewing distance from
//! a 3840-pixel, 0.7 m wide monitor), as `bench/race.py` computes it with `flip-evaluator`.
//! FLIP's error is in [0, 1] per pixel; the mean is the single number its authors recommend.
use crate::pipeline::frame::Frame;
use std::path::Path;

/// `frame`'s colour as 8-bit sRGB, clamped to [0, 1] (row-major RGB).
pub fn srgb8(frame: &Frame) -> Vec<u8> {
    frame.color.iter().flat_map(|c| c.map(|v| (255.0 * linear_to_srgb(v) + 0.5) as u8)).collect()
}

fn linear_to_srgb(v: f32) -> f32 {
    let c = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// FLIP's per-pixel error map of `test` against `reference` (same size).
pub fn error_map(test: &Frame, reference: &Frame) -> nv_flip::FlipImageFloat {
    assert_eq!((test.width, test.height), (reference.width, reference.height), "FLIP compares equal sizes");
    let image = |f: &Frame| nv_flip::FlipImageRgb8::with_data(f.width, f.height, &srgb8(f));
    nv_flip::flip(image(reference), image(test), nv_flip::DEFAULT_PIXELS_PER_DEGREE)
}

/// The mean FLIP error of `test` against `reference`.
pub fn mean_flip(test: &Frame, reference: &Frame) -> f64 {
    mean_where(test, reference, |_| true)
}

/// The mean FLIP error over the pixels `keep` marks (FLIP itself sees the whole image, as its
/// spatial filters need the neighbours).
pub fn mean_flip_kept(test: &Frame, reference: &Frame, keep: &[bool]) -> f64 {
    mean_where(test, reference, |p| keep[p])
}

fn mean_where(test: &Frame, reference: &Frame, keep: impl Fn(usize) -> bool) -> f64 {
    let map = error_map(test, reference).to_vec();
    let (sum, n) = map
        .iter()
        .enumerate()
        .filter(|(p, _)| keep(*p))
        .fold((0.0, 0usize), |(s, n), (_, &v)| (s + f64::from(v), n + 1));
    sum / n.max(1) as f64
}

/// Writes FLIP's error map of `test` against `reference` as a PNG in FLIP's magma colours
/// (black: no visible difference; yellow-white: the largest).
pub fn write_error_png(test: &Frame, reference: &Frame, path: &Path) -> anyhow::Result<()> {
    let coloured = error_map(test, reference).apply_color_lut(&nv_flip::magma_lut());
    let image = image::RgbImage::from_raw(coloured.width(), coloured.height(), coloured.to_vec())
        .ok_or_else(|| anyhow::anyhow!("FLIP map of the wrong size"))?;
    image.save(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> Frame {
        let color = (0..h).flat_map(|y| (0..w).map(move |x| (x, y))).map(|(x, y)| [f(x, y); 3]).collect();
        Frame { width: w, height: h, color, ..Default::default() }
    }

    #[test]
    fn identical_images_have_no_error_and_noise_has_more_the_more_there_is() {
        let reference = frame(64, 48, |x, y| 0.1 + 0.6 * (x + y) as f32 / 112.0);
        assert_eq!(mean_flip(&reference, &reference), 0.0);
        // A fixed pseudo-random pattern at three amplitudes.
        let noise =
            |x: u32, y: u32| ((x.wrapping_mul(2_654_435_761) ^ y.wrapping_mul(40_503)) % 1000) as f32 / 1000.0 - 0.5;
        let errors: Vec<f64> = [0.02f32, 0.1, 0.4]
            .iter()
            .map(|&a| {
                mean_flip(&frame(64, 48, |x, y| 0.1 + 0.6 * (x + y) as f32 / 112.0 + a * noise(x, y)), &reference)
            })
            .collect();
        assert!(errors[0] > 0.0 && errors[0] < errors[1] && errors[1] < errors[2], "{errors:?}");
        assert!(errors[2] < 1.0);
        // Values beyond [0, 1] and NaN are clamped as a display would, never a NaN error.
        let wild = frame(64, 48, |x, _| if x % 2 == 0 { f32::NAN } else { 1e9 });
        assert!(mean_flip(&wild, &reference).is_finite());
    }

    #[test]
    fn the_srgb_encoding_is_the_standard_curve() {
        let f = frame(4, 1, |x, _| [0.0, 0.001, 0.5, 1.0][x as usize]);
        assert_eq!(srgb8(&f).iter().step_by(3).copied().collect::<Vec<_>>(), [0, 3, 188, 255]);
    }

    #[test]
    fn the_error_map_is_written_as_a_png() {
        let dir = std::env::temp_dir().join(format!("wedge-flip-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (a, b) = (frame(16, 8, |x, _| x as f32 / 16.0), frame(16, 8, |_, _| 0.5));
        let path = dir.join("flip.png");
        write_error_png(&a, &b, &path).unwrap();
        let png = image::open(&path).unwrap().to_rgb8();
        assert_eq!(png.dimensions(), (16, 8));
        // The error is largest where the images differ most (the ends of the ramp), smallest
        // where they agree (the middle).
        let lum = |x: u32| png.get_pixel(x, 4).0.iter().map(|&c| u32::from(c)).sum::<u32>();
        assert!(lum(0) > lum(8) && lum(15) > lum(8), "{} {} {}", lum(0), lum(8), lum(15));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
