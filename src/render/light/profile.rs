//! Importance sampling of a Gaussian rectangle's emission profile: where to place light
//! samples so that their density follows it.

/// Importance sampling of a Gaussian rectangle's profile, one edge at a time (the profile of a
/// rectangle is separable): each edge's truncated Gaussian distribution function is inverted
/// exactly (erf, Newton's method inside a bracket) at `SEGMENTS` + 1 evenly spaced
/// probabilities, and `place` interpolates the inverse linearly between them. Segment j = floor(u
/// SEGMENTS) holds probability 1 / SEGMENTS, so the density actually sampled is piecewise
/// constant, 1 / (SEGMENTS (x_{j+1} - x_j)), and `sample` divides by exactly that density: the
/// estimate is unbiased, and a lookup is one read of two neighbours with no search (it runs
/// twice per light sample; the two tables take 32 KB). Within a segment the profile barely
/// changes where its mass lies (by under 1% within 2 sigma of the centre); in the tails the
/// segments widen and a sample's weight varies more (by 18% across the segment at 3 sigma),
/// but they hold a few samples in a thousand. Sample weights therefore
/// barely vary instead of ranging over the profile's whole span (a factor e^4.5 at +-3 sigma
/// under uniform placement, which made such lights far noisier). The authors placed samples
/// uniformly and weighted them by the profile (methods.md §1.1); either way a sample's weight is
/// radiance over density, and AAF's visibility ratio (Eq. 10) is the same estimator.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ProfileSampler {
    pub(super) u: EdgeDistribution,
    pub(super) v: EdgeDistribution,
}

#[derive(Clone, Debug, PartialEq)]
pub(super) struct EdgeDistribution {
    /// inverse[j]: the edge parameter (0 to 1) below which a fraction j / SEGMENTS of the
    /// edge's emitted power lies.
    pub(super) inverse: Box<[f32; ProfileSampler::SEGMENTS + 1]>,
}

impl ProfileSampler {
    pub(super) const SEGMENTS: usize = 4096;

    pub(super) fn new(len_u: f64, len_v: f64, sigma: f64) -> Self {
        ProfileSampler { u: EdgeDistribution::new(len_u, sigma), v: EdgeDistribution::new(len_v, sigma) }
    }
}

impl EdgeDistribution {
    /// An edge of length `len` under a profile of standard deviation `sigma`.
    pub(super) fn new(len: f64, sigma: f64) -> Self {
        const N: usize = ProfileSampler::SEGMENTS;
        // At edge parameter x the point lies z = (x - 1/2) len / sigma sigmas from the centre,
        // and erf's argument z / sqrt(2) is bound (2x - 1): F(x) = (erf(bound (2x - 1)) +
        // erf(bound)) / (2 erf(bound)).
        let bound = 0.5 * len / (sigma * std::f64::consts::SQRT_2);
        let half = libm::erf(bound);
        let mass = 2.0 * half;
        let cdf = |x: f64| (libm::erf(bound * (2.0 * x - 1.0)) + half) / mass;
        let pdf = |x: f64| {
            let z = bound * (2.0 * x - 1.0);
            4.0 * bound * (-z * z).exp() / (std::f64::consts::PI.sqrt() * mass)
        };
        let mut inverse = Box::new([0.0f32; N + 1]);
        inverse[N] = 1.0;
        let mut x = 0.0f64;
        for (j, out) in inverse.iter_mut().enumerate().take(N).skip(1) {
            let u = j as f64 / N as f64;
            // F is increasing: keep the root bracketed and fall back to bisection wherever a
            // Newton step would leave the bracket (in the flat tails). The first guess steps
            // one segment's mass along the density at the last root.
            let (mut lo, mut hi) = (x, 1.0f64);
            let guess = x + 1.0 / (N as f64 * pdf(x));
            x = if guess > lo && guess < hi { guess } else { 0.5 * (lo + hi) };
            for _ in 0..100 {
                let f = cdf(x) - u;
                if f.abs() <= 1e-15 {
                    break;
                }
                if f < 0.0 {
                    lo = x;
                } else {
                    hi = x;
                }
                let step = x - f / pdf(x);
                x = if step > lo && step < hi { step } else { 0.5 * (lo + hi) };
                if hi - lo <= 1e-15 {
                    break;
                }
            }
            *out = x as f32;
        }
        EdgeDistribution { inverse }
    }

    /// The edge parameter for `u` in [0, 1) and the reciprocal of the density of that
    /// parameter there.
    #[inline]
    pub(super) fn place(&self, u: f32) -> (f32, f32) {
        const N: usize = ProfileSampler::SEGMENTS;
        let s = u.clamp(0.0, 1.0) * N as f32;
        let j = (s as usize).min(N - 1);
        let (x0, x1) = (self.inverse[j], self.inverse[j + 1]);
        let width = x1 - x0;
        (x0 + (s - j as f32) * width, width * N as f32)
    }

    /// The reciprocal density `place` gives edge parameter `x` in [0, 1]: that of the segment
    /// holding it (a binary search; `place`'s inverse, for a point found by a ray).
    pub(super) fn reciprocal_density(&self, x: f32) -> f32 {
        const N: usize = ProfileSampler::SEGMENTS;
        let j = self.inverse.partition_point(|&e| e <= x).clamp(1, N) - 1;
        (self.inverse[j + 1] - self.inverse[j]) * N as f32
    }
}
