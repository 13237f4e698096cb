#!/usr/bin/env python3
"""Interactive remote preview from a terminal: opens a session on a wedge server, shows each
frame's statistics as it refines, and takes commands on standard input, one per line:

    a / d       orbit left / right (15 degrees)
    w / s       orbit up / down
    + / -       move closer / farther
    m METHOD    switch method (uniform, aaf, lobe-aware, ...)
    p FILE      save the newest frame as a PNG (tone-mapped to sRGB)
    q           quit

    python3 orbit.py --server 127.0.0.1:50051 --scene cornell --size 320x240

Start a server first (`wedge serve`). Commands can be piped in, which is how the package's
tests drive it.
"""
import argparse
import struct
import sys
import zlib

import numpy as np

import wedge_client


def srgb8(color: np.ndarray) -> np.ndarray:
    c = np.clip(color, 0.0, 1.0)
    c = np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)
    return (c * 255 + 0.5).astype(np.uint8)


def write_png(path: str, rgb: np.ndarray) -> None:
    """An 8-bit RGB PNG, written with zlib alone."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].tobytes() for y in range(h))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    header = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def describe(frame: wedge_client.Frame) -> str:
    kind = f"preview 1/{frame.preview_divider}" if frame.preview_divider else f"{frame.width}x{frame.height}"
    return (
        f"generation {frame.generation} {kind} pass {frame.pass_index} {frame.mean_spp:.1f} spp "
        f"{frame.elapsed_seconds:.2f} s mean {frame.color.mean():.4f}" + (" final" if frame.is_final else "")
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--server", default="127.0.0.1:50051")
    ap.add_argument("--token", default=None)
    ap.add_argument("--scene", default="cornell", help="a built-in scene or a scene file")
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--method", default=None)
    ap.add_argument("--passes", type=int, default=6, help="passes per view")
    args = ap.parse_args()
    width, height = (int(v) for v in args.size.split("x"))

    client = wedge_client.Client(args.server, token=args.token)
    with client.session(args.scene, width=width, height=height, method=args.method, max_passes=args.passes) as s:
        print(describe(s.next_frame(full_resolution=False)), flush=True)
        moves = {"a": (-15, 0, 1), "d": (15, 0, 1), "w": (0, 10, 1), "s": (0, -10, 1), "+": (0, 0, 0.8), "-": (0, 0, 1.25)}
        for line in sys.stdin:
            cmd, _, arg = line.strip().partition(" ")
            try:
                if cmd in moves:
                    generation = s.orbit(*moves[cmd])
                    print(describe(s.next_frame(generation=generation, final=True)), flush=True)
                elif cmd == "m":
                    generation = s.update(method=arg)
                    print(describe(s.next_frame(generation=generation, final=True)), flush=True)
                elif cmd == "p":
                    frame = s.latest()
                    write_png(arg, srgb8(frame.color))
                    print(f"saved {arg}", flush=True)
                elif cmd == "q":
                    break
                elif cmd:
                    print(f"unknown command {cmd!r} (a d w s + - m p q)", flush=True)
            except (wedge_client.SessionError, ValueError) as e:
                print(f"refused: {e}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
