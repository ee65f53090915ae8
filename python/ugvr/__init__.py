"""ugvr: volume rendering of unstructured grids, from Python.

    import ugvr
    ds = ugvr.read("wing.vtu")                      # any format `ugvr render` reads
    img = ugvr.render(ds, field="pressure", view="iso", size=(800, 600))
    img.save("wing.png")                            # the same pixels as `ugvr render wing.vtu ... -o wing.png`
    store = ugvr.build(ds, "wing.ugvr")             # the brick store of `ugvr build`
    v = ugvr.view(store)                            # the browser viewer; v.url, v.camera, v.tf; inline in Jupyter

Keyword arguments mirror `ugvr render` / `ugvr build` / `ugvr view` flags (--view-angle is view_angle=, and so on).
Errors are ugvr.Error with the library's message (the CLI's, naming the file or the argument). docs/python.md.
"""

import atexit as _atexit
import numbers as _numbers
import os as _os
import weakref as _weakref

from . import _ugvr
from ._ugvr import Camera, Dataset, Error, TransferFunction, set_progress_output

__version__ = _ugvr.__version__

# The compiled classes present themselves as ugvr.X (tracebacks, help()).
for _cls in (Camera, Dataset, Error, TransferFunction):
    try:
        _cls.__module__ = "ugvr"
    except (AttributeError, TypeError):
        pass

__all__ = [
    "Camera", "Dataset", "Error", "Image", "Store", "TransferFunction", "Viewer", "build", "compare", "demo",
    "from_meshio", "from_vtk", "generate", "open_store", "read", "read_image", "render", "set_progress_output", "view",
]


def _paths(source, what="path"):
    """A path, a path-like, or a list of them (a PLOT3D grid file and its solution) as a list of strings."""
    if isinstance(source, (str, bytes, _os.PathLike)):
        return [_os.fsdecode(source)]
    if isinstance(source, (list, tuple)) and source and all(isinstance(p, (str, bytes, _os.PathLike)) for p in source):
        return [_os.fsdecode(p) for p in source]
    raise Error(f"{what}: expected a Dataset, a Store, a file path or a list of paths, found {type(source).__name__}")


def _bytes(value, name):
    """512 * 2**20, "512MiB", "4GiB" -> bytes (binary units, as the CLI's --memory)."""
    if value is None or isinstance(value, int):
        return value
    if isinstance(value, str):
        units = {"": 1, "B": 1, "K": 1 << 10, "KIB": 1 << 10, "KB": 1 << 10, "M": 1 << 20, "MIB": 1 << 20,
                 "MB": 1 << 20, "G": 1 << 30, "GIB": 1 << 30, "GB": 1 << 30, "T": 1 << 40, "TIB": 1 << 40,
                 "TB": 1 << 40}
        text = value.strip()
        i = len(text)
        while i > 0 and not (text[i - 1].isdigit() or text[i - 1] == "."):
            i -= 1
        unit = text[i:].strip().upper()
        try:
            number = float(text[:i])
        except ValueError:
            number = None
        if number is not None and unit in units and number > 0:
            return int(number * units[unit])
    raise Error(f"{name}: expected a number of bytes or a size such as 512MiB, found {value!r}")


def _size(size):
    if size is None:
        return None
    if isinstance(size, _numbers.Integral) and not isinstance(size, bool):
        return (int(size), int(size))
    if isinstance(size, str):
        parts = size.lower().split("x")
        try:
            numbers = [int(p) for p in parts]
        except ValueError:
            raise Error(f"size: expected N or WxH, found {size!r}") from None
        return (numbers[0], numbers[0]) if len(numbers) == 1 else tuple(numbers)
    return tuple(size)


def _camera(camera):
    if camera is None or isinstance(camera, Camera):
        return camera
    if isinstance(camera, dict):
        return Camera.from_json(camera)
    if isinstance(camera, (str, _os.PathLike)):
        return Camera.read(_os.fspath(camera))
    raise Error(f"camera: expected a Camera, a camera JSON dict or a file, found {type(camera).__name__}")


def _tf(tf):
    if tf is None or isinstance(tf, TransferFunction):
        return tf
    if isinstance(tf, _os.PathLike):
        return _os.fspath(tf)
    if isinstance(tf, (dict, list)):
        return TransferFunction.from_json(tf)
    return tf


# ------------------------------------------------------------------------------------------------------------ data in

def read(path, solution=None, time_step=None, raw_dims=None, raw_type=None, raw_spacing=None, raw_origin=None,
         raw_big_endian=False, raw_header_bytes=None):
    """Reads a dataset in any format `ugvr info` reads (.vtu .vtk .vts .vti .msh .ugrid .e .inp .off .nas .nrrd .raw
    PLOT3D ...). `path` may be a list [grid, solution]; `solution` names a PLOT3D solution file. `time_step`: the
    Exodus time step (default the last); raw_*: the layout of a headerless .raw volume (as --raw-dims and so on)."""
    paths = _paths(path)
    if solution is not None:
        paths.append(_os.fsdecode(solution))
    options = dict(time_step=time_step, raw_dims=raw_dims, raw_type=raw_type, raw_spacing=raw_spacing,
                   raw_origin=raw_origin, raw_big_endian=raw_big_endian, raw_header_bytes=raw_header_bytes)
    return _ugvr._read(paths, options)


def _from_arrays(points, cells=None, offsets=None, types=None, point_data=None, cell_data=None):
    """A mesh from numpy arrays (copied once into ugvr's layout: float32 points, uint32 connectivity).

    points: (N, 3) float32/float64, finite. Cells either VTK style -- `cells` the connectivity (1-D integers),
    `offsets` (C + 1 entries from 0, VTK 9's) and `types` (C VTK type ids: 10 tetra, 12 hexahedron, 13 wedge,
    14 pyramid; 11 voxel and quadratic cells are linearised to their corners), or `cells` VTK's legacy array
    [n, id, ..., n, id, ...] with offsets=None -- or per type, `cells={"tetra": (M, 4), "hexahedron": (K, 8)}`
    (meshio's names, cells in the dict's order). point_data / cell_data: {name: (N,) or (N, k) array} of any
    integer or float dtype, kept in that dtype. Errors name the argument (ugvr.Error)."""
    return _ugvr._from_arrays(points, cells, offsets, types, dict(point_data or {}), dict(cell_data or {}))


def _from_image(dims, origin=(0, 0, 0), spacing=(1, 1, 1), point_data=None, cell_data=None):
    """A uniform grid: point (i, j, k) at origin + (i, j, k) * spacing, fields i fastest (VTK's order)."""
    return _ugvr._from_image(dims, origin, spacing, dict(point_data or {}), dict(cell_data or {}))


def _from_structured(dims, points, point_data=None, cell_data=None):
    """A curvilinear grid: dims point counts, points (ni*nj*nk, 3) i fastest (VTK's vtkStructuredGrid order)."""
    import numpy as np
    pts = np.asarray(points)
    if pts.ndim > 2 and pts.shape[-1] == 3:
        pts = pts.reshape(-1, 3)
    return _ugvr._from_structured(dims, pts, dict(point_data or {}), dict(cell_data or {}))


Dataset.from_arrays = staticmethod(_from_arrays)
Dataset.from_image = staticmethod(_from_image)
Dataset.from_structured = staticmethod(_from_structured)


def from_vtk(obj, point_data=None, cell_data=None):
    """A Dataset from a vtkUnstructuredGrid, vtkStructuredGrid or vtkImageData (PyVista grids are these).

    Copies: VTK's arrays are read through vtk.util.numpy_support as views, then copied once into ugvr's layout by
    Dataset.from_arrays -- points to float32 (VTK's points are often float64), connectivity from VTK's int64 to
    ugvr's uint32, offsets to uint64, fields in their own dtype. Nothing else is copied; the extra memory is the
    ugvr dataset itself (bench/README.md has the figure for 10M tetrahedra). `point_data` / `cell_data`: the names
    to take (default all)."""
    from vtk.util import numpy_support as ns

    def arrays(attributes, names):
        out = {}
        for i in range(attributes.GetNumberOfArrays()):
            array = attributes.GetArray(i)
            if array is None or array.GetName() is None:
                continue  # not a numeric array (strings) or unnamed
            if names is not None and array.GetName() not in names:
                continue
            out[array.GetName()] = ns.vtk_to_numpy(array)
        return out

    point_fields = arrays(obj.GetPointData(), point_data)
    cell_fields = arrays(obj.GetCellData(), cell_data)
    kind = obj.GetClassName()
    if obj.IsA("vtkImageData"):
        if hasattr(obj, "GetDirectionMatrix") and not obj.GetDirectionMatrix().IsIdentity():
            raise Error(f"from_vtk: {kind} with a direction matrix is not supported (axis-aligned images only)")
        return _from_image(obj.GetDimensions(), obj.GetOrigin(), obj.GetSpacing(), point_fields, cell_fields)
    if obj.IsA("vtkStructuredGrid"):
        points = ns.vtk_to_numpy(obj.GetPoints().GetData())
        return _from_structured(obj.GetDimensions(), points, point_fields, cell_fields)
    if obj.IsA("vtkUnstructuredGrid"):
        if obj.GetPoints() is None or obj.GetNumberOfCells() == 0:
            raise Error("from_vtk: the vtkUnstructuredGrid has no cells")
        points = ns.vtk_to_numpy(obj.GetPoints().GetData())
        cells = obj.GetCells()
        connectivity = ns.vtk_to_numpy(cells.GetConnectivityArray())
        offsets = ns.vtk_to_numpy(cells.GetOffsetsArray())
        types = ns.vtk_to_numpy(obj.GetCellTypesArray())
        return _from_arrays(points, connectivity, offsets, types, point_fields, cell_fields)
    raise Error(f"from_vtk: expected a vtkUnstructuredGrid, vtkStructuredGrid or vtkImageData, found {kind}")


def from_meshio(mesh):
    """A Dataset from a meshio.Mesh: its volume cell blocks in order (tetra, pyramid, wedge, hexahedron and their
    quadratic forms, linearised), point_data, and cell_data concatenated over those blocks. Surface blocks
    (triangle, quad, ...) are left out with their cell data. Copies as from_arrays."""
    import numpy as np
    vtk_ids = {"tetra": 10, "hexahedron": 12, "wedge": 13, "pyramid": 14, "tetra10": 24, "hexahedron20": 25,
               "wedge15": 26, "pyramid13": 27, "hexahedron27": 29, "wedge18": 32, "pyramid14": 37}
    blocks = [(i, b) for i, b in enumerate(mesh.cells) if b.type in vtk_ids and len(b.data)]
    if not blocks:
        raise Error("from_meshio: the mesh has no volume cells (tetra, pyramid, wedge, hexahedron)")
    # VTK-style arrays in the blocks' order, so that the cells keep the file's order (meshio splits a mixed file into
    # runs of one type); the index arrays are built here (one more copy of the connectivity than from_vtk makes).
    # meshio numbers a wedge's corners in the opposite orientation to VTK (its VTK writers swap 1<->2 and 4<->5, and
    # so does this; the mid-edge nodes of a wedge15 are then dropped by the linearisation anyway).
    def vtk_order(b):
        data = np.asarray(b.data, dtype=np.int64)
        if b.type.startswith("wedge"):
            data = data[:, [0, 2, 1, 3, 5, 4] + list(range(6, data.shape[1]))]
        return data.ravel()

    connectivity = np.concatenate([vtk_order(b) for _, b in blocks])
    sizes = np.concatenate([np.full(len(b.data), b.data.shape[1], dtype=np.int64) for _, b in blocks])
    offsets = np.concatenate([[0], np.cumsum(sizes)])
    types = np.concatenate([np.full(len(b.data), vtk_ids[b.type], dtype=np.uint8) for _, b in blocks])
    cell_data = {}
    for name, per_block in mesh.cell_data.items():
        parts = [np.asarray(per_block[i]) for i, _ in blocks]
        if all(p.dtype.kind in "iuf" for p in parts):
            cell_data[name] = np.concatenate(parts)
    point_data = {k: v for k, v in mesh.point_data.items() if np.asarray(v).dtype.kind in "iuf"}
    return _from_arrays(mesh.points, connectivity, offsets, types, point_data, cell_data)


def generate(out=None, cells=1_000_000, kind="hex", seed=1):
    """`ugvr generate`: the synthetic wing-on-a-floor dataset (hex, tet or mixed cells). Writes `out` (.vtu) and
    returns None, or returns the Dataset in memory when out is None."""
    return _ugvr._generate(int(cells), kind, int(seed), _os.fsdecode(out) if out is not None else "")


class Demo:
    """The built-in demo (`ugvr view --demo`): the mixed-cell wing and the view scripts/demo.sh renders."""

    def __init__(self, cells):
        field, camera, tf, background = _ugvr._demo_scene()
        self.dataset = generate(None, cells=cells, kind="mixed")
        self.field = field
        self.camera = Camera.from_json(camera)
        self.tf = TransferFunction.from_json(tf)
        self.background = background

    def render(self, **kwargs):
        """ugvr.render of the demo with its field, camera, transfer function (in data values) and background."""
        options = dict(field=self.field, camera=self.camera, tf=self.tf, keep_range=True, background=self.background)
        options.update(kwargs)
        return render(self.dataset, **options)


def demo(cells=200_000):
    """The demo dataset and its scene (.dataset .field .camera .tf .background; .render(**kwargs))."""
    return Demo(cells)


# ---------------------------------------------------------------------------------------------------------- rendering

class Image:
    """A rendered image: `array` is H x W x 4 (uint8, as the PNG `ugvr render` writes, or float32 with
    dtype="float32"), row 0 at the top. Array-like (numpy.asarray(image)); shows itself in Jupyter (_repr_png_).
    `camera` and `tf` are what was drawn (the transfer function rescaled, its unit distance set), `stats` the
    engine's figures (as `ugvr render --stats`)."""

    def __init__(self, array, stats=None, camera=None, tf=None, warnings=()):
        self.array = array
        self.stats = stats or {}
        self.camera = camera
        self.tf = tf
        self.warnings = list(warnings)

    def __array__(self, dtype=None, copy=None):
        return self.array if dtype is None else self.array.astype(dtype)

    @property
    def shape(self):
        return self.array.shape

    @property
    def width(self):
        return self.array.shape[1]

    @property
    def height(self):
        return self.array.shape[0]

    def __getitem__(self, index):
        return self.array[index]

    def __len__(self):
        return len(self.array)

    def _repr_png_(self):
        return _ugvr._png_bytes(self.array)

    def png(self):
        """The PNG file's bytes (RGB when every alpha is 1), as `ugvr render -o x.png` writes."""
        return _ugvr._png_bytes(self.array)

    def save(self, path):
        """Writes .png (8-bit) or .pfm (float RGB)."""
        _ugvr._write_image(self.array, _os.fsdecode(path))

    def __repr__(self):
        return f"<ugvr.Image {self.width}x{self.height} {self.array.dtype}, {self.stats.get('engine', '')} engine>"


def read_image(path):
    """A PNG (as uint8 H x W x 4) or PFM (float32) file as an Image: compare with what render() returns."""
    return Image(_ugvr._read_image(_os.fsdecode(path)))


def compare(a, b):
    """RMS, max difference, PSNR (dB) over RGB and SSIM of the luminance (`ugvr compare`'s figures) of two images."""
    return _ugvr._compare(_image_array(a), _image_array(b))


def _image_array(x):
    return x.array if isinstance(x, Image) else x


def _source(source):
    if isinstance(source, Dataset):
        return source
    if isinstance(source, Store):
        return [source.path]
    return _paths(source)


def _slice(s):
    """A slices= item as render_settings.h's JSON form: a dict as it is, else (px, py, pz, nx, ny, nz[, opacity])."""
    if isinstance(s, dict):
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in s.items()}
    v = [float(x) for x in s]
    if len(v) not in (6, 7):
        raise Error("slices: expected (px, py, pz, nx, ny, nz[, opacity]) or a dict, found %r" % (s,))
    out = {"point": v[0:3], "normal": v[3:6]}
    if len(v) == 7:
        out["opacity"] = v[6]
    return out


def render(source, field=None, view=None, camera=None, view_angle=None, tf=None, tf_name=None, keep_range=False,
           range=None, unit_distance=None, size=None, engine="auto", device="auto", exact_precision="double",
           mode=None, iso=None, iso_opacity=None, clip=None, boundary_opacity=None, lighting=None,
           no_lighting=False, volume_lighting=None, background=None, early_termination=None, sample_step=None,
           settings=None, threads=None, cut="pixels:1", gpu="auto", gpu_memory=None, ram_memory=None,
           step_voxels=None, time_step=None, dtype="uint8", progress=None, slices=None, hide_volume=None,
           time_budget=None, **read_options):
    """One image of a Dataset, a Store, or a file (path or [grid, solution]), as `ugvr render` draws it.

    Keywords are `ugvr render`'s flags: field="NAME[:x|y|z|k|magnitude]", view="+x|-x|+y|-y|+z|-z|iso",
    camera=Camera|dict|file, view_angle=deg, tf=preset name|file.json|TransferFunction (rescaled to the field's range
    unless keep_range=True or range=(lo, hi)), tf_name=, unit_distance=, size=N|(w, h)|"WxH", engine="auto|exact|lod",
    device="auto|cpu|gpu", exact_precision=, mode="ea|mip|iso", iso=[v, ...], iso_opacity=, clip=(px, py, pz, nx, ny,
    nz), boundary_opacity=, lighting=False (--no-lighting), volume_lighting=True, background=(r, g, b[, a]),
    early_termination=, sample_step=, settings=file|dict, threads=N, and for a store cut=, gpu=, gpu_memory=,
    ram_memory=, step_voxels=. dtype="float32" returns the float image (before 8-bit rounding).
    slices=[(px, py, pz, nx, ny, nz[, opacity]) or {"point": .., "normal": .., "opacity": .., "color_map": NAME,
    "range": (lo, hi), "contours": N or (v1, ..), "contour_color": (r, g, b), "contour_width": PIXELS}, ...] draws
    cutting planes (--slice, --slice-contours; docs/slices.md), hide_volume="none|front|back|all" where the volume is
    hidden around them (--hide-volume). time_budget=S (--time-budget): the best image drawable within S seconds of
    the call, reading included -- a store's cut refined while time is left, the exact image at the largest scale that
    fits, or for a file over the memory budget what of its store is built by then (stats["time_budget"] says what).

    progress(stage, fraction) is called (with the GIL) during long work -- the exact engine's walk mesh, built on a
    Dataset's first render -- and cancels it by returning False (ugvr.Error "cancelled"). The GIL is released while rendering, so other Python
    threads run. A Dataset keeps its walk mesh for the next render."""
    options = dict(read_options)
    if lighting is None and no_lighting:
        lighting = False
    if isinstance(settings, dict):
        import json
        options["settings_json"] = json.dumps(settings)
        settings = None
    elif settings is not None:
        settings = _os.fspath(settings)
    if slices is not None:
        import json
        options["slices_json"] = json.dumps([_slice(s) for s in slices])
    options.update(hide_volume=hide_volume)
    options.update(field=field, view=view, camera=_camera(camera), view_angle=view_angle, tf=_tf(tf), tf_name=tf_name,
                   keep_range=keep_range, range=range, unit_distance=unit_distance, size=_size(size), engine=engine,
                   device=device, exact_precision=exact_precision, mode=mode, iso=iso, iso_opacity=iso_opacity,
                   clip=clip, boundary_opacity=boundary_opacity, lighting=lighting, volume_lighting=volume_lighting,
                   background=background, early_termination=early_termination, sample_step=sample_step,
                   settings=settings, threads=threads, cut=cut, gpu=gpu,
                   gpu_memory=_bytes(gpu_memory, "gpu_memory"), ram_memory=_bytes(ram_memory, "ram_memory"),
                   step_voxels=step_voxels, time_step=time_step, dtype=dtype, time_budget=time_budget)
    array, stats, used_camera, used_tf, warnings = _ugvr._render(_source(source), options, progress)
    return Image(array, stats, used_camera, used_tf, warnings)


# ------------------------------------------------------------------------------------------------------------- stores

class Store:
    """A brick store (.ugvr): `path`, `info` (fields and their ranges, brick size, nodes, bounds, provenance) and,
    when just built, `summary` (`ugvr build --json`'s figures). Render it with ugvr.render(store) (the lod engine)."""

    def __init__(self, path, summary=None):
        self.path = _os.fsdecode(path)
        self.info = _ugvr._store_info(self.path)
        self.summary = summary

    @property
    def fields(self):
        return [f["name"] for f in self.info["fields"]]

    def __repr__(self):
        i = self.info
        return (f"<ugvr.Store {self.path}: fields {', '.join(self.fields)}, {i['nodes']} nodes, brick {i['brick']}, "
                f"{i['encoding']}, {i['bytes']} bytes>")


def open_store(path):
    """Opens (and validates) a brick store written by `ugvr build` or ugvr.build."""
    return Store(path)


def build(source, out, fields=None, brick=None, max_depth=None, error=None, float32=False, threads=None,
          memory=None, out_of_core=False, no_tf_errors=False, progress=None, **read_options):
    """`ugvr build`: the adaptive octree of bricks of a Dataset or a file, written to `out` (.ugvr).

    fields=["NAME", "NAME:x", ...] (default the first field that varies), brick=32, max_depth=8, error=0.01,
    float32=False, threads=0 (all), memory="1GiB" (a .vtu larger than 40 % of it is built out of core),
    out_of_core=False, no_tf_errors=False. progress(stage, fraction) as in render(); the GIL is released while it
    builds. Returns the Store (with .summary)."""
    if isinstance(fields, str):
        fields = fields.split(",")
    options = dict(read_options)
    options.update(fields=fields, brick=brick, max_depth=max_depth, error=error, float32=float32, threads=threads,
                   memory=_bytes(memory, "memory"), out_of_core=out_of_core, tf_errors=not no_tf_errors)
    src = source if isinstance(source, Dataset) else _paths(source, "source")
    summary = _ugvr._build(src, _os.fsdecode(out), options, progress)
    return Store(out, summary)


# ------------------------------------------------------------------------------------------------------------- viewer

class Viewer:
    """The browser viewer (`ugvr view`) serving in background threads. `url` opens it; `camera` and `tf` are live: get
    returns what the browser tab that moved last shows (before any tab moved, the view tabs start from), set moves
    every open tab (the pages follow) and every tab opened later; `close()` stops it. In Jupyter it shows inline (an
    IFrame of the page on loopback)."""

    def __init__(self, handle, temp_dir=None, height=560):
        self._handle = handle
        self._temp_dir = temp_dir
        self.height = height

    url = property(lambda self: self._handle.url)
    port = property(lambda self: self._handle.port)
    renderer = property(lambda self: self._handle.renderer, doc="The GL renderer the server draws with")
    running = property(lambda self: self._handle.running)
    store = property(lambda self: self._handle.store, doc="The brick store it shows (built in the background)")

    @property
    def camera(self):
        return self._handle.camera

    @camera.setter
    def camera(self, camera):
        self._handle.camera = _camera(camera)

    @property
    def tf(self):
        return self._handle.tf

    @tf.setter
    def tf(self, tf):
        tf = _tf(tf)
        if isinstance(tf, str):
            tf = TransferFunction.read(tf) if _os.path.isfile(tf) else TransferFunction.preset(tf)
        self._handle.tf = tf

    def close(self):
        self._handle.close()
        if self._temp_dir is not None:
            self._temp_dir.cleanup()
            self._temp_dir = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _repr_html_(self):
        if not self.running:
            return "<p>ugvr viewer (closed)</p>"
        return (f'<iframe src="{self.url}" width="100%" height="{int(self.height)}" '
                f'style="border:0" title="ugvr viewer"></iframe>'
                f'<p><a href="{self.url}" target="_blank">{self.url}</a></p>')

    def __repr__(self):
        return f"<ugvr.Viewer {self.url if self.running else '(closed)'}>"


_viewers = _weakref.WeakSet()


@_atexit.register
def _close_viewers():
    """Servers still running when the interpreter exits are stopped while it can still run their destructors."""
    for viewer in list(_viewers):
        viewer.close()


def view(source, port=0, host="127.0.0.1", camera=None, tf=None, fields=None, store=None, size=None, fps=None,
         error=None, max_depth=None, free_grid=False, background=None, gpu="auto", gpu_memory=None, ram_memory=None,
         height=560, **read_options):
    """Starts `ugvr view` on a Dataset, a Store or a file and returns a Viewer (.url, .camera, .tf, .close()).

    A Dataset or a grid file gets its brick store built in the background (a file's in the cache directory, as
    `ugvr view FILE`; a Dataset's in a temporary directory removed by close(), or at `store=`), shown meanwhile by
    the exact engine. Keywords are `ugvr view`'s flags: without `tf` (or "auto") the auto transfer function and,
    without `camera`, the view framed on what it leaves visible, as ugvr.render() starts."""
    import tempfile
    temp_dir = None
    src = source if isinstance(source, Dataset) else _source(source)
    store_path = _os.fsdecode(store) if store is not None else ""
    if isinstance(source, Dataset) and not store_path:
        temp_dir = tempfile.TemporaryDirectory(prefix="ugvr-view-")
        store_path = _os.path.join(temp_dir.name, "dataset.ugvr")
    if isinstance(fields, str):
        fields = fields.split(",")
    tf = _tf(tf)
    if isinstance(tf, str) and _os.path.isfile(tf):
        tf = TransferFunction.read(tf)
    options = dict(read_options)
    options.update(port=port, host=host, camera=_camera(camera), tf=tf, fields=fields, size=_size(size), fps=fps,
                   error=error, max_depth=max_depth, free_grid=free_grid, background=background, gpu=gpu,
                   gpu_memory=_bytes(gpu_memory, "gpu_memory"), ram_memory=_bytes(ram_memory, "ram_memory"))
    try:
        handle = _ugvr._view(src, store_path, options)
    except BaseException:
        if temp_dir is not None:
            temp_dir.cleanup()
        raise
    viewer = Viewer(handle, temp_dir, height)
    _viewers.add(viewer)
    return viewer
