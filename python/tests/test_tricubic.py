"""Tricubic isosurfaces of a voxel file from Python, as `ugvr render VOL --iso V --interpolation tricubic` draws them
(docs/tricubic.md, "Voxel volumes rendered directly"): the volume's store is built once into the cache that both front
ends share, and the image is the CLI's, bit for bit. A mesh (file or Dataset) stays an error with advice."""
import json
import math
import struct

import numpy as np
import pytest

import ugvr

SIZE = (64, 48)
K = 3 * math.pi


def write_sines_nrrd(path, n=33):
    """sin(3πx) sin(3πy) sin(3πz) on n³ points of the unit cube, a little-endian float NRRD."""
    h = 1.0 / (n - 1)
    values = [math.sin(K * i * h) * math.sin(K * j * h) * math.sin(K * k * h)
              for k in range(n) for j in range(n) for i in range(n)]
    with open(path, "wb") as f:
        f.write((f"NRRD0004\ntype: float\ndimension: 3\nsizes: {n} {n} {n}\nspacings: {h!r} {h!r} {h!r}\n"
                 "encoding: raw\nendian: little\n\n").encode())
        f.write(struct.pack(f"<{len(values)}f", *values))


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A store cache of the test's own, seen by the module and by the CLI it starts."""
    path = tmp_path / "cache"
    monkeypatch.setenv("UGVR_CACHE_DIR", str(path))
    return path


def test_voxel_file_tricubic_is_built_once_and_is_the_clis(cli, tmp_path, cache):
    nrrd = tmp_path / "sines.nrrd"
    write_sines_nrrd(nrrd)
    first = ugvr.render(nrrd, iso=[0.25], interpolation="tricubic", size=SIZE)
    assert first.stats["engine"] == "lod"
    assert first.stats["voxel_store"]["built"] is True
    store = first.stats["voxel_store"]["path"]
    assert store.startswith(str(cache))
    # The CLI draws the store Python built (its stats say it built nothing) and the same pixels.
    out, stats = tmp_path / "cli.png", tmp_path / "cli.json"
    cli("render", nrrd, "--iso", 0.25, "--interpolation", "tricubic", "--size", f"{SIZE[0]}x{SIZE[1]}", "-o", out,
        "--stats", stats)
    cli_stats = json.loads(stats.read_text())
    assert cli_stats["voxel_store"] == {"path": store, "built": False}
    assert np.array_equal(first.array, ugvr.read_image(out).array)
    again = ugvr.render(nrrd, iso=[0.25], settings={"interpolation": "tricubic"}, size=SIZE)
    assert again.stats["voxel_store"] == {"path": store, "built": False}
    assert np.array_equal(again.array, first.array)
    # Trilinear draws the file itself (the exact engine): no store, another image.
    trilinear = ugvr.render(nrrd, iso=[0.25], size=SIZE)
    assert "voxel_store" not in trilinear.stats
    assert not np.array_equal(trilinear.array, first.array)


def test_mesh_with_tricubic_gets_an_error_with_advice(small_vtu, cache):
    with pytest.raises(ugvr.Error, match=r"tricubic.*ugvr\.build"):
        ugvr.render(small_vtu, iso=[0.5], interpolation="tricubic", size=SIZE)
    with pytest.raises(ugvr.Error, match=r"tricubic.*ugvr\.build"):
        ugvr.render(ugvr.read(small_vtu), iso=[0.5], interpolation="tricubic", size=SIZE)
    with pytest.raises(ugvr.Error, match=r"interpolation"):
        ugvr.render(small_vtu, iso=[0.5], interpolation="cubic", size=SIZE)
    assert not cache.exists()


def test_voxel_file_with_the_exact_engine_is_an_error(tmp_path, cache):
    nrrd = tmp_path / "sines.nrrd"
    write_sines_nrrd(nrrd)
    with pytest.raises(ugvr.Error, match=r"engine: exact.*lod engine"):
        ugvr.render(nrrd, engine="exact", iso=[0.25], interpolation="tricubic", size=SIZE)
