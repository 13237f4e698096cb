//! gRPC layer: a thin tonic server around the render core. `frames` puts frames on the wire,
//! `render_service` is the `Renderer` service, `catalog` answers `ListScenes`, `state` holds
//! the counters; health and reflection are registered here.
pub mod admission;
pub mod auth;
pub mod catalog;
pub mod exposure;
pub mod log_text;
pub mod metrics;
pub mod render_service;
pub mod scene_cache;
pub mod session;
pub mod shutdown;
pub mod state;
pub mod web;
pub mod web_sessions;

pub use crate::api::wire::{FrameAssembler, DEFAULT_MAX_CHUNK_BYTES};
pub use render_service::RenderService;
pub use shutdown::shutdown_signal;
pub use state::ServerState;

use crate::proto::renderer_server::RendererServer;
use anyhow::Context;
use std::future::Future;
use std::net::SocketAddr;
use std::sync::Arc;
use std::time::Duration;
use tonic::transport::server::TcpIncoming;
use tonic::transport::Server;

/// The largest request by default: enough for an inline mesh of a million triangles with
/// normals and texture coordinates (24 MiB on the wire; see `bench/request_memory.py`).
pub const DEFAULT_MAX_REQUEST_BYTES: usize = 32 << 20;

/// Where and how `wedge serve` listens.
#[derive(Clone, Debug)]
pub struct ServerConfig {
    pub addr: SocketAddr,
    pub limits: crate::api::request::Limits,
    /// Renders running at once; more are refused with `RESOURCE_EXHAUSTED`.
    pub max_concurrent_renders: usize,
    /// Cap on the pixel bytes of one streamed chunk (at least one row is always sent).
    pub max_chunk_bytes: usize,
    /// Largest request message (inline scene) accepted, in bytes; larger ones get
    /// RESOURCE_EXHAUSTED before they are buffered.
    pub max_request_bytes: usize,
    /// After a shutdown signal, how long in-flight renders may run on before they are
    /// cancelled (their clients get UNAVAILABLE).
    pub shutdown_grace: Duration,
    /// A render whose client has not accepted a message for this long is cancelled and its
    /// slot freed (the client reads slower than nothing).
    pub stall_timeout: Duration,
    /// Serve over TLS with this identity; `None`: plaintext.
    pub tls: Option<exposure::TlsIdentity>,
    /// Tokens accepted as `authorization: Bearer <token>` on every call but health; empty:
    /// no check.
    pub tokens: auth::Tokens,
    /// Serve gRPC server reflection (v1 and v1alpha).
    pub reflection: bool,
    /// Serve Prometheus metrics at `GET /metrics` on this address; `None`: not at all.
    pub metrics_addr: Option<SocketAddr>,
    /// Connections older than this are asked to close (HTTP/2 GOAWAY) once their calls end, so
    /// that clients reconnect and rebalance across replicas; `None`: never.
    pub max_connection_age: Option<Duration>,
    /// Also serve `grpc.health.v1` alone, in plaintext and without tokens, on this address:
    /// for orchestrators' native gRPC probes, which speak neither TLS nor tokens.
    pub health_addr: Option<SocketAddr>,
    /// A session with no message from its client for this long ends with DEADLINE_EXCEEDED.
    pub session_idle_timeout: Duration,
    /// Bounds of the store of `PutScene` scenes: encoded bytes and triangles, over all scenes.
    pub scene_cache_bytes: u64,
    pub scene_cache_triangles: u64,
    /// Also serve the browser viewer's page and gRPC-web (HTTP/1.1) on the same port.
    pub web: bool,
    /// Changes a `WatchSession` session may have queued by `UpdateSession` and not yet read.
    pub web_session_queue: usize,
}

impl Default for ServerConfig {
    fn default() -> Self {
        ServerConfig {
            addr: SocketAddr::from(([127, 0, 0, 1], 50051)),
            limits: crate::api::request::Limits::default(),
            max_concurrent_renders: 2,
            max_chunk_bytes: DEFAULT_MAX_CHUNK_BYTES,
            max_request_bytes: DEFAULT_MAX_REQUEST_BYTES,
            shutdown_grace: Duration::from_secs(10),
            stall_timeout: Duration::from_secs(30),
            tls: None,
            tokens: auth::Tokens::default(),
            reflection: true,
            metrics_addr: None,
            max_connection_age: Some(Duration::from_secs(300)),
            health_addr: None,
            session_idle_timeout: Duration::from_secs(300),
            scene_cache_bytes: 256 << 20,
            scene_cache_triangles: 2_000_000,
            web: false,
            web_session_queue: web_sessions::DEFAULT_QUEUED_UPDATES,
        }
    }
}

/// Binds `config.addr` and serves until `shutdown` resolves.
pub async fn serve(config: ServerConfig, shutdown: impl Future<Output = ()>) -> anyhow::Result<()> {
    let listener = tokio::net::TcpListener::bind(config.addr)
        .await
        .with_context(|| format!("cannot listen on {}", config.addr))?;
    serve_on(listener, config, ServerState::new(), shutdown).await
}

/// Serves on an already bound listener (tests bind port 0) until `shutdown` resolves; then
/// reports NOT_SERVING, stops accepting, and lets in-flight streams finish for the grace period
/// (`shutdown::phases`). `config.addr` is ignored.
pub async fn serve_on(
    listener: tokio::net::TcpListener,
    config: ServerConfig,
    state: Arc<ServerState>,
    shutdown: impl Future<Output = ()>,
) -> anyhow::Result<()> {
    let local = listener.local_addr().context("listener has no address")?;
    let service = {
        let (config, state) = (config.clone(), Arc::clone(&state));
        tokio::task::spawn_blocking(move || RenderService::new(&config, state))
            .await
            .context("building the render service")?
    };

    let (health, health_service) = tonic_health::server::health_reporter();
    health.set_serving::<RendererServer<RenderService>>().await;
    let (reflection_v1, reflection_v1alpha) = reflection_services(config.reflection)?;

    let (signal, grace_over) = shutdown::phases(shutdown, config.shutdown_grace, health, Arc::clone(&state));
    let slots = service.slots();
    // Both stop when this function returns.
    let _health_port = match config.health_addr {
        Some(addr) => {
            let (listener, bound) = bind_side(addr, "health probes").await?;
            state.set_health_addr(bound);
            tracing::info!(addr = %bound, "serving grpc.health.v1 alone in plaintext");
            let health_only = Server::builder().add_service(health_service.clone());
            Some(AbortOnDrop(tokio::spawn(async move {
                if let Err(e) = health_only.serve_with_incoming(TcpIncoming::from(listener)).await {
                    tracing::warn!("health port failed: {e}");
                }
            })))
        }
        None => None,
    };
    let _metrics = match config.metrics_addr {
        Some(addr) => {
            let (listener, bound) = bind_side(addr, "metrics").await?;
            state.set_metrics_addr(bound);
            tracing::info!(addr = %bound, "serving Prometheus metrics at /metrics");
            let exported = Arc::clone(&state);
            Some(AbortOnDrop(tokio::spawn(metrics::serve(listener, Arc::new(move || exported.metrics.encode())))))
        }
        None => None,
    };
    let incoming = TcpIncoming::from(listener).with_nodelay(Some(true)).with_keepalive(Some(Duration::from_secs(60)));

    tracing::info!(
        addr = %local,
        max_concurrent_renders = config.max_concurrent_renders,
        max_chunk_bytes = config.max_chunk_bytes,
        limits = ?config.limits,
        tls = config.tls.is_some(),
        tokens = config.tokens.len(),
        reflection = config.reflection,
        web = config.web,
        "serving wedge.v1.Renderer"
    );
    let mut builder = Server::builder();
    if let Some(age) = config.max_connection_age {
        // No forced close after it: a render in flight keeps its connection until it ends.
        builder = builder.max_connection_age(age);
    }
    if let Some(tls) = &config.tls {
        let identity = tonic::transport::Identity::from_pem(&tls.cert_pem, &tls.key_pem);
        builder = builder
            .tls_config(tonic::transport::ServerTlsConfig::new().identity(identity))
            .context("TLS certificate and key")?;
    }
    let server = builder
        // Browsers speak gRPC-web over HTTP/1.1 (the viewer's page too).
        .accept_http1(config.web)
        // Notice clients that vanished without closing the connection, so their renders stop.
        .http2_keepalive_interval(Some(Duration::from_secs(30)))
        .http2_keepalive_timeout(Some(Duration::from_secs(20)))
        // Outermost: gRPC-web answers are translated after every layer inside has had its say
        // (the shutdown layer's trailers become gRPC-web trailers).
        .layer(web::WebLayer::new(config.web))
        .layer(shutdown::EndStreamsLayer::new(Arc::clone(&state)))
        .layer(auth::BearerAuthLayer::new(config.tokens.clone(), Arc::clone(&state)))
        .layer(admission::AdmissionLayer::new(slots, config.max_request_bytes, Arc::clone(&state)))
        .add_service(health_service)
        .add_optional_service(reflection_v1)
        .add_optional_service(reflection_v1alpha)
        // Inline scenes can be large: accept requests up to the configured size (replies are
        // chunked, so the 4 MiB default of clients is never an issue in that direction).
        .add_service(RendererServer::new(service).max_decoding_message_size(config.max_request_bytes))
        .serve_with_incoming_shutdown(incoming, signal);
    tokio::select! {
        result = server => result.context("gRPC server failed")?,
        () = grace_over => tracing::warn!("connections still open after the grace period: closing them"),
    }
    // Cancelled renders stop at their next check; wait for their threads (bounded), so that
    // the caller sees every slot free when this returns.
    if tokio::time::timeout(shutdown::CLOSE_AFTER_DRAIN, state.renders_ended()).await.is_err() {
        tracing::warn!(renders = state.active_renders(), "renders still winding down at exit");
    }
    tracing::info!("server stopped");
    Ok(())
}

/// Aborts a background task when dropped.
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

/// Server reflection, v1 and v1alpha (grpcurl and grpcui speak v1; Python's grpcio-reflection
/// and older tools only v1alpha), or neither.
#[allow(clippy::type_complexity)]
fn reflection_services(
    enabled: bool,
) -> anyhow::Result<(
    Option<tonic_reflection::server::v1::ServerReflectionServer<impl tonic_reflection::server::v1::ServerReflection>>,
    Option<
        tonic_reflection::server::v1alpha::ServerReflectionServer<
            impl tonic_reflection::server::v1alpha::ServerReflection,
        >,
    >,
)> {
    if !enabled {
        return Ok((None, None));
    }
    let builder = || {
        tonic_reflection::server::Builder::configure()
            .register_encoded_file_descriptor_set(crate::proto::FILE_DESCRIPTOR_SET)
            .register_encoded_file_descriptor_set(tonic_health::pb::FILE_DESCRIPTOR_SET)
    };
    let v1 = builder().build_v1().context("building the reflection service")?;
    let v1alpha = builder().build_v1alpha().context("building the reflection service")?;
    Ok((Some(v1), Some(v1alpha)))
}

/// Binds a side listener (health port, metrics) and says which address it got.
async fn bind_side(addr: SocketAddr, what: &str) -> anyhow::Result<(tokio::net::TcpListener, SocketAddr)> {
    let listener =
        tokio::net::TcpListener::bind(addr).await.with_context(|| format!("cannot listen for {what} on {addr}"))?;
    let bound = listener.local_addr().with_context(|| format!("the {what} listener has no address"))?;
    Ok((listener, bound))
}
