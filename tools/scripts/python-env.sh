#!/usr/bin/env bash
# Makes the virtual environment make test builds and tests the Python module
# with: Debian's python3 (python3-venv, python3-dev from install-deps.sh) and,
# from PyPI, nanobind, numpy, pytest, Ray and zarr (rayfold.batch's tests
# start a local Ray cluster and write zarr stores), and Mitsuba 3 (the resolved
# channels' peer in tests/python/test_mitsuba_peer.py); --peers adds Open3D (CPU
# build), the benchmark's other Python peer (tools/bench/bench_python.py), and
# trimesh, which reads glTF for Mitsuba in tools/bench/bench_dataset_loop.py.
# usage: python-env.sh DIR [--peers]
set -euo pipefail
dir=$1
modules="nanobind, numpy, pytest, ray, zarr, mitsuba"
packages=("nanobind>=2.4,<4" "numpy>=1.24" "pytest>=7" "ray>=2.9" "zarr>=3" "mitsuba>=3.5")
if [ "${2:-}" = "--peers" ]; then
  modules="$modules, open3d, trimesh"
  packages+=("open3d-cpu>=0.18" "trimesh>=4")
fi
if [ -x "$dir/bin/python" ] && "$dir/bin/python" -c "import $modules" 2>/dev/null; then exit 0; fi
[ -x "$dir/bin/python" ] || /usr/bin/python3 -m venv "$dir"
"$dir/bin/python" -m pip install -q --upgrade pip
"$dir/bin/python" -m pip install -q "${packages[@]}"
