"""Many views: camera batches from numpy and G-buffers streamed one trace at
a time, for jobs of 10^4 to 10^6 views whose cameras or G-buffers would not
fit in memory at once."""
import itertools
import os
import warnings

import numpy as np

from ._core import Camera, InputError, _plane_specs

# Views handed to one render_views call: a multiple of what one trace holds
# in every fold (32 unfolded, 16 folded once, 8 folded twice), so that the
# chunks cut no trace short.
CHUNK_VIEWS = 32


# Every name (plane, alias, EXR layer) of the planes that pair a view with the next.
_FLOW_NAMES = {n for s in _plane_specs() if s["name"] in ("flow", "flow_visible")
               for n in (s["name"], s["alias"], s["exr_layer"]) if n}


def asks_flow(channels):
    """Whether channels (as render takes them) name flow or flow_visible."""
    if channels is None:
        return False
    names = channels.split(",") if isinstance(channels, str) else list(channels)
    return any(n.strip() in _FLOW_NAMES for n in names)


def iter_views(scene, cameras, fold="none", align=0, backend="opencl", device="", kernel="auto", threads=0,
               channels=None, depth="distance", exact_depth=False):
    """Yields the GBuffer of each camera, in the order given; each view's bits
    equal scene.render(camera, fold=fold).

    cameras may be any iterable, a generator too: it is read 32 views at a
    time, and only those views' G-buffers are held, so memory stays flat
    however many views there are. align as in render_views (views of the same
    size and intrinsics within 32 of each other trace together), channels,
    depth and exact_depth as in render; with flow or flow_visible each view's flow
    goes to the next camera (the last one's is NaN), as in render_views. A
    GBuffer the caller keeps stays valid; the next ones are new arrays."""
    it = iter(cameras)
    index = 0
    # With flow each view flows to the next (render_views): a chunk's last
    # view is rendered with the next chunk's first after it, and handed on
    # with the next chunk.
    flow = asks_flow(channels)
    ahead = []
    while True:
        chunk = ahead + list(itertools.islice(it, CHUNK_VIEWS - len(ahead)))
        ahead = list(itertools.islice(it, 1)) if flow else []
        if not chunk:
            return
        for k, c in enumerate(chunk + ahead):
            if not isinstance(c, Camera):
                raise TypeError(f"iter_views: camera {index + k} is a {type(c).__name__}, not a rayfold.Camera")
        views = scene.render_views(chunk + ahead, fold=fold, align=align, backend=backend, device=device,
                                   kernel=kernel, threads=threads, channels=channels, depth=depth,
                                   exact_depth=exact_depth)
        yield from views[:len(chunk)]
        index += len(chunk)


def _intrinsics(K, i):
    if K[0, 1] != 0.0 or K[1, 0] != 0.0 or K[2, 0] != 0.0 or K[2, 1] != 0.0 or K[2, 2] != 1.0:
        raise InputError(f"Camera.from_matrices: K[{i}] is not a pinhole matrix [[fx, 0, cx], [0, fy, cy], "
                         f"[0, 0, 1]] (no skew): {K.tolist()}")
    return float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2])


def from_matrices(camera_to_world, K, width, height, *, convention):
    """A list of cameras from a batch of rigid camera-to-world matrices (B, 4, 4)
    and pinhole intrinsics K, (B, 3, 3) or one (3, 3) for all, in pixels with
    pixel centres at +0.5 (an OpenCV calibration adds 0.5 to cx and cy), as
    Camera.from_matrix for each. convention: 'opencv' (COLMAP) or 'opengl'
    (NeRF, Blender). InputError names the first camera that is not valid."""
    c2w = np.asarray(camera_to_world, dtype=np.float64)
    if c2w.ndim != 3 or c2w.shape[1:] != (4, 4):
        raise InputError(f"Camera.from_matrices: camera_to_world must be (B, 4, 4), not {c2w.shape}")
    k = np.asarray(K, dtype=np.float64)
    if k.shape == (3, 3):
        k = np.broadcast_to(k, (c2w.shape[0], 3, 3))
    if k.shape != (c2w.shape[0], 3, 3):
        raise InputError(f"Camera.from_matrices: K must be (3, 3) or ({c2w.shape[0]}, 3, 3) for "
                         f"{c2w.shape[0]} matrices, not {np.shape(K)}")
    cameras = []
    for i in range(c2w.shape[0]):
        fx, fy, cx, cy = _intrinsics(k[i], i)
        try:
            cameras.append(Camera.from_matrix(c2w[i], fx, fy, cx, cy, width, height, convention=convention))
        except InputError as e:
            raise InputError(f"Camera.from_matrices: camera {i}: {e}") from e
    return cameras


def from_nerf(path, width=0, height=0):
    """The cameras of a NeRF / instant-ngp transforms.json and their frames'
    file_path, as (cameras, names) in the file's order. transform_matrix is
    camera-to-world in OpenGL axes; intrinsics from fl_x, fl_y, cx, cy (pixel
    centres at +0.5) or camera_angle_x; the size from w and h, else width and
    height (the original synthetic scenes have none). Keys that change no view
    (aabb_scale, scale, offset, ...) are ignored with a warning naming them;
    a distortion coefficient or another unknown key raises InputError."""
    views, ignored = Camera._read_nerf(os.fspath(path), width, height)
    _warn_ignored(path, ignored)
    return [c for _, c in views], [n for n, _ in views]


def _warn_ignored(path, ignored):
    if ignored:
        warnings.warn(f"{os.fspath(path)}: ignored {', '.join(ignored)} (training settings and instant-ngp's own "
                      "pose normalisation: the poses are rendered as written, in the scene's coordinates)",
                      stacklevel=3)


def _is_colmap_dir(path, width, height):
    """A folder is a COLMAP model, which gives its own image sizes."""
    if not os.path.isdir(path):
        return False
    if width or height:
        raise InputError(f"{os.fspath(path)}: a COLMAP model gives its image sizes; width and height do not "
                         "combine with it")
    return True


def from_file(path, width=0, height=0):
    """The cameras a file holds and their names, as (cameras, names) in the
    file's order, told apart by content as `rayfold render --cameras` does:
    a rayfold camera list (names "0", "1", ...), a NeRF / instant-ngp
    transforms.json (an object with "frames"; width and height as from_nerf),
    or, for a directory, a COLMAP text model (as from_colmap). InputError
    names the file and what is wrong."""
    if _is_colmap_dir(path, width, height):
        return from_colmap(path)
    views, ignored, _ = Camera._read_file(os.fspath(path), width, height)
    _warn_ignored(path, ignored)
    return [c for _, c in views], [n for n, _ in views]


def read_views_lenient(path, width=0, height=0):
    """For a batch: the views of a camera file or COLMAP folder as
    (cameras by index in the file, None where a view's own entry is bad;
    skipped as (index, reason); the views' names by index, None where
    skipped). The file's structure still raises."""
    if _is_colmap_dir(path, width, height):
        views, skipped = Camera._read_colmap(os.fspath(path), True)
    else:
        views, ignored, skipped = Camera._read_file(os.fspath(path), width, height, True)
        _warn_ignored(path, ignored)
    cameras = [None] * (len(views) + len(skipped))
    names = [None] * len(cameras)
    bad = {i for i, _ in skipped}
    good = iter(views)
    for i in range(len(cameras)):
        if i not in bad:
            names[i], cameras[i] = next(good)
    return cameras, skipped, names


def from_colmap(model_dir):
    """The cameras of a COLMAP text model (model_dir/cameras.txt with PINHOLE or
    SIMPLE_PINHOLE cameras, model_dir/images.txt) and their image names, as
    (cameras, names) in images.txt's order. Models with distortion raise
    InputError by name: undistort first (colmap image_undistorter)."""
    views, _ = Camera._read_colmap(os.fspath(model_dir))
    return [c for _, c in views], [n for n, _ in views]
