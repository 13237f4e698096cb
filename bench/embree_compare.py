#!/usr/bin/env python3
"""Traces the rays that `wedge bench rays --dump DIR` wrote, with Embree (PyPI `embreex`), on the
same machine, and compares rays per second and hits with wedge's numbers from DIR/*/meta.json.

    pip install embreex numpy
    wedge bench rays --dump bench-results/rays
    python3 bench/embree_compare.py bench-results/rays

embreex traces one ray at a time from a C loop (rtcIntersect1/rtcOccluded1) on one thread, so
the fair comparison is wedge's 1-thread figure. The Python call overhead is amortised over the
whole batch; what remains per ray is a few tens of ns of loop and copy cost, which slightly
favours wedge and is stated in the output.
"""
import json
import os
import sys
import time

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def load_f32(path, width):
    a = np.fromfile(path, dtype="<f4")
    return a.reshape(-1, width)


def trace(scene, rays, kind, repeats):
    o = np.ascontiguousarray(rays[:, 0:3])
    d = np.ascontiguousarray(rays[:, 3:6])
    tmax = np.ascontiguousarray(rays[:, 6])
    query = "OCCLUDED" if kind == "shadow" else "INTERSECT"
    best, hits = [], 0
    for _ in range(repeats):
        start = time.perf_counter()
        out = scene.run(o, d, dists=tmax.copy(), query=query)
        best.append(len(o) / (time.perf_counter() - start))
        hits = int(np.count_nonzero(out >= 0))
    best.sort()
    return best[len(best) // 2], hits


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "bench-results/rays"
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    print("| scene | kind | rays | Embree 1 thread Mrays/s | wedge 1 thread Mrays/s | wedge/Embree | hits Embree | hits wedge |")
    print("|---|---|---|---|---|---|---|---|")
    for name in sorted(os.listdir(root)):
        d = os.path.join(root, name)
        meta_path = os.path.join(d, "meta.json")
        if not os.path.isfile(meta_path):
            continue
        meta = json.load(open(meta_path))
        tris = load_f32(os.path.join(d, "triangles.f32"), 9).reshape(-1, 3, 3)
        scene = rtcs.EmbreeScene()
        TriangleMesh(scene, tris)
        for kind in ["primary", "shadow", "bounce"]:
            rays = load_f32(os.path.join(d, f"rays_{kind}.f32"), 7)
            rate, hits = trace(scene, rays, kind, repeats)
            w = meta["wedge"][kind]
            print(f"| {name} | {kind} | {len(rays)} | {rate / 1e6:.2f} | {w['rays_per_second_1'] / 1e6:.2f} "
                  f"| {w['rays_per_second_1'] / rate:.2f} | {hits} | {w['hits']} |")


if __name__ == "__main__":
    main()
