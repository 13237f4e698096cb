//! `wedge serve`: the gRPC server with the limits given on the command line.
use super::ServeArgs;
use crate::api::request::Limits;
use crate::server::{serve, shutdown_signal, ServerConfig};

pub fn run(a: ServeArgs) -> anyhow::Result<()> {
    let config = ServerConfig {
        addr: a.addr,
        limits: Limits {
            max_pixels: a.max_pixels,
            max_triangles: a.max_triangles,
            max_passes: a.max_passes,
            max_mean_spp: a.max_spp,
            max_time_budget_seconds: a.max_time,
            mesh_root: None,
        },
        max_concurrent_renders: a.max_concurrent.max(1),
        max_chunk_bytes: a.max_chunk_bytes,
        max_request_bytes: a.max_request_bytes,
        shutdown_grace: std::time::Duration::try_from_secs_f64(a.shutdown_grace.max(0.0))
            .map_err(|e| anyhow::anyhow!("--shutdown-grace {}: {e}", a.shutdown_grace))?,
    };
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    runtime.block_on(serve(config, shutdown_signal()))
}
