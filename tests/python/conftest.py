import os
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def atrium_path():
    return str(ROOT / "scenes" / "atrium.glb")


@pytest.fixture(scope="session")
def cli():
    """The rayfold CLI of the same build (make test sets RAYFOLD_CLI)."""
    path = os.environ.get("RAYFOLD_CLI")
    if not path:
        pytest.skip("RAYFOLD_CLI is not set: run through ctest (make test)")
    return path


@pytest.fixture(scope="session")
def bin_dir(cli):
    """The folder of the build's programs (rayfold-gen-scene beside the CLI)."""
    return pathlib.Path(cli).parent
