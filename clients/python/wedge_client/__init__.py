"""Python client for wedge, the gRPC render-and-denoise service.

    import wedge_client
    client = wedge_client.Client("127.0.0.1:50051")
    frame = client.render("cornell", width=320, height=240, method="aaf", max_passes=4)
    frame.color        # (240, 320, 3) float32, linear radiance
    frame.spp          # (240, 320) samples per pixel the method chose
    with client.session("cornell", width=320, height=240) as s:
        first = s.next_frame()
        s.orbit(yaw_deg=15)
        moved = s.next_frame(final=True)

Frames are numpy arrays; the protobuf messages are `wedge_client.pb` (generated from the
server's proto when this package was built).
"""
from .client import Client, method_value
from .frames import Frame
from .session import Session, SessionError
from ._pb import wedge_pb2 as pb

__all__ = ["Client", "Frame", "Session", "SessionError", "pb", "method_value"]
