//! The command line: thin front ends over the library (`api`, `pipeline`, `client`, `output`).
use clap::{Args, Parser, Subcommand};
use std::net::SocketAddr;
use std::path::PathBuf;

pub mod bench;
mod client_cmd;
mod render_cmd;
mod request;
mod serve_cmd;

#[derive(Parser, Debug)]
#[command(
    name = "wedge",
    version,
    about = "Progressive CPU path tracing with adaptive sampling and filtering, over gRPC"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Run the gRPC server.
    Serve(ServeArgs),
    /// Render a scene in this process and write images.
    Render(RenderArgs),
    /// Render a scene on a server and write the same images.
    Client(ClientArgs),
    /// List the built-in scenes.
    Scenes,
    /// List the methods (the first is the default).
    Methods,
    /// Benchmarks: error against time per method, ray and path throughput, first-frame latency.
    Bench(bench::BenchArgs),
}

#[derive(Args, Debug)]
pub struct ServeArgs {
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1:50051")]
    pub addr: SocketAddr,
    /// Renders allowed at once; more get RESOURCE_EXHAUSTED.
    #[arg(long, default_value_t = 2)]
    pub max_concurrent: usize,
    /// Largest image (width x height) a request may ask for.
    #[arg(long, default_value_t = 4096 * 4096)]
    pub max_pixels: u64,
    /// Most triangles a scene may have.
    #[arg(long, default_value_t = 5_000_000)]
    pub max_triangles: u64,
    /// Most texels an environment map (inline, or a baked sky) may have.
    #[arg(long, default_value_t = crate::scene::DEFAULT_MAX_ENVIRONMENT_TEXELS)]
    pub max_environment_texels: u64,
    /// Most passes a render may run.
    #[arg(long, default_value_t = 64)]
    pub max_passes: u32,
    /// Most mean samples per pixel a render may ask for.
    #[arg(long, default_value_t = 65536.0)]
    pub max_spp: f64,
    /// Longest time budget (seconds) a render may ask for.
    #[arg(long, default_value_t = 3600.0)]
    pub max_time: f64,
    /// Largest streamed chunk in bytes (clients' default receive limit is 4 MiB).
    #[arg(long, default_value_t = 1 << 20)]
    pub max_chunk_bytes: usize,
    /// Largest request in bytes; larger ones get RESOURCE_EXHAUSTED. The default takes an inline
    /// mesh of a million triangles; a render's peak memory is about 20x its request.
    #[arg(long, default_value_t = crate::server::DEFAULT_MAX_REQUEST_BYTES)]
    pub max_request_bytes: usize,
    /// Seconds in-flight calls may run on after SIGINT/SIGTERM; then every stream still open
    /// (renders, health watches) ends with UNAVAILABLE and the process exits.
    #[arg(long, default_value_t = 10.0)]
    pub shutdown_grace: f64,
    /// Seconds a render may wait for a client that has stopped reading before it is cancelled
    /// with DEADLINE_EXCEEDED and its slot freed.
    #[arg(long, default_value_t = 30.0)]
    pub stall_timeout: f64,
    /// TLS certificate chain (PEM); with --tls-key, the server speaks only TLS.
    #[arg(long, requires = "tls_key")]
    pub tls_cert: Option<PathBuf>,
    /// TLS private key (PEM) for --tls-cert.
    #[arg(long, requires = "tls_cert")]
    pub tls_key: Option<PathBuf>,
    /// Bearer tokens, one per line, required on every call but health (the WEDGE_TOKEN
    /// environment variable adds one more).
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    /// Serve on an address other than loopback without TLS or a token.
    #[arg(long)]
    pub insecure: bool,
    /// Do not serve gRPC server reflection.
    #[arg(long)]
    pub no_reflection: bool,
    /// Also serve the browser viewer at http://ADDR/ and gRPC-web (HTTP/1.1) on the same port.
    #[arg(long)]
    pub web: bool,
    /// Changes a WatchSession session may have queued by UpdateSession and not yet read; more
    /// get RESOURCE_EXHAUSTED.
    #[arg(long, default_value_t = crate::server::web_sessions::DEFAULT_QUEUED_UPDATES)]
    pub web_session_queue: usize,
    /// Seconds after which a connection is asked to close once its calls end (clients then
    /// reconnect and rebalance across replicas); 0: never.
    #[arg(long, default_value_t = 300.0)]
    pub max_connection_age: f64,
    /// Also serve grpc.health.v1 alone, plaintext and without tokens, on this address (for
    /// Kubernetes' native gRPC probes, which speak neither TLS nor tokens).
    #[arg(long)]
    pub health_addr: Option<SocketAddr>,
    /// Seconds a session may go without a message from its client before it is ended.
    #[arg(long, default_value_t = 300.0)]
    pub session_idle_timeout: f64,
    /// Bytes of scenes the PutScene store keeps (least recently used ones are evicted).
    #[arg(long, default_value_t = 256 << 20)]
    pub scene_cache_bytes: u64,
    /// Triangles of scenes the PutScene store keeps (each under the ~470 bytes a triangle costs at
    /// the compile's peak).
    #[arg(long, default_value_t = 2_000_000)]
    pub scene_cache_triangles: u64,
    /// Serve Prometheus metrics at http://ADDR/metrics (off by default).
    #[arg(long)]
    pub metrics_addr: Option<SocketAddr>,
}

/// What to render and how: shared by `render` and `client`.
#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    /// A scene file (canonical protobuf JSON) or the name of a built-in scene.
    pub scene: String,
    /// Directory for the output images.
    #[arg(long, default_value = "out")]
    pub out: PathBuf,
    #[arg(long)]
    pub width: Option<u32>,
    #[arg(long)]
    pub height: Option<u32>,
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Sampling and filtering method of each pass: auto (the default), aaf, uniform, adaptive,
    /// uniform-filtered, lobe-aware, normal-aware, bandwidth (`wedge methods` describes them).
    #[arg(long)]
    pub method: Option<String>,
    /// Stop at this mean samples per pixel.
    #[arg(long)]
    pub max_spp: Option<f32>,
    /// Stop after this many passes.
    #[arg(long)]
    pub max_passes: Option<u32>,
    /// Stop after this many seconds.
    #[arg(long)]
    pub time: Option<f32>,
    /// Halt once the render's own estimate of its relative RMSE (RMSE over the image's mean)
    /// is at most this, e.g. 0.02. With no halt option here or in the scene file: 0.01 within
    /// 20 seconds.
    #[arg(long)]
    pub target_error: Option<f32>,
    /// Indirect bounces (0: direct light only).
    #[arg(long)]
    pub bounces: Option<u32>,
    /// Samples per pixel of the first pass (uniform method).
    #[arg(long)]
    pub initial_spp: Option<u32>,
    /// Shade every sample at its pixel's centre (no antialiasing), as the AAF papers do.
    #[arg(long)]
    pub pixel_centers: bool,
    /// lobe-aware and normal-aware: trace indirect light at every N-th pixel (2: half
    /// resolution, 4: quarter; at most 8) and upsample it (Tokuyoshi 2015, Sec. 5).
    #[arg(long)]
    pub upsample: Option<u32>,
    /// Render ambient occlusion (the open fraction of each visible point's hemisphere)
    /// instead of light.
    #[arg(long)]
    pub ao: bool,
    /// With --ao: occluders farther than this (scene units) do not count (default: no limit).
    #[arg(long, requires = "ao")]
    pub ao_distance: Option<f32>,
    /// Also write every N-th pass (the final frame is always written).
    #[arg(long)]
    pub every: Option<u32>,
    /// Leave timings out of the EXR header, so the same render gives the same bytes.
    #[arg(long)]
    pub reproducible: bool,
    /// Also write the denoiser inputs into the EXR: first-hit albedo (`albedo.R/G/B`), shading
    /// normal (`normal.X/Y/Z`) and depth (`depth.Z`), for OIDN or another denoiser.
    #[arg(long)]
    pub aovs: bool,
    /// Directory that mesh files named by a scene file must lie in (default: the scene's
    /// directory).
    #[arg(long)]
    pub mesh_root: Option<PathBuf>,
    /// Set a method option by name, GROUP.NAME=VALUE (repeatable; groups `auto`, `bandwidth`,
    /// `lobe`, `aaf`, `indirect` and `uniform`, e.g. `auto.narrow_scale=0.25`), for experiments; `wedge render` only (a
    /// server takes no options beyond its request's).
    #[arg(long = "set", value_name = "GROUP.NAME=VALUE")]
    pub settings: Vec<String>,
}

#[derive(Args, Debug)]
pub struct ClientArgs {
    /// Server address.
    #[arg(long, default_value = "http://127.0.0.1:50051")]
    pub addr: String,
    /// CA certificate (PEM) to trust for an https:// server (default: the public web roots).
    #[arg(long)]
    pub tls_ca: Option<PathBuf>,
    /// File whose first token is sent as `authorization: Bearer` (default: WEDGE_TOKEN).
    #[arg(long)]
    pub token_file: Option<PathBuf>,
    #[command(flatten)]
    pub render: RenderArgs,
}

pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Serve(a) => serve_cmd::run(a),
        Command::Render(a) => render_cmd::run(a),
        Command::Client(a) => client_cmd::run(a),
        Command::Scenes => {
            for s in crate::scene::builtin::list() {
                println!("{:10} {}", s.name, s.description);
            }
            Ok(())
        }
        Command::Methods => {
            use crate::pipeline::registry::{DEFAULT_METHOD, METHODS};
            let rows =
                std::iter::once(DEFAULT_METHOD.spec()).chain(METHODS.iter().filter(|m| m.method != DEFAULT_METHOD));
            for m in rows {
                println!("{:17} {}", m.name, m.summary);
            }
            Ok(())
        }
        Command::Bench(a) => bench::run(a),
    }
}
