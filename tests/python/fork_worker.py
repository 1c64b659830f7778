"""Worker functions for the multiprocessing tests (importable by spawned and
forkserver children, which cannot reach functions defined in a test file)."""
import rayfold


def render_hits(args):
    """The hit count and depth bytes of the scene's default camera, or the
    error a worker met, as (kind, value)."""
    path, backend = args
    try:
        scene = rayfold.Scene(path)
        g = scene.render(scene.default_camera(48, 27), fold="xy", backend=backend)
        return ("ok", g.depth.tobytes())
    except Exception as e:  # the parent asserts on it
        return (type(e).__name__, str(e))
