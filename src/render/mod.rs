//! The tracer and filter core. Knows nothing of gRPC, files, jobs or methods: everything here
//! imports only within `render`.
//!
//! One file per concept: `camera` (the view; `camera_samples`, a pixel's camera rays a packet
//! at a time), `sampler`, `geometry` (triangles and BVH;
//! `wide_bvh` its traversal), `texture`, `material`, `light` (with `environment` and its `distribution`, and `far_rule`, a Gaussian light's quadrature), `scene` (the compiled scene, no
//! camera), `integrator` (radiance along a path), `gbuffer` (one primary hit per pixel), `aovs` (denoiser inputs) and
//! `filter` (the G-buffer-guided Gaussian gather the methods filter with); `huge_pages`
//! allocates large arrays.
pub mod aovs;
pub mod camera;
pub mod camera_samples;
pub mod distribution;
pub mod environment;
pub mod far_rule;
pub mod fast_math;
pub mod filter;
pub mod frame_basis;
pub mod gbuffer;
pub mod geometry;
pub mod huge_pages;
pub mod integrator;
pub mod light;
pub mod material;
pub mod mis;
pub mod sampler;
pub mod scene;
pub mod sky;
#[cfg(test)]
pub mod test_rng;
pub mod texture;
pub mod wide_bvh;
