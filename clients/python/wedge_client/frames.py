"""Frames off the wire: `RenderStarted`, row chunks and `FrameComplete` assembled into numpy
arrays, one per layer."""
from dataclasses import dataclass, field
from typing import Dict, Optional

import numpy as np

from ._pb import wedge_pb2 as pb


@dataclass
class Frame:
    """One complete frame: every pixel estimated (the server never sends a partial frame)."""

    width: int
    height: int
    #: Layer name -> array of shape (height, width, channels), or (height, width) for one channel.
    layers: Dict[str, np.ndarray]
    #: 0-based refinement pass.
    pass_index: int
    mean_spp: float
    elapsed_seconds: float
    is_final: bool
    #: The render's own estimate of the frame's relative RMSE (0 on the first frame).
    estimated_relative_error: float
    #: Sessions only: the generation the frame belongs to, and for a quick first frame the
    #: divider of its reduced resolution (0 for full-resolution frames).
    generation: int = 0
    preview_divider: int = 0
    frames_dropped: int = 0
    #: The view the frame shows (a `pb.Camera`).
    camera: Optional[pb.Camera] = None

    @property
    def color(self) -> np.ndarray:
        """Linear radiance, (height, width, 3) float32."""
        return self.layers["color"]

    @property
    def spp(self) -> np.ndarray:
        return self.layers["spp"]

    @property
    def filter_width(self) -> Optional[np.ndarray]:
        return self.layers.get("filter_width")


@dataclass
class Assembler:
    """Collects one stream's chunks into frames."""

    started: Optional[pb.RenderStarted] = None
    _layers: Dict[str, np.ndarray] = field(default_factory=dict)
    _rows: int = 0

    def start(self, started: pb.RenderStarted) -> None:
        self.started = started
        self._layers = {}
        self._rows = 0

    def chunk(self, chunk: pb.FrameChunk) -> None:
        s = self.started
        if s is None:
            raise ValueError("a chunk before RenderStarted")
        dtype = "<f2" if s.format == pb.PIXEL_FORMAT_F16 else "<f4"
        for layer in chunk.layers:
            values = np.frombuffer(layer.data, dtype=dtype).astype(np.float32)
            rows = values.reshape(chunk.height, chunk.width, layer.channels)
            target = self._layers.get(layer.name)
            if target is None:
                target = np.zeros((s.height, s.width, layer.channels), np.float32)
                self._layers[layer.name] = target
            target[chunk.y : chunk.y + chunk.height, chunk.x : chunk.x + chunk.width] = rows
        self._rows += chunk.height

    def complete(self, done: pb.FrameComplete) -> Frame:
        s = self.started
        if s is None or self._rows != s.height:
            raise ValueError(f"a frame with {self._rows} of {s.height if s else '?'} rows")
        self._rows = 0
        layers = {k: (v[:, :, 0].copy() if v.shape[2] == 1 else v.copy()) for k, v in self._layers.items()}
        return Frame(
            width=s.width,
            height=s.height,
            layers=layers,
            pass_index=getattr(done, "pass"),  # a Python keyword
            mean_spp=done.mean_spp,
            elapsed_seconds=done.elapsed_seconds,
            is_final=done.is_final,
            estimated_relative_error=done.estimated_relative_error,
            camera=s.camera if s.HasField("camera") else None,
        )

