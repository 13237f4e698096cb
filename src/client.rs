//! A client of the render service: sends a `RenderRequest` and reassembles the streamed frames.
use crate::api::wire::FrameAssembler;
use crate::pipeline::frame::Frame;
use crate::proto::renderer_client::RendererClient;
use crate::proto::{RenderRequest, RenderStarted};
use anyhow::Context;
use std::fmt;
use std::time::Duration;
use tonic::transport::Endpoint;

/// A call that the server answered with a gRPC error status.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RemoteError {
    pub code: tonic::Code,
    pub message: String,
}

impl fmt::Display for RemoteError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "server error {}: {}", code_name(self.code), self.message)
    }
}
impl std::error::Error for RemoteError {}

impl From<tonic::Status> for RemoteError {
    fn from(status: tonic::Status) -> Self {
        RemoteError { code: status.code(), message: status.message().to_string() }
    }
}

/// The canonical upper-case name of a gRPC status code (`INVALID_ARGUMENT`, ...).
pub fn code_name(code: tonic::Code) -> &'static str {
    use tonic::Code::*;
    match code {
        Ok => "OK",
        Cancelled => "CANCELLED",
        Unknown => "UNKNOWN",
        InvalidArgument => "INVALID_ARGUMENT",
        DeadlineExceeded => "DEADLINE_EXCEEDED",
        NotFound => "NOT_FOUND",
        AlreadyExists => "ALREADY_EXISTS",
        PermissionDenied => "PERMISSION_DENIED",
        ResourceExhausted => "RESOURCE_EXHAUSTED",
        FailedPrecondition => "FAILED_PRECONDITION",
        Aborted => "ABORTED",
        OutOfRange => "OUT_OF_RANGE",
        Unimplemented => "UNIMPLEMENTED",
        Internal => "INTERNAL",
        Unavailable => "UNAVAILABLE",
        DataLoss => "DATA_LOSS",
        Unauthenticated => "UNAUTHENTICATED",
    }
}

/// `host:port` or a full `http://` URI.
fn endpoint_uri(addr: &str) -> String {
    if addr.contains("://") {
        addr.to_string()
    } else {
        format!("http://{addr}")
    }
}

/// Connects to a server at `addr` (`host:port` or `http://host:port`).
pub async fn connect(addr: &str) -> anyhow::Result<RendererClient<tonic::transport::Channel>> {
    let endpoint = Endpoint::from_shared(endpoint_uri(addr))
        .with_context(|| format!("invalid server address {addr:?}"))?
        .connect_timeout(Duration::from_secs(10))
        .tcp_nodelay(true);
    let channel = endpoint.connect().await.with_context(|| format!("cannot connect to {addr}"))?;
    Ok(RendererClient::new(channel))
}

/// Renders `req` on the server at `addr`, calling `on_frame` with every frame as it arrives.
/// Returns the last frame (the final one unless the server stopped early), or `None` when the
/// stream carried no frame. A server error is a `RemoteError` (downcast the `anyhow::Error` to
/// read its code).
pub async fn render_remote(
    addr: &str,
    req: RenderRequest,
    mut on_frame: impl FnMut(&RenderStarted, &Frame),
) -> anyhow::Result<Option<Frame>> {
    let mut client = connect(addr).await?;
    let mut stream = client.render(req).await.map_err(RemoteError::from)?.into_inner();
    let mut assembler = FrameAssembler::new();
    let mut last = None;
    while let Some(update) = stream.message().await.map_err(RemoteError::from)? {
        if let Some(frame) = assembler.push(update)? {
            let started = assembler.started().context("frame without RenderStarted")?;
            on_frame(started, &frame);
            last = Some(frame);
        }
    }
    if assembler.in_frame() {
        anyhow::bail!("the render stream ended in the middle of a frame");
    }
    Ok(last)
}
