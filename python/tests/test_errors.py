"""Bad input raises ugvr.Error naming the argument; nothing crashes the interpreter."""
import math

import numpy as np
import pytest

import ugvr

POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=np.float32)
CONN = np.array([0, 1, 2, 3])
OFFSETS = np.array([0, 4])
TYPES = np.array([10], dtype=np.uint8)


def make(**kwargs):
    args = dict(points=POINTS, cells=CONN, offsets=OFFSETS, types=TYPES)
    args.update(kwargs)
    return ugvr.Dataset.from_arrays(**args)


def test_good_tetra():
    assert make().cell_count == 1


@pytest.mark.parametrize("kwargs, message", [
    (dict(points=POINTS.astype(np.int32)), r"points: expected float32 or float64 coordinates, found dtype int32"),
    (dict(points=POINTS[:, :2]), r"points: expected shape \(N, 3\)"),
    (dict(points=np.array([[0, 0, math.nan]] + POINTS[1:].tolist(), dtype=np.float64)),
     r"points\[0\]: coordinates must be finite"),
    (dict(points=np.array(["a", "b"])), r"points: expected numbers"),
    (dict(points=None), r"points: expected an array, found None"),
    (dict(cells=np.array([0, 1, 2, 7])), r"cells: cell 0 vertex 3: index 7 is out of range \[0, 4\)"),
    (dict(cells=np.array([0, 1, -2, 3])), r"cells: cell 0 vertex 2: index -2 is out of range"),
    (dict(cells=np.array([0.0, 1, 2, 3])), r"cells: expected an integer array, found dtype float64"),
    (dict(offsets=np.array([0, 3])), r"offsets: must end at the connectivity's length 4, found 3"),
    (dict(offsets=np.array([1, 4])), r"offsets: must start at 0"),
    (dict(offsets=np.array([0, 4, 2]), types=np.array([10, 10])), r"offsets: must end at the connectivity's length"),
    (dict(cells=np.arange(8) % 4, offsets=np.array([0, 4, 3, 8]), types=np.array([10, 10, 10])),
     r"offsets: decrease at cell 1 \(4 then 3\): negative vertex count"),
    (dict(offsets=np.array([0, 2, 4]), types=np.array([10, 10])), r"cells: cell 0 \(VTK_TETRA\) has 2 vertices, expected 4"),
    (dict(types=np.array([5])), r"types\[0\]: VTK cell type 5 \(VTK_TRIANGLE\) is not a volume cell"),
    (dict(types=np.array([42])), r"types\[0\]: unsupported VTK cell type 42"),
    (dict(types=np.array([-1])), r"types\[0\]: VTK type id -1 out of range"),
    (dict(types=np.array([10, 10])), r"offsets: has 2 entries, expected cells \+ 1 = 3"),
    (dict(types=None), r"types: is required"),
    (dict(offsets=None, cells=np.array([-4, 0, 1, 2, 3])), r"cells: negative vertex count -4 for cell 0"),
    (dict(offsets=None, cells=np.array([9, 0, 1, 2, 3])), r"cells: cell 0 lists 9 vertices past the end"),
    (dict(cells={"tetra": np.array([[0, 1, 2]])}, offsets=None, types=None), r"cells\['tetra'\]: expected shape \(cells, 4\)"),
    (dict(cells={"triangle": np.array([[0, 1, 2]])}, offsets=None, types=None), r"cells\['triangle'\]: unknown cell type"),
    (dict(cells={"tetra": np.array([[0, 1, 2, 3]])}), r"offsets: not used with per-type cells"),
    (dict(point_data={"s": np.zeros(3)}), r"point_data\['s'\]: has 3 values, expected one per point \(4\)"),
    (dict(cell_data={"c": np.zeros((1, 2, 2))}), r"cell_data\['c'\]: expected shape"),
    (dict(cell_data={"c": np.zeros(1, dtype=np.float16)}), r"cell_data\['c'\]: unsupported dtype float16"),
    (dict(point_data={"s": np.array(["x"] * 4)}), r"point_data\['s'\]: expected numbers"),
    (dict(point_data={3: np.zeros(4)}), r"point_data: field names must be strings"),
])
def test_bad_arrays_name_the_argument(kwargs, message):
    with pytest.raises(ugvr.Error, match=message):
        make(**kwargs)


def test_uint64_indices_past_int64():
    with pytest.raises(ugvr.Error, match=r"cells: cell 0 vertex 0: index \d+ is out of range"):
        make(cells=np.array([2**63 + 5, 1, 2, 3], dtype=np.uint64))


def test_bad_grids():
    with pytest.raises(ugvr.Error, match=r"spacing: must be > 0"):
        ugvr.Dataset.from_image((2, 2, 2), spacing=(1, 0, 1))
    with pytest.raises(ugvr.Error, match=r"dims: expected three point counts"):
        ugvr.Dataset.from_image((2, -2, 2))
    with pytest.raises(ugvr.Error, match=r"points: has 4 points, dims make 8"):
        ugvr.Dataset.from_structured((2, 2, 2), POINTS)


@pytest.mark.parametrize("kwargs, message", [
    (dict(size=(0, 10)), r"size: each side must be an integer in \[1, 16384\]"),
    (dict(size="axb"), r"size: expected N or WxH"),
    (dict(view="top"), r"view: unknown view \"top\""),
    (dict(view="iso", camera={"position": [0, 0, 1], "focal_point": [0, 0, 0], "view_up": [0, 1, 0]}),
     r"view: cannot be combined with camera"),
    (dict(engine="gpu"), r"engine: unknown engine"),
    (dict(engine="lod"), r"engine: the lod engine renders a brick store"),
    (dict(mode="volume"), r"mode: unknown mode"),
    (dict(mode="iso"), r"mode: isosurface mode needs iso"),
    (dict(tf="nope"), r"tf: .*nope"),
    (dict(tf_name="x"), r"tf_name: needs tf=FILE.json"),
    (dict(range=(1, 0)), r"range: MIN must be less than MAX"),
    (dict(unit_distance=-1), r"unit_distance: must be > 0"),
    (dict(field="nope"), r"field: no field named 'nope'"),
    (dict(background=(2, 0, 0)), r"background: components must be in \[0, 1\]"),
    (dict(clip=(0, 0, 0, 0, 0, 0)), r"clip: the normal"),
    (dict(threads=0), r"threads: must be a positive integer"),
    (dict(view_angle=180), r"view_angle: must be in \(0, 180\)"),
    (dict(camera={"position": [0, 0, 0], "focal_point": [0, 0, 0], "view_up": [0, 1, 0]}), r"camera"),
    (dict(dtype="int16"), r"dtype: must be"),
    (dict(cut="sometimes"), r"cut: "),
])
def test_bad_render_arguments(kwargs, message):
    ds = make(point_data={"s": np.arange(4.0)})
    with pytest.raises(ugvr.Error, match=message):
        ugvr.render(ds, size=kwargs.pop("size", 8), **kwargs)


def test_bad_camera_object():
    ds = make(point_data={"s": np.arange(4.0)})
    camera = ugvr.Camera()
    camera.focal_point = camera.position
    with pytest.raises(ugvr.Error, match=r"camera"):
        ugvr.render(ds, camera=camera, size=8)
    with pytest.raises(ugvr.Error, match=r"position: expected 3 numbers"):
        camera.position = (1, 2)
    with pytest.raises(ugvr.Error, match=r"view_up: expected a number"):
        camera.view_up = ("a", 0, 0)


def test_empty_transfer_function():
    tf = ugvr.TransferFunction()
    for call in (lambda: tf.range, lambda: tf.color(0.5), lambda: tf.rescale(0, 1)):
        with pytest.raises(ugvr.Error, match="no colour points"):
            call()
    with pytest.raises(ugvr.Error, match="tf"):
        ugvr.render(make(point_data={"s": np.arange(4.0)}), tf=tf, size=8)


def test_numpy_integers_are_integers(tmp_path):
    ds = make(point_data={"s": np.arange(4.0)})
    assert ugvr.render(ds, size=np.int64(8), threads=np.int32(1)).shape == (8, 8, 4)
    with pytest.raises(ugvr.Error, match="threads: expected an integer"):
        ugvr.render(ds, size=8, threads=1.5)


def test_bad_files(tmp_path):
    with pytest.raises(ugvr.Error, match=r"missing.vtu"):
        ugvr.read(tmp_path / "missing.vtu")
    bad = tmp_path / "bad.vtu"
    bad.write_text("<VTKFile type='UnstructuredGrid'><oops")
    with pytest.raises(ugvr.Error, match=r"bad.vtu"):
        ugvr.read(bad)
    with pytest.raises(ugvr.Error, match=r"bad.vtu"):
        ugvr.render(bad)
    with pytest.raises(ugvr.Error, match=r"expected a Dataset, a Store, a file path"):
        ugvr.render(42)
    with pytest.raises(ugvr.Error, match=r"x.ugvr"):
        ugvr.open_store(tmp_path / "x.ugvr")
    with pytest.raises(ugvr.Error, match=r"the output must be a .ugvr file"):
        ugvr.build(make(), tmp_path / "x.vtu")
    with pytest.raises(ugvr.Error, match=r"brick must be between"):
        ugvr.build(make(), tmp_path / "x.ugvr", brick=1)
    with pytest.raises(ugvr.Error, match=r"memory: expected a number of bytes"):
        ugvr.build(make(), tmp_path / "x.ugvr", memory="lots")
