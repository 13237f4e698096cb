//! The tracer and filter core. Knows nothing of gRPC or files.
//!
//! One file per concept: `camera`, `sampler`, `geometry` (triangles and BVH; `wide_bvh` its traversal), `texture`,
//! `material`, `light`, `scene` (the compiled scene), `integrator` (radiance along a path),
//! `film` (per-pixel estimates), `strategy` (what a pass does) with its implementations
//! (`uniform`), and `progressive` (the pass loop and halt conditions).
pub mod aaf;
pub mod camera;
pub mod film;
pub mod filter;
pub mod frame;
pub mod frame_basis;
pub mod gbuffer;
pub mod geometry;
pub mod indirect;
pub mod integrator;
pub mod light;
pub mod material;
pub mod progressive;
pub mod sampler;
pub mod scene;
pub mod strategy;
#[cfg(test)]
pub mod test_rng;
pub mod texture;
pub mod uniform;
pub mod wide_bvh;
