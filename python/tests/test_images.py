"""The same image from Python as from `ugvr render` (bit-identical 8-bit pixels) for the same file, camera and transfer
function: from the file, from numpy arrays (the same mesh through Dataset.from_arrays), from a VTK object and from
meshio; and the flags that change the image give the same change in both."""
import json

import numpy as np
import pytest

import ugvr
from conftest import data_path

SIZE = (64, 48)


def cli_image(cli, tmp_path, inputs, *flags):
    out = tmp_path / "cli.png"
    cli("render", *inputs, "-o", out, "--size", f"{SIZE[0]}x{SIZE[1]}", *flags)
    return ugvr.read_image(out).array


@pytest.fixture
def scene_files(tmp_path):
    """A camera and a transfer function, as files both front ends read."""
    camera = tmp_path / "camera.json"
    camera.write_text(json.dumps({"position": [-8, -12, 9], "focal_point": [3, 0, 1], "view_up": [0, 0, 1],
                                  "view_angle": 35}))
    tf = tmp_path / "tf.json"
    tf.write_text(json.dumps([{"Name": "test", "RGBPoints": [0, 0, 0, 1, 0.5, 0, 1, 0, 1, 1, 0, 0],
                               "Points": [0, 0, 0.5, 0, 1, 0.8, 0.5, 0]}]))
    return camera, tf


def test_version():
    assert ugvr.__version__.count(".") == 2
    assert ugvr.__version__ == ugvr._ugvr.__version__


def test_file_default_view_is_bit_identical(cli, tmp_path, small_vtu):
    ref = cli_image(cli, tmp_path, [small_vtu])
    img = ugvr.render(small_vtu, size=SIZE)
    assert img.shape == (SIZE[1], SIZE[0], 4) and img.array.dtype == np.uint8
    assert np.array_equal(np.asarray(img), ref)
    assert img.stats["engine"] == "exact" and img.stats["field"] == "pressure"
    assert 0 < (img.array[..., :3] != img.array[0, 0, :3]).any(axis=2).mean() < 1  # the mesh is in the picture


def test_camera_and_tf_files_are_bit_identical(cli, tmp_path, small_vtu, scene_files):
    camera, tf = scene_files
    ref = cli_image(cli, tmp_path, [small_vtu], "--camera", camera, "--tf", tf, "--field", "velocity")
    ds = ugvr.read(small_vtu)
    img = ugvr.render(ds, camera=camera, tf=tf, field="velocity", size=SIZE)
    assert np.array_equal(img.array, ref)
    # The same through objects: Camera.read / TransferFunction.read, and a camera dict.
    img2 = ugvr.render(ds, camera=ugvr.Camera.read(str(camera)), tf=ugvr.TransferFunction.read(str(tf)),
                       field="velocity", size=SIZE)
    assert np.array_equal(img2.array, ref)
    img3 = ugvr.render(ds, camera=json.loads(camera.read_text()), tf=str(tf), field="velocity", size=SIZE)
    assert np.array_equal(img3.array, ref)


def test_flags_match(cli, tmp_path, small_vtu):
    flags = ["--view", "+y", "--tf", "inferno", "--range", "-1,0.5", "--unit-distance", "0.7", "--background",
             "0.1,0.2,0.3", "--mode", "mip"]
    ref = cli_image(cli, tmp_path, [small_vtu], *flags)
    img = ugvr.render(small_vtu, view="+y", tf="inferno", range=(-1, 0.5), unit_distance=0.7,
                      background=(0.1, 0.2, 0.3), mode="mip", size=SIZE)
    assert np.array_equal(img.array, ref)
    ref_iso = cli_image(cli, tmp_path, [small_vtu], "--iso", "-0.3,0.2", "--view", "iso", "--no-lighting")
    iso = ugvr.render(small_vtu, iso=[-0.3, 0.2], view="iso", lighting=False, size=SIZE)
    assert np.array_equal(iso.array, ref_iso)
    assert not np.array_equal(iso.array, img.array)


def test_numpy_arrays_are_bit_identical(cli, tmp_path, small_vtu):
    ref = cli_image(cli, tmp_path, [small_vtu], "--view", "iso")
    read = ugvr.read(small_vtu)
    # Plain numpy copies (not views of `read`), VTK's int64 connectivity and float64 points, as a user would have them.
    points = np.array(read.points, dtype=np.float64)
    conn = np.array(read.connectivity, dtype=np.int64)
    offsets = np.array(read.offsets, dtype=np.int64)
    types = np.array(read.cell_types)
    point_data = {k: np.array(v) for k, v in read.point_data.items()}
    cell_data = {k: np.array(v) for k, v in read.cell_data.items()}
    ds = ugvr.Dataset.from_arrays(points, conn, offsets, types, point_data=point_data, cell_data=cell_data)
    assert ds.cell_count == read.cell_count and ds.field_names == read.field_names
    assert np.array_equal(ugvr.render(ds, view="iso", size=SIZE).array, ref)
    # VTK's legacy cell array [n, ids..., n, ids...] without offsets: the same mesh.
    legacy = np.concatenate([np.concatenate([[e - s], conn[s:e]]) for s, e in zip(offsets[:-1], offsets[1:])])
    ds2 = ugvr.Dataset.from_arrays(points, legacy, None, types, point_data=point_data)
    assert np.array_equal(ds2.connectivity, read.connectivity)


def test_per_type_cells():
    points = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]], dtype=np.float32)
    ds = ugvr.Dataset.from_arrays(points, cells={"tetra": [[0, 1, 2, 3], [1, 2, 3, 4]]},
                                  point_data={"s": np.arange(5, dtype=np.float64)},
                                  cell_data={"c": np.array([1, 2], dtype=np.int32)})
    assert ds.cell_count == 2 and list(ds.cell_types) == [10, 10]
    assert list(ds.offsets) == [0, 4, 8]
    assert ds.cell_data["c"].dtype == np.int32 and list(ds.cell_data["c"]) == [1, 2]
    assert ds.field_range("s") == (0.0, 4.0)
    img = ugvr.render(ds, size=16)
    assert img.array.shape == (16, 16, 4)


def test_views_share_memory_and_keep_the_dataset_alive(small_vtu):
    ds = ugvr.read(small_vtu)
    points = ds.points
    pressure = ds.point_data["pressure"]
    assert not points.flags.writeable and not points.flags.owndata
    assert np.shares_memory(points, ds.points)  # a view of the dataset's own vector, not a copy
    expected = np.array(points)
    del ds  # the views hold the dataset
    assert np.array_equal(points, expected) and pressure.shape == (expected.shape[0],)
    with pytest.raises(ValueError):
        points[0, 0] = 1


def test_vtk_object_is_bit_identical(cli, tmp_path, small_vtu):
    vtk = pytest.importorskip("vtk")
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(small_vtu))
    reader.Update()
    ds = ugvr.from_vtk(reader.GetOutput())
    ref = cli_image(cli, tmp_path, [small_vtu], "--view", "-x")
    assert np.array_equal(ugvr.render(ds, view="-x", size=SIZE).array, ref)


def test_vtk_image_data(cli, tmp_path):
    vtk = pytest.importorskip("vtk")
    from vtk.util import numpy_support as ns
    image = vtk.vtkImageData()
    image.SetDimensions(6, 5, 4)
    image.SetSpacing(0.5, 1, 2)
    image.SetOrigin(1, 2, 3)
    values = np.linspace(0, 1, 6 * 5 * 4)
    array = ns.numpy_to_vtk(values, deep=True)
    array.SetName("s")
    image.GetPointData().AddArray(array)
    ds = ugvr.from_vtk(image)
    assert ds.grid_kind == "uniform" and ds.dims == (6, 5, 4) and ds.spacing == (0.5, 1.0, 2.0)
    assert ds.bounds == ((1.0, 2.0, 3.0), (3.5, 6.0, 9.0))
    # The same volume written as .vti by VTK and rendered by the CLI.
    writer = vtk.vtkXMLImageDataWriter()
    path = tmp_path / "grid.vti"
    writer.SetFileName(str(path))
    writer.SetInputData(image)
    writer.Write()
    ref = cli_image(cli, tmp_path, [path], "--view", "iso")
    assert np.array_equal(ugvr.render(ds, view="iso", size=SIZE).array, ref)


def test_meshio_is_bit_identical(cli, tmp_path, small_vtu):
    meshio = pytest.importorskip("meshio")
    ds = ugvr.from_meshio(meshio.read(small_vtu))
    ref = cli_image(cli, tmp_path, [small_vtu])
    assert np.array_equal(ugvr.render(ds, field="pressure", size=SIZE).array, ref)


def test_plot3d_blunt_fin(cli, tmp_path):
    xyz = data_path("blunt-fin/bluntfinxyz.bin")
    q = data_path("blunt-fin/bluntfinq.bin")
    ref = cli_image(cli, tmp_path, [xyz, q], "--field", "Pressure", "--view", "iso")
    ds = ugvr.read(xyz, solution=q)
    assert ds.grid_kind == "curvilinear" and ds.dims == (40, 32, 32)
    assert np.array_equal(ugvr.render(ds, field="Pressure", view="iso", size=SIZE).array, ref)


def test_kiefer_bracket_cell_data(cli, tmp_path):
    path = data_path("fea-kiefer-bracket/dataset.vtu")
    ref = cli_image(cli, tmp_path, [path])
    img = ugvr.render(path, size=SIZE)
    assert np.array_equal(img.array, ref)


def test_float_image_and_png(small_vtu, tmp_path):
    img = ugvr.render(small_vtu, size=SIZE, dtype="float32")
    assert img.array.dtype == np.float32 and img.array.shape == (SIZE[1], SIZE[0], 4)
    byte = ugvr.render(small_vtu, size=SIZE)
    assert np.array_equal(np.round(np.clip(img.array, 0, 1) * 255).astype(np.uint8), byte.array)
    png = byte._repr_png_()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    byte.save(tmp_path / "x.png")
    assert (tmp_path / "x.png").read_bytes() == png
    assert ugvr.compare(byte, ugvr.read_image(tmp_path / "x.png"))["max_abs"] == 0


def test_camera_and_tf_objects(small_vtu):
    ds = ugvr.read(small_vtu)
    cam = ugvr.Camera.preset("iso", ds)
    assert ugvr.Camera.from_json(cam.to_json()) == cam
    assert cam.to_json()["view_angle"] == 30
    cam.view_angle = 20
    tf = ugvr.TransferFunction.preset("viridis")
    assert "viridis" in ugvr.TransferFunction.presets() and tf.range == (0.0, 1.0)
    assert tf.opacity_unit_distance is None
    img = ugvr.render(ds, camera=cam, tf=tf, size=SIZE)
    assert img.camera == cam and img.tf.opacity_unit_distance > 0
    # A transfer-function edit: everything transparent but a band, in data values (keep_range).
    lo, hi = ds.field_range("pressure")
    band = ugvr.TransferFunction.preset("inferno")
    band.rescale(lo, hi)
    band.opacity_points = [(lo, 0), (-0.5, 0), (-0.4, 0.9), (-0.3, 0), (hi, 0)]
    edited = ugvr.render(ds, camera=cam, tf=band, keep_range=True, size=SIZE)
    assert not np.array_equal(edited.array, img.array)
    assert ugvr.TransferFunction.from_json(edited.tf.to_json()) == edited.tf
    with pytest.raises(ugvr.Error, match="opacity_points"):
        band.opacity_points = [(0, 0), (-1, 0.5)]  # not increasing


def test_slices_are_bit_identical_and_change_the_image(cli, tmp_path, small_vtu, scene_files):
    """slices= and hide_volume= (docs/slices.md) give --slice and --hide-volume's image, and a plane through the mesh
    changes it."""
    camera, tf = scene_files
    flags = ["--camera", camera, "--tf", tf]
    ref = cli_image(cli, tmp_path, [small_vtu], *flags, "--slice", "3,0,1,0,0.3,1,0.8", "--hide-volume", "front")
    img = ugvr.render(small_vtu, camera=camera, tf=tf, size=SIZE, slices=[(3, 0, 1, 0, 0.3, 1, 0.8)],
                      hide_volume="front")
    assert np.array_equal(img.array, ref)
    plain = ugvr.render(small_vtu, camera=camera, tf=tf, size=SIZE)
    assert (plain.array != img.array).any(axis=2).mean() > 0.01
    # The dict form, with its own colour map.
    d = ugvr.render(small_vtu, camera=camera, tf=tf, size=SIZE,
                    slices=[{"point": [3, 0, 1], "normal": [0, 0.3, 1], "opacity": 0.8}], hide_volume="front")
    assert np.array_equal(d.array, ref)
    # Contour lines: the dict's "contours" (a tuple passes as a list) is --slice-contours, and the lines show.
    lines = ugvr.render(small_vtu, camera=camera, tf=tf, size=SIZE, hide_volume="front",
                        slices=[{"point": [3, 0, 1], "normal": [0, 0.3, 1], "opacity": 0.8, "contours": (0.1, 0.5),
                                 "contour_color": (1, 1, 1)}])
    assert np.array_equal(lines.array, cli_image(cli, tmp_path, [small_vtu], *flags, "--slice", "3,0,1,0,0.3,1,0.8",
                                                 "--slice-contours", "0.1,0.5", "--slice-contour-color", "1,1,1",
                                                 "--hide-volume", "front"))
    assert (lines.array != ref).any(axis=2).mean() > 0.002
    with pytest.raises(ugvr.Error, match=r"slices\[0\]\.contours"):
        ugvr.render(small_vtu, size=SIZE, slices=[{"point": [3, 0, 1], "normal": [0, 0, 1], "contours": 99}])
    with pytest.raises(ugvr.Error, match="slices"):
        ugvr.render(small_vtu, size=SIZE, slices=[(3, 0, 1)])
    with pytest.raises(ugvr.Error, match="opacity"):
        ugvr.render(small_vtu, size=SIZE, slices=[(3, 0, 1, 0, 0, 1, 2.0)])
