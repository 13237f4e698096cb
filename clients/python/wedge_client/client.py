"""The client: requests built from keyword arguments, scenes named by built-in name, file or
digest, and frames returned as numpy arrays."""
import os
from typing import Iterator, List, Optional, Sequence, Union

import grpc

from ._pb import wedge_pb2 as pb
from ._pb import wedge_pb2_grpc as pb_grpc
from .frames import Assembler, Frame
from .session import Session

SceneArg = Union[str, "os.PathLike[str]", pb.Scene]

#: Layers a request streams unless told otherwise.
DEFAULT_OUTPUTS = ("color", "spp", "filter_width")


def method_value(name: Optional[str]) -> int:
    """`"aaf"`, `"lobe-aware"`, ... as the proto's Method value; None: the server's default."""
    if name is None:
        return pb.METHOD_UNSPECIFIED
    try:
        return pb.Method.Value("METHOD_" + name.upper().replace("-", "_"))
    except ValueError:
        names = [n[len("METHOD_") :].lower().replace("_", "-") for n in pb.Method.keys()[1:]]
        raise ValueError(f"method {name!r}: not one of {', '.join(names)}") from None


def vec3(v: Sequence[float]) -> pb.Vec3:
    x, y, z = (float(c) for c in v)
    return pb.Vec3(x=x, y=y, z=z)


def camera_override(camera: Optional[dict]) -> Optional[pb.CameraOverride]:
    """{"position": (x, y, z), "look_at": ..., "up": ..., "vertical_fov_deg": f}, any subset."""
    if camera is None:
        return None
    o = pb.CameraOverride()
    for key in ("position", "look_at", "up"):
        if camera.get(key) is not None:
            getattr(o, key).CopyFrom(vec3(camera[key]))
    if camera.get("vertical_fov_deg") is not None:
        o.vertical_fov_deg = float(camera["vertical_fov_deg"])
    unknown = set(camera) - {"position", "look_at", "up", "vertical_fov_deg"}
    if unknown:
        raise ValueError(f"camera: unknown keys {sorted(unknown)}")
    return o


def output_selection(outputs: Sequence[str], f16: bool) -> pb.OutputSelection:
    sel = pb.OutputSelection(format=pb.PIXEL_FORMAT_F16 if f16 else pb.PIXEL_FORMAT_F32)
    for name in outputs:
        if name not in pb.OutputSelection.DESCRIPTOR.fields_by_name or name == "format":
            raise ValueError(f"outputs: unknown layer {name!r}")
        setattr(sel, name, True)
    return sel


class Client:
    """A connection to a wedge server.

    `target` is host:port; `token` is sent as `authorization: Bearer <token>`; `credentials`
    (from `grpc.ssl_channel_credentials`) makes the channel TLS.
    """

    def __init__(self, target: str = "127.0.0.1:50051", token: Optional[str] = None, credentials=None):
        # Frames arrive in chunks below the default 4 MiB; an inline scene may be larger.
        options = [("grpc.max_send_message_length", 64 << 20)]
        if credentials is not None:
            self._channel = grpc.secure_channel(target, credentials, options=options)
        else:
            self._channel = grpc.insecure_channel(target, options=options)
        self.stub = pb_grpc.RendererStub(self._channel)
        self.metadata = (("authorization", f"Bearer {token}"),) if token else ()

    def close(self) -> None:
        self._channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def list_scenes(self) -> List[pb.SceneInfo]:
        return list(self.stub.ListScenes(pb.ListScenesRequest(), metadata=self.metadata).scenes)

    def put_scene(self, scene: SceneArg) -> str:
        """Stores a scene (a `pb.Scene`, or a scene file's path) on the server; its digest."""
        if isinstance(scene, pb.Scene):
            req = pb.PutSceneRequest(scene=scene)
        else:
            with open(scene, encoding="utf-8") as f:
                req = pb.PutSceneRequest(scene_json=f.read())
        return self.stub.PutScene(req, metadata=self.metadata).digest

    def request(
        self,
        scene: SceneArg,
        *,
        width: int = 0,
        height: int = 0,
        method: Optional[str] = None,
        seed: int = 0,
        max_passes: int = 0,
        max_spp: float = 0.0,
        time_budget: float = 0.0,
        target_error: float = 0.0,
        bounces: Optional[int] = None,
        camera: Optional[dict] = None,
        outputs: Sequence[str] = DEFAULT_OUTPUTS,
        f16: bool = False,
        frame_every: int = 0,
    ) -> pb.RenderRequest:
        """A RenderRequest. `scene`: a built-in name, a digest ("sha256:..."), the path of a
        scene file (uploaded with PutScene, then named by digest), or a `pb.Scene`."""
        req = pb.RenderRequest(width=width, height=height, seed=seed, frame_every=frame_every)
        if isinstance(scene, pb.Scene):
            req.scene.CopyFrom(scene)
        elif isinstance(scene, str) and scene.startswith("sha256:"):
            req.scene_digest = scene
        elif os.path.isfile(scene):
            req.scene_digest = self.put_scene(scene)
        else:
            req.builtin = str(scene)
        s = req.settings
        s.method = method_value(method)
        s.max_passes, s.max_mean_spp, s.time_budget_seconds, s.target_error = max_passes, max_spp, time_budget, target_error
        if bounces is not None:
            s.bounces = bounces
        override = camera_override(camera)
        if override is not None:
            req.camera.CopyFrom(override)
        req.outputs.CopyFrom(output_selection(outputs, f16))
        return req

    def render_frames(self, scene: SceneArg, **kw) -> Iterator[Frame]:
        """Renders and yields every frame as it arrives (the last one has `is_final`)."""
        asm = Assembler()
        for update in self.stub.Render(self.request(scene, **kw), metadata=self.metadata):
            kind = update.WhichOneof("kind")
            if kind == "started":
                asm.start(update.started)
            elif kind == "chunk":
                asm.chunk(update.chunk)
            elif kind == "frame_complete":
                yield asm.complete(update.frame_complete)

    def render(self, scene: SceneArg, **kw) -> Frame:
        """Renders and returns the final frame. Set a halt condition (max_passes, max_spp,
        time_budget or target_error) or the scene's own applies."""
        last = None
        for last in self.render_frames(scene, **kw):
            pass
        if last is None:
            raise RuntimeError("the render ended without a frame")
        return last

    def session(self, scene: SceneArg, **kw) -> Session:
        """Opens an editing session (the bidirectional `Session` call): see `Session`."""
        return Session(self.stub, self.request(scene, **kw), self.metadata)
