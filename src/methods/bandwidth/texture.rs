//! The spatial bandwidth of a texture (Bagher et al. 2012, Sec. 2.4: "the same approach" as
//! for maps): the wavelet estimate over an image of the texture, as a frequency in radians per
//! unit of u and v (`2 pi / (2^h texel)`). wedge's textures are constants (bandwidth 0) and
//! checkerboards, whose period (two squares) is rasterised at `texels_per_square` texels per
//! square and analysed as a periodic image: near an edge the estimate is the finest the
//! raster holds (an edge is not band-limited), inside a square it falls to the coarse levels.
//! The raster's resolution is therefore the bandwidth the edges are given; the strategy
//! catches the edges themselves in image space (a pixel whose neighbours differ in albedo is
//! shaded), so by default the raster is coarse (`options`). The strategy turns the estimate
//! into per-unit-length bandwidth with the pixel's uv footprint.
use super::illumination::{angular, WaveletOptions};
use crate::render::texture::Texture;
use glam::Vec2;

/// Raster resolution of one checker square at most (the raster is period^2 texels).
pub const MAX_TEXELS_PER_SQUARE: usize = 256;

#[derive(Clone, Debug, PartialEq)]
pub enum TextureBandwidth {
    /// A constant texture.
    Flat,
    /// A checkerboard of `scale` squares per unit of u and v: the bandwidth per unit of uv at
    /// each texel of one period, `period` x `period` texels.
    Checker { scale: f64, period: usize, nu: Vec<f32> },
}

impl TextureBandwidth {
    pub fn new<T: Copy>(
        texture: &Texture<T>,
        luminance: impl Fn(T) -> f64,
        opts: &WaveletOptions,
        texels_per_square: usize,
    ) -> Self {
        let texels = texels_per_square.clamp(1, MAX_TEXELS_PER_SQUARE);
        match texture {
            Texture::Constant(_) => TextureBandwidth::Flat,
            Texture::Checker { even, odd, scale } => {
                let (a, b) = (luminance(*even), luminance(*odd));
                if a == b || !(*scale > 0.0) || !scale.is_finite() {
                    return TextureBandwidth::Flat;
                }
                let period = 2 * texels;
                let image: Vec<f64> = (0..period * period)
                    .map(|i| if ((i % period) / texels + (i / period) / texels).is_multiple_of(2) { a } else { b })
                    .collect();
                let exponents = opts.exponents(&image, period, period);
                // A texel is 1 / (scale texels) of uv.
                let texel = 1.0 / (*scale as f64 * texels as f64);
                let nu = exponents.iter().map(|&h| angular(h, texel) as f32).collect();
                TextureBandwidth::Checker { scale: *scale as f64, period, nu }
            }
        }
    }

    /// Bandwidth per unit of uv at `uv`.
    pub fn at(&self, uv: Vec2) -> f64 {
        match self {
            TextureBandwidth::Flat => 0.0,
            TextureBandwidth::Checker { scale, period, nu } => {
                // Position within the period of two squares, in texels.
                let texel = |c: f32| {
                    let t = (c as f64 * scale / 2.0).rem_euclid(1.0) * *period as f64;
                    (t as usize).min(period - 1)
                };
                nu[texel(uv.y) * period + texel(uv.x)] as f64
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::bandwidth::wavelet::Basis;

    /// In the amplitude basis: in Appendix A's unit-area basis the squares' coarse coefficients
    /// outweigh their edges', and a square's middle reads as sharp as its edge (tested below).
    fn checker(scale: f32) -> TextureBandwidth {
        let opts = WaveletOptions { basis: Basis::Amplitude, ..WaveletOptions::default() };
        TextureBandwidth::new(&Texture::Checker { even: 0.8f32, odd: 0.2, scale }, |v| v as f64, &opts, 128)
    }

    #[test]
    fn constants_are_flat_and_checker_edges_are_sharp() {
        let opts = WaveletOptions::default();
        assert_eq!(
            TextureBandwidth::new(&Texture::Constant(0.5f32), |v| v as f64, &opts, 128).at(Vec2::new(0.3, 0.7)),
            0.0
        );
        let same =
            TextureBandwidth::new(&Texture::Checker { even: 0.5f32, odd: 0.5, scale: 4.0 }, |v| v as f64, &opts, 128);
        assert_eq!(same, TextureBandwidth::Flat);
        let c = checker(4.0);
        // An edge at u = 0.25 (scale 4: squares a quarter wide): far more bandwidth than the
        // middle of a square.
        let (edge, middle) = (c.at(Vec2::new(0.25, 0.125)), c.at(Vec2::new(0.125, 0.125)));
        assert!(edge > 4.0 * middle, "edge {edge}, middle {middle}");
        // The unit-area basis cannot tell them apart.
        let unit =
            TextureBandwidth::new(&Texture::Checker { even: 0.8f32, odd: 0.2, scale: 4.0 }, |v| v as f64, &opts, 128);
        assert_eq!(unit.at(Vec2::new(0.25, 0.125)), unit.at(Vec2::new(0.125, 0.125)));
    }

    #[test]
    fn the_bandwidth_scales_with_the_checker_and_repeats_with_its_period() {
        let (c4, c8) = (checker(4.0), checker(8.0));
        // Twice as many squares per unit: every frequency doubles at the same place in a square.
        for uv in [Vec2::new(0.25, 0.1), Vec2::new(0.1, 0.1), Vec2::new(0.0, 0.2)] {
            assert!((c8.at(uv / 2.0) - 2.0 * c4.at(uv)).abs() < 1e-3 * c4.at(uv).max(1.0), "{uv}");
            // Periodic over two squares, negative coordinates included.
            assert!((c4.at(uv) - c4.at(uv + Vec2::new(0.5, -1.0))).abs() < 1e-9);
        }
    }
}
