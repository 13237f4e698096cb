"""Split the error of a method's frames into bias and variance against a reference, and say
where in the image each sits.

Given N renders of the same frame with different seeds, the mean squared error against the
reference splits into the per-pixel variance across seeds (its unbiased estimate) and the
squared bias, (mean - reference)^2 minus the variance of that mean (variance / N). Pixels are
grouped twice:
- by a per-pixel layer of the first render (`--group-by`, default `filter_width`; `bandwidth`
  for the `bandwidth` method), in bins of its value;
- when the renders carry the denoiser layers (`wedge render --aovs`), by geometry: creases (the
  shading normal turns by more than `--normal-step` to a 4-neighbour: two faces of a room meet),
  depth edges (the depth jumps by more than `--depth-step` of the nearer), the pixels within
  `--near` px of either, and the rest. Each class gets its share of the MSE, the variance, the
  squared bias and the mean signed error (positive: too bright).

    for s in 1 2 3 4 5; do
      wedge render cornell --method auto --bounces 1 --time 1 --width 320 --height 320 \\
          --aovs --seed $s --out /tmp/auto/s$s
    done
    python3 bench/bias_variance.py REFERENCE.exr '/tmp/auto/s*/final.exr' --exclude-above 1

REFERENCE.exr is a high-spp `uniform` render of the same view (`wedge bench` and
`bench/race.py` cache one in bench-results/cache/). `--exclude-above 1` leaves out the pixels
whose reference exceeds 1 in a channel and their 8 neighbours (an area light and its edge), as
the race does. Needs numpy, scipy and mitsuba (for reading EXR layers).
"""
import argparse
import glob
import sys

import mitsuba as mi
import numpy as np
from scipy.ndimage import binary_dilation

mi.set_variant("scalar_rgb")


def layers(path):
    """The EXR's layers by name ('<root>' is the image), each H x W x C in float64."""
    out = {}
    for name, bitmap in mi.Bitmap(path).split():
        a = np.array(bitmap, copy=False).astype(np.float64)
        out[name] = a if a.ndim == 3 else a[..., None]
    return out


def edge_classes(first, normal_step, depth_step, near):
    """Masks of creases, depth edges, pixels near either and the rest; None without AOVs."""
    if "normal" not in first or "depth" not in first:
        return None
    n, d = first["normal"][..., :3], first["depth"][..., 0]
    shape = d.shape
    crease, depth = np.zeros(shape, bool), np.zeros(shape, bool)
    for axis in (0, 1):
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis], hi[axis] = slice(None, -1), slice(1, None)
        a_n, b_n, a_d, b_d = n[tuple(lo)], n[tuple(hi)], d[tuple(lo)], d[tuple(hi)]
        # Pixels without a surface (a zero normal: emitters, the background) make no edge.
        both = (np.abs(a_n).sum(axis=-1) > 0) & (np.abs(b_n).sum(axis=-1) > 0)
        turn = both & ((a_n * b_n).sum(axis=-1) < np.cos(np.radians(normal_step)))
        with np.errstate(invalid="ignore"):
            jump = both & (np.abs(a_d - b_d) > depth_step * np.minimum(a_d, b_d))
        for mask, b in ((crease, turn), (depth, jump)):
            view_lo, view_hi = mask[tuple(lo)], mask[tuple(hi)]
            view_lo |= b
            view_hi |= b
    crease &= ~depth
    edge = crease | depth
    near_edge = binary_dilation(edge, np.ones((2 * near + 1, 2 * near + 1))) & ~edge
    surface = np.abs(n).sum(axis=-1) > 0
    return [("crease", crease), ("depth edge", depth), (f"within {near} px", near_edge & surface),
            ("interior", ~edge & ~near_edge & surface), ("no surface", ~surface)]


def report(label, m, keep, err, var, bias2, signed, total):
    m = m & keep
    if not m.any():
        return
    k = keep.sum()
    print(f"{label:>22}: {m.sum() / k:6.1%} of pixels, {err[m].sum() / total:6.1%} of the MSE; "
          f"variance {var[m].sum() / k:.3e}, bias^2 {bias2[m].sum() / k:.3e}, "
          f"mean signed error {signed[m].mean():+.2e}")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("reference")
    ap.add_argument("renders", help="glob of the renders' EXRs (quoted)")
    ap.add_argument("--group-by", default="filter_width", help="per-pixel layer to bin by")
    ap.add_argument("--exclude-above", type=float, default=None)
    ap.add_argument("--normal-step", type=float, default=25.0, help="degrees")
    ap.add_argument("--depth-step", type=float, default=0.02, help="fraction of the nearer depth")
    ap.add_argument("--near", type=int, default=2, help="pixels")
    args = ap.parse_args(argv)
    ref = layers(args.reference)["<root>"][..., :3]
    paths = sorted(glob.glob(args.renders))
    if len(paths) < 2:
        sys.exit(f"{args.renders}: need at least two renders, found {len(paths)}")
    renders = [layers(p) for p in paths]
    rgb = np.stack([r["<root>"][..., :3] for r in renders])
    if rgb.shape[1:] != ref.shape:
        sys.exit(f"renders are {rgb.shape[1:3]}, the reference {ref.shape[:2]}")
    keep = np.ones(ref.shape[:2], bool)
    if args.exclude_above is not None:
        keep = ~binary_dilation((ref > args.exclude_above).any(axis=2), np.ones((3, 3)))
    n = len(paths)
    # Per pixel, summed over the channels' means (one number per pixel, as RMSE averages them).
    var = rgb.var(0, ddof=1).mean(axis=2)
    bias2 = ((rgb.mean(0) - ref) ** 2).mean(axis=2) - var / n
    err = ((rgb - ref) ** 2).mean(axis=(0, 3))
    signed = (rgb.mean(0) - ref).mean(axis=2)
    total = err[keep].sum()
    rmse = [np.sqrt(((r - ref) ** 2).mean(axis=2)[keep].mean()) for r in rgb]
    print(f"{n} renders, {keep.mean():.1%} of pixels kept; RMSE each: {np.round(rmse, 5)}")
    print(f"MSE {err[keep].mean():.3e} = variance {var[keep].mean():.3e} + bias^2 {bias2[keep].mean():.3e}")
    group = renders[0].get(args.group_by)
    if group is None:
        print(f"(no `{args.group_by}` layer in {paths[0]})")
    else:
        g = group[..., 0]
        print(f"by {args.group_by}:")
        for lo, hi in [(0, 0), (0, 0.5), (0.5, 1), (1, 2), (2, 4), (4, 8), (8, np.inf)]:
            m = (g == 0) if hi == 0 else (g > lo) & (g <= hi)
            report("0" if hi == 0 else f"({lo}, {hi}]", m, keep, err, var, bias2, signed, total)
    classes = edge_classes(renders[0], args.normal_step, args.depth_step, args.near)
    if classes is None:
        print("(no normal and depth layers: render with --aovs for the geometric split)")
    else:
        print("by geometry:")
        for label, m in classes:
            report(label, m, keep, err, var, bias2, signed, total)


if __name__ == "__main__":
    main()
