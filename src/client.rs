//! A client of the render service: sends a `RenderRequest` and reassembles the streamed frames.
use crate::api::wire::FrameAssembler;
use crate::pipeline::frame::Frame;
use crate::proto::renderer_client::RendererClient;
use crate::proto::{RenderRequest, RenderStarted};
use anyhow::Context;
use std::fmt;
use std::time::Duration;
use tonic::service::interceptor::InterceptedService;
use tonic::transport::{Certificate, Channel, ClientTlsConfig, Endpoint};

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

/// A server to call: its address (`host:port`, `http://host:port`, or `https://host:port` for
/// TLS), the CA certificates to trust for TLS (the public web roots when `None`), and a bearer
/// token to send.
#[derive(Clone, Default, PartialEq, Eq)]
pub struct Target {
    pub addr: String,
    pub ca_pem: Option<Vec<u8>>,
    pub token: Option<String>,
}

impl fmt::Debug for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let token = self.token.as_ref().map(|_| "<withheld>");
        f.debug_struct("Target")
            .field("addr", &self.addr)
            .field("ca", &self.ca_pem.is_some())
            .field("token", &token)
            .finish()
    }
}

impl From<&str> for Target {
    fn from(addr: &str) -> Target {
        Target { addr: addr.to_string(), ..Default::default() }
    }
}

impl From<&String> for Target {
    fn from(addr: &String) -> Target {
        Target::from(addr.as_str())
    }
}

impl Target {
    /// The address as a URI: `host:port` means plaintext `http://`.
    fn uri(&self) -> String {
        if self.addr.contains("://") {
            self.addr.clone()
        } else {
            format!("http://{}", self.addr)
        }
    }
}

/// Adds `authorization: Bearer <token>` to every call, when there is a token.
#[derive(Clone, Debug)]
pub struct BearerToken(Option<tonic::metadata::AsciiMetadataValue>);

impl tonic::service::Interceptor for BearerToken {
    fn call(&mut self, mut req: tonic::Request<()>) -> Result<tonic::Request<()>, tonic::Status> {
        if let Some(value) = &self.0 {
            req.metadata_mut().insert("authorization", value.clone());
        }
        Ok(req)
    }
}

/// A connected `Renderer` client that sends the target's token.
pub type Client = RendererClient<InterceptedService<Channel, BearerToken>>;

/// Connects to `target`.
pub async fn connect(target: &Target) -> anyhow::Result<Client> {
    let addr = &target.addr;
    let uri = target.uri();
    let mut endpoint = Endpoint::from_shared(uri.clone())
        .with_context(|| format!("invalid server address {addr:?}"))?
        .connect_timeout(Duration::from_secs(10))
        .tcp_nodelay(true);
    if uri.starts_with("https://") {
        let tls = match &target.ca_pem {
            Some(pem) => ClientTlsConfig::new().ca_certificate(Certificate::from_pem(pem)),
            None => ClientTlsConfig::new().with_webpki_roots(),
        };
        endpoint = endpoint.tls_config(tls).context("TLS configuration")?;
    } else if target.ca_pem.is_some() {
        anyhow::bail!("a CA certificate was given for {addr}, which is not an https:// address");
    }
    let token = match &target.token {
        Some(t) => {
            Some(format!("Bearer {t}").parse().map_err(|_| anyhow::anyhow!("the token is not valid header text"))?)
        }
        None => None,
    };
    let channel = endpoint.connect().await.with_context(|| format!("cannot connect to {addr}"))?;
    Ok(RendererClient::with_interceptor(channel, BearerToken(token)))
}

/// Renders `req` on the server at `addr`, calling `on_frame` with every frame as it arrives.
/// Returns the last frame (the final one unless the server stopped early), or `None` when the
/// stream carried no frame. A server error is a `RemoteError` (downcast the `anyhow::Error` to
/// read its code).
pub async fn render_remote(
    target: impl Into<Target>,
    req: RenderRequest,
    mut on_frame: impl FnMut(&RenderStarted, &Frame),
) -> anyhow::Result<Option<Frame>> {
    let mut client = connect(&target.into()).await?;
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
