//! `wedge bench throughput`: samples and rays per second of the `uniform` path tracer (the
//! integrator every method samples with), per scene, bounce count and thread count.
//!
//! Each measurement traces `spp` jittered camera paths per pixel into a fresh film, timed from
//! the first sample to the last (no scene build, no frame output), as a render's passes do. The
//! films of every thread count are compared: the sampler makes them bit-identical, and a
//! difference is reported rather than hidden. The thread counts take turns, one trace each per
//! round, so that a drift in the machine's speed (some hosts move by tens of per cent within
//! the hour) falls on all of them alike, and the scaling is the median of each round's own
//! ratio.
use crate::pipeline::film::Film;
use crate::pipeline::job::{CancelToken, Halt, Method, RenderJob, StopCheck};
use crate::render::scene::Scene;
use std::sync::Arc;
use std::time::Instant;

/// One scene at one bounce count on one thread count.
#[derive(Clone, Debug)]
pub struct Measurement {
    pub threads: usize,
    /// Median seconds of the repeats.
    pub seconds: f64,
    /// Each round's seconds, in order (`seconds` is their median).
    pub rounds: Vec<f64>,
    pub samples: u64,
    /// Rays traced per repeat (camera, shadow and bounce rays).
    pub rays: u64,
}

impl Measurement {
    pub fn samples_per_second(&self) -> f64 {
        self.samples as f64 / self.seconds
    }

    pub fn rays_per_second(&self) -> f64 {
        self.rays as f64 / self.seconds
    }
}

/// What one scene and bounce count gave on each thread count.
#[derive(Clone, Debug)]
pub struct SceneThroughput {
    pub bounces: u32,
    pub spp: u32,
    pub by_threads: Vec<Measurement>,
    /// Whether every thread count produced the same film, bit for bit.
    pub identical: bool,
}

impl SceneThroughput {
    /// Samples per second on the most threads over those on one (None without both): the
    /// median over the rounds of each round's ratio, the two traces of a round taken minutes
    /// apart at most.
    pub fn scaling(&self) -> Option<f64> {
        let one = self.by_threads.iter().find(|m| m.threads == 1)?;
        let most = self.by_threads.iter().max_by_key(|m| m.threads).filter(|m| m.threads > 1)?;
        let ratios = one.rounds.iter().zip(&most.rounds).map(|(a, b)| a / b).collect();
        Some(super::median(ratios))
    }
}

/// The uniform job the benchmark traces: the scene's own view, jittered pixels, `bounces`,
/// one path per sample (no splitting at the first hit, `pipeline::splitting`): the path
/// tracer's own speed, comparable with another renderer's samples per second.
pub fn job(scene: Arc<Scene>, bounces: u32, seed: u64) -> RenderJob {
    let mut job = RenderJob::new(scene, Method::Uniform, Halt::passes(1));
    (job.bounces, job.seed, job.uniform.max_splits) = (bounces, seed, 1);
    job
}

/// Traces `spp` samples per pixel of `job` into a new film on a pool of `threads` threads.
fn trace_once(job: &RenderJob, spp: u32, pool: &rayon::ThreadPool) -> anyhow::Result<(f64, u64, Film)> {
    let mut film = Film::new(job.width(), job.height());
    let stop = StopCheck::cancel_only(&CancelToken::new());
    let start = Instant::now();
    let tally = pool.install(|| film.add_samples(&job.scene, job, &|_| spp, &stop))?;
    Ok((start.elapsed().as_secs_f64(), tally.rays, film))
}

/// Measures `job` at `spp` on each of `threads`: one untimed warm-up trace per thread count,
/// then `repeats` rounds in which each thread count traces once in turn (the median is kept).
pub fn measure(job: &RenderJob, spp: u32, threads: &[usize], repeats: usize) -> anyhow::Result<SceneThroughput> {
    anyhow::ensure!(spp > 0, "--spp must be at least 1");
    anyhow::ensure!(threads.iter().all(|&n| n > 0), "--threads: thread counts must be at least 1");
    let samples = job.width() as u64 * job.height() as u64 * spp as u64;
    let mut pools = Vec::new();
    let mut by_threads = Vec::new();
    let mut first_film: Option<Film> = None;
    let mut identical = true;
    for &n in threads {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build()?;
        let (_, rays, film) = trace_once(job, spp, &pool)?;
        match &first_film {
            None => first_film = Some(film),
            Some(f) => identical &= f.pixels == film.pixels,
        }
        pools.push(pool);
        by_threads.push(Measurement { threads: n, seconds: 0.0, rounds: Vec::new(), samples, rays });
    }
    for _ in 0..repeats.max(1) {
        for (m, pool) in by_threads.iter_mut().zip(&pools) {
            m.rounds.push(trace_once(job, spp, pool)?.0);
        }
    }
    for m in &mut by_threads {
        m.seconds = super::median(m.rounds.clone());
    }
    Ok(SceneThroughput { bounces: job.bounces, spp, by_threads, identical })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::rays::terrain_builder;

    /// A drift between rounds moves both thread counts of a round alike: the median of the
    /// rounds' ratios sees through it where the ratio of the medians does not.
    #[test]
    fn scaling_is_the_median_of_each_rounds_ratio() {
        let m = |threads, rounds: Vec<f64>| Measurement {
            threads,
            seconds: crate::bench::median(rounds.clone()),
            rounds,
            samples: 100,
            rays: 100,
        };
        // The machine slows down 2x after the first round.
        let t = SceneThroughput {
            bounces: 0,
            spp: 1,
            by_threads: vec![m(1, vec![1.0, 2.0, 2.2]), m(2, vec![0.5, 1.0, 1.2])],
            identical: true,
        };
        assert_eq!(t.scaling(), Some(2.0));
        assert!((t.by_threads[1].samples_per_second() / t.by_threads[0].samples_per_second() - 2.0).abs() < 1e-9);
        let alone = SceneThroughput { by_threads: vec![m(1, vec![1.0])], ..t };
        assert_eq!(alone.scaling(), None);
    }

    #[test]
    fn counts_samples_and_rays_and_films_agree_across_threads() {
        let scene = Arc::new(terrain_builder(2_000, 12, 8).build());
        let t = measure(&job(scene.clone(), 1, 3), 2, &[1, 2], 1).unwrap();
        assert!(t.identical);
        assert_eq!(t.by_threads.len(), 2);
        for m in &t.by_threads {
            assert_eq!(m.samples, 12 * 8 * 2);
            // At least the camera ray of every sample; at most camera, shadow, bounce and the
            // bounce's shadow ray.
            assert!((m.samples..=4 * m.samples).contains(&m.rays), "{} rays", m.rays);
            assert!(m.seconds > 0.0 && m.samples_per_second().is_finite());
        }
        assert_eq!(t.by_threads[0].rays, t.by_threads[1].rays);
        // The scaling is the median of each round's ratio of the two thread counts' seconds.
        let ratio = t.by_threads[0].rounds[0] / t.by_threads[1].rounds[0];
        assert_eq!(t.scaling(), Some(ratio));
        // Direct light only: one camera ray and one shadow ray at most per sample.
        let d = measure(&job(scene, 0, 3), 1, &[1], 1).unwrap();
        assert!(d.by_threads[0].rays <= 2 * d.by_threads[0].samples);
        assert!(d.scaling().is_none());
        assert!(measure(&job(Arc::new(terrain_builder(200, 4, 4).build()), 0, 3), 0, &[1], 1).is_err());
    }
}
