//! Per-pixel running estimates (f64 sums) and the parallel loop that adds samples to them.
use super::job::{RenderError, RenderJob, StopCheck};
use super::splitting::{self, MAX_SPLITS};
use crate::render::camera_samples::CameraSamples;
use crate::render::huge_pages::filled;
use crate::render::integrator::{path_pairs, radiance_split, sample_from, PathResult};
use crate::render::sampler::PixelSampler;
use crate::render::scene::Scene;
use crate::render::wide_bvh::MAX_PACKET;
use glam::Vec3;
use rayon::prelude::*;

/// Rows per unit of parallel work. Stop requests are checked before every pixel.
const BAND_ROWS: usize = 4;

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelEstimate {
    pub sum: [f64; 3],
    /// Finite samples in `sum`.
    pub n: u32,
    /// Samples drawn, including dropped non-finite ones: the next sample's index.
    pub taken: u32,
}

impl PixelEstimate {
    pub fn mean(&self) -> [f32; 3] {
        if self.n == 0 {
            return [0.0; 3];
        }
        let k = 1.0 / self.n as f64;
        self.sum.map(|s| (s * k) as f32)
    }
}

/// sum / n per channel (0 for no samples).
pub fn mean(sum: [f64; 3], n: u32) -> [f64; 3] {
    if n == 0 {
        [0.0; 3]
    } else {
        sum.map(|s| s / n as f64)
    }
}

/// What one call of `Film::add_samples` did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Tally {
    pub rays: u64,
    pub dropped: u64,
    /// False when the deadline stopped the pass before every pixel got its samples.
    pub complete: bool,
}

/// The rows of an image of `height` rows in the order a pass traces them: the van der Corput
/// order of their indices (0, h/2, h/4, 3h/4, ...), so that a pass the deadline cuts leaves
/// the rows it reached spread over the image, every unreached row close to reached ones, rather
/// than a band of rows with the previous pass's samples only. Threads split the list into
/// contiguous parts, each again spread over the image.
pub fn interleaved_rows(height: usize) -> Vec<usize> {
    let mut rows: Vec<usize> = (0..height).collect();
    rows.sort_by_key(|&y| interleave_rank(y));
    rows
}

/// Row `y`'s place in `interleaved_rows`' order (sort by it).
pub fn interleave_rank(y: usize) -> u64 {
    (y as u64).reverse_bits()
}

impl Tally {
    /// A pass's outcome from its parts: adds their rays and dropped samples to the running
    /// counts and says whether every pixel got its samples; a cancellation is an error.
    pub fn settle(parts: &[Tally], stop: &StopCheck, rays: &mut u64, dropped: &mut u64) -> Result<bool, RenderError> {
        if stop.is_cancelled() {
            return Err(RenderError::Cancelled);
        }
        let total = Tally::total(parts);
        *rays += total.rays;
        *dropped += total.dropped;
        Ok(total.complete)
    }

    /// The tally of work done in parts (e.g. bands of rows traced in parallel).
    pub fn total(parts: &[Tally]) -> Tally {
        parts.iter().fold(Tally { complete: true, ..Tally::default() }, |a, t| Tally {
            rays: a.rays + t.rays,
            dropped: a.dropped + t.dropped,
            complete: a.complete && t.complete,
        })
    }
}

/// Visits every pixel of `pixels` (row-major, `width` wide) as `visit(scratch, x, y, pixel,
/// tally)`, in parallel over bands of `BAND_ROWS` rows, until `stop` asks. Each band makes one
/// `scratch()` and hands it to every pixel it visits: a visit's working buffers (a packet of
/// camera samples is kilobytes) are then set up once per band, not once per pixel, which
/// mattered where a pass sweeps the image many times for a sample or two per pixel. Returns the
/// bands' tally (not complete if the stop came first), or the cancellation.
pub fn trace_bands<P: Send, S>(
    pixels: &mut [P],
    width: usize,
    stop: &StopCheck,
    scratch: impl Fn() -> S + Sync,
    visit: impl Fn(&mut S, usize, usize, &mut P, &mut Tally) + Sync,
) -> Result<Tally, RenderError> {
    let w = width.max(1);
    let tallies: Vec<Tally> = pixels
        .par_chunks_mut(w * BAND_ROWS)
        .enumerate()
        .map(|(band, rows)| {
            let mut t = Tally { complete: true, ..Tally::default() };
            let mut s = scratch();
            for (r, row) in rows.chunks_mut(w).enumerate() {
                let y = band * BAND_ROWS + r;
                for (x, px) in row.iter_mut().enumerate() {
                    if stop.should_stop() {
                        t.complete = false;
                        return t;
                    }
                    visit(&mut s, x, y, px, &mut t);
                }
            }
            t
        })
        .collect();
    if stop.is_cancelled() {
        return Err(RenderError::Cancelled);
    }
    Ok(Tally::total(&tallies))
}

/// A band's working buffers: a packet of camera samples and a sample's split paths.
struct Scratch {
    camera: CameraSamples,
    splits: [PixelSampler; MAX_SPLITS],
    paths: [PathResult; MAX_SPLITS],
}

#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<PixelEstimate>,
    /// Paths per sample past the first hit (`splitting`), chosen when the first samples are
    /// added.
    pub splits: Option<u32>,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film { width, height, pixels: filled(width as usize * height as usize, PixelEstimate::default()), splits: None }
    }

    /// Traces `count(pixel_index)` more camera samples of `job` (its seed, bounces, integrand and
    /// pixel sampling) for every pixel, in parallel over bands of rows. Each sample's numbers
    /// depend only on (seed, pixel, sample index), and the paths each splits into at its first
    /// hit only on the seed (`splitting`'s pilot, run at the first call), so the result is the
    /// same for any thread count. Non-finite sample values are counted and dropped.
    pub fn add_samples(
        &mut self,
        scene: &Scene,
        job: &RenderJob,
        count: &(dyn Fn(usize) -> u32 + Sync),
        stop: &StopCheck,
    ) -> Result<Tally, RenderError> {
        let (seed, bounces, integrand, pixel_centers) = (job.seed, job.bounces, job.integrand, job.pixel_centers);
        let w = self.width as usize;
        let cam = &job.view;
        // Paths per sample past the first hit: chosen at the first call (`splitting`).
        let k = *self.splits.get_or_insert_with(|| {
            let k = splitting::choose(scene, job);
            tracing::debug!(paths_per_sample = k, "uniform: the pilot's paths per camera sample");
            k
        }) as usize;
        let split = k > 1;
        let first_pairs = path_pairs(scene, integrand, if split { 0 } else { bounces });
        let split_pairs = path_pairs(scene, integrand, bounces) - first_pairs;
        let scratch = || Scratch {
            camera: CameraSamples { pairs_ahead: first_pairs, ..CameraSamples::default() },
            splits: [PixelSampler::new(0, 0, 0); MAX_SPLITS],
            paths: [PathResult::default(); MAX_SPLITS],
        };
        trace_bands(&mut self.pixels, w, stop, scratch, |scratch, x, y, px, t| {
            let Scratch { camera: c, splits, paths } = scratch;
            let index = y * w + x;
            let n = count(index);
            // With pixel centres, every sample of the pass starts at the same hit.
            let centre_hit = (pixel_centers && n > 0).then(|| {
                t.rays += 1;
                scene.intersect(cam.position, cam.direction(x as f32 + 0.5, y as f32 + 0.5), 0.0)
            });
            let split_key = PixelSampler::split_key(PixelSampler::pixel_key(seed, index as u32));
            // The pixel's camera rays go to the BVH a packet at a time (`CameraSamples`). Each
            // sample's numbers and path are its own, and the sums take the samples in order, as
            // one at a time would.
            let mut done = 0;
            while done < n {
                let m = (n - done).min(MAX_PACKET as u32) as usize;
                c.set(cam, seed, (x, y), index as u32, px.taken, m, !pixel_centers);
                match centre_hit {
                    Some(hit) => c.hits[..m].fill(hit),
                    None => t.rays += c.trace(scene, cam.position),
                }
                px.taken += m as u32;
                done += m as u32;
                for i in 0..m {
                    let p = match c.hits[i] {
                        Some(hit) if split => {
                            // Sample s's paths are points s k .. s k + k - 1 of the pixel's
                            // split stream: those of all its samples form one stratified set.
                            let sample = px.taken - m as u32 + i as u32;
                            let (splits, paths) = (&mut splits[..k], &mut paths[..k]);
                            PixelSampler::consecutive(split_key, sample.wrapping_mul(k as u32), splits);
                            PixelSampler::draw_ahead(splits, split_pairs);
                            let first =
                                radiance_split(scene, hit, -c.dirs[i], bounces, &mut c.samplers[i], splits, paths);
                            let mut sum = Vec3::ZERO;
                            let mut rays = first.rays;
                            for p in paths.iter() {
                                sum += p.radiance;
                                rays += p.rays;
                            }
                            PathResult { radiance: first.radiance + sum / k as f32, rays }
                        }
                        hit => sample_from(scene, hit, -c.dirs[i], integrand, bounces, &mut c.samplers[i]),
                    };
                    t.rays += p.rays as u64;
                    if p.radiance.is_finite() {
                        for c in 0..3 {
                            px.sum[c] += p.radiance[c] as f64;
                        }
                        px.n += 1;
                    } else {
                        t.dropped += 1;
                    }
                }
            }
        })
    }

    pub fn mean_image(&self) -> Vec<[f32; 3]> {
        self.pixels.iter().map(PixelEstimate::mean).collect()
    }

    pub fn spp_map(&self) -> Vec<f32> {
        self.pixels.iter().map(|p| p.n as f32).collect()
    }

    /// Mean samples drawn per pixel (kept and dropped).
    pub fn mean_taken(&self) -> f64 {
        if self.pixels.is_empty() {
            return 0.0;
        }
        self.pixels.iter().map(|p| p.taken as f64).sum::<f64>() / self.pixels.len() as f64
    }

    pub fn mean_spp(&self) -> f64 {
        if self.pixels.is_empty() {
            return 0.0;
        }
        self.pixels.iter().map(|p| p.n as f64).sum::<f64>() / self.pixels.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::methods::tests::{builtin, rmse};
    use crate::pipeline::job::{CancelToken, Halt, Method};

    /// The test films' size: large enough that a pixel's camera samples see one wall.
    const W: u32 = 48;
    const H: u32 = 36;

    /// `spp` samples per pixel of `uniform` on `cornell` with a bounce, `splits` paths per sample
    /// (None: the pilot's choice), traced on `threads` threads in two calls, as two passes
    /// make them (the second continues the first's streams).
    fn cornell_film(spp: u32, splits: Option<u32>, seed: u64, threads: usize) -> Film {
        let mut job = RenderJob::new(builtin("cornell", W, H), Method::Uniform, Halt::passes(1));
        (job.bounces, job.seed) = (1, seed);
        let mut film = Film::new(W, H);
        film.splits = splits;
        let stop = StopCheck::cancel_only(&CancelToken::new());
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        for n in [spp / 4, spp - spp / 4] {
            pool.install(|| film.add_samples(&job.scene, &job, &|_| n, &stop)).unwrap();
        }
        film
    }

    /// Samples split into several paths converge to the image unsplit paths converge to, with
    /// less error at equal samples per pixel, and the same bits on any thread count.
    #[test]
    fn split_samples_converge_to_the_unsplit_image_with_less_error() {
        let reference = cornell_film(256, Some(1), 7, 2);
        let split = cornell_film(8, Some(4), 1, 2);
        let plain = cornell_film(8, Some(1), 1, 2);
        // The light's own pixels (and the edges jitter puts in them) are left out: their
        // error is the camera samples', which splitting does not touch.
        let lit = reference.mean_image();
        let kept: Vec<usize> = (0..lit.len()).filter(|&i| lit[i].iter().all(|&v| v < 1.0)).collect();
        let error = |f: &Film| {
            let img = f.mean_image();
            rmse(&kept.iter().map(|&i| img[i]).collect::<Vec<_>>(), &kept.iter().map(|&i| lit[i]).collect::<Vec<_>>())
        };
        assert!(error(&split) < 0.8 * error(&plain), "split {} vs plain {}", error(&split), error(&plain));
        let mean = |f: &Film| f.mean_image().iter().flatten().map(|&v| v as f64).sum::<f64>() / (3 * W * H) as f64;
        let (m, r) = (mean(&split), mean(&reference));
        assert!((m / r - 1.0).abs() < 0.02, "image means: split {m}, reference {r}");
        assert_eq!(split.pixels, cornell_film(8, Some(4), 1, 1).pixels, "one thread against two");
    }

    use super::interleaved_rows;

    /// Every row once, and any prefix spread over the image: after k rows no gap between
    /// reached rows (or to the image's ends) exceeds 2 h / k rows.
    #[test]
    fn interleaved_rows_are_a_permutation_whose_prefixes_spread() {
        for h in [1usize, 2, 7, 240, 320, 1081] {
            let rows = interleaved_rows(h);
            let mut sorted = rows.clone();
            sorted.sort_unstable();
            assert_eq!(sorted, (0..h).collect::<Vec<_>>());
            for k in [2usize, 5, 16, 100].into_iter().filter(|&k| k <= h) {
                let mut reached = rows[..k].to_vec();
                reached.sort_unstable();
                let gaps = reached.windows(2).map(|p| p[1] - p[0]).chain([reached[0], h - 1 - reached[k - 1]]);
                let widest = gaps.max().unwrap();
                assert!(widest <= 2 * h / k + 1, "h {h}, first {k} rows: a gap of {widest}");
            }
        }
    }
}
