"""Fixtures of the Python suite: the `ugvr` binary (UGVR_BINARY, set by ctest) that Python's images are compared with,
small generated meshes (seconds to make), and the real datasets of ../shared/data (UGVR_DATA), skipped when absent."""
import os
import pathlib
import shutil
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def ugvr_binary():
    binary = os.environ.get("UGVR_BINARY") or shutil.which("ugvr") or str(ROOT / "build" / "ugvr")
    if not os.path.exists(binary):
        pytest.skip("the ugvr binary is not built (set UGVR_BINARY)")
    return binary


@pytest.fixture(scope="session")
def cli(ugvr_binary):
    """Runs `ugvr ARGS...`, failing the test with its stderr when it fails."""

    def run(*args):
        result = subprocess.run([ugvr_binary, "--quiet", *map(str, args)], capture_output=True, text=True)
        assert result.returncode == 0, f"ugvr {' '.join(map(str, args))}: {result.stderr}"
        return result

    return run


@pytest.fixture(scope="session")
def small_vtu(tmp_path_factory, cli):
    """A 3000-cell mixed mesh (tetra, pyramid, wedge, hexahedron) with point and cell fields."""
    path = tmp_path_factory.mktemp("data") / "small.vtu"
    cli("generate", "-o", path, "--cells", 3000, "--kind", "mixed")
    return path


def data_path(relative):
    """A file of the real datasets, or skip."""
    base = pathlib.Path(os.environ.get("UGVR_DATA") or ROOT.parent / "shared" / "data")
    path = base / relative
    if not path.exists():
        pytest.skip(f"dataset not found: {relative} (set UGVR_DATA)")
    return path
