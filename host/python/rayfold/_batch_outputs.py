"""Where rayfold.batch writes views: one EXR per view (a %d pattern: its
index; %s: its name in the camera file) or one
zarr store (a path ending in .zarr). Each output is made by the driver,
sent to the workers (it pickles as its paths), and answers for a view: its
record name in the manifest, whether a record still matches, and writing it
whole or not at all."""
import glob
import hashlib
import json
import os

import numpy as np

from ._core import MISS, InputError, __version__, _check_exr_compression, _plane_specs, _view_files


def _store_name(spec):
    """A plane's array in the store: its name ("barycentrics", not its older
    name uv, which read as texture coordinates; the store's attributes say so)."""
    return spec["name"]


# A plane's trailing shape, dtype and the value of a view not yet written,
# from the core's one table of planes (output/channels.h), in its order.
PLANES = {
    _store_name(s): ((() if s["components"] == 1 else (s["components"],)), s["dtype"],
                     MISS if s["dtype"] == "uint32" else float("nan"))
    for s in _plane_specs()
}
# The visibility buffer, what a render writes unless channels= says more.
VISIBILITY = [_store_name(s) for s in _plane_specs() if s["visibility"]]


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def make_output(out, count, exr_compression=None, names=None):
    """The output `out` names for `count` views, EXRs compressed with
    exr_compression (GBuffer.write_exr; None: its default), named by the
    views' names (the camera file's; None for none) under %s; InputError
    for one that cannot hold them, or an EXR compression for a zarr store."""
    out = os.fspath(out)
    if out.rstrip("/").endswith(".zarr"):
        if exr_compression is not None:
            raise InputError(f"exr_compression {exr_compression!r} is for EXR outputs; {out} is a zarr store")
        return ZarrOutput(out)
    return ExrOutput(out, count, exr_compression or "zip", names)


def make_folder(folder):
    """The output folder and its missing parents, as mkdir -p and `rayfold
    render` make them; InputError naming the folder when one cannot be made
    (a file in the way, no permission)."""
    try:
        os.makedirs(folder, exist_ok=True)
    except OSError as e:
        raise InputError(f"{folder}: cannot make the output folder: {e.strerror}") from e


class ExrOutput:
    """out % index, or out with %s the view's name: one EXR per view, all in one folder (with the
    manifest)."""

    def __init__(self, pattern, count, compression="zip", names=None):
        _check_exr_compression(compression)  # InputError for a name OpenEXR has not, or a lossy one
        self.compression = compression
        self.files = None
        if not pattern.endswith(".exr"):
            raise InputError(f"output pattern {pattern!r}: rayfold-batch writes EXR files (end it in .exr) or one "
                             "zarr store (end it in .zarr)")
        if "%s" in pattern:
            self._name_views(pattern, names)
            return
        message = (f"output pattern {pattern!r} must hold one integer field such as %06d (the view's index) or %s "
                   "(its name)")
        try:
            first = [pattern % i for i in range(min(count, 2))]
        except (TypeError, ValueError):
            raise InputError(message)
        if count > 1 and first[0] == first[1]:
            raise InputError(message)
        self.pattern = os.path.abspath(pattern)
        if os.path.dirname(self.pattern % 0) != os.path.dirname(self.pattern % max(count - 1, 0)):
            raise InputError(f"output pattern {pattern!r}: the index goes in the file's name, not its folder (one "
                             "folder holds a job's views and its manifest)")
        self.folder = os.path.dirname(self.pattern % 0)

    def _name_views(self, pattern, names):
        """%s: each view's file named by its name in the camera file, as
        `rayfold render -o out/%s.exr` names it (the last component, less its
        extension); two views whose names end alike are refused by name."""
        if "%s" in os.path.dirname(pattern):
            raise InputError(f"output pattern {pattern!r}: the name goes in the file's name, not its folder (one "
                             "folder holds a job's views and its manifest)")
        if names is None:
            raise InputError(f"output pattern {pattern!r}: %s names each view by its camera file's names, and "
                             "these cameras come without a file; use an integer field such as %06d")
        self.pattern = os.path.abspath(pattern)
        self.folder = os.path.dirname(self.pattern)
        # InputError for another field, a name that gives no file or two names that give one (as the CLI's -o).
        files = _view_files(pattern, names)
        self.files = [None if name is None else os.path.abspath(f) for f, name in zip(files, names)]

    def path(self, i):
        if self.files is not None:
            return self.files[i]
        return self.pattern % i

    def record_name(self, i):
        return os.path.basename(self.path(i))

    def prepare(self, cameras, scene, options):
        make_folder(self.folder)

    def open(self):
        pass

    def matches(self, i, record, verify):
        try:
            if os.path.getsize(self.path(i)) != record["bytes"]:
                return False
        except OSError:
            return False
        return not verify or sha256_file(self.path(i)) == record["sha256"]

    def write(self, i, g, scene):
        """Writes view i; returns (bytes, sha256) for its record."""
        path = self.path(i)
        g.write_exr(path, scene, compression=self.compression)
        return os.path.getsize(path), sha256_file(path)

    def remove_partial(self, indices, pid):
        """What a killed worker was writing: the temporaries of these views'
        files that carry its pid (the files' own names never appeared)."""
        for i in indices:
            folder, name = os.path.split(self.path(i))
            for temp in glob.glob(os.path.join(glob.escape(folder), f".{glob.escape(name)}.rayfold-{pid}-*.tmp")):
                try:
                    os.remove(temp)
                except FileNotFoundError:
                    pass

    def remove_all_partial(self):
        """At the end of a run: the temporaries that writers which have
        ended left in the folder (a run stopped by a signal, whose workers
        Ray killed mid-write; at the rerun's start they could still be
        exiting, so its own scan kept them)."""
        for temp in glob.glob(os.path.join(glob.escape(self.folder), ".*.rayfold-*-*.tmp")):
            pid = os.path.basename(temp).rsplit(".rayfold-", 1)[1].split("-", 1)[0]
            if pid.isdigit() and not _alive(int(pid)):
                try:
                    os.remove(temp)
                except FileNotFoundError:
                    pass


def _alive(pid):
    """Whether process pid runs (a zombie, ended but not yet reaped, does not)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return True


class ZarrOutput:
    """One zarr store: per plane an array (views, height, width[, k]) with
    one chunk per view, so workers write views apart; the cameras and what
    the planes mean as attributes. zarr writes each chunk to a temporary and
    renames it into place."""

    def __init__(self, path):
        self.store = os.path.abspath(os.fspath(path).rstrip("/"))
        self.folder = os.path.dirname(self.store)
        self.group = None

    def __getstate__(self):
        return {"store": self.store, "folder": self.folder}

    def __setstate__(self, state):
        self.__dict__.update(state, group=None)

    def record_name(self, i):
        return f"{os.path.basename(self.store)}[{i}]"

    def _zarr(self):
        try:
            import zarr
        except ImportError as e:
            raise InputError(f"{self.store}: a zarr store needs zarr: pip install 'rayfold[batch]' "
                             "(or pip install zarr)") from e
        return zarr

    def prepare(self, cameras, scene, options):
        """Makes the store, or checks the one there holds these views."""
        zarr = self._zarr()
        make_folder(self.folder)
        sizes = {(c.width, c.height) for c in cameras if c is not None}
        if len(sizes) != 1:
            raise InputError(f"{self.store}: a zarr store holds views of one size; these have "
                             f"{', '.join(f'{w}x{h}' for w, h in sorted(sizes))} (write EXRs instead)")
        (width, height), = sizes
        channels = options["channels"]
        planes = VISIBILITY if channels is None else [p for p in PLANES if p in _channel_names(channels)]
        attrs = {
            "rayfold_version": __version__,
            "scene": scene.path,
            "instance_names": list(scene.instance_names),
            "fold": options["fold"],
            "depth": ("distance along each pixel's ray" if options["depth"] == "distance"
                      else "depth along the camera's axis (planar)") +
                     (", exact (double-float, within 2^-24)" if options.get("exact_depth") else ""),
            "unwritten": "float planes NaN; ids 4294967295 (also a miss's id)",
            "miss": "depth inf, instance_id, primitive_id, material_id, label and flow_visible 4294967295, "
                    "other planes 0 (docs/channels.md)",
            "barycentrics": "the weights (u, v) of each hit triangle's 2nd and 3rd vertex, not texture "
                            "coordinates (texcoord); stores of rayfold before 2026-12-07 named this array uv",
            "pixel_centres": "at (x + 0.5, y + 0.5) from the top-left corner, rows going down",
            "cameras": [None if c is None else _camera_attrs(c) for c in cameras],
        }
        if "label" in planes:  # what the label plane's integers name, as the EXR header's rayfold:labels
            attrs["labels"] = list(scene.labels)
        if os.path.exists(self.store):
            group = zarr.open_group(self.store, mode="r+")
            if "uv" in group and "barycentrics" not in group:
                raise InputError(f"{self.store}: was written by a rayfold before 2026-12-07, which named the "
                                 "barycentrics uv: remove it or write another store")
            for p in planes:
                extra, dtype, _ = PLANES[p]
                want = (len(cameras), height, width) + extra
                if p not in group or group[p].shape != want or str(group[p].dtype) != dtype:
                    raise InputError(f"{self.store}: holds other views ({p} is not {dtype} {want}): remove it or "
                                     "write another store")
            if dict(group.attrs) != json.loads(json.dumps(attrs)):
                raise InputError(f"{self.store}: was written for another scene, cameras or options: remove it or "
                                 "write another store")
            return
        group = zarr.open_group(self.store, mode="w-")
        for p in planes:
            extra, dtype, fill = PLANES[p]
            group.create_array(p, shape=(len(cameras), height, width) + extra,
                               chunks=(1, height, width) + extra, dtype=dtype, fill_value=fill)
        group.attrs.update(attrs)

    def open(self):
        self.group = self._zarr().open_group(self.store, mode="r+")

    def _view_bytes(self, planes):
        h = hashlib.sha256()
        for p in PLANES:
            if p in planes:
                h.update(np.ascontiguousarray(planes[p]).tobytes())
        return h.hexdigest()

    def matches(self, i, record, verify):
        # Always read back: a view's chunks are whole or absent, and an absent
        # one reads as its fill value, which only an identical view matches.
        if self.group is None:
            self.open()
        return self._view_bytes({p: self.group[p][i] for p in PLANES if p in self.group}) == record["sha256"]

    def write(self, i, g, scene):
        planes = {p: getattr(g, p) for p in PLANES if p in self.group}
        for p, v in planes.items():
            self.group[p][i] = v
        return sum(v.nbytes for v in planes.values()), self._view_bytes(planes)

    def remove_partial(self, indices, pid):
        """zarr's temporaries carry no pid; they go at the end of the run."""

    def remove_all_partial(self):
        for temp in glob.glob(os.path.join(glob.escape(self.store), "**", "*.partial"), recursive=True):
            try:
                os.remove(temp)
            except FileNotFoundError:
                pass


_CHANNEL_PLANES = {n: _store_name(s) for s in _plane_specs() for n in (s["name"], s["alias"], s["exr_layer"]) if n}


def _channel_names(channels):
    """The planes `channels` asks for (the names Scene.render takes)."""
    names = channels.split(",") if isinstance(channels, str) else list(channels)
    out = set()
    for n in names:
        if n.strip() not in _CHANNEL_PLANES:
            names = ", ".join(s["name"] for s in _plane_specs())
            layers = ", ".join(s["exr_layer"] for s in _plane_specs())
            raise InputError(f"channels: unknown channel {n.strip()!r} ({names}; or as the EXR names them: "
                             f"{layers}; uv is barycentrics' older name)")
        out.add(_CHANNEL_PLANES[n.strip()])
    return out


def _camera_attrs(c):
    fx, fy, cx, cy = c.intrinsics
    return {"camera_to_world": c.camera_to_world.tolist(), "convention": "opengl", "fx": fx, "fy": fy, "cx": cx,
            "cy": cy, "width": c.width, "height": c.height,
            "projection": "orthographic" if c.is_orthographic else "perspective"}
