"""Python stubs for wedge.v1, generated from proto/ at import time with grpcio-tools, so that a
script always matches the proto of its checkout.

    from wedge_stubs import load_stubs
    pb, rpc = load_stubs()
"""
import os
import sys
import tempfile


def load_stubs():
    from grpc_tools import protoc

    root = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "proto")
    out = tempfile.mkdtemp(prefix="wedge-stubs-")
    proto = os.path.join(root, "wedge", "v1", "wedge.proto")
    include = os.path.join(os.path.dirname(protoc.__file__), "_proto")
    rc = protoc.main(["protoc", f"-I{root}", f"-I{include}", f"--python_out={out}", f"--grpc_python_out={out}", proto])
    if rc != 0:
        sys.exit(f"protoc failed on {proto}")
    sys.path.insert(0, out)
    from wedge.v1 import wedge_pb2, wedge_pb2_grpc

    return wedge_pb2, wedge_pb2_grpc
