//! Prometheus metrics of one server (`--metrics-addr`, off by default): renders by outcome,
//! rejections by reason, active renders, frame latencies and rays traced. Each server has its
//! own registry (no process-wide globals), so servers in one process, as in tests, keep
//! separate counts.
use prometheus_client::encoding::{EncodeLabelSet, EncodeLabelValue};
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{exponential_buckets, Histogram};
use prometheus_client::registry::Registry;
use std::sync::Arc;

/// Why a call was refused before it rendered.
#[derive(Clone, Copy, Debug, Hash, PartialEq, Eq)]
pub enum RejectReason {
    /// Every render slot was taken.
    Busy,
    /// The request was over `max_request_bytes`.
    TooLarge,
    /// The request was invalid (a field named in the status).
    Invalid,
    /// No valid bearer token.
    Unauthenticated,
}

impl RejectReason {
    pub fn name(self) -> &'static str {
        match self {
            RejectReason::Busy => "busy",
            RejectReason::TooLarge => "too_large",
            RejectReason::Invalid => "invalid",
            RejectReason::Unauthenticated => "unauthenticated",
        }
    }
}

impl EncodeLabelValue for RejectReason {
    fn encode(&self, encoder: &mut prometheus_client::encoding::LabelValueEncoder) -> Result<(), std::fmt::Error> {
        EncodeLabelValue::encode(&self.name(), encoder)
    }
}

#[derive(Clone, Debug, Hash, PartialEq, Eq, EncodeLabelSet)]
struct RejectLabels {
    reason: RejectReason,
}

#[derive(Debug)]
pub struct Metrics {
    registry: Registry,
    pub(super) renders_started: Counter,
    pub(super) renders_finished: Counter,
    pub(super) renders_cancelled: Counter,
    pub(super) renders_failed: Counter,
    pub(super) active_renders: Gauge,
    rejected: Family<RejectLabels, Counter>,
    first_frame_seconds: Histogram,
    frame_interval_seconds: Histogram,
    rays_traced: Counter,
    sessions_started: Counter,
    active_sessions: Gauge,
}

/// Counts a session as active until dropped.
#[derive(Debug)]
pub struct ActiveSession(Gauge);

impl Drop for ActiveSession {
    fn drop(&mut self) {
        self.0.dec();
    }
}

impl Default for Metrics {
    fn default() -> Self {
        Metrics::new()
    }
}

/// Latency buckets from 5 ms to about 80 s, doubling.
fn latency_buckets() -> Histogram {
    Histogram::new(exponential_buckets(0.005, 2.0, 15))
}

impl Metrics {
    pub fn new() -> Metrics {
        let mut m = Metrics {
            registry: Registry::with_prefix("wedge"),
            renders_started: Counter::default(),
            renders_finished: Counter::default(),
            renders_cancelled: Counter::default(),
            renders_failed: Counter::default(),
            active_renders: Gauge::default(),
            rejected: Family::default(),
            first_frame_seconds: latency_buckets(),
            frame_interval_seconds: latency_buckets(),
            rays_traced: Counter::default(),
            sessions_started: Counter::default(),
            active_sessions: Gauge::default(),
        };
        let r = &mut m.registry;
        r.register("renders_started", "Renders started", m.renders_started.clone());
        r.register("renders_finished", "Renders that reached a halt condition", m.renders_finished.clone());
        r.register(
            "renders_cancelled",
            "Renders cancelled: the client went away or stalled, or the server drained",
            m.renders_cancelled.clone(),
        );
        r.register("renders_failed", "Renders that ended with an error", m.renders_failed.clone());
        r.register("renders_rejected", "Calls refused before rendering, by reason", m.rejected.clone());
        r.register("active_renders", "Renders running now", m.active_renders.clone());
        r.register(
            "first_frame_seconds",
            "Seconds from a render's start to its first frame on the wire",
            m.first_frame_seconds.clone(),
        );
        r.register(
            "frame_interval_seconds",
            "Seconds between consecutive frames of a render on the wire",
            m.frame_interval_seconds.clone(),
        );
        r.register("rays_traced", "Rays traced by renders (rate() gives rays per second)", m.rays_traced.clone());
        r.register("sessions_started", "Sessions opened", m.sessions_started.clone());
        r.register("active_sessions", "Sessions open now", m.active_sessions.clone());
        m
    }

    /// Counts a session as opened and active until the returned guard drops.
    pub fn begin_session(&self) -> ActiveSession {
        self.sessions_started.inc();
        self.active_sessions.inc();
        ActiveSession(self.active_sessions.clone())
    }

    pub fn active_sessions(&self) -> i64 {
        self.active_sessions.get()
    }

    pub fn reject(&self, reason: RejectReason) {
        self.rejected.get_or_create(&RejectLabels { reason }).inc();
    }

    pub fn rejected(&self, reason: RejectReason) -> u64 {
        self.rejected.get_or_create(&RejectLabels { reason }).get()
    }

    /// Records a frame put on the wire: `since_start` seconds after its render began, the
    /// previous one `since_previous` seconds before (None for the first), `rays` new rays.
    pub fn frame_sent(&self, since_start: f64, since_previous: Option<f64>, rays: u64) {
        match since_previous {
            None => self.first_frame_seconds.observe(since_start),
            Some(dt) => self.frame_interval_seconds.observe(dt),
        }
        self.rays_traced.inc_by(rays);
    }

    /// The OpenMetrics text exposition.
    pub fn encode(&self) -> String {
        let mut text = String::new();
        // Writing into a String cannot fail.
        let _ = prometheus_client::encoding::text::encode(&mut text, &self.registry);
        text
    }
}

/// The content type of `Metrics::encode`'s text.
pub const CONTENT_TYPE: &str = "application/openmetrics-text; version=1.0.0; charset=utf-8";

/// Serves `GET /metrics` on `listener` until the task is dropped.
pub async fn serve(listener: tokio::net::TcpListener, metrics: Arc<dyn Fn() -> String + Send + Sync>) {
    use http_body_util::Full;
    use hyper::service::service_fn;
    loop {
        let Ok((stream, _)) = listener.accept().await else { continue };
        let metrics = Arc::clone(&metrics);
        tokio::spawn(async move {
            let service = service_fn(move |req: http::Request<hyper::body::Incoming>| {
                let metrics = Arc::clone(&metrics);
                async move {
                    let response = if req.method() == http::Method::GET && req.uri().path() == "/metrics" {
                        http::Response::builder()
                            .header(http::header::CONTENT_TYPE, CONTENT_TYPE)
                            .body(Full::new(bytes::Bytes::from(metrics())))
                    } else {
                        http::Response::builder()
                            .status(http::StatusCode::NOT_FOUND)
                            .body(Full::new(bytes::Bytes::from_static(b"metrics are at GET /metrics\n")))
                    };
                    response
                }
            });
            let io = hyper_util::rt::TokioIo::new(stream);
            if let Err(e) = hyper::server::conn::http1::Builder::new().serve_connection(io, service).await {
                tracing::debug!("metrics connection: {e}");
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exposition_names_every_metric_with_its_value() {
        let m = Metrics::new();
        m.renders_started.inc();
        m.reject(RejectReason::Busy);
        m.reject(RejectReason::Busy);
        m.reject(RejectReason::TooLarge);
        m.frame_sent(0.04, None, 1000);
        m.frame_sent(0.3, Some(0.26), 3000);
        let text = m.encode();
        for line in [
            "wedge_renders_started_total 1",
            "wedge_renders_rejected_total{reason=\"busy\"} 2",
            "wedge_renders_rejected_total{reason=\"too_large\"} 1",
            "wedge_first_frame_seconds_count 1",
            "wedge_first_frame_seconds_bucket{le=\"0.04\"} 1",
            "wedge_frame_interval_seconds_count 1",
            "wedge_rays_traced_total 4000",
            "wedge_active_renders 0",
        ] {
            assert!(text.lines().any(|l| l == line), "no line {line:?} in\n{text}");
        }
        assert!(text.ends_with("# EOF\n"));
    }
}
