"""Write ``static/head_mesh.bin`` from :func:`headmotion.render.mesh.build_head_mesh` (detail 0).

Run ``python -m headmotion.web.build_assets`` after changing the mesh; the test suite checks that
the committed file matches what the code builds.
"""

from __future__ import annotations

from pathlib import Path

from ..io.atomic import atomic_write_bytes
from ..render.mesh import build_head_mesh, mesh_to_bytes

MESH_FILE = Path(__file__).resolve().parent / "static" / "head_mesh.bin"
WEB_DETAIL = 0


def build(path=MESH_FILE) -> Path:
    atomic_write_bytes(path, mesh_to_bytes(build_head_mesh(detail=WEB_DETAIL)))
    return Path(path)


if __name__ == "__main__":
    print(f"wrote {build()}")
