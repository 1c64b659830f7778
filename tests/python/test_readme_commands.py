"""The command lines of the README and its guide (run_readme.GUIDE), run:
every `build/rayfold...` line of their shell blocks and the camera-list
example, at a small image size so the suite stays
quick (the size is the only change), each expected to exit 0; and every
option the README names is one the tool's --help documents. Docs that a
test runs stay true."""
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys

import pytest

from run_readme import ROOT, guide_text

README = guide_text()
SMALL = "96x54"


def shell_lines():
    """Each `build/rayfold...` command of the README's sh blocks, continuation
    lines joined, comments dropped."""
    lines = []
    for block in re.findall(r"```sh\n(.*?)```", README, re.S):
        joined = block.replace("\\\n", " ")
        for line in joined.splitlines():
            line = line.split("  #")[0].strip()
            if line.startswith("build/rayfold"):
                lines.append(line)
    return lines


def small(argv):
    """The command at a small size: a given --size shrinks, the tracing
    commands without one get it."""
    out = list(argv)
    if "--colmap" in out:  # the model gives the size (the fixture's is small)
        return out
    if "--size" in out:
        out[out.index("--size") + 1] = SMALL
    elif len(out) > 1 and out[1] in ("render", "bench") and "--help" not in out:
        out += ["--size", SMALL]
    elif pathlib.Path(out[0]).name in ("rayfold-peers", "rayfold-stats"):
        out += ["--size", SMALL]
    return out


@pytest.fixture(scope="module")
def scenes(tmp_path_factory, bin_dir):
    """scene.glb is the bundled scene; scene.gltf the same written as .gltf;
    sparse/0 a COLMAP text model of two small views of it. out/ is not
    made: the commands make their output folders."""
    d = tmp_path_factory.mktemp("readme")
    (d / "sparse" / "0").mkdir(parents=True)
    (d / "sparse" / "0" / "cameras.txt").write_text("1 PINHOLE 96 54 60 60 48 27\n")
    (d / "sparse" / "0" / "images.txt").write_text("1 0 1 0 0 0 2 14 1 a.jpg\n\n2 0 1 0 0 1 2 14 1 b.jpg\n\n")
    (d / "scene.glb").write_bytes((ROOT / "scenes" / "atrium.glb").read_bytes())
    subprocess.run([str(bin_dir / "rayfold-gen-scene"), "-o", str(d / "scene.gltf"), "--objects", "24",
                    "--triangles", "3000"], check=True, capture_output=True)
    return d


def test_the_readme_shows_commands():
    assert len(shell_lines()) >= 12, shell_lines()


@pytest.mark.parametrize("line", shell_lines())
def test_every_readme_command_runs(line, bin_dir, scenes):
    argv = shlex.split(line)
    argv[0] = str(bin_dir / pathlib.Path(argv[0]).name)
    if not pathlib.Path(argv[0]).exists():
        pytest.skip(f"{argv[0]} is not built here")
    argv = small(argv)
    if "bench" in argv[1:2]:
        argv += ["--frames", "1"] if "--frames" not in argv else []
    r = subprocess.run(argv, cwd=scenes, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, f"{' '.join(argv)}\n{r.stderr[-2000:]}"


def test_the_camera_list_example_renders(cli, tmp_path):
    block = re.search(r'```json\n(\{"width".*?)```', README, re.S)
    assert block, "the README's camera-list example"
    views = json.loads(block.group(1))
    views["width"], views["height"] = 64, 36  # the size only
    (tmp_path / "views.json").write_text(json.dumps(views))
    r = subprocess.run([cli, "render", "--cameras", "views.json", "-o", "view_%02d.exr"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["view_00.exr", "view_01.exr", "views.json"]


def test_every_option_the_readme_names_is_documented_by_help(cli, bin_dir):
    helps = ""
    for args in (["render", "--help"], ["bench", "--help"], ["info", "--help"], ["devices", "--help"]):
        helps += subprocess.run([cli] + args, capture_output=True, text=True).stdout
    for tool in ("rayfold-peers", "rayfold-stats", "rayfold-limits", "rayfold-gen-scene"):
        if (bin_dir / tool).exists():
            r = subprocess.run([str(bin_dir / tool), "--help"], capture_output=True, text=True)
            helps += r.stdout + r.stderr
    helps += subprocess.run([sys.executable, "-m", "rayfold.batch", "--help"], capture_output=True, text=True).stdout
    bench = pathlib.Path(__file__).resolve().parents[2] / "tools" / "bench"
    for script in ("bench_dataset_loop.py", "bench_channels.py"):
        helps += subprocess.run([sys.executable, str(bench / script), "--help"], capture_output=True, text=True).stdout
    options = set(re.findall(r"(?<![\w-])(--[a-z][a-z-]+)", README))
    # Options of other programs the README quotes (pip, cmake, make, ray start).
    foreign = {"--prefix", "--build", "--install", "--target", "--peers", "--help", "--version", "--head"}
    missing = sorted(o for o in options - foreign if o not in helps)
    assert not missing, f"options the README names that no --help documents: {missing}"
