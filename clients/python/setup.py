"""Builds wedge_client with its gRPC stubs generated from the repository's proto
(proto/wedge/v1/wedge.proto, two directories up) by grpcio-tools, so that the stubs always
match the server they were built next to. Install from a checkout:

    python3 -m pip install clients/python
"""
import os
import shutil

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
PROTO_ROOT = os.environ.get("WEDGE_PROTO_ROOT", os.path.join(HERE, "..", "..", "proto"))
PROTO = os.path.join("wedge", "v1", "wedge.proto")


class BuildWithStubs(build_py):
    """Runs protoc (from grpcio-tools) into the build directory before copying the package."""

    def run(self):
        from grpc_tools import protoc
        import grpc_tools

        source = os.path.join(PROTO_ROOT, PROTO)
        if not os.path.exists(source):
            raise SystemExit(
                f"{source}: not found. Build wedge_client from a wedge checkout "
                "(or set WEDGE_PROTO_ROOT to the directory that holds wedge/v1/wedge.proto)."
            )
        # Compiled as wedge_client/_pb/wedge.proto, so that the generated modules import each
        # other inside the package (protoc derives the import path from the file's path).
        staging = os.path.join(self.build_temp if hasattr(self, "build_temp") else self.build_lib, "proto-staging")
        staged = os.path.join(staging, "wedge_client", "_pb")
        os.makedirs(staged, exist_ok=True)
        shutil.copyfile(source, os.path.join(staged, "wedge.proto"))
        os.makedirs(self.build_lib, exist_ok=True)
        includes = os.path.join(os.path.dirname(grpc_tools.__file__), "_proto")
        args = [
            "protoc",
            f"-I{staging}",
            f"-I{includes}",
            f"--python_out={self.build_lib}",
            f"--grpc_python_out={self.build_lib}",
            os.path.join(staged, "wedge.proto"),
        ]
        if protoc.main(args) != 0:
            raise SystemExit(f"protoc failed on {source}")
        open(os.path.join(self.build_lib, "wedge_client", "_pb", "__init__.py"), "a").close()
        super().run()


setup(cmdclass={"build_py": BuildWithStubs})
