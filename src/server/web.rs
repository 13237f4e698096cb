//! The browser viewer (`wedge serve --web`): the same port also answers gRPC-web (tonic-web
//! translates it to gRPC for the services inside) and serves the viewer's page, a static page
//! that talks to `WatchSession` and `UpdateSession` over gRPC-web. Off, this layer passes every
//! request through untouched.
use bytes::Bytes;
use std::future::Future;
use std::pin::Pin;
use std::task::{Context, Poll};
use tonic::body::Body;
use tower_layer::Layer;
use tower_service::Service;

/// The viewer's files, compiled into the binary: (path, content type, content).
const FILES: [(&str, &str, &str); 4] = [
    ("/", "text/html; charset=utf-8", include_str!("web/index.html")),
    ("/viewer.js", "text/javascript; charset=utf-8", include_str!("web/viewer.js")),
    ("/grpc_web.js", "text/javascript; charset=utf-8", include_str!("web/grpc_web.js")),
    ("/colormap.js", "text/javascript; charset=utf-8", include_str!("web/colormap.js")),
];

/// The response to a `GET` of `path` when the viewer is on: a file, or 404.
fn page(path: &str) -> http::Response<Body> {
    let path = if path == "/index.html" { "/" } else { path };
    let (status, kind, text) = match FILES.iter().find(|(p, _, _)| *p == path) {
        Some(&(_, kind, text)) => (http::StatusCode::OK, kind, text),
        None => (http::StatusCode::NOT_FOUND, "text/plain; charset=utf-8", "not found: the viewer is at /"),
    };
    let mut response = http::Response::new(Body::new(full(text)));
    *response.status_mut() = status;
    let headers = response.headers_mut();
    headers.insert(http::header::CONTENT_TYPE, http::HeaderValue::from_static(kind));
    headers.insert(http::header::CACHE_CONTROL, http::HeaderValue::from_static("no-cache"));
    response
}

fn full(text: &'static str) -> http_body_util::Full<Bytes> {
    http_body_util::Full::new(Bytes::from_static(text.as_bytes()))
}

#[derive(Clone, Debug)]
pub struct WebLayer {
    enabled: bool,
}

impl WebLayer {
    pub fn new(enabled: bool) -> Self {
        WebLayer { enabled }
    }
}

impl<S: Clone> Layer<S> for WebLayer {
    type Service = Web<S>;
    fn layer(&self, inner: S) -> Web<S> {
        let grpc_web = self.enabled.then(|| tonic_web::GrpcWebLayer::new().layer(inner.clone()));
        Web { inner, grpc_web }
    }
}

/// Serves the viewer's files and gRPC-web when on; passes everything through when off.
#[derive(Clone, Debug)]
pub struct Web<S> {
    inner: S,
    grpc_web: Option<tonic_web::GrpcWebService<S>>,
}

type BoxFuture<T> = Pin<Box<dyn Future<Output = T> + Send>>;

impl<S, ResBody> Service<http::Request<Body>> for Web<S>
where
    S: Service<http::Request<Body>, Response = http::Response<ResBody>> + Clone + Send + 'static,
    S::Future: Send + 'static,
    S::Error: Send + 'static,
    ResBody: http_body::Body<Data = Bytes> + Send + 'static,
    ResBody::Error: Into<Box<dyn std::error::Error + Send + Sync>> + std::fmt::Display,
{
    type Response = http::Response<Body>;
    type Error = S::Error;
    type Future = BoxFuture<Result<http::Response<Body>, S::Error>>;

    fn poll_ready(&mut self, cx: &mut Context<'_>) -> Poll<Result<(), Self::Error>> {
        if let Some(web) = &mut self.grpc_web {
            if Service::<http::Request<Body>>::poll_ready(web, cx)?.is_pending() {
                return Poll::Pending;
            }
        }
        self.inner.poll_ready(cx)
    }

    fn call(&mut self, req: http::Request<Body>) -> Self::Future {
        match &mut self.grpc_web {
            Some(_) if req.method() == http::Method::GET => {
                let response = page(req.uri().path());
                Box::pin(async move { Ok(response) })
            }
            Some(web) => Box::pin(web.call(req)),
            None => {
                let response = self.inner.call(req);
                Box::pin(async move { Ok(response.await?.map(Body::new)) })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_page_and_its_scripts_are_served_and_nothing_else() {
        for path in ["/", "/index.html", "/viewer.js", "/grpc_web.js", "/colormap.js"] {
            let r = page(path);
            assert_eq!(r.status(), http::StatusCode::OK, "{path}");
        }
        assert_eq!(page("/../Cargo.toml").status(), http::StatusCode::NOT_FOUND);
        assert_eq!(page("/wedge.v1.Renderer/Render").status(), http::StatusCode::NOT_FOUND);
    }

    #[test]
    fn the_page_loads_every_script_it_names() {
        let (_, _, html) = FILES[0];
        for (path, _, _) in &FILES[1..] {
            assert!(html.contains(&format!("src=\"{}\"", &path[1..])), "{path} is not loaded by the page");
        }
    }
}
