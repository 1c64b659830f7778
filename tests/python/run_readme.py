"""Runs the README's Python blocks as written, in order in one namespace (a
later block uses the names an earlier one made), from the repository root
(they name scenes/atrium.glb). Used by pip_install.sh in a fresh environment and
by the pytest suite."""
import os
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]


def run():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "README.md has no Python block"
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        names = {}
        for k, block in enumerate(blocks):
            exec(compile(block, f"README.md (Python block {k + 1})", "exec"), names)
    finally:
        os.chdir(here)


if __name__ == "__main__":
    run()
