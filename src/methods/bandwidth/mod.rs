//! Bandwidth prediction and multiresolution shading (Bagher, Soler, Subr, Belcour, Holzschuch
//! 2012): per pixel, the local bandwidth of the reflected light field from the bandwidths of
//! the environment, the BRDF and the texture carried through the surface's geometry to the eye
//! (`vector`); the bandwidths of environment maps (`illumination`), BRDF lobes (`brdf`) and
//! textures (`texture`) from wavelets (`wavelet`); what they decide, per pixel and per
//! pyramid level (`levels`), and how unshaded pixels take their parents' values (`upsample`);
//! the surface curvature the shear `C_c` needs, measured on the G-buffer (`curvature`).
//!
//! The method `bandwidth` puts them to work (`shading`): the per-pixel analysis (`analysis`),
//! coarse-to-fine shading on nested grids (`grid`) and the camera samples that add what the
//! paper leaves out, shadows, bounces and other lights (`sample`), more of them where they
//! vary most (`counts`). docs/methods.md §4.
pub mod analysis;
pub mod brdf;
pub mod counts;
pub mod curvature;
pub mod grid;
pub mod illumination;
pub mod levels;
pub mod options;
#[cfg(test)]
mod render_tests;
pub mod sample;
pub mod shading;
pub mod texture;
pub mod upsample;
pub mod vector;
pub mod wavelet;

pub use shading::BandwidthShading;
