//! Specular lobe-aware filtering (Tokuyoshi 2015, "Specular Lobe-Aware Filtering and
//! Upsampling for Interactive Indirect Illumination"): cross-bilateral weights that compare two
//! pixels' reflection lobes, as spherical Gaussians built from the G-buffer, instead of their
//! normals. `sg` holds the SG algebra, `lobe` the per-pixel lobes (App. B, D), `weights` the
//! weights (Eqs. 3, 4, 11, 12; App. A), `asg` the optional anisotropic lobes and their weight
//! (Eq. 13), `filter` the cross-bilateral gather (Eq. 1), `upsample` the joint upsampling and
//! the re-render test of Fig. 16.
pub mod asg;
pub mod filter;
pub mod lobe;
pub mod options;
pub mod packed;
pub mod sg;
pub mod upsample;
pub mod weights;

#[cfg(test)]
mod render_tests;
#[cfg(test)]
mod tests;
