//! wedge: a gRPC render-and-denoise service. Layers, bottom up (each imports only those below
//! it; `tests/layers.rs` checks): `render`, the tracer and filter core; `methods`' options and
//! `pipeline::job`, the leaf every render layer shares; `pipeline::{frame, film, strategy}`;
//! `methods`, one folder per paper; `pipeline::{registry, progressive}`; `scene`, the scene
//! schema and its compiler; `api`, the request-to-job mapping and the wire codec; `runner`, the
//! render task model; then the front ends `server`, `client`, `cli`, `bench` and `output`.
pub mod api;
pub mod bench;
pub mod cli;
pub mod client;
pub mod methods;
pub mod output;
pub mod pipeline;
pub mod render;
pub mod runner;
pub mod scene;
pub mod server;

// Generated code: a session's first message (a whole render request) is larger than the
// others, and boxing it would only change prost's API.
#[allow(clippy::large_enum_variant)]
pub mod proto {
    tonic::include_proto!("wedge.v1");
    /// The encoded descriptor set of proto/, for reflection and canonical-JSON scene files.
    pub const FILE_DESCRIPTOR_SET: &[u8] = tonic::include_file_descriptor_set!("wedge_descriptor");
}
