"""Split the error of a method's frames into bias and variance against a reference.

Given N renders of the same frame with different seeds, the mean squared error against the
reference splits into the per-pixel variance across seeds (its unbiased estimate) and the
squared bias, (mean - reference)^2 minus the variance of that mean (variance / N). Pixels
are also grouped by the filter width the frame used (the EXR's `filter_width` channel).

    for s in 1 2 3 4 5 6 7 8; do
      wedge render grids --method aaf --max-passes 3 --width 640 --height 480 \\
          --pixel-centers --seed $s --out /tmp/aaf/s$s
    done
    python3 bench/bias_variance.py REFERENCE.exr '/tmp/aaf/s*/final.exr'

REFERENCE.exr is a high-spp `uniform` render of the same view (`wedge bench` caches one in
bench-results/cache/). Needs numpy and mitsuba (for reading EXR).
"""
import glob
import sys

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")


def load(path):
    return np.array(mi.Bitmap(path), copy=False).astype(np.float64)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    ref = load(sys.argv[1])[..., :3]
    paths = sorted(glob.glob(sys.argv[2]))
    if len(paths) < 2:
        sys.exit(f"{sys.argv[2]}: need at least two renders, found {len(paths)}")
    imgs = np.stack([load(p) for p in paths])
    rgb, width_px = imgs[..., :3], imgs[0, ..., 3]
    n = len(paths)
    var = rgb.var(0, ddof=1)
    bias2 = (rgb.mean(0) - ref) ** 2 - var / n
    mse = ((rgb - ref) ** 2).mean(axis=(1, 2, 3))
    print(f"{n} renders; RMSE each: {np.sqrt(mse).round(5)}")
    print(f"MSE {mse.mean():.3e} = variance {var.mean():.3e} + bias^2 {bias2.mean():.3e}")
    for lo, hi in [(0, 0), (0, 0.5), (0.5, 1), (1, 2), (2, 4), (4, 8), (8, np.inf)]:
        m = (width_px == 0) if hi == 0 else (width_px > lo) & (width_px <= hi)
        if m.any():
            label = "unfiltered" if hi == 0 else f"width ({lo}, {hi}] px"
            share = m.mean()
            print(f"{label:>20}: {share:6.1%} of pixels, variance {var[m].mean() * share:.3e}, "
                  f"bias^2 {bias2[m].mean() * share:.3e}")


if __name__ == "__main__":
    main()
