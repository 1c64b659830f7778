"""rayfold: exact primary-visibility G-buffers (depth, normal, barycentrics,
instance and primitive ids) from glTF scenes, by affine-transformed ray
alignment, on OpenCL devices or the CPU reference tracer.

    import rayfold
    scene = rayfold.Scene("scene.glb")
    camera = rayfold.Camera.look_at(eye=(0, 1, 5), target=(0, 1, 0), up=(0, 1, 0),
                                    vfov_deg=60, width=640, height=480)
    g = scene.render(camera, fold="xy")
    g.depth            # (H, W) float32, distance along each pixel's ray, inf on a miss
    g.instance_id      # (H, W) uint32, rayfold.MISS on a miss; scene.instance_names[id]

Errors about inputs raise rayfold.InputError (a ValueError) naming the file;
a missing OpenCL device or a failed kernel build raises rayfold.RuntimeFailure
(a RuntimeError).
"""

from ._core import (
    MISS,
    Camera,
    GBuffer,
    InputError,
    Renderer,
    RuntimeFailure,
    Scene,
    __version__,
    opencl_devices,
    read_exr,
    read_exr_header,
)

from ._geometry import WorldTriangles
from ._geometry import world_triangles as _world_triangles
from ._streams import from_colmap as _from_colmap
from ._streams import from_file as _from_file
from ._streams import from_matrices as _from_matrices
from ._streams import from_nerf as _from_nerf
from ._streams import iter_views as _iter_views

Camera.from_matrices = staticmethod(_from_matrices)
Camera.from_nerf = staticmethod(_from_nerf)
Camera.from_colmap = staticmethod(_from_colmap)
Camera.from_file = staticmethod(_from_file)
Scene.iter_views = _iter_views
Scene.world_triangles = _world_triangles

__all__ = ["MISS", "Camera", "GBuffer", "InputError", "Renderer", "RuntimeFailure", "Scene", "WorldTriangles",
           "__version__", "opencl_devices", "read_exr", "read_exr_header"]
