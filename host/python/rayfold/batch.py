"""Many views of one scene on a Ray cluster: this machine's, started for the
job and stopped after it, or a running one (address=). Each worker is a Ray
actor holding one Renderer; it writes its views' outputs itself.

    rayfold-batch scene.glb --cameras cams.json -o out/view_%06d.exr --workers 2

    import rayfold.batch
    summary = rayfold.batch.render("scene.glb", cameras, "out/view_%06d.exr", workers=2)

Nothing is lost. A view's file appears whole or not at all. Each written view
is recorded in the manifest, OUT_DIR/rayfold-manifest/ (one JSON-lines file
per worker process, so that no two processes append to one file), with its
size, its SHA-256 and a key of what it shows (the scene file's bytes, the
camera's, fold, channels, depth, rayfold's version). A rerun skips every view
whose file still matches its record and renders only the rest. The unfinished
views of a worker that dies are retried on a fresh one. A view that fails is
reported with its index and reason while the rest complete.

Outputs: an EXR per view, or one zarr store (rayfold/_batch_outputs.py).
Needs Ray (pip install rayfold[batch], which brings zarr too)."""
import argparse
import dataclasses
import hashlib
import json
import os
import resource
import signal
import socket
import sys
import time
import warnings

from ._core import Camera, InputError, RuntimeFailure, Scene, __version__, _channels_read_attributes
from ._batch_outputs import _channel_names, make_output, sha256_file
from ._streams import asks_flow, read_views_lenient

MANIFEST_DIR = "rayfold-manifest"
# Views a worker renders per call: a multiple of what one trace holds in
# every fold (as iter_views), and few enough that a lost worker costs little.
BATCH_VIEWS = 32


@dataclasses.dataclass
class Summary:
    """What a batch did. written: views whose file is complete (rendered now
    or kept from an earlier run); failed: (view index, reason) for the rest."""
    views: int
    rendered: int
    kept: int
    failed: list
    warnings: list            # (view index, warning) as GBuffer.warnings
    seconds: float             # the whole call, but stopping the cluster
    startup_seconds: float     # of which starting Ray and the workers (trees and kernels built or loaded)
    cluster_seconds: float     # of which starting Ray (or joining the cluster)
    workers: int
    workers_lost: int          # workers that died and were replaced
    views_retried: int         # views rendered again after their worker died
    driver_peak_rss_mb: float
    worker_peak_rss_mb: float  # the largest of any worker's

    @property
    def written(self):
        return self.rendered + self.kept

    @property
    def views_per_second(self):
        """Once the workers are up."""
        busy = self.seconds - self.startup_seconds
        return self.rendered / busy if busy > 0 else 0.0

    def line(self):
        s = (f"rayfold-batch: {self.written} of {self.views} views written ({self.rendered} rendered, "
             f"{self.kept} kept from an earlier run), {len(self.failed)} failed; "
             f"{self.views_per_second:.1f} views/s on {self.workers} worker{'s' if self.workers != 1 else ''} "
             f"after {self.startup_seconds:.1f} s starting them ({self.cluster_seconds:.1f} s of it Ray's)")
        if self.workers_lost:
            s += f"; {self.workers_lost} worker(s) lost and replaced, {self.views_retried} view(s) retried"
        return s


def _peak_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _read_manifest(directory):
    """path (relative to the output folder) -> the last record written for
    it, by its write time (the part files' names, host and pid, say nothing of
    their order; a record without a time, from an older rayfold, is the
    oldest). A line cut short by a killed worker is no record."""
    records = {}
    if not os.path.isdir(directory):
        return records
    for name in sorted(os.listdir(directory)):
        if not name.endswith(".jsonl"):
            continue
        with open(os.path.join(directory, name), encoding="utf-8") as f:
            for line in f:
                try:
                    r = json.loads(line)
                except json.JSONDecodeError:
                    continue
                if isinstance(r, dict) and {"path", "bytes", "sha256", "key"} <= r.keys():
                    last = records.get(r["path"])
                    if last is None or r.get("written_ns", 0) >= last.get("written_ns", 0):
                        records[r["path"]] = r
    return records


def _complete(output, i, key, records, verify):
    r = records.get(output.record_name(i))
    return r is not None and r["key"] == key and output.matches(i, r, verify)


class _Worker:
    """One Renderer on one scene; renders lists of views and records each."""

    def __init__(self, scene, render_options, output, manifest_dir, label_key=""):
        # The trees as bytes (from Ray's object store, once per node), or the file's path.
        self.scene = Scene.from_bytes(scene) if isinstance(scene, bytes) else Scene(scene, label_key=label_key)
        self.options = render_options
        self.output = output
        output.open()
        # Trees (unless they came built) and kernels now, so that a worker is
        # ready when it says so: the time to its first view is the start's.
        warm = {o: v for o, v in render_options.items() if o not in ("align", "channels")}
        warm["fold"] = "none"  # fold="auto" probes each size of view on first use: the real views' size, later
        # Any view will do: the default one would probe a camera-less file for its view first.
        lo, hi = self.scene.bounds[:3], self.scene.bounds[3:]
        centre = [(a + b) / 2 for a, b in zip(lo, hi)]
        eye = (centre[0], centre[1], centre[2] + 1.0 + sum(b - a for a, b in zip(lo, hi)))
        self.scene.render(Camera.look_at(eye, centre, (0, 1, 0), 60, 1, 1), **warm)
        os.makedirs(manifest_dir, exist_ok=True)
        self.part_path = os.path.join(manifest_dir, f"{socket.gethostname()}-{os.getpid()}.jsonl")
        self.part = open(self.part_path, "a", encoding="utf-8")

    def where(self):
        return socket.gethostname(), os.getpid()

    def _write(self, index, g, key):
        size, sha = self.output.write(index, g, self.scene)
        record = {"view": index, "path": self.output.record_name(index), "bytes": size, "sha256": sha, "key": key,
                  "written_ns": time.time_ns()}
        self.part.write(json.dumps(record) + "\n")
        self.part.flush()  # a worker killed later keeps this view; fsync once per batch
        return list(g.warnings)

    def render(self, views):
        """views: (index, camera, key, next camera) tuples of one size and
        intrinsics; the next camera is the one the view's flow goes to (None
        without flow or after the last view). Returns (done indices,
        failures, warnings, peak RSS MB)."""
        done, failures, warnings = [], [], []
        flow = asks_flow(self.options["channels"])
        gbuffers = None
        if not flow:  # with flow each view goes alone with its next one
            try:
                gbuffers = self.scene.render_views([v[1] for v in views], **self.options)
            except (InputError, RuntimeFailure):
                pass  # one view spoils the trace: each alone, to name it
        single = {o: v for o, v in self.options.items() if o != "align"}
        for k, (index, camera, key, after) in enumerate(views):
            try:
                if gbuffers is not None:
                    g = gbuffers[k]
                elif flow and after is None:
                    g = self.scene.render_views([camera], **self.options)[0]  # the last view: NaN flow
                else:
                    g = self.scene.render(camera, **single, **({"flow_to": after} if flow else {}))
                warnings += [(index, w) for w in self._write(index, g, key)]
                done.append(index)
            except (InputError, RuntimeFailure, OSError) as e:
                failures.append((index, str(e)))
            if gbuffers is not None:
                gbuffers[k] = None  # each G-buffer freed once written
        self.part.flush()
        os.fsync(self.part.fileno())
        return done, failures, warnings, _peak_rss_mb()


def _read_cameras(cameras, width, height):
    """(cameras by index, None for a view whose entry is bad; those as
    (index, reason); the views' names from a camera file, else None)."""
    if isinstance(cameras, (str, os.PathLike)):
        return read_views_lenient(cameras, width, height)
    cameras = list(cameras)
    for i, c in enumerate(cameras):
        if not isinstance(c, Camera):
            raise TypeError(f"rayfold.batch: camera {i} is a {type(c).__name__}, not a rayfold.Camera")
    return cameras, [], None


def _batches(cameras, todo, batch_views):
    """The views to render in batches of one size and intrinsics each (so
    that alignment applies inside a batch), in index order within each."""
    groups = {}
    for i in todo:
        c = cameras[i]
        groups.setdefault((c.width, c.height, c.intrinsics, c.is_orthographic), []).append(i)
    out = []
    for indices in groups.values():
        out += [indices[k:k + batch_views] for k in range(0, len(indices), batch_views)]
    return out


class _Progress:
    def __init__(self, total, enabled):
        self.total, self.enabled = total, enabled and total > 0
        self.tty = sys.stderr.isatty()
        self.t0 = self.last = time.monotonic()

    def show(self, done, retried, final=False):
        if not self.enabled:
            return
        now = time.monotonic()
        if not final and now - self.last < (0.2 if self.tty else 5.0):
            return
        self.last = now
        rate = done / (now - self.t0) if now > self.t0 else 0.0
        bar = "#" * int(30 * done / self.total)
        text = f"  [{bar:<30}] {done}/{self.total} views, {rate:.1f}/s" + (f", {retried} retried" if retried else "")
        sys.stderr.write(("\r" + text + ("\n" if final else "")) if self.tty else text + "\n")
        sys.stderr.flush()


def render(scene, cameras, out, *, workers=1, address=None, fold="none", align=0, channels=None,
           depth="distance", exact_depth=False, backend="opencl", device="", kernel="auto", verify=True, retries=3,
           batch_views=BATCH_VIEWS, width=0, height=0, progress=True, send="auto", gpu_workers=0,
           exr_compression=None, label_key="", _after_ray_start=None):
    """Renders every camera's view of `scene` (a rayfold.Scene, or the path
    of a glTF or scene file) to out % index (an .exr pattern such as
    'dir/view_%06d.exr'), or to one zarr store (a path ending in .zarr: per
    plane an array (views, height, width[, k]) with one chunk per view, the
    cameras and instance names as attributes; views of one size), on
    `workers` Ray actors, each with its share of the
    cluster's cores (CPU workers, on the OpenCL CPU device when GPU workers
    run too), and gpu_workers more with one GPU each (Ray's num_gpus=1, the
    OpenCL device "gpu"); returns a Summary. send: 'trees' builds the trees here
    once and hands them to the workers through Ray's object store
    (Scene.to_bytes; once per node), 'file' has each worker load the path
    and build its own (every machine then needs the file); 'auto', the
    default: 'file' for a path (measured faster to start, docs/results.md),
    'trees' for a Scene. cameras:
    a list of rayfold.Camera, or a file as Camera.from_file reads it (width,
    height as there). Views already complete from an earlier run (manifest,
    size and, with verify, SHA-256) are kept. address: a running Ray cluster
    ('auto' or host:port); None starts one on this machine for the job, or
    uses the session this process already has. Each view's pixels equal
    Scene.render_views(cameras, fold=fold, ...) bit for bit. InputError for
    bad input before anything is rendered. exr_compression: the EXRs'
    (GBuffer.write_exr: 'zip' by default, 'none' writes 3 to 4 times faster
    at 10 times the bytes); a rerun with another rewrites the views.
    label_key: as Scene's, for a scene given by its path (the label channel's
    table is in each EXR's header and the zarr store's attributes). Channels
    that read the glTF's attributes, materials or labels (shading_normal,
    texcoord, material channels, label, tangent, mapped_normal) need the
    file in each worker: a scene loaded from a glTF file and sent as trees
    (a Scene, or send='trees') would reach them with positions only, so
    that is refused; a Scene built in memory has the same stand-ins in its
    own renders and goes as trees."""
    try:
        import ray
    except ImportError as e:
        raise RuntimeFailure("rayfold.batch needs Ray: pip install 'rayfold[batch]' (or pip install ray)") from e
    t0 = time.monotonic()
    if send not in ("auto", "trees", "file"):
        raise InputError(f"rayfold.batch.render: send must be 'auto', 'trees' or 'file', not {send!r}")
    # Unknown channels fail here, before a folder or a cluster is made.
    reads_attributes = _channels_read_attributes(channels)
    if send == "auto":
        send = "trees" if isinstance(scene, Scene) else "file"
    # Trees carry positions only: where the scene's own renders read its glTF's
    # attributes, the workers' would give stand-ins instead. (A Scene built in
    # memory or from a scene file has stand-ins in both.)
    if send == "trees" and reads_attributes and (not isinstance(scene, Scene) or scene._reads_file):
        raise InputError(f"rayfold.batch.render: channels {channels!r} read the glTF's attributes, materials or "
                         "labels, which a scene sent as trees does not carry (a scene file keeps positions only): "
                         + ("pass the scene's path instead of a Scene" if isinstance(scene, Scene) else
                            "send='file' (--send file) loads them in each worker"))
    if isinstance(scene, Scene):
        if send == "file":
            raise InputError("rayfold.batch.render: send='file' needs the scene's path, not a Scene")
        if label_key:
            raise InputError("rayfold.batch.render: label_key is for a scene given by its path; a Scene has its own "
                             "(Scene(path, label_key=...))")
        loaded, scene_path = scene, None
    elif isinstance(scene, (str, os.PathLike)):
        scene_path = os.path.abspath(os.fspath(scene))
        # Bad input fails here, naming the file, before a cluster starts.
        loaded = Scene(scene_path, label_key=label_key)
    else:
        raise TypeError(f"rayfold.batch.render: scene is a rayfold.Scene or a file's path, not a "
                        f"{type(scene).__name__}")
    cameras, skipped, names = _read_cameras(cameras, width, height)
    if not cameras:
        raise InputError("rayfold.batch.render: no cameras")
    if workers < 0 or gpu_workers < 0 or workers + gpu_workers < 1 or batch_views < 1 or retries < 0:
        raise InputError(f"rayfold.batch.render: workers ({workers}) and gpu_workers ({gpu_workers}) must be at "
                         f"least 0 and together at least 1, batch_views ({batch_views}) at least 1, retries "
                         f"({retries}) at least 0")
    output = make_output(out, len(cameras), exr_compression, names)
    manifest_dir = os.path.join(output.folder, MANIFEST_DIR)
    options = dict(fold=fold, align=align, backend=backend, device=device, kernel=kernel, channels=channels,
                   depth=depth, exact_depth=bool(exact_depth))
    output.prepare(cameras, loaded, options)
    # What a view's file shows: a rerun keeps the file only when all of it is the same.
    scene_bytes = None if scene_path else loaded.to_bytes()
    scene_digest = sha256_file(scene_path) if scene_path else hashlib.sha256(scene_bytes).hexdigest()
    common = json.dumps([scene_digest, fold, str(channels), depth, __version__] +
                        ([exr_compression] if exr_compression not in (None, "zip") else []) +
                        ([f"label_key={label_key}"] if label_key and "label" in _channel_names(channels or ()) else
                         []) +
                        (["exact_depth"] if exact_depth else [])).encode()
    # With flow a view's planes depend on the next view too (it flows there).
    flow = asks_flow(channels)
    keys = [hashlib.sha256(common + c.__getstate__() +
                           (cameras[i + 1].__getstate__() if flow and i + 1 < len(cameras) and cameras[i + 1] else
                            b"")).hexdigest() if c is not None else None for i, c in enumerate(cameras)]

    records = _read_manifest(manifest_dir)
    todo = [i for i in range(len(cameras))
            if cameras[i] is not None and not _complete(output, i, keys[i], records, verify)]
    kept = len(cameras) - len(todo) - len(skipped)

    if not todo:  # nothing to render: no cluster
        return Summary(len(cameras), 0, kept, sorted(skipped), [], time.monotonic() - t0, 0.0, 0.0,
                       workers + gpu_workers, 0, 0, _peak_rss_mb(), 0.0)
    if send == "trees" and scene_bytes is None:
        scene_bytes = loaded.to_bytes()  # the trees, built here once
    started = not ray.is_initialized()
    t_cluster = time.monotonic()
    if started:
        ray.init(address=address, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
    cluster = time.monotonic() - t_cluster
    failed, warnings = list(skipped), []
    rendered = lost = retried = 0
    worker_peak = startup = 0.0
    finished = None
    try:
        if _after_ray_start:
            _after_ray_start()
        gpus = ray.cluster_resources().get("GPU", 0)
        if gpu_workers > gpus:  # Ray would wait for them forever
            raise InputError(f"rayfold.batch.render: {gpu_workers} GPU workers, but the Ray cluster has {gpus:g} "
                             "GPUs")
        # CPU workers share the cores a GPU worker's host thread leaves.
        cpu_total = ray.cluster_resources().get("CPU", 1.0) - gpu_workers
        cores = max(1.0, cpu_total // workers) if workers else 1.0
        kinds = {
            "cpu": (ray.remote(_Worker).options(
                num_cpus=cores, max_restarts=0,
                # PoCL runs a thread per core it sees: the cores Ray gives the worker.
                runtime_env={"env_vars": {"POCL_MAX_PTHREAD_COUNT": str(int(cores))}}),
                dict(options, threads=int(cores), device=device or ("cpu" if gpu_workers else ""))),
            # Ray shows a GPU actor its one GPU (CUDA_VISIBLE_DEVICES), which
            # NVIDIA's OpenCL honours: "gpu" is that one.
            "gpu": (ray.remote(_Worker).options(num_gpus=1, num_cpus=1, max_restarts=0),
                    dict(options, threads=1, device=device or "gpu")),
        }

        # Ray hands an object-store argument over resolved: the bytes.
        scene_arg = ray.put(scene_bytes) if send == "trees" else scene_path
        del scene_bytes

        def new_worker(kind):
            actor_class, worker_options = kinds[kind]
            return actor_class.remote(scene_arg, worker_options, output, manifest_dir, label_key)

        slots = (["gpu"] * gpu_workers + ["cpu"] * workers)[:len(todo)]
        pool = [new_worker(kind) for kind in slots]
        hosts = ray.get([w.where.remote() for w in pool])
        startup = time.monotonic() - t0
        idle = list(range(len(pool)))
        # Small jobs in smaller batches, so that every worker gets some: four
        # batches a worker at least, up to batch_views.
        size = max(1, min(batch_views, -(-len(todo) // (4 * len(pool)))))
        pending = [[(i, cameras[i], keys[i], cameras[i + 1] if flow and i + 1 < len(cameras) else None) for i in b]
                   for b in _batches(cameras, todo, size)]
        pending.reverse()  # popped from the end: index order
        attempts = {}
        in_flight = {}
        bar = _Progress(len(todo), progress)
        while pending or in_flight:
            while idle and pending:
                slot, batch = idle.pop(), pending.pop()
                in_flight[pool[slot].render.remote(batch)] = (slot, batch)
            ready, _ = ray.wait(list(in_flight), num_returns=1)
            slot, batch = in_flight.pop(ready[0])
            try:
                done, bad, warned, peak = ray.get(ready[0])
            except ray.exceptions.RayActorError:
                # The worker died: what it recorded is done, the rest goes again.
                lost += 1
                output.remove_partial([v[0] for v in batch], hosts[slot][1])
                pool[slot] = new_worker(slots[slot])
                hosts[slot] = ray.get(pool[slot].where.remote())
                idle.append(slot)
                records = _read_manifest(manifest_dir)
                rest = [v for v in batch if not _complete(output, v[0], v[2], records, verify)]
                rendered += len(batch) - len(rest)
                key = rest[0][0] if rest else None
                attempts[key] = attempts.get(key, 0) + 1
                if rest and attempts[key] > retries:
                    failed += [(v[0], f"its worker died {attempts[key]} times") for v in rest]
                elif rest:
                    retried += len(rest)
                    pending.append(rest)
                bar.show(rendered + len(failed), retried)
                continue
            idle.append(slot)
            rendered += len(done)
            failed += bad
            warnings += warned
            worker_peak = max(worker_peak, peak)
            bar.show(rendered + len(failed), retried)
        bar.show(rendered + len(failed), retried, final=True)
        finished = time.monotonic()  # the cluster's stop is not the job's
        for actor in pool:
            ray.kill(actor)
        if hasattr(output, "remove_all_partial"):
            output.remove_all_partial()  # a killed worker's, now that no one writes
    finally:
        if started:
            ray.shutdown()
    return Summary(len(cameras), rendered, kept, sorted(failed), sorted(warnings), finished - t0, startup, cluster,
                   workers + gpu_workers, lost, retried, _peak_rss_mb(), worker_peak)


_stopped_by = [signal.SIGINT]


def _raise_stopped(signum, frame):
    # As KeyboardInterrupt: Ray's calls pass that one through (another
    # exception raised in their signal check comes out as a SystemError).
    _stopped_by[0] = signum
    raise KeyboardInterrupt


def _unwind_on_signals():
    """SIGTERM and SIGHUP unwind as Ctrl-C does, so that the cluster this run
    started is stopped (its processes would outlive a killed driver). After
    ray.init, whose own handlers would end the driver at once."""
    for sig in (signal.SIGTERM, signal.SIGHUP):
        signal.signal(sig, _raise_stopped)


def _align_arg(text):
    """--align as the CLI spells it: N views a trace (1: each alone), all
    (as many as a trace holds; 0, the Python default, means the same) or
    auto (as the cost model predicts fastest)."""
    if text == "all":
        return 0
    if text == "auto":
        return "auto"
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected N, all or auto, not {text!r}")
    if n < 0:
        raise argparse.ArgumentTypeError(f"expected N (1 or more), all or auto, not {text!r}")
    return n


def _print_warning(message, category, filename, lineno, file=None, line=None):
    """A note to a rayfold-batch user as the CLI gives it: one "warning:"
    line, without Python's category and source line."""
    print(f"warning: {message}", file=sys.stderr)


def main(argv=None):
    """rayfold-batch: exit 0 when every view is written, 1 when some failed
    (listed), 2 for bad input, 3 when the run could not go on."""
    warnings.showwarning = _print_warning
    p = argparse.ArgumentParser(prog="rayfold-batch", description=(
        "Renders every view of a camera file to one EXR each on a Ray cluster: this machine's, started for the "
        "job, or a running one (--address). A rerun keeps the views already written and renders the rest."))
    p.add_argument("scene", help="glTF 2.0 file (.glb or .gltf), or a scene file rayfold saved (Scene.save)")
    views = p.add_mutually_exclusive_group(required=True)
    views.add_argument("--cameras", metavar="FILE", help="a rayfold camera list or a NeRF transforms.json")
    views.add_argument("--colmap", metavar="DIR", help="a COLMAP text model (cameras.txt, images.txt)")
    p.add_argument("-o", "--output", required=True, metavar="PATTERN",
                   help="an EXR per view, with the view's index as an integer field (out/view_%%06d.exr) or its "
                        "name in the camera file as %%s (out/%%s.exr: a file_path or COLMAP image name less folders "
                        "and extension), or one zarr store (out/views.zarr: per plane an array of views, one chunk "
                        "per view); missing folders are made")
    p.add_argument("--workers", type=int, default=1, help="Ray actors, each with its share of the cores (1)")
    p.add_argument("--gpu-workers", type=int, default=0,
                   help="more actors with one GPU each (OpenCL device 'gpu'; the CPU workers then take 'cpu')")
    p.add_argument("--address", help="a running Ray cluster (auto, or host:port); default: start one here")
    p.add_argument("--fold", default="none", choices=["none", "y", "x", "xy", "auto"],
                   help="the same bits in every mode, less work folded; auto: the fold (and, with --kernel auto, "
                        "the kernel) the cost model predicts fastest, chosen by each worker on its first views")
    p.add_argument("--align", type=_align_arg, default=0, metavar="N|all|auto",
                   help="views traced together: N (1: each alone), all, the default: as many as a trace holds, "
                        "or auto: as the cost model predicts fastest")
    p.add_argument("--channels", help="the planes written, for example depth,instance_id (default the visibility "
                                      "buffer: depth, normal, barycentrics, instance_id, primitive_id); flow and "
                                      "flow_visible go from each view to the next (docs/channels.md)")
    p.add_argument("--depth", default="distance", choices=["distance", "planar"])
    p.add_argument("--label-key", default="", metavar="KEY",
                   help="the member of a node's extras that labels it for the label channel (default: the whole "
                        "extras), as rayfold render's --label-key")
    p.add_argument("--exact-depth", action="store_true",
                   help="each depth from the pixel's exact ray in double-float, within 2^-24 of the exact value "
                        "(about 1.2x to 1.5x the frame time on a CPU)")
    p.add_argument("--exr-compression", choices=["zip", "zips", "piz", "rle", "none"],
                   help="the EXRs' lossless compression: zip (default); none writes 3 to 4 times faster at 10 times "
                        "the bytes")
    p.add_argument("--backend", default="opencl", choices=["opencl", "cpu"])
    p.add_argument("--device", default="", help="the first OpenCL device whose platform or name holds this")
    p.add_argument("--kernel", default="auto", choices=["auto", "tile", "single", "measure"],
                   help="the OpenCL kernel, as rayfold render's --kernel (default auto: tile on CPU devices); the "
                        "same bits with each")
    p.add_argument("--size", metavar="WxH", help="image size for a transforms.json without w and h")
    p.add_argument("--retries", type=int, default=3, help="times a view whose worker died is tried again (3)")
    p.add_argument("--send", default="file", choices=["trees", "file"],
                   help="file: each worker loads the scene file and builds its trees (default; the file on every "
                        "machine); trees: build them once here and send them through Ray's object store")
    p.add_argument("--no-verify", action="store_true",
                   help="keep views from an earlier run on their size alone, without reading them for the SHA-256")
    p.add_argument("--summary", metavar="FILE.json", help="also write the summary as JSON")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    a = p.parse_args(argv)
    try:
        width = height = 0
        if a.size:
            try:
                width, height = (int(v) for v in a.size.lower().split("x"))
            except ValueError:
                raise InputError(f"--size {a.size!r}: expected WxH, for example 640x480")
        cameras = a.cameras if a.cameras else a.colmap
        s = render(a.scene, cameras, a.output, workers=a.workers, address=a.address, fold=a.fold, align=a.align,
                   channels=a.channels, depth=a.depth, exact_depth=a.exact_depth, backend=a.backend,
                   device=a.device, kernel=a.kernel, verify=not a.no_verify,
                   retries=a.retries, width=width, height=height, progress=not a.quiet, send=a.send,
                   gpu_workers=a.gpu_workers, exr_compression=a.exr_compression, label_key=a.label_key,
                   _after_ray_start=_unwind_on_signals)
    except (InputError, TypeError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    except (RuntimeFailure, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        sig = _stopped_by[0]
        print(f"error: stopped ({signal.Signals(sig).name}); every view written so far is complete and recorded, "
              "a rerun renders the rest", file=sys.stderr)
        return 128 + sig
    for index, reason in s.failed:
        print(f"error: view {index}: {reason}", file=sys.stderr)
    for index, warning in s.warnings:
        print(f"warning: view {index}: {warning}", file=sys.stderr)
    print(s.line(), file=sys.stderr)
    if a.summary:
        d = dataclasses.asdict(s)
        d.update(written=s.written, views_per_second=s.views_per_second)
        tmp = a.summary + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(d, f, indent=1)
        os.replace(tmp, a.summary)
    return 0 if not s.failed else 1


if __name__ == "__main__":
    sys.exit(main())
