//! Admission before any expensive work: a `Render` call takes its render slot before its
//! request is read, so the memory of decoding and compiling scenes is bounded by the slot count
//! times the request size; and no message may exceed `max_request_bytes`, checked on the gRPC
//! length prefix before a byte of it is buffered, with RESOURCE_EXHAUSTED as gRPC prescribes.
use super::log_text::Escaped;
use super::metrics::RejectReason;
use super::state::ServerState;
use crate::runner::Slots;
use bytes::{Buf, Bytes};
use http_body::{Body as HttpBody, Frame, SizeHint};
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::task::{Context, Poll};
use tokio::sync::OwnedSemaphorePermit;
use tonic::body::Body;
use tonic::Status;

/// The calls that render or compile scenes and so need a slot (a session holds its slot as
/// long as it is open).
const SLOT_PATHS: [&str; 4] = [
    "/wedge.v1.Renderer/Render",
    "/wedge.v1.Renderer/Session",
    "/wedge.v1.Renderer/WatchSession",
    "/wedge.v1.Renderer/PutScene",
];

/// A render slot taken for a call, handed to its handler in the request's extensions.
#[derive(Clone, Debug)]
pub struct RenderSlot(pub Arc<OwnedSemaphorePermit>);

/// The id of a call, in every log line about it (handed on in the request's extensions).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RequestId(pub u64);

#[derive(Clone, Debug)]
pub struct AdmissionLayer {
    slots: Slots,
    state: Arc<ServerState>,
    max_message_bytes: usize,
    next_request: Arc<AtomicU64>,
}

impl AdmissionLayer {
    pub fn new(slots: Slots, max_message_bytes: usize, state: Arc<ServerState>) -> Self {
        AdmissionLayer { slots, state, max_message_bytes, next_request: Arc::new(AtomicU64::new(0)) }
    }
}

impl<S> tower_layer::Layer<S> for AdmissionLayer {
    type Service = Admission<S>;
    fn layer(&self, inner: S) -> Admission<S> {
        Admission { inner, layer: self.clone() }
    }
}

#[derive(Clone, Debug)]
pub struct Admission<S> {
    inner: S,
    layer: AdmissionLayer,
}

type BoxFuture<T> = Pin<Box<dyn std::future::Future<Output = T> + Send>>;

impl<S> tower_service::Service<http::Request<Body>> for Admission<S>
where
    S: tower_service::Service<http::Request<Body>, Response = http::Response<Body>>,
    S::Future: Send + 'static,
    S::Error: Send + 'static,
{
    type Response = http::Response<Body>;
    type Error = S::Error;
    type Future = BoxFuture<Result<http::Response<Body>, S::Error>>;

    fn poll_ready(&mut self, cx: &mut Context<'_>) -> Poll<Result<(), Self::Error>> {
        self.inner.poll_ready(cx)
    }

    fn call(&mut self, req: http::Request<Body>) -> Self::Future {
        let id = RequestId(self.layer.next_request.fetch_add(1, Ordering::Relaxed) + 1);
        let (mut parts, body) = req.into_parts();
        parts.extensions.insert(id);
        if SLOT_PATHS.contains(&parts.uri.path()) {
            let Some(permit) = self.layer.slots.try_acquire() else {
                let peer = parts
                    .extensions
                    .get::<tonic::transport::server::TcpConnectInfo>()
                    .and_then(|c| c.remote_addr())
                    .map_or_else(|| "unknown".to_string(), |a| a.to_string());
                tracing::warn!(request = id.0, peer = %Escaped(&peer), "rejected render: server busy");
                self.layer.state.metrics.reject(RejectReason::Busy);
                return Box::pin(std::future::ready(Ok(busy(&self.layer.slots).into_http())));
            };
            parts.extensions.insert(RenderSlot(Arc::new(permit)));
        }
        let limit = MessageSizeLimit::new(body, self.layer.max_message_bytes, Arc::clone(&self.layer.state));
        let body = Body::new(limit);
        let response = self.inner.call(http::Request::from_parts(parts, body));
        Box::pin(response)
    }
}

/// The status of a render refused because every slot is taken.
pub fn busy(slots: &Slots) -> Status {
    Status::resource_exhausted(format!(
        "server busy: all {} render slots are in use (max_concurrent_renders)",
        slots.limit()
    ))
}

/// Bytes of the gRPC length prefix: a compression flag and a big-endian u32 length.
const PREFIX_BYTES: usize = 5;

/// A request body that fails with RESOURCE_EXHAUSTED as soon as a message's length prefix
/// announces more than `limit` bytes, before the decoder reserves memory for it.
struct MessageSizeLimit {
    inner: Body,
    limit: usize,
    /// The prefix of the message being read, and how many of its bytes have arrived.
    prefix: [u8; PREFIX_BYTES],
    prefix_len: usize,
    /// Payload bytes of the current message still to come (after its prefix).
    payload_left: usize,
    failed: bool,
    /// Counts the refusal.
    state: Arc<ServerState>,
}

impl MessageSizeLimit {
    fn new(inner: Body, limit: usize, state: Arc<ServerState>) -> Self {
        MessageSizeLimit {
            inner,
            limit,
            prefix: [0; PREFIX_BYTES],
            prefix_len: 0,
            payload_left: 0,
            failed: false,
            state,
        }
    }

    /// Walks the message framing through `data`; an error for the first oversized message.
    fn check(&mut self, mut data: &[u8]) -> Result<(), Status> {
        while !data.is_empty() {
            if self.payload_left > 0 {
                let n = self.payload_left.min(data.len());
                self.payload_left -= n;
                data.advance(n);
                continue;
            }
            let n = (PREFIX_BYTES - self.prefix_len).min(data.len());
            self.prefix[self.prefix_len..self.prefix_len + n].copy_from_slice(&data[..n]);
            self.prefix_len += n;
            data.advance(n);
            if self.prefix_len == PREFIX_BYTES {
                self.prefix_len = 0;
                let len = u32::from_be_bytes([self.prefix[1], self.prefix[2], self.prefix[3], self.prefix[4]]);
                let len = usize::try_from(len).unwrap_or(usize::MAX);
                if len > self.limit {
                    return Err(Status::resource_exhausted(format!(
                        "request message of {len} bytes is over the server's limit of {} bytes \
                         (max_request_bytes)",
                        self.limit
                    )));
                }
                self.payload_left = len;
            }
        }
        Ok(())
    }
}

impl HttpBody for MessageSizeLimit {
    type Data = Bytes;
    type Error = Status;

    fn poll_frame(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<Option<Result<Frame<Bytes>, Status>>> {
        let this = &mut *self;
        if this.failed {
            return Poll::Ready(None);
        }
        let frame = match Pin::new(&mut this.inner).poll_frame(cx) {
            Poll::Ready(Some(Ok(frame))) => frame,
            other => return other,
        };
        if let Some(data) = frame.data_ref() {
            if let Err(status) = this.check(data) {
                this.failed = true;
                this.state.metrics.reject(RejectReason::TooLarge);
                return Poll::Ready(Some(Err(status)));
            }
        }
        Poll::Ready(Some(Ok(frame)))
    }

    fn is_end_stream(&self) -> bool {
        self.failed || self.inner.is_end_stream()
    }

    fn size_hint(&self) -> SizeHint {
        self.inner.size_hint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limiter(limit: usize) -> MessageSizeLimit {
        MessageSizeLimit::new(Body::empty(), limit, ServerState::new())
    }

    fn message(len: u32) -> Vec<u8> {
        let mut m = vec![0u8];
        m.extend_from_slice(&len.to_be_bytes());
        m.resize(PREFIX_BYTES + len as usize, 7);
        m
    }

    #[test]
    fn messages_at_the_limit_pass_and_one_byte_more_fails() {
        let mut l = limiter(100);
        let mut stream = message(100);
        stream.extend(message(0));
        stream.extend(message(3));
        assert!(l.check(&stream).is_ok());
        let err = limiter(100).check(&message(101)).unwrap_err();
        assert_eq!(err.code(), tonic::Code::ResourceExhausted);
        assert!(err.message().contains("101 bytes") && err.message().contains("max_request_bytes"), "{err:?}");
    }

    #[test]
    fn a_prefix_split_across_chunks_is_still_read() {
        // The second message announces 2^24 bytes; its prefix arrives one byte at a time, after
        // the first message's payload in pieces.
        let mut stream = message(10);
        stream.extend_from_slice(&[0, 1, 0, 0, 0]);
        let mut l = limiter(1000);
        let chunks: Vec<&[u8]> = stream.chunks(1).collect();
        let failed_at = chunks.iter().position(|c| l.check(c).is_err());
        assert_eq!(failed_at, Some(stream.len() - 1), "fails on the prefix's last byte, not before");
    }

    #[test]
    fn the_largest_announced_length_fails_without_overflow() {
        let mut prefix = vec![0u8];
        prefix.extend_from_slice(&u32::MAX.to_be_bytes());
        assert!(limiter(1 << 20).check(&prefix).is_err());
        assert!(limiter(usize::MAX).check(&prefix).is_ok());
    }
}
