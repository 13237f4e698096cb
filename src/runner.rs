//! The render task model every front end shares: render slots (permits), the render on a
//! blocking thread with its frames handed to a sink, cancellation, and a supervisor that stops
//! the render when its caller goes away. `wedge render` runs `run` on its own thread; the
//! `Render` handler (and later sessions) run it through `spawn`. Knows nothing of gRPC: the
//! sink decides what a frame becomes (files, wire chunks).
use crate::pipeline::frame::{Frame, FrameStats, HaltReason};
use crate::pipeline::job::{CancelToken, RenderError, RenderJob};
use crate::pipeline::progressive;
use std::future::Future;
use std::sync::Arc;
use tokio::sync::{OwnedSemaphorePermit, Semaphore};
use tokio::task::{JoinError, JoinHandle};

/// The renders a process runs at once: a request past the limit is refused, not queued.
#[derive(Clone, Debug)]
pub struct Slots {
    permits: Arc<Semaphore>,
    limit: usize,
}

impl Slots {
    pub fn new(limit: usize) -> Slots {
        let limit = limit.max(1);
        Slots { permits: Arc::new(Semaphore::new(limit)), limit }
    }

    pub fn limit(&self) -> usize {
        self.limit
    }

    /// A slot, held until the permit drops; None when all are taken.
    pub fn try_acquire(&self) -> Option<OwnedSemaphorePermit> {
        Arc::clone(&self.permits).try_acquire_owned().ok()
    }
}

/// What a finished render did.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSummary {
    pub passes: u32,
    pub frames_sent: u32,
    pub mean_spp: f64,
    pub halt: HaltReason,
}

#[derive(Debug, PartialEq)]
pub enum RunError<E> {
    /// Cancelled, by the token or by the sink's caller going away.
    Cancelled,
    /// The sink refused a frame (a write failed, the client is gone).
    Sink(E),
}

/// Renders `job` on this thread, handing every `frame_every`-th frame (and always the final
/// one) to `sink`; `frame_every` 0 hands the final frame alone. Frames not handed on are not
/// composed (`progressive::render_frames`). A sink error stops the render at once and is
/// returned.
pub fn run<E>(
    job: &RenderJob,
    cancel: &CancelToken,
    frame_every: u32,
    sink: &mut dyn FnMut(&Frame) -> Result<(), E>,
) -> Result<RunSummary, RunError<E>> {
    run_with_progress(job, cancel, frame_every, &mut |_| {}, sink)
}

/// `run`, also calling `progress` after every pass, composed or not (a progress bar).
pub fn run_with_progress<E>(
    job: &RenderJob,
    cancel: &CancelToken,
    frame_every: u32,
    progress: &mut dyn FnMut(&FrameStats),
    sink: &mut dyn FnMut(&Frame) -> Result<(), E>,
) -> Result<RunSummary, RunError<E>> {
    let mut frames_sent = 0u32;
    let mut failure = None;
    let wanted = |pass: u32| frame_every > 0 && (pass + 1).is_multiple_of(frame_every);
    let result = progressive::render_frames(job, cancel, &wanted, &mut |stats, frame| {
        progress(stats);
        let Some(frame) = frame.filter(|_| stats.is_final || wanted(stats.pass)) else {
            return true;
        };
        match sink(frame) {
            Ok(()) => {
                frames_sent += 1;
                true
            }
            Err(e) => {
                failure = Some(e);
                false
            }
        }
    });
    if let Some(e) = failure {
        return Err(RunError::Sink(e));
    }
    match result {
        Ok(stats) => {
            Ok(RunSummary { passes: stats.pass + 1, frames_sent, mean_spp: stats.mean_spp, halt: stats.halt_reason })
        }
        Err(RenderError::Cancelled) => Err(RunError::Cancelled),
    }
}

/// Runs `task` (which should call `run`) on a blocking thread holding `permit` (whatever holds
/// its render slot), and cancels it
/// when `stop` completes first (the client went away, the server is draining). Resolves to
/// the task's result and, when `stop` fired, what it said.
pub async fn spawn<T: Send + 'static, S>(
    permit: impl Send + 'static,
    cancel: CancelToken,
    stop: impl Future<Output = S>,
    task: impl FnOnce() -> T + Send + 'static,
) -> (Result<T, JoinError>, Option<S>) {
    let mut handle: JoinHandle<T> = tokio::task::spawn_blocking(move || {
        let _permit = permit;
        task()
    });
    tokio::select! {
        r = &mut handle => (r, None),
        s = stop => {
            cancel.cancel();
            (handle.await, Some(s))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::job::{Halt, Method};
    use crate::render::scene::{CameraDesc, SceneBuilder};
    use glam::Vec3;

    fn job(passes: u32) -> RenderJob {
        let b = SceneBuilder::new(CameraDesc {
            position: Vec3::new(0.0, 0.0, 3.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            vertical_fov_deg: 40.0,
            width: 8,
            height: 6,
        });
        RenderJob::new(Arc::new(b.build()), Method::Uniform, Halt::passes(passes))
    }

    #[test]
    fn frames_are_thinned_and_the_final_one_always_sent() {
        let mut passes = Vec::new();
        let r = run::<()>(&job(5), &CancelToken::new(), 2, &mut |f| {
            passes.push(f.stats.pass);
            Ok(())
        })
        .unwrap();
        assert_eq!(passes, [1, 3, 4]);
        assert_eq!((r.passes, r.frames_sent, r.halt), (5, 3, HaltReason::MaxPasses));
        // 0: the final frame alone; progress hears of every pass.
        let (mut passes, mut progress) = (Vec::new(), Vec::new());
        let r = run_with_progress::<()>(&job(5), &CancelToken::new(), 0, &mut |s| progress.push(s.pass), &mut |f| {
            passes.push(f.stats.pass);
            Ok(())
        })
        .unwrap();
        assert_eq!((passes, progress), (vec![4], vec![0, 1, 2, 3, 4]));
        assert_eq!((r.passes, r.frames_sent), (5, 1));
    }

    #[test]
    fn a_sink_error_stops_the_render_and_is_returned() {
        let mut calls = 0;
        let r = run(&job(5), &CancelToken::new(), 1, &mut |_| {
            calls += 1;
            Err("disk full")
        });
        assert_eq!((r, calls), (Err(RunError::Sink("disk full")), 1));
        let cancel = CancelToken::new();
        cancel.cancel();
        assert_eq!(run::<()>(&job(5), &cancel, 1, &mut |_| Ok(())), Err(RunError::Cancelled));
    }

    #[test]
    fn slots_refuse_past_the_limit_and_free_on_drop() {
        let slots = Slots::new(2);
        let (a, b) = (slots.try_acquire(), slots.try_acquire());
        assert!(a.is_some() && b.is_some() && slots.try_acquire().is_none());
        drop(a);
        assert!(slots.try_acquire().is_some());
        assert_eq!(Slots::new(0).limit(), 1);
    }

    #[tokio::test]
    async fn the_stop_future_cancels_the_render() {
        let slots = Slots::new(1);
        let cancel = CancelToken::new();
        let (c, j) = (cancel.clone(), job(1_000_000));
        let (result, stopped) = spawn(slots.try_acquire().unwrap(), cancel, std::future::ready(()), move || {
            run::<()>(&j, &c, 1, &mut |_| Ok(()))
        })
        .await;
        assert_eq!(stopped, Some(()));
        assert_eq!(result.unwrap(), Err(RunError::Cancelled));
        assert!(slots.try_acquire().is_some(), "the slot is free again");
    }
}
