#!/usr/bin/env python3
"""A stock grpcio client balancing over several wedge servers, driven by tests/balance.rs.

    round_robin.py 127.0.0.1:p1,127.0.0.1:p2,127.0.0.1:p3

Speaks a line protocol on stdout/stdin with the test: after warming up it renders 9 small
frames and prints `spread`, waits for a line on stdin, starts a long render and prints
`long-started` once its first frame arrived, then reads it to its end and prints
`long-ended CODE`, retries a short render on UNAVAILABLE (as a client does when a replica
drains) and prints `retried OK` or `retried CODE`.
"""
import json
import os
import sys
import time

import grpc

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench"))
from wedge_stubs import load_stubs  # noqa: E402


def say(line):
    print(line, flush=True)


def render(stub, pb, passes, time_budget=0.0):
    req = pb.RenderRequest(builtin="cornell", width=8, height=6, seed=1,
                           settings=pb.RenderSettings(method=pb.METHOD_UNIFORM, max_passes=passes,
                                                      time_budget_seconds=time_budget),
                           outputs=pb.OutputSelection(spp=True))
    return stub.Render(req)


def main():
    addrs = sys.argv[1]
    pb, rpc = load_stubs()
    config = json.dumps({"loadBalancingConfig": [{"round_robin": {}}]})
    # A target of several addresses has no host name: grpcio would send them all, commas
    # included, as :authority, which HTTP/2 servers refuse. Name one, as DNS targets do.
    options = [("grpc.service_config", config), ("grpc.default_authority", "localhost")]
    channel = grpc.insecure_channel(f"ipv4:{addrs}", options=options)
    grpc.channel_ready_future(channel).result(timeout=30)
    stub = rpc.RendererStub(channel)
    # Let every subchannel connect, so that the rotation covers all servers.
    for _ in range(30):
        stub.ListScenes(pb.ListScenesRequest(), timeout=10)
        time.sleep(0.02)
    for _ in range(9):
        for _ in render(stub, pb, 2):
            pass
    say("spread")
    sys.stdin.readline()

    long = render(stub, pb, 64, time_budget=600.0)
    for update in long:
        if update.WhichOneof("kind") == "frame_complete":
            break
    say("long-started")
    try:
        for _ in long:
            pass
        say("long-ended OK")
    except grpc.RpcError as e:
        say(f"long-ended {e.code().name}")

    code = "UNAVAILABLE"
    for _ in range(20):
        try:
            for _ in render(stub, pb, 2):
                pass
            code = "OK"
            break
        except grpc.RpcError as e:
            code = e.code().name
            if e.code() != grpc.StatusCode.UNAVAILABLE:
                break
            time.sleep(0.1)
    say(f"retried {code}")


if __name__ == "__main__":
    main()
