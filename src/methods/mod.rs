//! The methods, one folder (or file) per paper's method; `pipeline::registry` lists them. Each
//! implements `pipeline::strategy::Strategy` over the core (`render`).
pub mod aaf_indirect;
pub mod aaf_shadows;
pub mod auto;
pub mod bandwidth;
pub mod lobe_aware;
pub mod mode;
pub mod parts;
#[cfg(test)]
pub(crate) mod tests;
pub mod uniform;
