//! wedge: a gRPC render-and-denoise service. `render` is the tracer and filter core, `scene`
//! the scene schema and its compiler, `job` the request-to-job mapping shared by the CLI and
//! the server, `output` the image files, `server` the thin tonic layer.
pub mod bench;
pub mod cli;
pub mod client;
pub mod job;
pub mod output;
pub mod render;
pub mod scene;
pub mod server;

pub mod proto {
    tonic::include_proto!("wedge.v1");
    /// The encoded descriptor set of proto/, for reflection and canonical-JSON scene files.
    pub const FILE_DESCRIPTOR_SET: &[u8] = tonic::include_file_descriptor_set!("wedge_descriptor");
}
