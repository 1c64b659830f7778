#!/usr/bin/env bash
# Makes the virtual environment make test builds and tests the Python module
# with: Debian's python3 (python3-venv, python3-dev from install-deps.sh) and,
# from PyPI, nanobind, numpy and pytest. usage: python-env.sh DIR
set -euo pipefail
dir=$1
if [ -x "$dir/bin/python" ] && "$dir/bin/python" -c "import nanobind, numpy, pytest" 2>/dev/null; then exit 0; fi
/usr/bin/python3 -m venv "$dir"
"$dir/bin/python" -m pip install -q --upgrade pip
"$dir/bin/python" -m pip install -q "nanobind>=2.4,<4" "numpy>=1.24" "pytest>=7"
