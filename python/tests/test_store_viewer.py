"""ugvr.build + open_store (every `ugvr build` option reaches the store), rendering a store with the lod engine as the
CLI does, and the viewer: started, serving its page, camera and transfer function get + set, closed."""
import time
import urllib.request

import numpy as np
import pytest

import ugvr


@pytest.fixture(scope="module")
def mesh():
    return ugvr.generate(cells=5000, kind="mixed")


def test_build_and_open_store(mesh, tmp_path):
    store = ugvr.build(mesh, tmp_path / "a.ugvr", fields="pressure,velocity:x", brick=16, max_depth=3, error=0.02,
                       float32=True, no_tf_errors=True, memory="256MiB")
    assert store.summary["fields"] == "pressure,velocity:x" and store.summary["brick"] == 16
    again = ugvr.open_store(tmp_path / "a.ugvr")
    info = again.info
    assert again.fields == ["pressure", "velocity:x"]
    assert info["brick"] == 16 and info["encoding"] == "float32" and not info["tf_errors"]
    assert info["max_level"] <= 3 and info["nodes"] == store.summary["nodes"]
    lo, hi = info["fields"][0]["range"]
    assert lo < hi
    bounds = np.array(info["bounds"])
    assert np.allclose(bounds, np.array(mesh.bounds), rtol=1e-5)
    default = ugvr.build(mesh, tmp_path / "b.ugvr", max_depth=2)
    assert default.info["encoding"] == "quant16" and default.info["tf_errors"] and default.info["brick"] == 32


def test_store_renders_as_the_cli(mesh, tmp_path, cli):
    path = tmp_path / "m.vtu"
    ugvr.generate(path, cells=3000, kind="mixed")
    store = ugvr.build(path, tmp_path / "m.ugvr", max_depth=3)
    out = tmp_path / "cli.png"
    cli("render", store.path, "-o", out, "--size", "40x32", "--view", "+y")
    img = ugvr.render(store, size=(40, 32), view="+y")
    assert img.stats["engine"] == "lod"
    assert np.array_equal(img.array, ugvr.read_image(out).array)


def fetch(url):
    with urllib.request.urlopen(url, timeout=30) as response:
        return response.status, response.read().decode("utf-8", "replace")


def test_view_dataset(mesh):
    # A named tf: the whole domain's default view (auto's framed one is test_view_frames_what_auto_leaves_visible's).
    with ugvr.view(mesh, fields=["pressure"], max_depth=2, tf="viridis") as viewer:
        assert viewer.running and viewer.url.startswith("http://127.0.0.1:")
        status, page = fetch(viewer.url)
        assert status == 200 and "<html" in page.lower()
        assert f'src="{viewer.url}"' in viewer._repr_html_()
        default = viewer.camera
        assert default == ugvr.Camera.default(mesh)
        camera = ugvr.Camera.preset("+x", mesh)
        port = viewer.port
        viewer.camera = camera  # live: the same server
        assert viewer.camera == camera and viewer.port == port
        assert fetch(viewer.url)[0] == 200
        tf = ugvr.TransferFunction.preset("inferno")
        viewer.tf = tf
        assert viewer.tf.color_points == tf.color_points
    assert not viewer.running
    with pytest.raises(OSError):
        fetch(viewer.url)


def settled_camera(viewer, expected, seconds=30):
    """The viewer's camera once it is `expected`, or after `seconds`: until the grid is loaded (a fraction of a second
    here) the viewer reports the whole domain's default view."""
    deadline = time.monotonic() + seconds
    camera = viewer.camera
    while camera != expected and time.monotonic() < deadline:
        time.sleep(0.05)
        camera = viewer.camera
    return camera


def test_view_frames_what_auto_leaves_visible(mesh):
    """No tf: the auto transfer function, and the view framed on what it leaves visible, as ugvr.render() and
    `ugvr view` start (render/visible_bounds.h); a camera given is kept."""
    framed = ugvr.render(mesh, field="pressure", size=(16, 16)).camera
    whole = ugvr.Camera.default(mesh)
    def distance(c):
        return np.linalg.norm(np.subtract(c.position, c.focal_point))

    assert distance(framed) < 0.5 * distance(whole), "the generated wing should be framed closer than the whole domain"
    with ugvr.view(mesh, fields=["pressure"], max_depth=2) as viewer:
        assert settled_camera(viewer, framed) == framed
        assert viewer.tf.opacity_points[1][1] == 0, "auto's transparent free stream"
    given = ugvr.Camera.preset("+y", mesh)
    with ugvr.view(mesh, fields=["pressure"], max_depth=2, camera=given) as viewer:
        assert settled_camera(viewer, framed, seconds=1) == given


def test_view_store(mesh, tmp_path):
    store = ugvr.build(mesh, tmp_path / "v.ugvr", max_depth=2)
    viewer = ugvr.view(store, tf="cool-warm")
    try:
        assert fetch(viewer.url)[0] == 200
        assert viewer.tf.name == ugvr.TransferFunction.preset("cool-warm").name
        assert viewer.store == store.path
    finally:
        viewer.close()
    viewer.close()  # idempotent
    with pytest.raises(ugvr.Error, match="port"):
        ugvr.view(store, port=70000)


def test_a_mesh_over_the_memory_budget_is_drawn_from_its_store(small_vtu, tmp_path, monkeypatch):
    """Never read whole: its store is built out of core into the viewer's cache (view/over_budget_store.h), said in the
    warnings and the stats; the exact engine is refused, naming the option."""
    monkeypatch.setenv("UGVR_VIEW_MEMORY_BUDGET", "100KiB")
    monkeypatch.setenv("UGVR_CACHE_DIR", str(tmp_path / "cache"))
    img = ugvr.render(str(small_vtu), size=48, view="iso", field="pressure")
    assert img.stats["engine"] == "lod" and img.stats["drew_from"] == "store"
    assert any("over the memory budget" in w for w in img.warnings), img.warnings
    assert len(list((tmp_path / "cache").glob("*.ugvr"))) == 1
    assert np.asarray(img).std() > 0
    with pytest.raises(Exception, match="engine"):
        ugvr.render(str(small_vtu), size=48, engine="exact")
    monkeypatch.delenv("UGVR_VIEW_MEMORY_BUDGET")
    assert "drew_from" not in ugvr.render(str(small_vtu), size=48, view="iso", field="pressure").stats


def test_time_budget(mesh, small_vtu, tmp_path, monkeypatch):
    """time_budget=S (`ugvr render --time-budget S`): a store's time-critical cut refined while time is left, the exact
    image at the largest scale that fits (the probe alone when nothing fits), and for a file over the memory budget
    what of its store is built by then; stats["time_budget"] says what was drawn."""
    store = ugvr.build(mesh, tmp_path / "t.ugvr", max_depth=2)
    ample = ugvr.render(store, size=64, view="iso", time_budget=300)
    report = ample.stats["time_budget"]
    assert ample.stats["engine"] == "lod" and report["within_budget"] and report["frames"] >= 1, report
    assert "level-of-detail cut" in report["drew"] and ample.shape == (64, 64, 4)
    # A Dataset with the exact engine and no time at all: the 64-pixel probe, magnified to the size asked for.
    tight = ugvr.render(mesh, size=(128, 96), view="iso", time_budget=1e-6)
    report = tight.stats["time_budget"]
    assert report["scale"] == 0.5 and not report["within_budget"], report
    assert "magnified to 128 x 96" in report["drew"] and tight.shape == (96, 128, 4)
    assert "time_budget" not in ugvr.render(mesh, size=32).stats
    with pytest.raises(ugvr.Error, match="time_budget"):
        ugvr.render(mesh, size=32, time_budget=0)
    # Over the memory budget: drawn from what is built within the time (here the whole store: it is small).
    monkeypatch.setenv("UGVR_VIEW_MEMORY_BUDGET", "100KiB")
    monkeypatch.setenv("UGVR_CACHE_DIR", str(tmp_path / "cache"))
    big = ugvr.render(str(small_vtu), size=48, view="iso", field="pressure", time_budget=300)
    report = big.stats["time_budget"]
    assert report["drew_from"] == big.stats["drew_from"] == "store" and report["drew"].startswith("the store: "), report
    assert np.asarray(big).std() > 0
