//! The progressive pipeline every method runs in. Bottom up: `job` (the leaf every layer shares),
//! `frame` and `film` (what a pass produces and accumulates), `strategy` (the per-pass trait),
//! `settings` (method options' names and limits) and `named_options` (`RenderJob::set`), then, above the methods, `registry` (the one table of methods) and `progressive` (the pass
//! loop, the shared G-buffer and the halt conditions).
pub mod allocation;
pub mod film;
pub mod frame;
pub mod job;
pub mod named_options;
pub mod noise;
pub mod progressive;
pub mod registry;
pub mod settings;
pub mod splitting;
pub mod strategy;
