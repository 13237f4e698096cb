#!/usr/bin/env python3
"""The Sibenik cathedral (shared assets: 75K flat-shaded triangles, geometry only) lit by one
area light, as a wedge scene, and the check of issue 16 item 12: does light leak at inside
corners and edges (wedge brighter than Mitsuba 3 along the edges of steps and on the walls next to
the light)?

    python3 bench/sibenik.py scene --out /tmp/sibenik.json
    python3 bench/mitsuba_compare.py /tmp/sibenik.json --bounces 0 --width 160 --height 120 \\
        --reference-spp 4096 --max-spp 4 --save /tmp/sib-b0
    python3 bench/sibenik.py edges /tmp/sib-b0 sibenik

`scene` writes the scene with the mesh inline (mitsuba_compare converts inline meshes only).
`edges` reads the four images mitsuba_compare saved (wedge seeds 7 and 8, Mitsuba seeds 1 and 3)
and compares wedge with Mitsuba on the pixels at edges of the image (a neighbour differing by more
than --edge-contrast in luminance in the Mitsuba reference) and on the others: the mean ratio
wedge / Mitsuba of each set with two standard errors (from the spread between the seeds), and the
4x4-pixel blocks whose ratio exceeds 1 by more than three of their own standard errors.
"""
import argparse
import json
import lzma
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ASSET = os.path.join(ROOT, "..", "shared", "assets", "scenes", "sibenik", "sibenik.obj.xz")


def read_obj(path):
    """Positions and triangle indices of an OBJ with `v` and `f` lines (polygons fanned)."""
    opener = lzma.open if path.endswith(".xz") else open
    pos, tri = [], []
    with opener(path, "rt") as f:
        for line in f:
            if line.startswith("v "):
                pos.append([float(x) for x in line.split()[1:4]])
            elif line.startswith("f "):
                idx = [int(t.split("/")[0]) for t in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(pos) + i for i in idx]
                tri.extend([idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1))
    return np.array(pos, dtype=np.float64), np.array(tri, dtype=np.int64)


def build_scene(asset, width, height):
    p, t = read_obj(asset)
    lo, hi = p.min(0), p.max(0)
    size = hi - lo
    # The nave runs along the longest horizontal axis; y is up in this conversion.
    up = 1
    long_axis = 0 if size[0] >= size[2] else 2
    side = 2 - long_axis
    centre = (lo + hi) / 2
    floor = lo[up]
    eye = centre.copy()
    eye[long_axis] = lo[long_axis] + 0.12 * size[long_axis]
    eye[up] = floor + 0.18 * size[up]
    look = centre.copy()
    look[long_axis] = hi[long_axis] - 0.2 * size[long_axis]
    look[up] = floor + 0.25 * size[up]
    # One area light under the vault, in the middle of the nave, facing down.
    lc = centre.copy()
    lc[up] = floor + 0.55 * size[up]
    a, b = 0.06 * size[long_axis], 0.06 * size[side]
    corner = lc.copy()
    corner[long_axis] -= a / 2
    corner[side] -= b / 2
    eu, ev = np.zeros(3), np.zeros(3)
    # edge_u x edge_v points down (the emitting side).
    if long_axis == 0:
        eu[2], ev[0] = b, a
    else:
        eu[0], ev[2] = b, a
    if np.cross(eu, ev)[up] > 0:
        eu, ev = ev, eu
    v3 = lambda v: {"x": float(v[0]), "y": float(v[1]), "z": float(v[2])}
    area = a * b
    radiance = 40.0 * (size[long_axis] * size[side]) / (400.0 * area)
    return {
        "description": "the Sibenik cathedral (Marko Dabrovic; McGuire's archive), geometry only, one area light",
        "camera": {"position": v3(eye), "lookAt": v3(look), "up": {"x": 0, "y": 1, "z": 0}, "verticalFovDeg": 60,
                   "width": width, "height": height},
        "materials": [{"name": "stone", "lambertian": {"albedo": {"constant": {"r": 0.6, "g": 0.58, "b": 0.55}}}}],
        "shapes": [{"name": "cathedral", "material": "stone",
                    "mesh": {"positions": [round(float(x), 6) for x in p.ravel()], "indices": [int(i) for i in t.ravel()]}}],
        "lights": [{"rect": {"corner": v3(corner), "edgeU": v3(eu), "edgeV": v3(ev),
                             "radiance": {"r": radiance, "g": radiance, "b": radiance}}}],
        "settings": {"bounces": 1},
    }


def luminance(img):
    return img @ np.array([0.2126, 0.7152, 0.0722])


def edges(directory, name, contrast):
    load = lambda key: np.load(os.path.join(directory, f"{name}-{key}.npy")).astype(np.float64)
    w7, w8, m1, m3 = (luminance(load(k)) for k in ("wedge-7", "wedge-8", "mitsuba-1", "mitsuba-3"))
    w, m = (w7 + w8) / 2, (m1 + m3) / 2
    lit = m > 1e-3 * m.mean()
    edge = np.zeros_like(m, dtype=bool)
    for axis in (0, 1):
        for shift in (1, -1):
            other = np.roll(m, shift, axis=axis)
            edge |= np.abs(other - m) > contrast * np.maximum(m, other)
    edge[0, :] = edge[-1, :] = edge[:, 0] = edge[:, -1] = False
    print(f"{name}: {w.shape[1]}x{w.shape[0]}, {lit.sum()} lit pixels, {int((edge & lit).sum())} at edges")
    print("| pixels | count | mean ratio wedge/Mitsuba | two standard errors |")
    print("|---|---|---|---|")
    for label, mask in (("all lit", lit), ("edges", edge & lit), ("elsewhere", lit & ~edge)):
        ratio = w[mask].sum() / m[mask].sum()
        # Seed-to-seed spread of each renderer's mean over the set, combined.
        se = np.hypot((w7[mask].sum() - w8[mask].sum()) / 2, (m1[mask].sum() - m3[mask].sum()) / 2) / m[mask].sum()
        # With two seeds the spread of the sums is a rough error; use per-pixel spreads too.
        px = np.sqrt(np.sum(((w7 - w8) ** 2 + (m1 - m3) ** 2)[mask]) / 4) / m[mask].sum()
        print(f"| {label} | {int(mask.sum())} | {ratio:.4f} | {2 * max(se, px):.4f} |")
    h, wd = (m.shape[0] // 4) * 4, (m.shape[1] // 4) * 4
    block = lambda a: a[:h, :wd].reshape(h // 4, 4, wd // 4, 4).sum(axis=(1, 3))
    bw, bm = block(w), block(m)
    var = block(((w7 - w8) ** 2 + (m1 - m3) ** 2) / 4)
    ok = bm > 1e-3 * bm.mean()
    z = np.where(ok, (bw - bm) / np.sqrt(np.maximum(var, 1e-30)), 0.0)
    hot = z > 3
    print(f"4x4 blocks: {int(ok.sum())} lit, {int(hot.sum())} with wedge brighter by more than 3 standard errors "
          f"(expected by chance: {0.00135 * ok.sum():.1f}), {int((z < -3).sum())} darker")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    s = sub.add_parser("scene")
    s.add_argument("--asset", default=ASSET)
    s.add_argument("--out", required=True)
    s.add_argument("--width", type=int, default=160)
    s.add_argument("--height", type=int, default=120)
    e = sub.add_parser("edges")
    e.add_argument("directory")
    e.add_argument("name")
    e.add_argument("--edge-contrast", type=float, default=0.2)
    args = ap.parse_args()
    if args.cmd == "scene":
        with open(args.out, "w") as f:
            json.dump(build_scene(args.asset, args.width, args.height), f, separators=(",", ":"))
        print(f"wrote {args.out}")
    else:
        edges(args.directory, args.name, args.edge_contrast)
    return 0


if __name__ == "__main__":
    sys.exit(main())
