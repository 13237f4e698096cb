//! Shutdown that always ends. The signal starts a graceful drain (NOT_SERVING, no new
//! connections, in-flight calls run on); when the grace period is over, `EndStreamsLayer` ends
//! every response stream still open (health watches and reflection included, not only
//! renders) with UNAVAILABLE, and `serve_on` returns shortly after even if a client never reads
//! its trailers.
use super::state::ServerState;
use super::RenderService;
use crate::proto::renderer_server::RendererServer;
use bytes::Bytes;
use http_body::{Body as HttpBody, Frame, SizeHint};
use std::future::Future;
use std::pin::Pin;
use std::sync::Arc;
use std::task::{Context, Poll};
use tonic::body::Body;
use tonic::Status;

/// The message every stream still open at the end of the grace period ends with.
pub const DRAINED_MESSAGE: &str = "the server is shutting down";

/// Wraps every response body so that it ends with UNAVAILABLE once the server drains.
#[derive(Clone, Debug)]
pub struct EndStreamsLayer {
    state: Arc<ServerState>,
}

impl EndStreamsLayer {
    pub fn new(state: Arc<ServerState>) -> Self {
        EndStreamsLayer { state }
    }
}

impl<S> tower_layer::Layer<S> for EndStreamsLayer {
    type Service = EndStreams<S>;
    fn layer(&self, inner: S) -> EndStreams<S> {
        EndStreams { inner, state: Arc::clone(&self.state) }
    }
}

#[derive(Clone, Debug)]
pub struct EndStreams<S> {
    inner: S,
    state: Arc<ServerState>,
}

type BoxFuture<T> = Pin<Box<dyn Future<Output = T> + Send>>;

impl<S, Req> tower_service::Service<http::Request<Req>> for EndStreams<S>
where
    S: tower_service::Service<http::Request<Req>, Response = http::Response<Body>>,
    S::Future: Send + 'static,
{
    type Response = http::Response<Body>;
    type Error = S::Error;
    type Future = BoxFuture<Result<http::Response<Body>, S::Error>>;

    fn poll_ready(&mut self, cx: &mut Context<'_>) -> Poll<Result<(), Self::Error>> {
        self.inner.poll_ready(cx)
    }

    fn call(&mut self, req: http::Request<Req>) -> Self::Future {
        let response = self.inner.call(req);
        let state = Arc::clone(&self.state);
        Box::pin(async move { Ok(response.await?.map(|body| Body::new(EndOnDrain::new(body, state)))) })
    }
}

/// A response body that ends with UNAVAILABLE trailers once the server drains, unless it has
/// ended by itself. Frames are whole gRPC messages, so cutting between two is clean.
struct EndOnDrain {
    inner: Body,
    drained: BoxFuture<()>,
    /// The inner body sent its trailers (its own status): nothing may follow them.
    inner_trailers_sent: bool,
    cut: bool,
}

impl EndOnDrain {
    fn new(inner: Body, state: Arc<ServerState>) -> Self {
        let drained = Box::pin(async move { state.drained().await });
        EndOnDrain { inner, drained, inner_trailers_sent: false, cut: false }
    }
}

impl HttpBody for EndOnDrain {
    type Data = Bytes;
    type Error = Status;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, Status>>> {
        let this = &mut *self;
        if this.cut {
            return Poll::Ready(None);
        }
        if !this.inner_trailers_sent && !this.inner.is_end_stream() && this.drained.as_mut().poll(cx).is_ready() {
            this.cut = true;
            let mut trailers = http::HeaderMap::new();
            // Only fails on a message that is not a valid header value; this one is.
            let _ = Status::unavailable(DRAINED_MESSAGE).add_header(&mut trailers);
            return Poll::Ready(Some(Ok(Frame::trailers(trailers))));
        }
        let frame = Pin::new(&mut this.inner).poll_frame(cx);
        if let Poll::Ready(Some(Ok(f))) = &frame {
            this.inner_trailers_sent |= f.is_trailers();
        }
        frame
    }

    fn is_end_stream(&self) -> bool {
        self.cut || self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}

/// After the grace period, how long streams have to deliver their UNAVAILABLE status before
/// the server stops waiting for their connections.
pub const CLOSE_AFTER_DRAIN: std::time::Duration = std::time::Duration::from_millis(500);

/// The two phases of a shutdown, as futures for `serve_on`. `signal` resolves once `shutdown`
/// has: health turns NOT_SERVING and the server stops accepting (the graceful drain). The
/// grace period then starts; `grace_over` resolves when it and `CLOSE_AFTER_DRAIN` have passed,
/// having ended every open stream with UNAVAILABLE and cancelled every render, so that
/// shutdown never waits for a long time budget, a health watch or a client that stopped
/// reading. It never resolves if `signal` was never awaited.
pub fn phases(
    shutdown: impl Future<Output = ()>,
    grace: std::time::Duration,
    health: tonic_health::server::HealthReporter,
    state: Arc<ServerState>,
) -> (impl Future<Output = ()>, impl Future<Output = ()>) {
    let (ended_tx, ended_rx) = tokio::sync::oneshot::channel::<()>();
    let signal = async move {
        shutdown.await;
        tracing::info!(
            grace_seconds = grace.as_secs_f64(),
            "shutting down: refusing new calls, finishing in-flight renders"
        );
        health.set_not_serving::<RendererServer<RenderService>>().await;
        health.set_service_status("", tonic_health::ServingStatus::NotServing).await;
        tokio::spawn(async move {
            tokio::time::sleep(grace).await;
            let _ = ended_tx.send(());
        });
    };
    let grace_over = async move {
        if ended_rx.await.is_err() {
            return std::future::pending().await;
        }
        let renders = state.active_renders();
        tracing::warn!(renders, "grace period over: ending every open stream with UNAVAILABLE");
        state.begin_drain();
        // Time for the UNAVAILABLE trailers to reach clients that still read; connections of
        // clients that do not are closed when the server returns.
        tokio::time::sleep(CLOSE_AFTER_DRAIN).await;
    };
    (signal, grace_over)
}

/// Resolves on SIGINT (Ctrl-C) or, on Unix, SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        if let Err(e) = tokio::signal::ctrl_c().await {
            tracing::warn!("cannot listen for Ctrl-C: {e}");
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        use tokio::signal::unix::{signal, SignalKind};
        match signal(SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(e) => {
                tracing::warn!("cannot listen for SIGTERM: {e}");
                std::future::pending::<()>().await;
            }
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => tracing::info!("received SIGINT"),
        () = term => tracing::info!("received SIGTERM"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use http_body_util::BodyExt;

    fn streaming_body() -> (tokio::sync::mpsc::Sender<Result<Frame<Bytes>, Status>>, Body) {
        let (tx, rx) = tokio::sync::mpsc::channel(4);
        let body = http_body_util::StreamBody::new(tokio_stream::wrappers::ReceiverStream::new(rx));
        (tx, Body::new(body))
    }

    #[tokio::test]
    async fn an_open_stream_ends_with_unavailable_when_the_server_drains() {
        let state = ServerState::new();
        let (tx, inner) = streaming_body();
        let mut body = EndOnDrain::new(inner, Arc::clone(&state));
        tx.send(Ok(Frame::data(Bytes::from_static(b"one")))).await.unwrap();
        let first = body.frame().await.unwrap().unwrap();
        assert_eq!(first.into_data().unwrap(), Bytes::from_static(b"one"));
        state.begin_drain();
        let last = body.frame().await.unwrap().unwrap();
        let trailers = last.into_trailers().unwrap();
        assert_eq!(trailers.get("grpc-status").unwrap(), "14");
        assert!(body.frame().await.is_none());
        assert!(body.is_end_stream());
        drop(tx);
    }

    #[tokio::test]
    async fn a_stream_that_sent_its_own_status_is_left_alone() {
        let state = ServerState::new();
        let (tx, inner) = streaming_body();
        let mut body = EndOnDrain::new(inner, Arc::clone(&state));
        let mut own = http::HeaderMap::new();
        own.insert("grpc-status", http::HeaderValue::from_static("0"));
        tx.send(Ok(Frame::trailers(own))).await.unwrap();
        let trailers = body.frame().await.unwrap().unwrap().into_trailers().unwrap();
        assert_eq!(trailers.get("grpc-status").unwrap(), "0");
        state.begin_drain();
        drop(tx);
        assert!(body.frame().await.is_none(), "no second status after the stream's own");
    }
}
