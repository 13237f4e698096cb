//! The tracer and filter core. Knows nothing of gRPC or files.
pub mod frame;
pub mod progressive;
pub mod scene;
