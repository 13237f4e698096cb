"""Per-seed errors at equal spp for this build and an earlier one: the mean squared error over
seeds next to the median RMSE the race reports, and the share of the squared error in the worst
1% of pixels. A heavy-tailed estimator (rare, huge samples) has a mean far above its median,
which medians of a few seeds hide. Not run in CI.

    python3 bench/seeds.py scenes/glossy-plates.json --reference bench-results/cache/race-...exr \\
        --method uniform --spp 16 --seeds 8 --wedge-base OLD/target/release/wedge

The reference is a race reference (`bench/race.py` caches it); errors leave out the pixels above
1 in it and their 8 neighbours, as the race does.
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mitsuba_compare as mc  # noqa: E402


def kept(ref):
    bright = (ref > 1).any(axis=2)
    mask = bright.copy()
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            mask |= np.roll(np.roll(bright, dy, 0), dx, 1)
    return ~mask


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--reference", required=True)
    ap.add_argument("--method", default="uniform")
    ap.add_argument("--spp", default="16", help="comma-separated")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--wedge-base", help="an earlier build to compare with")
    args = ap.parse_args()
    ref = mc.read_wedge_exr(args.reference)
    keep = kept(ref)
    builds = [("this build", mc.WEDGE)] + ([("base", args.wedge_base)] if args.wedge_base else [])
    print("| spp | build | mean MSE over seeds | median RMSE | worst 1% of pixels' share of the squared error |")
    print("|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for spp in (int(s) for s in args.spp.split(",")):
            for name, binary in builds:
                mse, share = [], []
                for seed in range(1, args.seeds + 1):
                    subprocess.run([binary, "render", args.scene, "--out", tmp, "--width", str(ref.shape[1]),
                                    "--height", str(ref.shape[0]), "--method", args.method, "--max-spp", str(spp),
                                    "--seed", str(seed)], check=True, capture_output=True)
                    e = ((mc.read_wedge_exr(os.path.join(tmp, "final.exr")) - ref) ** 2).mean(axis=2)[keep]
                    mse.append(e.mean())
                    worst = np.sort(e)[::-1]
                    share.append(worst[: len(worst) // 100].sum() / worst.sum())
                print(f"| {spp} | {name} | {np.mean(mse):.3e} | {np.median(np.sqrt(mse)):.5f} | {np.median(share):.2f} |",
                      flush=True)


if __name__ == "__main__":
    main()
