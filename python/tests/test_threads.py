"""The GIL is released while render and build run: another Python thread keeps running. Progress callbacks are called
with the GIL, and cancel by returning False or raising."""
import threading
import time

import pytest

import ugvr


def largest_stall(fn):
    """Runs fn() while a Python thread records the time of each of its loop turns; returns (the longest time the
    thread went without a turn while fn ran, fn's duration). Holding the GIL through fn would stall it all along."""
    stamps = []
    stop = threading.Event()

    def spin():
        while not stop.is_set():
            stamps.append(time.perf_counter())

    thread = threading.Thread(target=spin)
    thread.start()
    time.sleep(0.02)
    start = time.perf_counter()
    fn()
    end = time.perf_counter()
    stop.set()
    thread.join()
    inside = [start] + [t for t in stamps if start <= t <= end] + [end]
    return max(b - a for a, b in zip(inside, inside[1:])), end - start


@pytest.fixture(scope="module")
def mesh():
    return ugvr.generate(cells=50_000, kind="mixed")


def test_render_releases_the_gil(mesh):
    ugvr.render(mesh, size=16)  # the walk mesh, built once per Dataset
    # Several renders in one call, so that it lasts well beyond the interpreter's 5 ms switch interval.
    stall, duration = largest_stall(lambda: [ugvr.render(mesh, size=200, threads=1) for _ in range(3)])
    assert duration > 0.05
    assert stall < duration / 2, f"a Python thread stalled {stall:.3f} s of a {duration:.3f} s render"


def test_build_releases_the_gil(mesh, tmp_path):
    stall, duration = largest_stall(lambda: ugvr.build(mesh, tmp_path / "m.ugvr", threads=1, max_depth=4))
    assert duration > 0.05
    assert stall < duration / 2, f"a Python thread stalled {stall:.3f} s of a {duration:.3f} s build"


def test_renders_from_two_threads(mesh):
    """Two threads render the same Dataset at once (its walk mesh is shared; renders take turns on it)."""
    results = [None, None]

    def work(i):
        results[i] = ugvr.render(mesh, size=32, view="+x").array

    threads = [threading.Thread(target=work, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert (results[0] == results[1]).all()


def test_build_progress_and_cancel(mesh, tmp_path):
    seen = []

    def record(stage, fraction):
        assert threading.current_thread() is not None  # called with the GIL: Python runs here
        seen.append((stage, fraction))

    store = ugvr.build(mesh, tmp_path / "p.ugvr", max_depth=3, progress=record)
    assert seen and all(0 <= f <= 1 for _, f in seen) and store.info["nodes"] > 0

    with pytest.raises(ugvr.Error, match="cancel"):
        ugvr.build(mesh, tmp_path / "c.ugvr", max_depth=3, progress=lambda stage, fraction: False)
    assert not (tmp_path / "c.ugvr").exists()

    class Stop(Exception):
        pass

    def boom(stage, fraction):
        raise Stop("from the callback")

    with pytest.raises(Stop, match="from the callback"):
        ugvr.build(mesh, tmp_path / "e.ugvr", max_depth=3, progress=boom)


def test_render_progress_and_cancel():
    ds = ugvr.generate(cells=2000, kind="tet")
    with pytest.raises(ugvr.Error, match="cancelled"):
        ugvr.render(ds, size=16, progress=lambda stage, fraction: False)
    stages = []
    ugvr.render(ds, size=16, progress=lambda stage, fraction: stages.append(stage))
    assert "walk mesh" in stages
