#!/usr/bin/env python3
"""Python's stock reflection client (grpcio-reflection, which speaks v1alpha) against a wedge
server, driven by tests/grpcio.rs: prints the services, then the methods of wedge.v1.Renderer
as the descriptor database resolved them.

    reflection.py 127.0.0.1:50051
"""
import sys

import grpc
from grpc_reflection.v1alpha.proto_reflection_descriptor_database import ProtoReflectionDescriptorDatabase
from google.protobuf.descriptor_pool import DescriptorPool


def main():
    channel = grpc.insecure_channel(sys.argv[1])
    db = ProtoReflectionDescriptorDatabase(channel)
    for name in sorted(db.get_services()):
        print(f"service {name}")
    pool = DescriptorPool(db)
    renderer = pool.FindServiceByName("wedge.v1.Renderer")
    for m in renderer.methods:
        print(f"method {m.name} {m.input_type.full_name} -> {m.output_type.full_name}")


if __name__ == "__main__":
    main()
