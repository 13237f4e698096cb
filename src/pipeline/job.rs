//! What every layer of a render shares: the job, its view, its halt conditions, the cancel token
//! and the stop check, and the render error. The leaf of the pipeline: it imports only the core
//! (`render`) and the methods' option types (plain data, `methods::*::options`), so that
//! strategies, the pass loop, the runner and the front ends can all import it downwards.
use crate::methods::aaf_indirect::options::IndirectOptions;
use crate::methods::aaf_shadows::options::AafOptions;
use crate::methods::auto::options::AutoOptions;
use crate::methods::bandwidth::options::BandwidthOptions;
use crate::methods::lobe_aware::options::LobeAwareOptions;
use crate::methods::uniform::options::UniformOptions;
use crate::render::camera::Camera;
pub use crate::render::integrator::Integrand;
use crate::render::scene::Scene;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Shared flag that stops a render within one pixel's work.
#[derive(Clone, Debug, Default)]
pub struct CancelToken(Arc<AtomicBool>);

impl CancelToken {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn cancel(&self) {
        self.0.store(true, Ordering::Relaxed);
    }
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::Relaxed)
    }
}

/// Halt conditions; the render stops at whichever is met first. Every render yields at least
/// one frame, and every frame is complete: the first pass always finishes (it is made cheap
/// enough to), and a later pass cut by the deadline ends in a valid estimate of every pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Halt {
    pub max_passes: u32,
    pub max_mean_spp: f64,
    pub time_budget: Option<Duration>,
    /// Stop once the render's own estimate of the image's relative RMSE falls to this value
    /// (`pipeline::noise`); `None`: no noise target.
    pub target_error: Option<f64>,
}

impl Halt {
    /// Only a pass count.
    pub fn passes(max_passes: u32) -> Halt {
        Halt { max_passes, max_mean_spp: f64::INFINITY, time_budget: None, target_error: None }
    }
}

/// The methods; `pipeline::registry` has one row for each (names, parts, constructor).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Method {
    Uniform,
    Aaf,
    Adaptive,
    UniformFiltered,
    LobeAware,
    NormalAware,
    Auto,
    Bandwidth,
}

/// One render: the compiled scene, the view it is seen from, the method and its options.
#[derive(Clone, Debug)]
pub struct RenderJob {
    pub scene: Arc<Scene>,
    /// Camera and resolution, in the scene's internal frame (`Scene::view`).
    pub view: Camera,
    pub method: Method,
    pub halt: Halt,
    pub seed: u64,
    /// Indirect bounces after the first hit (0: direct light only).
    pub bounces: u32,
    /// Samples per pixel of the first uniform pass.
    pub initial_spp: u32,
    /// Light or ambient occlusion.
    pub integrand: Integrand,
    /// Shade every sample at its pixel's centre (the AAF papers' setting, no antialiasing):
    /// the ground truth is then the pixel-centre image. Default: samples jittered over the pixel.
    pub pixel_centers: bool,
    /// Parameters of the AAF family of methods (soft shadows).
    pub aaf: AafOptions,
    /// Parameters of the AAF family of methods (indirect light).
    pub indirect: IndirectOptions,
    /// Parameters of the lobe-aware filter (Tokuyoshi 2015) and its normal-aware baseline.
    pub lobe: LobeAwareOptions,
    /// Parameters of `auto` (its widths' schedule and the gather); it also reads `aaf`,
    /// `indirect` and `lobe` for the papers' own constants.
    pub auto: AutoOptions,
    /// Parameters of `bandwidth` (Bagher et al. 2012).
    pub bandwidth: BandwidthOptions,
    /// Parameters of `uniform`'s path tracer (splitting at the first hit, `splitting`).
    pub uniform: UniformOptions,
    /// Camera rays per pixel of the denoiser inputs (albedo, normal, depth: `render::aovs`),
    /// traced once before pass 0 and attached to every frame; 0 traces none.
    pub aov_samples: u32,
}

impl RenderJob {
    /// A job of `method` on `scene` from its own camera, with every other setting at its
    /// default: direct light, 1 initial spp, jittered pixels, seed 0.
    pub fn new(scene: Arc<Scene>, method: Method, halt: Halt) -> RenderJob {
        RenderJob {
            view: scene.default_view(),
            scene,
            method,
            halt,
            seed: 0,
            bounces: 0,
            initial_spp: 1,
            integrand: Integrand::Radiance,
            pixel_centers: false,
            aaf: AafOptions::default(),
            indirect: IndirectOptions::default(),
            lobe: LobeAwareOptions::default(),
            auto: AutoOptions::default(),
            bandwidth: BandwidthOptions::default(),
            uniform: UniformOptions::default(),
            aov_samples: 0,
        }
    }

    pub fn width(&self) -> u32 {
        self.view.width
    }

    pub fn height(&self) -> u32 {
        self.view.height
    }
}

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    #[error("render cancelled")]
    Cancelled,
}

/// Tells a pass when to stop early: on cancellation (the render ends) or at the time-budget
/// deadline (the pass ends with the samples it has, and its frame becomes the final one).
#[derive(Clone, Debug)]
pub struct StopCheck {
    pub cancel: CancelToken,
    pub deadline: Option<Instant>,
    /// Tests only: a deadline counted in stop checks rather than in time, so that a test can
    /// cut a pass part-way whatever the machine's load (see `tests::cut_pass_after_checks`).
    #[cfg(test)]
    checks_left: Option<Arc<std::sync::atomic::AtomicI64>>,
}

impl StopCheck {
    /// A check that only a cancellation trips: for the first pass, which always completes.
    pub fn cancel_only(cancel: &CancelToken) -> StopCheck {
        StopCheck::new(cancel, None)
    }

    pub fn new(cancel: &CancelToken, deadline: Option<Instant>) -> StopCheck {
        StopCheck {
            cancel: cancel.clone(),
            deadline,
            #[cfg(test)]
            checks_left: None,
        }
    }

    /// The check for `pass` of a render: pass 0 always completes, later ones stop at the
    /// deadline.
    pub fn for_pass(cancel: &CancelToken, pass: u32, deadline: Option<Instant>) -> StopCheck {
        #[allow(unused_mut)]
        let mut stop = StopCheck::new(cancel, if pass == 0 { None } else { deadline });
        #[cfg(test)]
        if let Some((_, checks)) = tests::CUT.with(|c| c.get()).filter(|&(cut, _)| cut == pass && pass > 0) {
            stop.checks_left = Some(Arc::new(std::sync::atomic::AtomicI64::new(checks)));
        }
        stop
    }

    #[inline]
    pub fn should_stop(&self) -> bool {
        #[cfg(test)]
        if let Some(left) = &self.checks_left {
            if left.fetch_sub(1, Ordering::Relaxed) <= 0 {
                return true;
            }
        }
        self.cancel.is_cancelled() || self.deadline.is_some_and(|d| clock_due() && Instant::now() >= d)
    }

    pub fn is_cancelled(&self) -> bool {
        self.cancel.is_cancelled()
    }

    /// Whether anything but a cancellation can stop the pass: a deadline (or a test's cut).
    /// Without one, a pass either completes or is thrown away, so a method that sweeps the
    /// image several times to keep a cut pass even can trace each pixel's samples in one go.
    pub fn can_cut(&self) -> bool {
        #[cfg(test)]
        if self.checks_left.is_some() {
            return true;
        }
        self.deadline.is_some()
    }
}

/// A thread reads the clock at every this many stop checks. The methods check once per pixel
/// and sweep of the image, and in the sweeps of a pass's adaptive extras most pixels have
/// nothing to add, so reading the clock at each check cost more than the bookkeeping it
/// guards. A deadline is then overrun by at most this many pixels' work per thread, which
/// grows with a pass's samples as the budget does.
const CLOCK_EVERY: u32 = 8;

thread_local! {
    static CHECKS: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Whether this check is one of the `CLOCK_EVERY` that read the clock.
#[inline]
fn clock_due() -> bool {
    CHECKS.with(|c| {
        let n = c.get().wrapping_add(1);
        c.set(n);
        n.is_multiple_of(CLOCK_EVERY)
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use std::cell::Cell;

    thread_local! {
        /// The pass to cut and the number of stop checks it passes first, for renders started
        /// on this thread.
        pub(super) static CUT: Cell<Option<(u32, i64)>> = const { Cell::new(None) };
    }

    /// Runs `f` with every render it starts on this thread cutting `pass` after `checks` stop
    /// checks, as a deadline would, but at the same point of the work on any machine.
    pub(crate) fn cut_pass_after_checks<T>(pass: u32, checks: i64, f: impl FnOnce() -> T) -> T {
        CUT.with(|c| c.set(Some((pass, checks))));
        let out = f();
        CUT.with(|c| c.set(None));
        out
    }

    /// A passed deadline stops within `CLOCK_EVERY` checks on a thread, a cancellation at the
    /// next check, and a deadline ahead or none never.
    #[test]
    fn a_passed_deadline_stops_within_a_few_checks() {
        use super::{CancelToken, StopCheck, CLOCK_EVERY};
        use std::time::{Duration, Instant};
        let cancel = CancelToken::default();
        let passed = StopCheck::new(&cancel, Some(Instant::now() - Duration::from_millis(1)));
        let first = (1..=2 * CLOCK_EVERY).find(|_| passed.should_stop());
        assert!(first.is_some_and(|n| n <= CLOCK_EVERY), "stopped at check {first:?}");
        let ahead = StopCheck::new(&cancel, Some(Instant::now() + Duration::from_secs(3600)));
        let none = StopCheck::new(&cancel, None);
        assert!((0..4 * CLOCK_EVERY).all(|_| !ahead.should_stop() && !none.should_stop()));
        cancel.cancel();
        assert!(ahead.should_stop() && none.should_stop());
    }
}
