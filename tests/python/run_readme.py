"""Runs the Python blocks of the README and the Python guide as written, in
order in one namespace (a later block uses the names an earlier one made),
from the repository root (they name scenes/atrium.glb). Used by
pip_install.sh in a fresh environment and by the pytest suite. GUIDE names
the pages whose commands and examples the tests run."""
import os
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]
# The front page and the guide it links, in reading order.
GUIDE = ["README.md", "docs/cli.md", "docs/python.md", "docs/cpp.md", "docs/batch.md", "docs/formats.md",
         "docs/how_it_works.md", "docs/exactness.md", "docs/benchmarks.md"]


def guide_text():
    """Every page of GUIDE, one after the other."""
    return "\n".join((ROOT / page).read_text() for page in GUIDE)


def run():
    blocks = []
    for page in GUIDE:
        for k, block in enumerate(re.findall(r"```python\n(.*?)```", (ROOT / page).read_text(), re.S)):
            blocks.append((f"{page} (Python block {k + 1})", block))
    assert blocks, "the README and guide have no Python block"
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        names = {}
        for where, block in blocks:
            exec(compile(block, where, "exec"), names)
    finally:
        os.chdir(here)


if __name__ == "__main__":
    run()
