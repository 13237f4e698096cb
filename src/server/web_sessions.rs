//! Sessions for clients that cannot stream requests (browsers over gRPC-web): `WatchSession`
//! opens a session whose changes arrive by `UpdateSession` calls naming it. Each open session
//! has a random id and a bounded queue of changes; the session's control task reads the queue
//! as it would read a `Session` call's request stream, so both kinds share one session model.
use super::session::Inbound;
use crate::proto::{session_request, SessionRequest, SessionUpdate};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use tokio::sync::mpsc;
use tokio_stream::wrappers::ReceiverStream;
use tokio_stream::StreamExt;
use tonic::Status;

/// Changes a session may have queued and not yet read, by default (`--web-session-queue`);
/// more get RESOURCE_EXHAUSTED: the client sends faster than the session validates, which
/// only a broken client does (the viewer keeps one update in flight).
pub const DEFAULT_QUEUED_UPDATES: usize = 16;

/// The open sessions, by id.
pub struct WebSessions {
    open: Mutex<HashMap<String, Queue>>,
    /// Changes each session may have queued (at least 1).
    capacity: usize,
}

impl Default for WebSessions {
    fn default() -> Self {
        WebSessions::new(DEFAULT_QUEUED_UPDATES)
    }
}

struct Queue {
    tx: mpsc::Sender<SessionRequest>,
    /// The number the next change will have (the open is 1).
    next_update: u64,
}

/// Keeps a session's id registered; dropping it (when the session ends) removes the id, so
/// that later updates get NOT_FOUND.
pub struct Registration {
    sessions: Arc<WebSessions>,
    id: String,
}

impl Drop for Registration {
    fn drop(&mut self) {
        self.sessions.lock().remove(&self.id);
    }
}

impl WebSessions {
    pub fn new(capacity: usize) -> WebSessions {
        WebSessions { open: Mutex::default(), capacity: capacity.max(1) }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<String, Queue>> {
        self.open.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Registers a new session: its id, the stream of its changes, and the registration that
    /// must live as long as the session.
    pub fn open(self: &Arc<Self>) -> Result<(String, Inbound, Registration), Status> {
        let id = new_id()?;
        let (tx, rx) = mpsc::channel(self.capacity);
        self.lock().insert(id.clone(), Queue { tx, next_update: 2 });
        let inbound: Inbound = Box::pin(ReceiverStream::new(rx).map(Ok));
        Ok((id.clone(), inbound, Registration { sessions: Arc::clone(self), id }))
    }

    /// Queues `update` for the session `id`; the number its acknowledgement will carry.
    pub fn update(&self, id: &str, update: SessionUpdate) -> Result<u64, Status> {
        let mut open = self.lock();
        let Some(queue) = open.get_mut(id) else {
            return Err(Status::not_found(format!(
                "session_id: no open session {:?} (it ended, or the id is wrong): open a new one with WatchSession",
                id.chars().take(64).collect::<String>()
            )));
        };
        let message = SessionRequest { kind: Some(session_request::Kind::Update(update)) };
        match queue.tx.try_send(message) {
            Ok(()) => {
                queue.next_update += 1;
                Ok(queue.next_update - 1)
            }
            Err(mpsc::error::TrySendError::Full(_)) => Err(Status::resource_exhausted(format!(
                "session_id: the session has {} changes not yet read (--web-session-queue): wait for their acknowledgements",
                self.capacity
            ))),
            Err(mpsc::error::TrySendError::Closed(_)) => {
                Err(Status::not_found("session_id: the session has ended: open a new one with WatchSession"))
            }
        }
    }

    /// Sessions open now.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// 128 random bits in hex.
fn new_id() -> Result<String, Status> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).map_err(|e| Status::internal(format!("no randomness for a session id: {e}")))?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn update() -> SessionUpdate {
        SessionUpdate { width: 8, ..Default::default() }
    }

    #[tokio::test]
    async fn updates_are_numbered_from_two_and_arrive_in_order() {
        let sessions = Arc::new(WebSessions::default());
        let (id, mut inbound, _reg) = sessions.open().unwrap();
        assert_eq!(id.len(), 32);
        assert_eq!(sessions.update(&id, update()).unwrap(), 2);
        assert_eq!(sessions.update(&id, SessionUpdate { width: 9, ..Default::default() }).unwrap(), 3);
        for width in [8, 9] {
            let got = inbound.next().await.unwrap().unwrap();
            assert!(matches!(got.kind, Some(session_request::Kind::Update(u)) if u.width == width));
        }
    }

    #[tokio::test]
    async fn a_full_queue_is_refused_and_an_ended_session_is_not_found() {
        let sessions = Arc::new(WebSessions::new(3));
        let (id, _inbound, reg) = sessions.open().unwrap();
        for _ in 0..3 {
            sessions.update(&id, update()).unwrap();
        }
        let full = sessions.update(&id, update()).unwrap_err();
        assert_eq!(full.code(), tonic::Code::ResourceExhausted);
        assert!(full.message().starts_with("session_id: the session has 3 changes"), "{}", full.message());
        drop(reg);
        assert!(sessions.is_empty());
        assert_eq!(sessions.update(&id, update()).unwrap_err().code(), tonic::Code::NotFound);
        assert_eq!(sessions.update("nonsense", update()).unwrap_err().code(), tonic::Code::NotFound);
    }

    #[test]
    fn ids_differ() {
        let sessions = Arc::new(WebSessions::default());
        let (a, _, _ra) = sessions.open().unwrap();
        let (b, _, _rb) = sessions.open().unwrap();
        assert_ne!(a, b);
        assert_eq!(sessions.len(), 2);
    }
}
