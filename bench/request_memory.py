#!/usr/bin/env python3
"""Server memory per request size: how much a `Render` call with a large inline mesh costs.

Starts `wedge serve`, sends the Cornell box plus an inline height-field mesh of N triangles
(positions, indices, normals and uvs: the largest form a mesh takes on the wire) with
`wedge client`, and reads the server's peak resident memory (VmHWM) before and after. Prints the
encoded request size and the peak above the idle server, so that the memory each limit implies
(`--max-request-bytes`, `--max-triangles`, `--max-concurrent`) can be documented.

    python3 bench/request_memory.py --wedge target/release/wedge --triangles 1000000
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))


def varint_len(v):
    n = 1
    while v >= 0x80:
        v >>= 7
        n += 1
    return n


def packed_len(field_bytes):
    # tag (1 byte) + length varint + payload
    return 1 + varint_len(field_bytes) + field_bytes


def height_field(triangles):
    """A grid of about `triangles` triangles over the Cornell box floor, with normals and uvs."""
    n = int(math.sqrt(triangles / 2)) + 1  # vertices per side
    pos, nrm, uv = [], [], []
    for j in range(n):
        for i in range(n):
            u, v = i / (n - 1), j / (n - 1)
            pos += [50 + 450 * u, 20 + 10 * math.sin(12 * u) * math.cos(9 * v), 50 + 450 * v]
            nrm += [0.0, 1.0, 0.0]
            uv += [u, v]
    idx = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            idx += [a, a + 1, a + n, a + n, a + 1, a + n + 1]
    return pos, idx, nrm, uv


def mesh_wire_bytes(pos, idx, nrm, uv):
    floats = sum(packed_len(4 * len(a)) for a in (pos, nrm, uv))
    return floats + packed_len(sum(varint_len(i) for i in idx))


def vm_hwm_kib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1])
    raise RuntimeError("no VmHWM")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--wedge", default=os.path.join(HERE, "..", "target", "release", "wedge"))
    ap.add_argument("--triangles", type=int, default=1_000_000)
    args = ap.parse_args()

    pos, idx, nrm, uv = height_field(args.triangles)
    tris = len(idx) // 3
    with open(os.path.join(HERE, "..", "scenes", "cornell.json")) as f:
        scene = json.load(f)
    scene["shapes"].append({"name": "field", "material": "white",
                            "mesh": {"positions": pos, "indices": idx, "normals": nrm, "uvs": uv}})
    wire = mesh_wire_bytes(pos, idx, nrm, uv)
    tmp = tempfile.mkdtemp(prefix="wedge-reqmem-")
    scene_path = os.path.join(tmp, "scene.json")
    with open(scene_path, "w") as f:
        json.dump(scene, f)

    server = subprocess.Popen([args.wedge, "serve", "--addr", "127.0.0.1:0", "--max-request-bytes", str(1 << 30)],
                              stderr=subprocess.PIPE, text=True, env={**os.environ, "RUST_LOG": "wedge=info"})
    addr = None
    for line in server.stderr:
        m = re.search(r"addr=(\S+)", line)
        if "serving" in line and m:
            addr = m.group(1)
            break
    if addr is None:
        sys.exit("the server did not start")
    try:
        time.sleep(0.5)
        idle = vm_hwm_kib(server.pid)
        t0 = time.time()
        out = subprocess.run([args.wedge, "client", "--addr", f"http://{addr}", scene_path, "--out", tmp,
                              "--width", "64", "--height", "64", "--max-passes", "1"],
                             capture_output=True, text=True)
        secs = time.time() - t0
        if out.returncode != 0:
            sys.exit(f"client failed: {out.stderr}")
        peak = vm_hwm_kib(server.pid)
    finally:
        server.terminate()
        server.wait(timeout=30)
    mib = 1 << 20
    print(f"triangles {tris}, mesh on the wire {wire / mib:.1f} MiB, render call {secs:.1f} s")
    print(f"server peak RSS {peak / 1024:.0f} MiB, idle {idle / 1024:.0f} MiB, "
          f"per request {(peak - idle) / 1024:.0f} MiB = {(peak - idle) * 1024 / wire:.1f}x the request")


if __name__ == "__main__":
    main()
