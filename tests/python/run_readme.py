"""Runs the README's Python block as written, from the repository root (it
names scenes/atrium.glb). Used by pip_install.sh in a fresh environment and
by the pytest suite."""
import os
import pathlib
import re

ROOT = pathlib.Path(__file__).resolve().parents[2]


def run():
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        exec(compile(block, "README.md (Python block)", "exec"), {})
    finally:
        os.chdir(here)


if __name__ == "__main__":
    run()
