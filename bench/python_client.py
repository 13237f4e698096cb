#!/usr/bin/env python3
"""A wedge client in Python: renders a scene over gRPC and reassembles the streamed frames.

    pip install grpcio grpcio-tools numpy
    wedge serve &
    python3 bench/python_client.py --scene cornell --width 160 --height 120 --passes 4

Stubs are generated from proto/ at start-up (grpcio-tools), so the client always matches the
proto in this checkout. Frames arrive as row chunks (each under the default 4 MiB message
limit); this script stitches them into numpy arrays and prints one line per frame.
"""
import argparse

import numpy as np

from wedge_stubs import load_stubs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--addr", default="127.0.0.1:50051")
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--f16", action="store_true", help="stream half floats")
    ap.add_argument("--save", help="write the final colour as .npy here")
    args = ap.parse_args()

    import grpc

    pb, rpc = load_stubs()
    channel = grpc.insecure_channel(args.addr)
    stub = rpc.RendererStub(channel)
    for s in stub.ListScenes(pb.ListScenesRequest()).scenes:
        print(f"built-in: {s.name} ({s.width}x{s.height}, {s.triangles} triangles)")

    fmt = pb.PIXEL_FORMAT_F16 if args.f16 else pb.PIXEL_FORMAT_F32
    req = pb.RenderRequest(
        builtin=args.scene, width=args.width, height=args.height, seed=args.seed,
        settings=pb.RenderSettings(max_passes=args.passes),
        outputs=pb.OutputSelection(color=True, spp=True, format=fmt),
    )
    dtype = np.float16 if args.f16 else np.float32
    layers, size, final = None, None, None
    for update in stub.Render(req):
        kind = update.WhichOneof("kind")
        if kind == "started":
            size = (update.started.height, update.started.width)
            layers = {}
        elif kind == "chunk":
            c = update.chunk
            for layer in c.layers:
                buf = layers.setdefault(layer.name, np.zeros(size + (layer.channels,), np.float32))
                rows = np.frombuffer(layer.data, dtype=dtype).reshape(c.height, c.width, layer.channels)
                buf[c.y:c.y + c.height, c.x:c.x + c.width] = rows
        elif kind == "frame_complete":
            f = update.frame_complete
            color, spp = layers["color"], layers["spp"]
            print(f"pass {getattr(f, 'pass')}: mean spp {f.mean_spp:.1f} (map mean {spp.mean():.1f}), "
                  f"mean radiance {color.mean():.4f}, {f.elapsed_seconds:.3f} s, final={f.is_final}")
            final = color.copy()
    if args.save and final is not None:
        np.save(args.save, final)


if __name__ == "__main__":
    main()
