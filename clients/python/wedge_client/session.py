"""Editing sessions over the bidirectional `Session` call: frames of the newest view as they
arrive, changes acknowledged (or refused, naming the field) before `update` returns."""
import math
import queue
import threading
from typing import Optional, Sequence

import numpy as np

from ._pb import wedge_pb2 as pb
from .frames import Assembler, Frame


class SessionError(Exception):
    """A change the server refused in band (the session stays open), or the session's end."""

    def __init__(self, field: str, message: str, update: int = 0):
        super().__init__(f"{field}: {message}" if field else message)
        self.field, self.message, self.update = field, message, update


class Session:
    """An open session. Frames are kept newest-first: a reader that is slower than the render
    sees the newest frame, as the server does for a slow client.

        with client.session("cornell", width=320, height=240) as s:
            s.next_frame()                      # the first frame (maybe a quick preview)
            g = s.orbit(yaw_deg=10)             # acknowledged: frames of g follow
            f = s.next_frame(final=True)        # the final frame of the newest generation
    """

    def __init__(self, stub, open_request: pb.RenderRequest, metadata=()):
        self._settings = pb.RenderSettings()
        self._settings.CopyFrom(open_request.settings)
        self._queue: "queue.Queue[Optional[pb.SessionRequest]]" = queue.Queue()
        self._queue.put(pb.SessionRequest(open=open_request))
        self._sent = 1
        self._cond = threading.Condition()
        self._acks = {}
        self._errors = {}
        self._latest: Optional[Frame] = None
        self._seq, self._taken = 0, 0
        self._ended: Optional[BaseException] = None
        self._camera: Optional[pb.Camera] = None
        self.generation = 0
        self._call = stub.Session(iter(self._queue.get, None), metadata=metadata)
        self._reader = threading.Thread(target=self._read, name="wedge-session", daemon=True)
        self._reader.start()

    # ---- events ----------------------------------------------------------------------------

    def _read(self) -> None:
        asm, ending = Assembler(), None
        try:
            for e in self._call:
                kind = e.WhichOneof("kind")
                with self._cond:
                    if kind == "ack":
                        self._acks[e.ack.update] = e.generation
                        self.generation = max(self.generation, e.generation)
                    elif kind == "error":
                        self._errors[e.error.update] = SessionError(e.error.field, e.error.message, e.error.update)
                    elif kind == "started":
                        asm.start(e.started)
                        if self._camera is None and e.started.HasField("camera"):
                            self._camera = e.started.camera
                    elif kind == "chunk":
                        asm.chunk(e.chunk)
                    elif kind == "frame_complete":
                        frame = asm.complete(e.frame_complete)
                        frame.generation, frame.preview_divider = e.generation, e.preview_divider
                        frame.frames_dropped = e.frames_dropped
                        self._latest, self._seq = frame, self._seq + 1
                    self._cond.notify_all()
            ending = SessionError("", "the session ended")
        except Exception as err:  # grpc.RpcError, or a malformed stream
            ending = err
        with self._cond:
            self._ended = ending
            self._cond.notify_all()

    def _wait(self, ready, timeout: float, what: str):
        with self._cond:
            if not self._cond.wait_for(lambda: ready() or self._ended is not None, timeout):
                raise TimeoutError(f"{what}: nothing within {timeout} s")
            result = ready()
            if not result:
                raise self._ended
            return result

    def next_frame(
        self, *, generation: Optional[int] = None, full_resolution: bool = True, final: bool = False, timeout: float = 60
    ) -> Frame:
        """The newest frame not returned before, of `generation` (default: the newest
        acknowledged) or later; by default not a reduced-resolution preview; with `final`, only
        the last frame of its render."""

        def ready():
            f = self._latest
            g = self.generation if generation is None else generation
            ok = (
                f is not None
                and self._seq > self._taken
                and f.generation >= g
                and not (full_resolution and f.preview_divider)
                and not (final and not f.is_final)
            )
            return f if ok else None

        frame = self._wait(ready, timeout, "next_frame")
        with self._cond:
            self._taken = self._seq
        return frame

    def latest(self) -> Optional[Frame]:
        """The newest frame received, returned before or not."""
        with self._cond:
            return self._latest

    # ---- changes ---------------------------------------------------------------------------

    def send(self, update: pb.SessionUpdate, timeout: float = 30) -> int:
        """Sends a change and waits for its acknowledgement: the new generation. Raises
        SessionError with the field the server named when it refuses the change."""
        with self._cond:
            self._sent += 1
            number = self._sent
        self._queue.put(pb.SessionRequest(update=update))

        def answered():
            return (number in self._acks or number in self._errors) and number

        self._wait(answered, timeout, "the change's acknowledgement")
        with self._cond:
            if number in self._errors:
                raise self._errors.pop(number)
            return self._acks.pop(number)

    def update(
        self,
        *,
        camera: Optional[dict] = None,
        width: int = 0,
        height: int = 0,
        method: Optional[str] = None,
        outputs: Optional[Sequence[str]] = None,
        f16: bool = False,
        materials: Sequence[pb.Material] = (),
        lights: Sequence[pb.LightEdit] = (),
    ) -> int:
        """Changes the view, size, method, layers, materials or lights; the new generation."""
        from .client import camera_override, method_value, output_selection

        u = pb.SessionUpdate(width=width, height=height)
        override = camera_override(camera)
        if override is not None:
            u.camera.CopyFrom(override)
        if method is not None:
            # The server replaces the whole settings message: keep the others as opened.
            self._settings.method = method_value(method)
            u.settings.CopyFrom(self._settings)
        if outputs is not None:
            u.outputs.CopyFrom(output_selection(outputs, f16))
        if materials or lights:
            u.edit.materials.extend(materials)
            u.edit.lights.extend(lights)
        generation = self.send(u)
        if override is not None and self._camera is not None:
            for key in ("position", "look_at", "up"):
                if override.HasField(key):
                    getattr(self._camera, key).CopyFrom(getattr(override, key))
        return generation

    def camera(self, timeout: float = 60) -> pb.Camera:
        """The current view (known once the first frame has started), as a copy."""
        current = self._wait(lambda: self._camera, timeout, "the session's camera")
        with self._cond:
            copy = pb.Camera()
            copy.CopyFrom(current)
            return copy

    def orbit(self, yaw_deg: float = 0.0, pitch_deg: float = 0.0, zoom: float = 1.0) -> int:
        """Turns the camera about its look-at point (yaw about the up vector, pitch about the
        view's horizontal axis) and moves it `zoom` times as far; the new generation."""
        c = self.camera()
        target = np.array([c.look_at.x, c.look_at.y, c.look_at.z], float)
        up = np.array([c.up.x, c.up.y, c.up.z], float) if c.HasField("up") else np.array([0.0, 1.0, 0.0])
        up /= np.linalg.norm(up)
        offset = np.array([c.position.x, c.position.y, c.position.z], float) - target
        offset = rotate(offset, up, math.radians(yaw_deg))
        right = np.cross(offset, up)
        if np.linalg.norm(right) > 0:
            tilted = rotate(offset, right / np.linalg.norm(right), math.radians(pitch_deg))
            if abs(np.dot(tilted / np.linalg.norm(tilted), up)) < 0.98:  # not over the pole
                offset = tilted
        position = target + offset * zoom
        return self.update(camera={"position": position, "look_at": target, "up": up})

    def pause(self) -> int:
        return self.send(pb.SessionUpdate(pause=True))

    def resume(self) -> int:
        return self.send(pb.SessionUpdate(resume=True))

    def close(self, timeout: float = 10) -> None:
        """Closes the request side; the server ends the session and the call."""
        self._queue.put(None)
        self._reader.join(timeout)
        if self._reader.is_alive():
            self._call.cancel()

    def __enter__(self) -> "Session":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def rotate(v: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """Rodrigues' rotation of `v` about the unit `axis`."""
    c, s = math.cos(angle), math.sin(angle)
    return v * c + np.cross(axis, v) * s + axis * np.dot(axis, v) * (1 - c)
