//! Counters shared by the server's handlers and render tasks; tests read them to see that a
//! cancelled render really stopped.
use super::metrics::Metrics;
use std::sync::atomic::Ordering;
use std::sync::Arc;

#[derive(Debug, Default)]
pub struct ServerState {
    /// The counters, exported on `--metrics-addr`.
    pub metrics: Metrics,
    /// Where the metrics endpoint and the plaintext health port listen, once bound.
    metrics_addr: std::sync::OnceLock<std::net::SocketAddr>,
    health_addr: std::sync::OnceLock<std::net::SocketAddr>,
    /// Set when the shutdown grace period is over: running renders must stop.
    draining: std::sync::atomic::AtomicBool,
    drain: tokio::sync::Notify,
    /// Signalled whenever the last active render ends.
    idle: tokio::sync::Notify,
}

/// How a render task ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RenderOutcome {
    /// Reached a halt condition.
    Finished,
    /// The client cancelled or went away.
    Cancelled,
    /// The render panicked or ended with an error.
    Failed,
}

impl ServerState {
    pub fn new() -> Arc<Self> {
        Arc::new(Self::default())
    }

    /// Render tasks running now (including ones winding down after a cancellation).
    pub fn active_renders(&self) -> usize {
        usize::try_from(self.metrics.active_renders.get()).unwrap_or(0)
    }

    /// Renders started since the server started.
    pub fn renders_started(&self) -> u64 {
        self.metrics.renders_started.get()
    }

    pub fn renders_finished(&self) -> u64 {
        self.metrics.renders_finished.get()
    }

    pub fn renders_cancelled(&self) -> u64 {
        self.metrics.renders_cancelled.get()
    }

    pub fn renders_failed(&self) -> u64 {
        self.metrics.renders_failed.get()
    }

    /// The bound address of the metrics endpoint, if it is served.
    pub fn metrics_addr(&self) -> Option<std::net::SocketAddr> {
        self.metrics_addr.get().copied()
    }

    pub(super) fn set_metrics_addr(&self, addr: std::net::SocketAddr) {
        let _ = self.metrics_addr.set(addr);
    }

    /// The bound address of the plaintext health port, if it is served.
    pub fn health_addr(&self) -> Option<std::net::SocketAddr> {
        self.health_addr.get().copied()
    }

    pub(super) fn set_health_addr(&self, addr: std::net::SocketAddr) {
        let _ = self.health_addr.set(addr);
    }

    /// Tells every running render to stop (the shutdown grace period is over).
    pub fn begin_drain(&self) {
        self.draining.store(true, Ordering::SeqCst);
        self.drain.notify_waiters();
    }

    /// Resolves once `begin_drain` has been called (at once if it already was).
    pub async fn drained(&self) {
        let notified = self.drain.notified();
        if self.draining.load(Ordering::SeqCst) {
            return;
        }
        notified.await;
    }

    /// Resolves once no render is active (at once if none is).
    pub async fn renders_ended(&self) {
        loop {
            let notified = self.idle.notified();
            if self.active_renders() == 0 {
                return;
            }
            notified.await;
        }
    }

    /// Counts a render as started and active until the returned guard is dropped.
    pub fn begin_render(self: &Arc<Self>) -> ActiveRender {
        let id = self.metrics.renders_started.inc() + 1;
        self.metrics.active_renders.inc();
        ActiveRender { state: Arc::clone(self), id, outcome: RenderOutcome::Failed }
    }
}

/// Keeps a render counted as active; dropping it (also on unwinding) ends the render with the
/// outcome last set (`Failed` unless `set_outcome` was called).
#[derive(Debug)]
pub struct ActiveRender {
    state: Arc<ServerState>,
    id: u64,
    outcome: RenderOutcome,
}

impl ActiveRender {
    /// 1-based number of this render since the server started (for logs).
    pub fn id(&self) -> u64 {
        self.id
    }

    pub fn set_outcome(&mut self, outcome: RenderOutcome) {
        self.outcome = outcome;
    }
}

impl Drop for ActiveRender {
    fn drop(&mut self) {
        let m = &self.state.metrics;
        let counter = match self.outcome {
            RenderOutcome::Finished => &m.renders_finished,
            RenderOutcome::Cancelled => &m.renders_cancelled,
            RenderOutcome::Failed => &m.renders_failed,
        };
        counter.inc();
        if m.active_renders.dec() == 1 {
            self.state.idle.notify_waiters();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guard_counts_and_releases() {
        let state = ServerState::new();
        let mut a = state.begin_render();
        let b = state.begin_render();
        assert_eq!((a.id(), b.id()), (1, 2));
        assert_eq!((state.active_renders(), state.renders_started()), (2, 2));
        a.set_outcome(RenderOutcome::Cancelled);
        drop(a);
        assert_eq!(state.active_renders(), 1);
        assert_eq!(state.renders_cancelled(), 1);
        let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || {
            let _b = b;
            panic!("render blew up");
        }));
        assert!(r.is_err());
        assert_eq!(state.active_renders(), 0);
        assert_eq!(state.renders_failed(), 1);
    }

    #[tokio::test]
    async fn renders_ended_waits_for_the_last_render() {
        let state = ServerState::new();
        state.renders_ended().await;
        let (a, b) = (state.begin_render(), state.begin_render());
        let waiter = tokio::spawn({
            let state = Arc::clone(&state);
            async move { state.renders_ended().await }
        });
        drop(a);
        tokio::task::yield_now().await;
        assert!(!waiter.is_finished(), "one render is still active");
        drop(b);
        tokio::time::timeout(std::time::Duration::from_secs(5), waiter).await.expect("resolves").unwrap();
    }
}
