//! Options of `uniform`'s path tracer (group `uniform`).
use crate::pipeline::settings::{Settable, Setting, Value};

/// The most paths one sample splits into: the limit of `uniform.max_splits`.
pub const MAX_SPLITS: usize = 16;

/// Options of `uniform`'s path tracer (splitting at the first hit: `pipeline::splitting`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UniformOptions {
    /// The most paths a camera sample splits into at its first hit; 1 turns splitting off (one
    /// path per sample, as a plain path tracer).
    pub max_splits: u32,
}

impl Default for UniformOptions {
    fn default() -> Self {
        UniformOptions { max_splits: MAX_SPLITS as u32 }
    }
}

impl Settable for UniformOptions {
    const GROUP: &'static str = "uniform";

    fn settings() -> &'static [Setting] {
        const SETTINGS: &[Setting] = &[Setting::integer("max_splits", 1, MAX_SPLITS as u64)];
        SETTINGS
    }

    fn apply(&mut self, name: &str, v: Value) {
        match name {
            "max_splits" => self.max_splits = v.integer() as u32,
            _ => unreachable!("{name}: not a setting of uniform"),
        }
    }
}
