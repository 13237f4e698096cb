//! Bearer tokens: every call but health must carry `authorization: Bearer <token>` with one of
//! the server's tokens. Only SHA-256 digests of the tokens are kept, and a presented token is
//! compared against every one of them in constant time, so neither the time taken nor the
//! length of a token tells a caller how close it came.
use super::metrics::RejectReason;
use super::state::ServerState;
use sha2::{Digest, Sha256};
use std::fmt;
use std::sync::Arc;
use std::task::{Context, Poll};
use subtle::ConstantTimeEq;
use tonic::body::Body;
use tonic::Status;

/// Calls under this prefix need no token: orchestrators probe health without credentials.
const OPEN_PREFIX: &str = "/grpc.health.v1.Health/";

/// The tokens a server accepts, as digests. Empty: no token check.
#[derive(Clone, Default, PartialEq, Eq)]
pub struct Tokens {
    digests: Vec<[u8; 32]>,
}

impl fmt::Debug for Tokens {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Tokens({} configured)", self.digests.len())
    }
}

fn digest(token: &str) -> [u8; 32] {
    Sha256::digest(token.as_bytes()).into()
}

impl Tokens {
    /// Tokens from a file's text: one per line; blank lines and lines starting with `#` are
    /// skipped, surrounding whitespace is trimmed. Errors name the line of a token that could
    /// never be sent in a header.
    pub fn parse(text: &str) -> Result<Tokens, String> {
        let mut tokens = Tokens::default();
        for (i, line) in text.lines().enumerate() {
            let t = line.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            tokens.add(t).map_err(|e| format!("line {}: {e}", i + 1))?;
        }
        Ok(tokens)
    }

    /// Adds one token: visible ASCII without spaces, at least 16 characters.
    pub fn add(&mut self, token: &str) -> Result<(), String> {
        if token.len() < 16 {
            return Err(format!("a token must have at least 16 characters (this one has {})", token.len()));
        }
        if !token.bytes().all(|b| b.is_ascii_graphic()) {
            return Err("a token must be visible ASCII without spaces".to_string());
        }
        self.digests.push(digest(token));
        Ok(())
    }

    pub fn is_empty(&self) -> bool {
        self.digests.is_empty()
    }

    pub fn len(&self) -> usize {
        self.digests.len()
    }

    /// Whether `token` is one of these, in time independent of which (if any) it matches.
    pub fn accepts(&self, token: &str) -> bool {
        let d = digest(token);
        self.digests.iter().fold(subtle::Choice::from(0), |any, known| any | known.ct_eq(&d)).into()
    }

    /// Whether an `authorization` header value carries an accepted bearer token.
    fn authorizes(&self, header: Option<&http::HeaderValue>) -> bool {
        let Some(value) = header.and_then(|v| v.to_str().ok()) else { return false };
        let Some((scheme, token)) = value.split_once(' ') else { return false };
        scheme.eq_ignore_ascii_case("bearer") && self.accepts(token.trim())
    }
}

#[derive(Clone, Debug)]
pub struct BearerAuthLayer {
    tokens: Arc<Tokens>,
    state: Arc<ServerState>,
}

impl BearerAuthLayer {
    pub fn new(tokens: Tokens, state: Arc<ServerState>) -> Self {
        BearerAuthLayer { tokens: Arc::new(tokens), state }
    }
}

impl<S> tower_layer::Layer<S> for BearerAuthLayer {
    type Service = BearerAuth<S>;
    fn layer(&self, inner: S) -> BearerAuth<S> {
        BearerAuth { inner, tokens: Arc::clone(&self.tokens), state: Arc::clone(&self.state) }
    }
}

#[derive(Clone, Debug)]
pub struct BearerAuth<S> {
    inner: S,
    tokens: Arc<Tokens>,
    state: Arc<ServerState>,
}

type BoxFuture<T> = std::pin::Pin<Box<dyn std::future::Future<Output = T> + Send>>;

impl<S> tower_service::Service<http::Request<Body>> for BearerAuth<S>
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
        let open = self.tokens.is_empty() || req.uri().path().starts_with(OPEN_PREFIX);
        if open || self.tokens.authorizes(req.headers().get(http::header::AUTHORIZATION)) {
            return Box::pin(self.inner.call(req));
        }
        tracing::warn!(path = %super::log_text::Escaped(req.uri().path()), "refused a call without a valid bearer token");
        self.state.metrics.reject(RejectReason::Unauthenticated);
        let status =
            Status::unauthenticated("a valid bearer token is required (metadata authorization: Bearer <token>)");
        Box::pin(std::future::ready(Ok(status.into_http())))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: &str = "correct-horse-battery-staple";
    const B: &str = "0123456789abcdef0123";

    #[test]
    fn only_configured_tokens_are_accepted() {
        let tokens = Tokens::parse(&format!("# rotation: both valid\n{A}\n\n  {B}  \n")).unwrap();
        assert_eq!(tokens.len(), 2);
        assert!(tokens.accepts(A) && tokens.accepts(B));
        assert!(!tokens.accepts("correct-horse-battery-stapl"));
        assert!(!tokens.accepts(&format!("{A}x")));
        assert!(!tokens.accepts(""));
        assert!(!format!("{tokens:?}").contains(A), "Debug must not show tokens");
    }

    #[test]
    fn the_header_needs_the_bearer_scheme() {
        let tokens = Tokens::parse(A).unwrap();
        let h = |s: &str| http::HeaderValue::from_str(s).unwrap();
        assert!(tokens.authorizes(Some(&h(&format!("Bearer {A}")))));
        assert!(tokens.authorizes(Some(&h(&format!("bearer {A}")))));
        assert!(!tokens.authorizes(Some(&h(&format!("Basic {A}")))));
        assert!(!tokens.authorizes(Some(&h(A))));
        assert!(!tokens.authorizes(None));
    }

    #[test]
    fn bad_tokens_are_refused_with_their_line() {
        let e = Tokens::parse(&format!("{A}\nshort\n")).unwrap_err();
        assert!(e.starts_with("line 2:") && e.contains("16 characters"), "{e}");
        let e = Tokens::parse("a token with spaces in it\n").unwrap_err();
        assert!(e.contains("visible ASCII"), "{e}");
        assert!(Tokens::parse("# only a comment\n").unwrap().is_empty());
    }
}
