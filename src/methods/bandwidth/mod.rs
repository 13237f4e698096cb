//! Bandwidth prediction and multiresolution shading (Bagher, Soler, Subr, Belcour, Holzschuch
//! 2012): per pixel, the local bandwidth of the reflected light field from the bandwidths of
//! the environment, the BRDF and the texture carried through the surface's geometry to the eye
//! (`vector`); the bandwidths of environment maps (`illumination`), BRDF lobes (`brdf`) and
//! textures (`texture`) from wavelets (`wavelet`); what they decide, per pixel and per pyramid level (`levels`),
//! and how unshaded pixels take their parents' values (`upsample`); the surface curvature the
//! shear `C_c` needs, measured on the G-buffer (`curvature`).
//!
//! Being built: the analysis is here and tested; the strategy that shades with it (levels,
//! sample counts, coarse-to-fine shading) is not in the registry yet (docs/methods.md §4).
pub mod brdf;
pub mod curvature;
pub mod illumination;
pub mod levels;
pub mod texture;
pub mod upsample;
pub mod vector;
pub mod wavelet;
