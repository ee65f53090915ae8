// The compiled part of `import ugvr` (_ugvr): datasets with numpy views, the camera and transfer-function types, and
// the entry points render / build / open_store / view that python/ugvr/__init__.py wraps with keyword arguments.
//
// It links ugvr_internal, not only the public API (include/ugvr): `ugvr render`'s engine choices (--device,
// --exact-precision), a walk mesh kept per Dataset across renders (ExactScene), every `ugvr build` option
// (--no-tf-errors) and the viewer's server (src/ugvr/view) are not in the public API.
//
// Threads: every long call (reading, walk mesh, rendering, building, starting and stopping the viewer) runs with the
// GIL released. A progress callback re-acquires it for each report; when it returns False or raises, the work is
// cancelled and the call raises (ugvr.Error "cancelled", or the callback's own exception).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "arrays.h"
#include "cli/demo_scene.h"
#include "ugvr/api/default_field.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"
#include "ugvr/core/memory.h"
#include "ugvr/core/progress.h"
#include "ugvr/gen/generator.h"
#include "ugvr/io/reader.h"
#include "ugvr/octree/builder.h"
#include "ugvr/octree/input.h"
#include "ugvr/octree/out_of_core.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"
#include "ugvr/render/lod/lod_cut.h"
#include "ugvr/render/render_settings.h"
#include "ugvr/render/renderer_factory.h"
#include "ugvr/render/resolve_view.h"
#include "ugvr/render/time_budget.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"
#include "ugvr/ugvr.h"
#include "ugvr/view/over_budget_store.h"
#include "ugvr/view/view_protocol.h"
#include "ugvr/view/view_server.h"
#include "ugvr/view/view_store.h"
#include "ugvr/view/voxel_store.h"

namespace ugvr::python {
namespace {

using nlohmann::json;

// ---------------------------------------------------------------- small conversions

py::tuple tuple3(const Vec3d& v) { return py::make_tuple(v.x, v.y, v.z); }

double to_double(py::handle h, const std::string& name) {
  try {
    return py::float_(py::reinterpret_borrow<py::object>(h)).cast<double>();
  } catch (const py::error_already_set&) {
    fail_in(name, "expected a number, found " + py::repr(h).cast<std::string>());
  }
}

std::vector<double> to_doubles(py::handle h, const std::string& name, size_t min_count, size_t max_count) {
  if (!py::isinstance<py::sequence>(h) || py::isinstance<py::str>(h))
    fail_in(name, "expected a sequence of numbers, found " + py::repr(h).cast<std::string>());
  std::vector<double> v;
  for (py::handle item : py::reinterpret_borrow<py::sequence>(h)) v.push_back(to_double(item, name));
  if (v.size() < min_count || v.size() > max_count)
    fail_in(name, "expected " +
                      (min_count == max_count ? std::to_string(min_count)
                                              : std::to_string(min_count) + " to " + std::to_string(max_count)) +
                      " numbers, found " + std::to_string(v.size()));
  for (double d : v)
    if (!std::isfinite(d)) fail_in(name, "numbers must be finite");
  return v;
}

Vec3d to_vec3(py::handle h, const std::string& name) {
  const std::vector<double> v = to_doubles(h, name, 3, 3);
  return {v[0], v[1], v[2]};
}

json to_json(py::handle obj) { return json::parse(py::module_::import("json").attr("dumps")(obj).cast<std::string>()); }
py::object from_json(const json& j) { return py::module_::import("json").attr("loads")(j.dump()); }

// Options dict access: a key that is absent or None is "not given".
struct Options {
  py::dict d;
  bool has(const char* key) const { return d.contains(key) && !d[key].is_none(); }
  py::object get(const char* key) const { return d[key]; }
  std::string str(const char* key, std::string fallback = "") const {
    if (!has(key)) return fallback;
    py::object v = get(key);
    if (!py::isinstance<py::str>(v)) fail_in(key, "expected a string, found " + py::repr(v).cast<std::string>());
    return v.cast<std::string>();
  }
  double number(const char* key) const { return to_double(get(key), key); }
  bool flag(const char* key, bool fallback = false) const { return has(key) ? bool(py::bool_(get(key))) : fallback; }
  int64_t integer(const char* key) const {
    py::object v = get(key);
    // Anything with __index__ (int, numpy.int64), not bool and not float.
    if (!PyIndex_Check(v.ptr()) || py::isinstance<py::bool_>(v))
      fail_in(key, "expected an integer, found " + py::repr(v).cast<std::string>());
    try {
      PyObject* index = PyNumber_Index(v.ptr());
      if (!index) throw py::error_already_set();
      return py::reinterpret_steal<py::int_>(index).cast<int64_t>();
    } catch (const py::cast_error&) {
      fail_in(key, "out of range: " + py::repr(v).cast<std::string>());
    }
  }
  uint64_t bytes(const char* key, uint64_t fallback) const {
    if (!has(key)) return fallback;
    const int64_t v = integer(key);
    if (v < 1) fail_in(key, "must be a positive number of bytes");
    return uint64_t(v);
  }
  std::vector<std::string> strings(const char* key) const {
    std::vector<std::string> out;
    if (!has(key)) return out;
    py::object v = get(key);
    if (py::isinstance<py::str>(v)) return {v.cast<std::string>()};
    for (py::handle item : v) {
      if (!py::isinstance<py::str>(item)) fail_in(key, "expected strings, found " + py::repr(item).cast<std::string>());
      out.push_back(item.cast<std::string>());
    }
    return out;
  }
};

ReadOptions read_options(const Options& o) {
  ReadOptions r;
  if (o.has("time_step")) r.time_step = o.integer("time_step");
  if (o.has("raw_dims")) {
    const std::vector<double> d = to_doubles(o.get("raw_dims"), "raw_dims", 3, 3);
    for (int i = 0; i < 3; ++i) {
      if (d[i] < 1 || d[i] > 4294967295.0 || d[i] != std::floor(d[i]))
        fail_in("raw_dims", "expected three positive integers");
      r.raw.dims[i] = uint32_t(d[i]);
    }
  }
  if (o.has("raw_type")) r.raw.type = o.str("raw_type");
  if (o.has("raw_spacing")) {
    const std::vector<double> s = to_doubles(o.get("raw_spacing"), "raw_spacing", 3, 3);
    r.raw.spacing = {s[0], s[1], s[2]};
  }
  if (o.has("raw_origin")) {
    const std::vector<double> s = to_doubles(o.get("raw_origin"), "raw_origin", 3, 3);
    r.raw.origin = {s[0], s[1], s[2]};
  }
  r.raw.big_endian = o.flag("raw_big_endian");
  if (o.has("raw_header_bytes")) {
    const int64_t h = o.integer("raw_header_bytes");
    if (h < 0) fail_in("raw_header_bytes", "must be >= 0");
    r.raw.header_bytes = uint64_t(h);
  }
  return r;
}

// ---------------------------------------------------------------- progress callbacks

// A Python progress callback seen from worker threads. `callback` is borrowed: the caller's arguments keep it alive
// for the whole call. The first exception it raises is kept and re-raised once the GIL is back with the caller.
struct PyProgress {
  py::handle callback;
  std::mutex mutex;
  std::optional<py::error_already_set> error;
  std::atomic<bool> stop{false};

  bool report(std::string_view stage, double fraction) {
    if (!callback || callback.is_none() || stop) return !stop;
    py::gil_scoped_acquire gil;
    try {
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // Ctrl-C in a notebook or a terminal
      py::object r = callback(std::string(stage), fraction);
      if (!r.is_none() && !bool(py::bool_(r))) stop = true;
    } catch (py::error_already_set& e) {
      std::lock_guard lock(mutex);
      if (!error) error = std::move(e);
      stop = true;
    }
    return !stop;
  }
  // With the GIL held: the callback's exception, if it raised one.
  void rethrow() {
    if (error) {
      py::error_already_set e = std::move(*error);
      error.reset();
      throw e;
    }
  }
};

// Runs f with the GIL released; a callback's exception wins over the "cancelled" error it caused.
template <class F>
auto without_gil(PyProgress* progress, F&& f) {
  try {
    py::gil_scoped_release release;
    return f();
  } catch (const Error&) {
    if (progress) progress->rethrow();
    throw;
  }
}

// ---------------------------------------------------------------- datasets

// A dataset shared with Python: the walk mesh the exact engine builds over it is kept for the next render.
struct PyDataset {
  std::shared_ptr<const Dataset> data;
  std::shared_ptr<ExactScene> scene;
  std::mutex mutex;  // one render at a time over `scene` (a renderer is used from one thread at a time)

  const Block& block0() const {
    if (data->blocks.empty()) fail_in("dataset", "has no blocks");
    return data->blocks[0];
  }
};
using DatasetPtr = std::shared_ptr<PyDataset>;

DatasetPtr wrap(Dataset&& d) {
  auto p = std::make_shared<PyDataset>();
  p->data = std::make_shared<const Dataset>(std::move(d));
  return p;
}

// Reads one element of an integer array as int64; uint64 values past INT64_MAX read as INT64_MAX (out of range for
// every check they meet).
struct IntReader {
  const void* data = nullptr;
  char kind = 'i';
  int size = 8;
  size_t count = 0;

  explicit IntReader(const py::array& a, const std::string& name)
      : data(a.data()), kind(a.dtype().kind()), size(int(a.itemsize())), count(size_t(a.size())) {
    if (kind != 'i' && kind != 'u')
      fail_in(name, "expected an integer array, found dtype " + py::str(a.dtype()).cast<std::string>());
  }
  int64_t operator[](size_t i) const {
    if (kind == 'i') {
      switch (size) {
        case 1: return static_cast<const int8_t*>(data)[i];
        case 2: return static_cast<const int16_t*>(data)[i];
        case 4: return static_cast<const int32_t*>(data)[i];
        default: return static_cast<const int64_t*>(data)[i];
      }
    }
    switch (size) {
      case 1: return static_cast<const uint8_t*>(data)[i];
      case 2: return static_cast<const uint16_t*>(data)[i];
      case 4: return static_cast<const uint32_t*>(data)[i];
      default: {
        const uint64_t v = static_cast<const uint64_t*>(data)[i];
        return v > uint64_t(INT64_MAX) ? INT64_MAX : int64_t(v);
      }
    }
  }
};

template <class T>
void copy_points(const py::array& a, std::vector<Vec3f>& out, const std::string& name) {
  const T* p = static_cast<const T*>(a.data());
  const size_t n = size_t(a.shape(0));
  out.resize(n);
  for (size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      const T v = p[i * 3 + size_t(c)];
      if (!std::isfinite(v))
        fail_in(name + "[" + std::to_string(i) + "]", "coordinates must be finite, found " + std::to_string(double(v)));
      out[i][c] = float(v);
    }
  }
}

// (N, 3) float32 or float64 points, finite, into float32 (ugvr's vertex format: float64 input is rounded).
std::vector<Vec3f> read_points(py::handle obj, const std::string& name) {
  const py::array a = as_array(obj, name);
  if (a.dtype().kind() != 'f' || (a.itemsize() != 4 && a.itemsize() != 8))
    fail_in(name, "expected float32 or float64 coordinates, found dtype " + py::str(a.dtype()).cast<std::string>());
  if (a.ndim() != 2 || a.shape(1) != 3)
    fail_in(name, "expected shape (N, 3), found " + py::str(py::tuple(a.attr("shape"))).cast<std::string>());
  if (uint64_t(a.shape(0)) > uint64_t(UINT32_MAX)) fail_in(name, "more than 2^32-1 points");
  std::vector<Vec3f> points;
  if (a.itemsize() == 4)
    copy_points<float>(a, points, name);
  else
    copy_points<double>(a, points, name);
  return points;
}

// meshio's names of the cells ugvr keeps (quadratic ones are linearised to their corners, as the readers do).
int vtk_type_of(py::handle key, const std::string& name) {
  if (py::isinstance<py::int_>(key)) return key.cast<int>();
  if (!py::isinstance<py::str>(key)) fail_in(name, "cell type keys must be names or VTK type ids");
  static const std::pair<const char*, int> kNames[] = {
      {"tetra", 10},     {"voxel", 11},        {"hexahedron", 12},   {"wedge", 13},
      {"pyramid", 14},   {"tetra10", 24},      {"hexahedron20", 25}, {"wedge15", 26},
      {"pyramid13", 27}, {"hexahedron27", 29}, {"wedge18", 32},      {"pyramid14", 37},
  };
  const std::string s = key.cast<std::string>();
  for (const auto& [n, id] : kNames)
    if (s == n) return id;
  fail_in(name, "unknown cell type \"" + s + "\" (volume cells: tetra, pyramid, wedge, hexahedron, voxel and their " +
                    "quadratic forms tetra10, pyramid13, wedge15, hexahedron20 ...)");
}

const VtkCellMapping& checked_mapping(int vtk_type, const std::string& name, VtkCellMapping& m) {
  m = map_vtk_cell_type(vtk_type);
  if (m.kind == VtkCellMapping::Kind::DropLowerDimension)
    fail_in(name, "VTK cell type " + std::to_string(vtk_type) + " (" + std::string(m.vtk_name) +
                      ") is not a volume cell; remove lower-dimensional cells first (ugvr renders volumes)");
  if (m.kind != VtkCellMapping::Kind::Keep)
    fail_in(name, "unsupported VTK cell type " + std::to_string(vtk_type) +
                      (m.vtk_name.empty() ? "" : " (" + std::string(m.vtk_name) + ")"));
  return m;
}

// Appends one cell given by `count` vertex ids read at ids[start..]; checks every index against `points`.
void add_cell(UnstructuredMesh& mesh, const VtkCellMapping& m, const IntReader& ids, size_t start, size_t count,
              uint64_t points, const std::string& name, uint64_t cell) {
  if (m.expected_points >= 0 && count != size_t(m.expected_points))
    fail_in(name, "cell " + std::to_string(cell) + " (" + std::string(m.vtk_name) + ") has " + std::to_string(count) +
                      " vertices, expected " + std::to_string(m.expected_points));
  if (count < m.corner_count)
    fail_in(name, "cell " + std::to_string(cell) + " (" + std::string(m.vtk_name) + ") has " + std::to_string(count) +
                      " vertices, expected at least " + std::to_string(m.corner_count));
  std::array<uint32_t, 8> v{};
  for (size_t k = 0; k < m.corner_count; ++k) {
    const int64_t id = ids[start + k];
    if (id < 0 || uint64_t(id) >= points)
      fail_in(name, "cell " + std::to_string(cell) + " vertex " + std::to_string(k) + ": index " + std::to_string(id) +
                        " is out of range [0, " + std::to_string(points) + ")");
    v[k] = uint32_t(id);
  }
  if (m.voxel_order) std::swap(v[2], v[3]), std::swap(v[6], v[7]);
  mesh.add_cell(m.type, std::span<const uint32_t>(v.data(), m.corner_count));
}

void add_fields(Block& block, const py::dict& data, Association association, uint64_t tuples, const char* arg) {
  for (auto [key, value] : data) {
    if (!py::isinstance<py::str>(key))
      fail_in(arg, "field names must be strings, found " + py::repr(key).cast<std::string>());
    const std::string field = key.cast<std::string>();
    const std::string name = std::string(arg) + "['" + field + "']";
    if (field.empty()) fail_in(arg, "a field name is empty");
    block.fields.add(
        Field(field, association,
              data_array_from(value, name, tuples, association == Association::Vertex ? "point" : "cell")));
  }
}

DatasetPtr finish(Block block, const std::string& format, std::string_view source) {
  block.validate_fields(source);
  Dataset d;
  d.format = format;
  d.blocks.push_back(std::move(block));
  return wrap(std::move(d));
}

DatasetPtr from_arrays(py::handle points_obj, py::handle cells_obj, py::handle offsets_obj, py::handle types_obj,
                       const py::dict& point_data, const py::dict& cell_data) {
  UnstructuredMesh mesh;
  mesh.points = read_points(points_obj, "points");
  const uint64_t n = mesh.points.size();
  VtkCellMapping m;
  if (py::isinstance<py::dict>(cells_obj)) {
    // Per-type connectivity, meshio style: {"tetra": (M, 4), "hexahedron": (K, 8), ...}, cells in the dict's order.
    if (!offsets_obj.is_none() || !types_obj.is_none())
      fail_in("offsets", "not used with per-type cells (a dict of connectivity arrays)");
    for (auto [key, value] : py::reinterpret_borrow<py::dict>(cells_obj)) {
      const std::string name = "cells[" + py::repr(key).cast<std::string>() + "]";
      checked_mapping(vtk_type_of(key, name), name, m);
      const py::array a = as_array(value, name);
      const size_t per_cell = m.expected_points >= 0 ? size_t(m.expected_points) : m.corner_count;
      if (a.ndim() != 2 || size_t(a.shape(1)) != per_cell)
        fail_in(name, "expected shape (cells, " + std::to_string(per_cell) + "), found " +
                          py::str(py::tuple(a.attr("shape"))).cast<std::string>());
      const IntReader ids(a, name);
      const size_t count = size_t(a.shape(0));
      mesh.reserve(mesh.cell_count() + count, mesh.connectivity.size() + count * m.corner_count);
      for (size_t c = 0; c < count; ++c) add_cell(mesh, m, ids, c * per_cell, per_cell, n, name, c);
    }
  } else {
    // VTK style: connectivity + offsets (cells + 1, from 0) + types; or VTK's legacy cell array [n, id, id, ..., n,
    // ...] without offsets.
    if (cells_obj.is_none()) fail_in("cells", "is required (a connectivity array, or a dict of per-type arrays)");
    if (types_obj.is_none()) fail_in("types", "is required with a connectivity array (one VTK type id per cell)");
    const py::array cells = as_array(cells_obj, "cells");
    const py::array types = as_array(types_obj, "types");
    if (cells.ndim() != 1) fail_in("cells", "expected a 1-D array of vertex indices");
    if (types.ndim() != 1) fail_in("types", "expected a 1-D array of VTK type ids");
    const IntReader ids(cells, "cells"), type_ids(types, "types");
    const size_t count = type_ids.count;
    std::optional<py::array> offsets;
    std::optional<IntReader> off;
    if (!offsets_obj.is_none()) {
      offsets = as_array(offsets_obj, "offsets");
      if (offsets->ndim() != 1) fail_in("offsets", "expected a 1-D array");
      off.emplace(*offsets, "offsets");
      if (off->count != count + 1)
        fail_in("offsets", "has " + std::to_string(off->count) + " entries, expected cells + 1 = " +
                               std::to_string(count + 1) + " (VTK's offsets: 0, then the end of each cell)");
      if ((*off)[0] != 0) fail_in("offsets", "must start at 0, found " + std::to_string((*off)[0]));
      if ((*off)[count] != int64_t(ids.count))
        fail_in("offsets", "must end at the connectivity's length " + std::to_string(ids.count) + ", found " +
                               std::to_string((*off)[count]));
    }
    mesh.reserve(count, ids.count);
    size_t pos = 0;  // legacy layout: the position of the next cell's count
    for (size_t c = 0; c < count; ++c) {
      const int64_t t = type_ids[c];
      const std::string tname = "types[" + std::to_string(c) + "]";
      if (t < 0 || t > 255) fail_in(tname, "VTK type id " + std::to_string(t) + " out of range");
      checked_mapping(int(t), tname, m);
      size_t start = 0, size = 0;
      if (off) {
        const int64_t a = (*off)[c], b = (*off)[c + 1];
        if (b < a)
          fail_in("offsets", "decrease at cell " + std::to_string(c) + " (" + std::to_string(a) + " then " +
                                 std::to_string(b) + "): negative vertex count");
        start = size_t(a), size = size_t(b - a);
      } else {
        if (pos >= ids.count)
          fail_in("cells", "ends after " + std::to_string(c) + " cells, types lists " + std::to_string(count));
        const int64_t k = ids[pos];
        if (k < 0) fail_in("cells", "negative vertex count " + std::to_string(k) + " for cell " + std::to_string(c));
        if (uint64_t(k) > ids.count - pos - 1)
          fail_in("cells", "cell " + std::to_string(c) + " lists " + std::to_string(k) + " vertices past the end");
        start = pos + 1, size = size_t(k), pos += 1 + size_t(k);
      }
      add_cell(mesh, m, ids, start, size, n, "cells", c);
    }
    if (!off && pos != ids.count)
      fail_in("cells", "has " + std::to_string(ids.count - pos) + " entries after the last of the " +
                           std::to_string(count) + " cells types lists");
  }
  if (mesh.cell_count() == 0) fail_in("cells", "no cells");
  mesh.validate("from_arrays");
  Block block;
  const uint64_t cells = mesh.cell_count();
  block.grid = std::move(mesh);
  add_fields(block, point_data, Association::Vertex, n, "point_data");
  add_fields(block, cell_data, Association::Cell, cells, "cell_data");
  return finish(std::move(block), "numpy arrays (unstructured)", "from_arrays");
}

GridDims read_dims(py::handle obj) {
  const std::vector<double> d = to_doubles(obj, "dims", 3, 3);
  GridDims dims;
  for (int i = 0; i < 3; ++i) {
    if (d[i] < 1 || d[i] > 2147483647.0 || d[i] != std::floor(d[i]))
      fail_in("dims", "expected three point counts >= 1");
    dims.points[size_t(i)] = uint32_t(d[i]);
  }
  if (dims.point_count() > uint64_t(UINT32_MAX)) fail_in("dims", "more than 2^32-1 points");
  return dims;
}

DatasetPtr from_image(py::handle dims_obj, py::handle origin, py::handle spacing, const py::dict& point_data,
                      const py::dict& cell_data) {
  ImageGrid g;
  g.dims = read_dims(dims_obj);
  g.origin = to_vec3(origin, "origin");
  g.spacing = to_vec3(spacing, "spacing");
  if (!(g.spacing.x > 0 && g.spacing.y > 0 && g.spacing.z > 0)) fail_in("spacing", "must be > 0 along every axis");
  Block block;
  const GridDims dims = g.dims;
  block.grid = g;
  add_fields(block, point_data, Association::Vertex, dims.point_count(), "point_data");
  add_fields(block, cell_data, Association::Cell, dims.cell_count(), "cell_data");
  return finish(std::move(block), "numpy arrays (uniform)", "from_image");
}

DatasetPtr from_structured(py::handle dims_obj, py::handle points_obj, const py::dict& point_data,
                           const py::dict& cell_data) {
  StructuredGrid g;
  g.dims = read_dims(dims_obj);
  g.points = read_points(points_obj, "points");
  if (g.points.size() != g.dims.point_count())
    fail_in("points",
            "has " + std::to_string(g.points.size()) + " points, dims make " + std::to_string(g.dims.point_count()));
  Block block;
  const GridDims dims = g.dims;
  block.grid = std::move(g);
  add_fields(block, point_data, Association::Vertex, dims.point_count(), "point_data");
  add_fields(block, cell_data, Association::Cell, dims.cell_count(), "cell_data");
  return finish(std::move(block), "numpy arrays (curvilinear)", "from_structured");
}

py::dict field_views(const PyDataset& d, Association a, py::handle base) {
  py::dict out;
  for (const Field& f : d.block0().fields)
    if (f.association() == a) out[py::str(f.name())] = data_array_view(f.data(), base);
  return out;
}

// ---------------------------------------------------------------- transfer functions

// A transfer function and whether its opacity unit distance was given (by a preset file's
// ScalarOpacityUnitDistance or by assignment); when not, render() uses `ugvr render`'s default (bounds diagonal / 10).
struct PyTransferFunction : TransferFunction {
  bool unit_set = false;
};

// The colour points' range is what rescale() and range read: a transfer function without any is refused first.
const PyTransferFunction& with_colors(const PyTransferFunction& tf) {
  if (tf.color_points.empty()) fail_in("transfer function", "has no colour points");
  return tf;
}

py::list color_points_list(const TransferFunction& tf) {
  py::list l;
  for (const ColorPoint& p : tf.color_points) l.append(py::make_tuple(p.x, p.rgb.x, p.rgb.y, p.rgb.z));
  return l;
}
py::list opacity_points_list(const TransferFunction& tf) {
  py::list l;
  for (const OpacityPoint& p : tf.opacity_points) l.append(py::make_tuple(p.x, p.opacity));
  return l;
}

PyTransferFunction tf_from_file(const std::string& path, const std::string& name) {
  PyTransferFunction tf;
  static_cast<TransferFunction&>(tf) = read_paraview_preset(path, name);
  if (const auto unit = read_preset_unit_distance(path, name)) tf.opacity_unit_distance = *unit, tf.unit_set = true;
  return tf;
}

PyTransferFunction tf_from_json_text(const std::string& text, const std::string& name) {
  const std::vector<TransferFunction> all = parse_paraview_presets(text, "transfer function JSON");
  PyTransferFunction tf;
  bool found = false;
  for (const TransferFunction& t : all)
    if (name.empty() || t.name == name) {
      static_cast<TransferFunction&>(tf) = t;
      found = true;
      break;
    }
  if (!found) fail_in("transfer function JSON", "no preset called \"" + name + "\"");
  const json j = json::parse(text);
  for (const json& p : j.is_array() ? j : json::array({j}))
    if (p.value("Name", std::string()) == tf.name && p.contains("ScalarOpacityUnitDistance")) {
      tf.opacity_unit_distance = p["ScalarOpacityUnitDistance"].get<double>();
      tf.unit_set = true;
      break;
    }
  return tf;
}

// ---------------------------------------------------------------- images

py::array image_array(const Image& image, bool as_float) {
  const std::vector<py::ssize_t> shape{image.height, image.width, 4};
  if (as_float) {
    py::array_t<float> a(shape);
    std::copy(image.rgba.begin(), image.rgba.end(), a.mutable_data());
    return a;
  }
  py::array_t<uint8_t> a(shape);
  uint8_t* out = a.mutable_data();
  for (size_t i = 0; i < image.rgba.size(); ++i) {
    // write_png's conversion (render/image.cpp): clamp to [0, 1], NaN to 0, round to nearest.
    const float v = image.rgba[i];
    const float c = v > 0 ? (v < 1 ? v : 1.0f) : 0.0f;
    out[i] = uint8_t(std::lround(c * 255.0f));
  }
  return a;
}

// An H x W x 3|4 uint8 (/255) or float array as an Image (alpha 1 when absent).
Image image_from(py::handle obj, const std::string& name) {
  const py::array a = as_array(obj, name);
  if (a.ndim() != 3 || (a.shape(2) != 3 && a.shape(2) != 4))
    fail_in(name, "expected an image of shape (height, width, 3 or 4)");
  if (a.shape(0) < 1 || a.shape(1) < 1) fail_in(name, "is empty");
  const bool bytes = a.dtype().kind() == 'u' && a.itemsize() == 1;
  const py::array f = bytes ? a : py::array_t<float, py::array::c_style | py::array::forcecast>(a);
  Image image(int(a.shape(1)), int(a.shape(0)));
  const size_t pixels = size_t(image.width) * size_t(image.height), ch = size_t(a.shape(2));
  for (size_t p = 0; p < pixels; ++p)
    for (size_t c = 0; c < 4; ++c) {
      float v = 1.0f;
      if (c < ch)
        v = bytes ? float(static_cast<const uint8_t*>(f.data())[p * ch + c]) / 255.0f
                  : static_cast<const float*>(f.data())[p * ch + c];
      image.rgba[p * 4 + c] = v;
    }
  return image;
}

// ---------------------------------------------------------------- rendering

RenderMode parse_mode(const std::string& text) {
  if (text == "ea" || text == "emission_absorption") return RenderMode::EmissionAbsorption;
  if (text == "mip") return RenderMode::Mip;
  if (text == "iso" || text == "isosurface") return RenderMode::Isosurface;
  fail_in("mode", "unknown mode \"" + text + "\" (expected ea, mip or iso)");
}

double fraction(const Options& o, const char* key) {
  const double v = o.number(key);
  if (!(v >= 0 && v <= 1)) fail_in(key, "must be in [0, 1], found " + std::to_string(v));
  return v;
}

// `ugvr render`'s settings_from_flags (src/cli/render_flags.cpp) over keyword arguments.
bool tricubic_isosurface(const RenderSettings& s) {
  return s.mode == RenderMode::Isosurface && s.interpolation == Interpolation::Tricubic;
}

RenderSettings settings_from(const Options& o) {
  RenderSettings s;
  if (o.has("settings")) s = read_render_settings(o.str("settings"));
  if (o.has("settings_json")) s = settings_from_json(parse_json_text(o.str("settings_json"), "settings"), "settings");
  if (o.has("size")) {
    const std::vector<double> size = to_doubles(o.get("size"), "size", 2, 2);
    for (double v : size)
      if (v < 1 || v > kMaxImageSide || v != std::floor(v))
        fail_in("size", "each side must be an integer in [1, " + std::to_string(kMaxImageSide) + "]");
    s.width = int(size[0]), s.height = int(size[1]);
  }
  if (o.has("field")) s.field = o.str("field");
  if (o.has("iso")) {
    s.iso_values = to_doubles(o.get("iso"), "iso", 1, 4096);
    if (!o.has("mode")) s.mode = RenderMode::Isosurface;  // as --iso: the values pick isosurface mode
  }
  if (o.has("mode")) s.mode = parse_mode(o.str("mode"));
  if (s.mode == RenderMode::Isosurface && s.iso_values.empty()) fail_in("mode", "isosurface mode needs iso=[V1, ...]");
  if (o.has("iso_opacity")) s.iso_opacity = fraction(o, "iso_opacity");
  if (o.has("clip")) {
    const std::vector<double> c = to_doubles(o.get("clip"), "clip", 6, 6);
    const ClipPlane plane{{c[0], c[1], c[2]}, {c[3], c[4], c[5]}};
    if (length(plane.normal) == 0) fail_in("clip", "the normal NX, NY, NZ must be non-zero");
    s.clip_plane = plane;
  }
  // slices=: the list as render_settings.h's JSON form (python/ugvr/__init__.py turns tuples into it), added to those
  // of settings= like --slice; errors name "slices".
  if (o.has("slices_json")) {
    const std::vector<Slice> added =
        settings_from_json(json{{"slices", parse_json_text(o.str("slices_json"), "slices")}}, "slices").slices;
    s.slices.insert(s.slices.end(), added.begin(), added.end());
  }
  // interpolation="trilinear|tricubic" (--interpolation): parsed as the settings' key, so the names and errors agree.
  if (o.has("interpolation"))
    s.interpolation =
        settings_from_json(json{{"interpolation", o.str("interpolation")}}, "interpolation").interpolation;
  if (o.has("hide_volume")) s.hide_volume = parse_hide_volume(o.str("hide_volume"), "hide_volume");
  if (o.has("boundary_opacity")) s.boundary_overlay_opacity = fraction(o, "boundary_opacity");
  if (o.has("early_termination")) s.early_termination_opacity = o.number("early_termination");
  if (o.has("sample_step")) s.sample_step = o.number("sample_step");
  if (o.has("lighting")) s.lighting = o.flag("lighting");
  if (o.has("volume_lighting")) s.volume_lighting = o.flag("volume_lighting");
  if (o.has("background")) {
    const std::vector<double> b = to_doubles(o.get("background"), "background", 3, 4);
    for (double c : b)
      if (c < 0 || c > 1) fail_in("background", "components must be in [0, 1]");
    s.background = {b[0], b[1], b[2], b.size() == 4 ? b[3] : 1.0};
  }
  s.validate("render settings");
  return s;
}

const std::vector<std::string> kViews = {"+x", "-x", "+y", "-y", "+z", "-z", "iso"};

// An OptionError (an unknown field, a GPU that is not there) named by its keyword.
template <class F>
auto naming_option(F&& f) {
  try {
    return f();
  } catch (const OptionError& e) {
    // The library names the CLI's flag ("time-budget"); Python's keyword has underscores.
    std::string name = e.option;
    std::replace(name.begin(), name.end(), '-', '_');
    throw OptionError(name, name + ": " + e.what());
  }
}

// What render() hands back to __init__.py.
py::tuple render(py::object source, const py::dict& kwargs, py::object progress_cb) {
  // time_budget= counts from here, reading and preparing the input included, as `ugvr render --time-budget`.
  const auto start = std::chrono::steady_clock::now();
  const Options o{kwargs};
  // Checked before any data is read, in `ugvr render`'s order (cmd_render.cpp run_render).
  const std::string engine = o.str("engine", "auto");
  if (std::find(engine_names().begin(), engine_names().end(), engine) == engine_names().end())
    fail_in("engine", "unknown engine \"" + engine + "\" (valid: auto, exact, lod)");
  const std::string view = o.str("view");
  if (o.has("camera") && !view.empty()) fail_in("view", "cannot be combined with camera");
  if (!view.empty() && std::find(kViews.begin(), kViews.end(), view) == kViews.end())
    fail_in("view", "unknown view \"" + view + "\" (expected +x, -x, +y, -y, +z, -z, iso)");
  std::optional<double> view_angle;
  if (o.has("view_angle")) {
    view_angle = o.number("view_angle");
    if (!(*view_angle > 0 && *view_angle < 180)) fail_in("view_angle", "must be in (0, 180) degrees");
  }
  // The transfer function and camera are resolved once the data is open, as `ugvr render` (render/resolve_view.h).
  ViewChoices choices;
  choices.view = view;
  choices.view_angle = view_angle;
  // Validated as a --camera file is (position != focal point, view up not along the view, finite numbers).
  if (o.has("camera")) choices.camera = camera_from_json(camera_to_json(o.get("camera").cast<Camera>()), "camera");
  TransferFunction& tf = choices.tf;
  std::optional<double>& unit_distance = choices.unit_distance;
  const std::string tf_name = o.str("tf_name");
  // "auto" (tf left out): made from the field's histogram once the data is open, as `ugvr render` does
  // (render/default_transfer_function.h).
  bool auto_tf = false;
  if (o.has("tf") && py::isinstance<PyTransferFunction>(o.get("tf"))) {
    const PyTransferFunction& t = o.get("tf").cast<const PyTransferFunction&>();
    tf = t;
    if (t.unit_set) unit_distance = t.opacity_unit_distance;
    tf.validate("tf");
  } else {
    const std::string name = o.str("tf");
    std::error_code ec;
    const bool from_file =
        !name.empty() && (extension_lower(name) == ".json" || std::filesystem::is_regular_file(name, ec));
    if (!tf_name.empty() && !from_file) fail_in("tf_name", "needs tf=FILE.json");
    auto_tf = !from_file && (name.empty() || name == "auto");
    try {
      if (from_file) {
        const PyTransferFunction t = tf_from_file(name, tf_name);
        tf = t;
        if (t.unit_set) unit_distance = t.opacity_unit_distance;
      } else if (!auto_tf) {
        tf = builtin_preset(name);
      }
    } catch (const Error& e) {
      fail_in("tf", e.what());
    }
  }
  std::optional<std::pair<double, double>>& range = choices.range;
  if (o.has("range")) {
    const std::vector<double> r = to_doubles(o.get("range"), "range", 2, 2);
    if (!(r[0] < r[1])) fail_in("range", "MIN must be less than MAX");
    range = {r[0], r[1]};
  }
  if (o.has("unit_distance")) {
    unit_distance = o.number("unit_distance");
    if (!(*unit_distance > 0)) fail_in("unit_distance", "must be > 0");
  }
  int threads = 0;
  if (o.has("threads")) {
    const int64_t t = o.integer("threads");
    if (t < 1 || t > 4096) fail_in("threads", "must be a positive integer");
    threads = int(t);
  }
  std::optional<double> time_budget;
  if (o.has("time_budget")) {
    time_budget = o.number("time_budget");
    if (!(*time_budget > 0) || !std::isfinite(*time_budget)) fail_in("time_budget", "must be > 0 seconds");
  }
  RenderSettings settings = settings_from(o);
  const bool as_float = o.str("dtype", "uint8") == "float32";
  if (!as_float && o.str("dtype", "uint8") != "uint8") fail_in("dtype", "must be \"uint8\" or \"float32\"");

  RendererOptions ro;
  ro.engine = engine;
  ro.field = settings.field;
  ro.gpu = o.str("gpu", "auto");
  ro.device = o.str("device", "auto");
  const std::string precision = o.str("exact_precision", "double");
  if (precision != "double" && precision != "float") fail_in("exact_precision", "must be double or float");
  ro.exact_gpu.double_precision = precision == "double";
  ro.lod.atlas_budget_bytes = o.bytes("gpu_memory", uint64_t(2) << 30);
  if (o.has("step_voxels")) {
    ro.lod.step_voxels = o.number("step_voxels");
    if (!(ro.lod.step_voxels > 0) || ro.lod.step_voxels > 8) fail_in("step_voxels", "must be in (0, 8]");
    ro.time_critical.resting_step_voxels = ro.lod.step_voxels;
  }
  try {
    ro.cut = parse_cut_spec(o.str("cut", "pixels:1"));
  } catch (const Error& e) {
    fail_in("cut", e.what());
  }
  ro.time_critical.ram_budget_bytes = o.bytes("ram_memory", uint64_t(1) << 30);
  PyProgress progress;
  progress.callback = progress_cb;
  if (!progress_cb.is_none())
    ro.progress = [&progress](std::string_view stage, double f) { return progress.report(stage, f); };

  DatasetPtr dataset;
  std::vector<std::string> inputs;
  if (py::isinstance<PyDataset>(source)) {
    dataset = source.cast<DatasetPtr>();
    if (engine == "lod")
      fail_in("engine", "the lod engine renders a brick store: ugvr.build(dataset, \"x.ugvr\") makes one");
    if (tricubic_isosurface(settings))
      fail_in("settings",
              "interpolation \"tricubic\": isosurfaces on the spline are drawn by the lod engine from a "
              "brick store: ugvr.build(dataset, \"x.ugvr\") makes one (a voxel file rendered by its path "
              "has its store built and cached)");
  } else {
    inputs = source.cast<std::vector<std::string>>();
  }
  const ReadOptions read = read_options(o);
  // Read with the GIL held: the render below runs without it, and the options are a Python dict.
  choices.keep_range = o.flag("keep_range");
  if (choices.keep_range && auto_tf) fail_in("keep_range", "keeps a tf's own range: name one (tf=\"viridis\")");
  choices.auto_tf = auto_tf;

  struct Result {
    Frame frame;
    std::string field;
    FieldRange range;
    Camera camera;
    TransferFunction tf;
    json stats;
    std::vector<std::string> warnings;
    std::string drew_from;  // a mesh over the memory budget: "store" (view/over_budget_store.h)
    json voxel_store;       // a voxel volume's tricubic store: its path, and whether this call built it
  };
  Result r = without_gil(&progress, [&] {
    std::optional<tbb::global_control> limit;
    if (threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, size_t(threads));
    std::unique_lock<std::mutex> lock;
    std::unique_ptr<Renderer> renderer;
    Result out;
    if (dataset) {
      lock = std::unique_lock(dataset->mutex);
      RendererOptions opts = ro;
      if (opts.field.empty()) {  // the first field that varies, as open_renderer_default_field
        const std::vector<std::string> names = default_field_names(dataset->block0(), 1);
        if (!names.empty()) opts.field = names[0];
      }
      if (!dataset->scene) dataset->scene = std::make_shared<ExactScene>(dataset->data, ro.progress);
      renderer = naming_option([&] { return make_renderer(dataset->scene, opts); });
    } else {
      OpenedInput opened;
      // A mesh over the memory budget is never read whole: drawn from its store, built out of core into the viewer's
      // cache (view/over_budget_store.h; "drew_from" in the stats).
      std::optional<view::OverBudgetStore> big = naming_option(
          [&] { return view::store_for_a_mesh_over_budget(inputs, ro.field, engine, time_budget, start, false); });
      // Within a time budget a store is drawn by its time-critical cut, refined while time is left.
      const bool store_input = inputs.size() == 1 && std::filesystem::path(inputs[0]).extension() == ".ugvr";
      // Tricubic isosurfaces are the lod engine's, from a store: a voxel volume's is built once into the cache
      // (view/voxel_store.h, as `ugvr render`); a mesh has its own interpolants, which the exact engine draws.
      std::optional<view::VoxelStore> voxel;
      if (tricubic_isosurface(settings) && !big && !store_input &&
          !(inputs.size() == 1 && extension_lower(inputs[0]) == ".json")) {
        if (!view::is_voxel_volume_input(inputs))
          fail_in("settings",
                  "interpolation \"tricubic\": isosurfaces on the spline are drawn by the lod engine from "
                  "a brick store, and " +
                      (inputs.empty() ? std::string("the input") : inputs[0]) +
                      " is not one (nor a voxel volume: NRRD, raw, .vti, whose store is built here): "
                      "ugvr.build(INPUT, \"x.ugvr\") makes one");
        if (engine != "auto" && engine != "lod")
          fail_in("engine", engine +
                                ": tricubic isosurfaces of a voxel volume are drawn by the lod engine from its "
                                "store (leave engine out, or \"lod\")");
        voxel = view::voxel_store_for_tricubic(inputs, read, ro.field, false);
      }
      RendererOptions opts = ro;
      if (time_budget && (big || voxel || engine == "lod" || (engine == "auto" && store_input)))
        opts.interactive = true;
      renderer = naming_option([&] {
        if (voxel) return open_renderer_default_field({voxel->path}, read, opts, &opened);
        return open_renderer_default_field(big ? std::vector<std::string>{big->path} : inputs, read, opts, &opened);
      });
      if (voxel) {
        out.voxel_store = {{"path", voxel->path}, {"built", voxel->built}};
        if (!voxel->lattice.note.empty()) out.warnings.push_back(inputs[0] + ": " + voxel->lattice.note);
      }
      if (big) {
        out.warnings.push_back(big->why + ": drawn from its store " + big->path + ", built out of core");
        out.drew_from = big->shown;
      }
      out.warnings.insert(out.warnings.end(), opened.warnings.begin(), opened.warnings.end());
    }
    if (settings.field.empty()) settings.field = renderer->field_name();
    out.range = renderer->field_range();
    ResolvedView resolved = resolve_view(*renderer, choices, out.range);
    out.tf = std::move(resolved.tf);
    out.camera = resolved.camera;
    FrameRequest request;
    request.camera = out.camera;
    request.tf = out.tf;
    request.settings = settings;
    json budget_report;
    out.frame = time_budget ? render_within_budget(*renderer, request, *time_budget, start, budget_report, false)
                            : renderer->render(request);
    out.field = renderer->field_name();
    out.stats = {
        {"engine", std::string(renderer->engine())},     {"device", renderer->device()}, {"field", out.field},
        {"field_range", {out.range.min, out.range.max}}, {"width", settings.width},      {"height", settings.height},
        {"settings", settings_to_json(settings)}};
    out.frame.stats.to_json(out.stats);
    if (!out.drew_from.empty()) out.stats["drew_from"] = out.drew_from;
    if (!out.voxel_store.is_null()) out.stats["voxel_store"] = out.voxel_store;
    if (time_budget) {
      if (!out.drew_from.empty()) {
        budget_report["drew_from"] = out.drew_from;
        budget_report["drew"] = "the " + out.drew_from + ": " + budget_report["drew"].get<std::string>();
      }
      out.stats["time_budget"] = budget_report;
    }
    return out;
  });
  PyTransferFunction used;
  static_cast<TransferFunction&>(used) = r.tf;
  used.unit_set = true;
  return py::make_tuple(image_array(r.frame.image, as_float), from_json(r.stats), r.camera, used, r.warnings);
}

// ---------------------------------------------------------------- stores

py::dict store_info(const std::string& path) {
  const BrickStoreReader store = [&] {
    py::gil_scoped_release release;
    return BrickStoreReader(path);
  }();
  const BrickStoreLayout& l = store.layout();
  py::list fields;
  for (const BrickStoreField& f : l.fields) {
    py::dict d;
    d["name"] = f.name;
    d["association"] = std::string(association_name(f.association));
    d["range"] = py::make_tuple(f.min, f.max);
    fields.append(d);
  }
  uint64_t bricks = 0, leaves = 0;
  int depth = 0;
  for (const BrickNode& n : store.nodes()) {
    bricks += n.brick_offset != 0;
    leaves += n.is_leaf();
    depth = std::max(depth, int(n.level));
  }
  py::dict info;
  info["path"] = path;
  info["fields"] = fields;
  info["brick"] = l.resolution;
  info["encoding"] = l.encoding.samples == SampleEncoding::Float32 ? "float32" : "quant16";
  info["nodes"] = store.node_count();
  info["leaves"] = leaves;
  info["bricks"] = bricks;
  info["max_level"] = depth;
  info["bytes"] = store.file_size();
  info["bounds"] = py::make_tuple(tuple3(l.data.lo), tuple3(l.data.hi));
  info["root"] = py::make_tuple(tuple3(l.root.lo), tuple3(l.root.hi));
  info["tf_errors"] = store.has_tf_errors();
  info["provenance"] = l.provenance.empty() ? py::object(py::none()) : from_json(json::parse(l.provenance));
  return info;
}

// `ugvr build`'s callback (src/cli/cmd_build.cpp) over keyword arguments; returns its --json summary.
py::dict build(py::object source, const std::string& output, const py::dict& kwargs, py::object progress_cb) {
  const Options o{kwargs};
  if (extension_lower(output) != ".ugvr") fail_in(output, "the output must be a .ugvr file");
  OctreeBuildOptions b;
  if (o.has("brick")) {
    const int64_t v = o.integer("brick");
    if (v < 0 || v > 1 << 20) fail_in("brick", "out of range");
    b.resolution = uint32_t(v);
  }
  if (o.has("max_depth")) b.max_depth = int(std::clamp<int64_t>(o.integer("max_depth"), -1, 1 << 20));
  if (o.has("error")) b.error = o.number("error");
  if (o.has("threads")) b.threads = int(std::clamp<int64_t>(o.integer("threads"), -1, 1 << 20));
  if (b.error > 1) fail_in("error", "must be in [0, 1]");
  const bool float32 = o.flag("float32");
  if (float32) b.encoding.samples = SampleEncoding::Float32;
  b.tf_errors = o.flag("tf_errors", true);
  const std::vector<std::string> fields = o.strings("fields");
  const uint64_t memory = o.bytes("memory", uint64_t(1) << 30);
  const bool force_out_of_core = o.flag("out_of_core");
  try {
    validate_build_options(b);
  } catch (const Error& e) {
    std::string m = e.what();
    if (m.rfind("--", 0) == 0) m = m.substr(2);  // "--brick must ..." -> "brick must ..."
    throw Error(m);
  }
  PyProgress progress;
  progress.callback = progress_cb;
  if (!progress_cb.is_none()) {
    b.cancel = &progress.stop;
    b.progress = [&progress](const std::string& label, double f) { progress.report(label, f); };
  }
  DatasetPtr dataset;
  std::vector<std::string> inputs;
  if (py::isinstance<PyDataset>(source))
    dataset = source.cast<DatasetPtr>();
  else
    inputs = source.cast<std::vector<std::string>>();
  const ReadOptions read = read_options(o);
  const bool vtu = inputs.size() == 1 && extension_lower(inputs[0]) == ".vtu";
  if (force_out_of_core && !vtu) fail_in("out_of_core", "reads a single .vtu file");
  b.inputs = inputs;

  struct Result {
    OctreeBuildStats s;
    std::string names;
    bool out_of_core = false;
  };
  const Result r = without_gil(&progress, [&] {
    Result out;
    std::error_code ec;
    out.out_of_core = force_out_of_core || (vtu && std::filesystem::file_size(inputs[0], ec) > memory / 5 * 2);
    if (out.out_of_core) {
      out.s = build_octree_out_of_core(inputs[0], fields, b, memory, output);
      const BrickStoreReader store(output);
      for (const BrickStoreField& f : store.layout().fields) out.names += (out.names.empty() ? "" : ",") + f.name;
    } else {
      std::shared_ptr<const Dataset> ds =
          dataset ? dataset->data : std::make_shared<const Dataset>(read_dataset(inputs, read));
      const OctreeInput input = prepare_octree_input(*ds, fields);
      out.s = build_octree(input, b, output);
      for (const BrickStoreField& f : input.fields) out.names += (out.names.empty() ? "" : ",") + f.name;
    }
    return out;
  });
  progress.rethrow();
  const OctreeBuildStats& s = r.s;
  py::dict d;
  d["output"] = output;
  d["fields"] = r.names;
  d["brick"] = b.resolution;
  d["max_depth"] = b.max_depth;
  d["error"] = b.error;
  d["encoding"] = float32 ? "float32" : "quant16";
  d["cells"] = s.cells;
  d["out_of_core"] = r.out_of_core;
  d["nodes"] = s.nodes;
  d["leaves"] = s.leaves;
  d["nodes_with_data"] = s.bricks;
  d["depth_avg"] = s.mean_leaf_level;
  d["depth_max"] = s.max_level;
  d["seconds"] = s.seconds;
  d["store_bytes"] = s.store_bytes;
  d["tf_error_table_bytes"] = s.tf_error_table_bytes;
  return d;
}

// ---------------------------------------------------------------- viewer

// `ugvr view` in a background thread of its own (the server's I/O and render threads). `camera` and `tf` are live:
// the getters report what the browser tab that moved last shows, the setters move every open tab (the pages follow)
// and every tab opened later (ViewServer::current_view / set_view).
class PyViewer {
 public:
  PyViewer(view::ViewServerOptions options, Bounds bounds, std::string temp_store)
      : options_(std::move(options)), bounds_(bounds), temp_store_(std::move(temp_store)) {
    start();
  }
  ~PyViewer() { close(); }

  std::string url() const { return url_; }
  int port() const { return port_; }
  std::string renderer() const { return renderer_; }
  bool running() const { return bool(server_); }
  Camera camera() const {
    if (!server_) return options_.camera.value_or(default_camera(bounds_));
    return server_->current_view().camera;
  }
  void set_camera(const Camera& c) {
    const Camera checked = camera_from_json(camera_to_json(c), "camera");
    options_.camera = checked;
    if (server_) server_->set_view(checked, std::nullopt);
  }
  py::object tf() const {
    PyTransferFunction t;
    if (server_) {
      static_cast<TransferFunction&>(t) = server_->current_view().tf;
      t.unit_set = true;
    } else if (options_.tf) {
      static_cast<TransferFunction&>(t) = *options_.tf;
      t.unit_set = options_.tf->opacity_unit_distance > 0;
    } else {
      static_cast<TransferFunction&>(t) = builtin_preset(options_.preset);
    }
    return py::cast(t);
  }
  void set_tf(const PyTransferFunction& t) {
    t.validate("tf");
    TransferFunction tf = t;
    if (!t.unit_set) tf.opacity_unit_distance = 0;  // 0: the viewer's default
    options_.tf = tf;
    if (server_) server_->set_view(std::nullopt, tf);
  }
  void close() {
    if (!server_) return;
    py::gil_scoped_release release;
    server_->stop();
    server_.reset();
  }
  const std::string& store() const { return options_.store; }

 private:
  void start() {
    py::gil_scoped_release release;
    server_ = std::make_unique<view::ViewServer>(options_);
    port_ = server_->port();
    url_ = server_->url();
    renderer_ = server_->renderer();
  }

  view::ViewServerOptions options_;
  Bounds bounds_;
  std::string temp_store_;
  std::unique_ptr<view::ViewServer> server_;
  std::string url_, renderer_;
  int port_ = 0;
};

std::unique_ptr<PyViewer> start_view(py::object source, const std::string& store, const py::dict& kwargs) {
  const Options o{kwargs};
  view::ViewServerOptions vo;
  vo.host = o.str("host", "127.0.0.1");
  if (o.has("port")) {
    const int64_t p = o.integer("port");
    if (p < 0 || p > 65535) fail_in("port", "must be in [0, 65535] (0: a free port)");
    vo.port = uint16_t(p);
  }
  vo.gpu = o.str("gpu", "auto");
  vo.gpu_memory = o.bytes("gpu_memory", vo.gpu_memory);
  vo.ram_per_session = o.bytes("ram_memory", vo.ram_per_session);
  vo.free_grid = o.flag("free_grid");
  if (o.has("size")) {
    const std::vector<double> s = to_doubles(o.get("size"), "size", 2, 2);
    for (double v : s)
      if (v < view::kMinViewSide || v > view::kMaxViewSide || v != std::floor(v))
        fail_in("size", "each side must be an integer in [" + std::to_string(view::kMinViewSide) + ", " +
                            std::to_string(view::kMaxViewSide) + "]");
    vo.width = int(s[0]), vo.height = int(s[1]);
  }
  if (o.has("fps")) {
    vo.fps = o.number("fps");
    if (!(vo.fps >= 0) || vo.fps > view::kMaxFps) fail_in("fps", "must be in [0, 240]");
  }
  if (o.has("error")) vo.build.error = o.number("error");
  if (o.has("max_depth")) vo.build.max_depth = int(std::clamp<int64_t>(o.integer("max_depth"), -1, 1 << 20));
  validate_build_options(vo.build);
  if (o.has("camera")) vo.camera = camera_from_json(camera_to_json(o.get("camera").cast<Camera>()), "camera");
  if (o.has("background")) {
    const std::vector<double> b = to_doubles(o.get("background"), "background", 3, 4);
    vo.background = std::array<double, 4>{b[0], b[1], b[2], b.size() == 4 ? b[3] : 1.0};
  }
  // No tf (or "auto"): the auto transfer function, the reset view framed on what it leaves visible unless a camera is
  // given, as `ugvr view` and ugvr.render() (ViewServerOptions::auto_tf).
  vo.auto_tf = !o.has("tf") || (!py::isinstance<PyTransferFunction>(o.get("tf")) && o.str("tf") == "auto");
  if (o.has("tf") && !vo.auto_tf) {
    if (py::isinstance<PyTransferFunction>(o.get("tf"))) {
      const PyTransferFunction& t = o.get("tf").cast<const PyTransferFunction&>();
      t.validate("tf");
      vo.tf = t;
      if (!t.unit_set) vo.tf->opacity_unit_distance = 0;
    } else {
      const std::string name = o.str("tf");
      try {
        builtin_preset(name);
      } catch (const Error& e) {
        fail_in("tf", std::string("neither a TransferFunction nor a preset: ") + e.what());
      }
      vo.preset = name;
    }
  }
  const std::vector<std::string> fields = o.strings("fields");
  Bounds bounds;
  if (py::isinstance<PyDataset>(source)) {
    const DatasetPtr d = source.cast<DatasetPtr>();
    vo.dataset = d->data;
    vo.fields = fields.empty() ? view::default_view_fields(*d->data) : fields;
    vo.build.inputs = {"python"};
    vo.build.threads = std::max(1, int(std::thread::hardware_concurrency()) - 1);
    vo.store = store;
    bounds = d->data->bounds();
    return std::make_unique<PyViewer>(std::move(vo), bounds, store);
  }
  const std::vector<std::string> inputs = source.cast<std::vector<std::string>>();
  if (inputs.size() == 1 && is_brick_store(inputs[0])) {
    vo.store = inputs[0];
    bounds = BrickStoreReader(inputs[0]).layout().data;
    return std::make_unique<PyViewer>(std::move(vo), bounds, "");
  }
  // A grid file: its store is built in the background into the cache directory (reused while the file is unchanged),
  // as `ugvr view FILE` does.
  vo.build.inputs = inputs;
  vo.build.threads = std::max(1, int(std::thread::hardware_concurrency()) - 1);
  vo.store = !store.empty() ? store : view::cached_store_path(inputs, fields, vo.build);
  auto dataset = std::make_shared<const Dataset>([&] {
    py::gil_scoped_release release;
    return read_dataset(inputs, read_options(o));
  }());
  bounds = dataset->bounds();
  bool reuse = false;
  std::error_code ec;
  if (std::filesystem::exists(vo.store, ec)) try {
      BrickStoreReader check(vo.store);
      reuse = true;
    } catch (const Error&) {
    }
  if (!reuse) {
    vo.fields = fields.empty() ? view::default_view_fields(*dataset) : fields;
    vo.dataset = std::move(dataset);
  }
  return std::make_unique<PyViewer>(std::move(vo), bounds, "");
}

// ---------------------------------------------------------------- camera helpers

Bounds bounds_of(py::handle obj) {
  if (py::isinstance<PyDataset>(obj)) return obj.cast<const PyDataset&>().data->bounds();
  const py::sequence s = py::reinterpret_borrow<py::sequence>(obj);
  if (py::len(s) != 2) fail_in("bounds", "expected ((xmin, ymin, zmin), (xmax, ymax, zmax)) or a Dataset");
  Bounds b;
  b.lo = to_vec3(s[0], "bounds");
  b.hi = to_vec3(s[1], "bounds");
  return b;
}

}  // namespace
}  // namespace ugvr::python

PYBIND11_MODULE(_ugvr, m) {
  using namespace ugvr;
  using namespace ugvr::python;
  m.doc() = "ugvr's compiled core; use the `ugvr` package (python/ugvr/__init__.py)";
  m.attr("__version__") = version();
  // pybind11 looks numpy's C API up in a function-local static on first use; that lookup imports numpy and lets go of
  // the GIL meanwhile, so two threads making their first arrays at once deadlocked (one waiting for the static with
  // the GIL, the other for the GIL inside the static). Made here, on import, with one thread.
  (void)py::dtype::of<uint8_t>();

  static py::exception<Error> error(m, "Error");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Error& e) {
      error(e.what());
    } catch (const std::bad_alloc&) {
      PyErr_SetString(PyExc_MemoryError, "out of memory");
    } catch (const std::filesystem::filesystem_error& e) {
      error(e.what());
    } catch (const nlohmann::json::exception& e) {
      error((std::string("JSON: ") + e.what()).c_str());
    }
  });

  // ---- datasets
  py::class_<PyDataset, DatasetPtr>(m, "Dataset")
      .def_property_readonly("format", [](const PyDataset& d) { return d.data->format; })
      .def_property_readonly("sources", [](const PyDataset& d) { return d.data->sources; })
      .def_property_readonly("warnings", [](const PyDataset& d) { return d.data->warnings; })
      .def_property_readonly("point_count", [](const PyDataset& d) { return d.data->point_count(); })
      .def_property_readonly("cell_count", [](const PyDataset& d) { return d.data->cell_count(); })
      .def_property_readonly("memory_bytes", [](const PyDataset& d) { return d.data->memory_bytes(); })
      .def_property_readonly("block_count", [](const PyDataset& d) { return d.data->blocks.size(); })
      .def_property_readonly("bounds",
                             [](const PyDataset& d) {
                               const Bounds b = d.data->bounds();
                               return py::make_tuple(tuple3(b.lo), tuple3(b.hi));
                             })
      .def_property_readonly("grid_kind",
                             [](const PyDataset& d) { return std::string(grid_kind_name(d.block0().grid)); })
      .def_property_readonly(
          "points",
          [](py::object self) -> py::object {
            const PyDataset& d = self.cast<const PyDataset&>();
            const std::vector<Vec3f>* p = nullptr;
            if (auto* u = std::get_if<UnstructuredMesh>(&d.block0().grid)) p = &u->points;
            if (auto* s = std::get_if<StructuredGrid>(&d.block0().grid)) p = &s->points;
            if (!p) return py::none();
            static_assert(sizeof(Vec3f) == 3 * sizeof(float));
            return readonly_view(reinterpret_cast<const float*>(p->data()), {py::ssize_t(p->size()), 3}, self);
          })
      .def_property_readonly("cell_types",
                             [](py::object self) -> py::object {
                               auto* u = std::get_if<UnstructuredMesh>(&self.cast<const PyDataset&>().block0().grid);
                               if (!u) return py::none();
                               return readonly_view(reinterpret_cast<const uint8_t*>(u->cell_types.data()),
                                                    {py::ssize_t(u->cell_types.size())}, self);
                             })
      .def_property_readonly("offsets",
                             [](py::object self) -> py::object {
                               auto* u = std::get_if<UnstructuredMesh>(&self.cast<const PyDataset&>().block0().grid);
                               if (!u) return py::none();
                               return readonly_view(u->cell_offsets.data(), {py::ssize_t(u->cell_offsets.size())},
                                                    self);
                             })
      .def_property_readonly("connectivity",
                             [](py::object self) -> py::object {
                               auto* u = std::get_if<UnstructuredMesh>(&self.cast<const PyDataset&>().block0().grid);
                               if (!u) return py::none();
                               return readonly_view(u->connectivity.data(), {py::ssize_t(u->connectivity.size())},
                                                    self);
                             })
      .def_property_readonly("dims",
                             [](const PyDataset& d) -> py::object {
                               return std::visit(
                                   [](const auto& g) -> py::object {
                                     if constexpr (requires { g.dims; })
                                       return py::make_tuple(g.dims.points[0], g.dims.points[1], g.dims.points[2]);
                                     else
                                       return py::none();
                                   },
                                   d.block0().grid);
                             })
      .def_property_readonly("origin",
                             [](const PyDataset& d) -> py::object {
                               if (auto* g = std::get_if<ImageGrid>(&d.block0().grid)) return tuple3(g->origin);
                               return py::none();
                             })
      .def_property_readonly("spacing",
                             [](const PyDataset& d) -> py::object {
                               if (auto* g = std::get_if<ImageGrid>(&d.block0().grid)) return tuple3(g->spacing);
                               return py::none();
                             })
      .def_property_readonly(
          "point_data",
          [](py::object self) { return field_views(self.cast<const PyDataset&>(), Association::Vertex, self); })
      .def_property_readonly(
          "cell_data",
          [](py::object self) { return field_views(self.cast<const PyDataset&>(), Association::Cell, self); })
      .def_property_readonly("field_names",
                             [](const PyDataset& d) {
                               std::vector<std::string> names;
                               for (const Field& f : d.block0().fields) names.push_back(f.name());
                               return names;
                             })
      .def(
          "field_range",
          [](const PyDataset& d, const std::string& selector) {
            const ScalarRef ref = d.block0().fields.scalar(selector);
            const Range r = ref.field->range(ref.component);
            return py::make_tuple(r.min, r.max);
          },
          py::arg("field"), "The (min, max) of a scalar (NAME, NAME:x|y|z|k, NAME:magnitude), NaN skipped")
      .def("__repr__", [](const PyDataset& d) {
        std::string names;
        for (const Field& f : d.block0().fields) names += (names.empty() ? "" : ", ") + f.name();
        return "<ugvr.Dataset " + d.data->format + ": " + std::to_string(d.data->cell_count()) + " cells, " +
               std::to_string(d.data->point_count()) + " points, fields [" + names + "]>";
      });

  m.def(
      "_read",
      [](const std::vector<std::string>& paths, const py::dict& kwargs) {
        if (paths.empty() || paths.size() > 2) fail_in("path", "give one file, or a PLOT3D grid file and its solution");
        const ReadOptions read = read_options(Options{kwargs});
        py::gil_scoped_release release;
        return wrap(read_dataset(paths, read));
      },
      py::arg("paths"), py::arg("options"));
  m.def("_from_arrays", &from_arrays, py::arg("points"), py::arg("cells"), py::arg("offsets"), py::arg("types"),
        py::arg("point_data"), py::arg("cell_data"));
  m.def("_from_image", &from_image);
  m.def("_from_structured", &from_structured);
  m.def(
      "_generate",
      [](uint64_t cells, const std::string& kind, uint64_t seed, const std::string& output) -> py::object {
        GenerateOptions g;
        if (cells < 1000 || cells > 10'000'000'000ull) fail_in("cells", "must be in [1000, 10000000000]");
        g.cells = cells;
        const auto k = parse_gen_cell_kind(kind);
        if (!k) fail_in("kind", "must be hex, tet or mixed");
        g.kind = *k;
        g.seed = seed;
        if (!output.empty()) {
          py::gil_scoped_release release;
          generate_dataset(g, output);
          return py::none();
        }
        Dataset d = [&] {
          py::gil_scoped_release release;
          return generate_in_memory(g);
        }();
        return py::cast(wrap(std::move(d)));
      },
      py::arg("cells"), py::arg("kind"), py::arg("seed"), py::arg("output"));
  m.def("_demo_scene", [] {
    return py::make_tuple(std::string(cli::kDemoField), std::string(cli::kDemoCameraJson),
                          std::string(cli::kDemoTfJson),
                          py::make_tuple(cli::kDemoBackground[0], cli::kDemoBackground[1], cli::kDemoBackground[2],
                                         cli::kDemoBackground[3]));
  });

  // ---- camera
  py::class_<Camera>(m, "Camera",
                     "ParaView's camera (render/camera.h): position, focal_point, view_up, view_angle "
                     "(vertical, degrees), parallel_projection, parallel_scale")
      .def(py::init<>())
      .def_property(
          "position", [](const Camera& c) { return tuple3(c.position); },
          [](Camera& c, py::handle v) { c.position = to_vec3(v, "position"); })
      .def_property(
          "focal_point", [](const Camera& c) { return tuple3(c.focal_point); },
          [](Camera& c, py::handle v) { c.focal_point = to_vec3(v, "focal_point"); })
      .def_property(
          "view_up", [](const Camera& c) { return tuple3(c.view_up); },
          [](Camera& c, py::handle v) { c.view_up = to_vec3(v, "view_up"); })
      .def_readwrite("view_angle", &Camera::view_angle)
      .def_readwrite("parallel_projection", &Camera::parallel_projection)
      .def_readwrite("parallel_scale", &Camera::parallel_scale)
      .def(
          "to_json", [](const Camera& c) { return from_json(camera_to_json(c)); },
          "The camera JSON `ugvr render --save-camera` writes, as a dict")
      .def_static(
          "from_json",
          [](py::handle j) {
            return camera_from_json(
                py::isinstance<py::str>(j) ? parse_json_text(j.cast<std::string>(), "camera") : to_json(j), "camera");
          },
          py::arg("json"), "A camera from its JSON (a dict or a string), validated as `ugvr render --camera`")
      .def_static("read", &read_camera, py::arg("path"))
      .def(
          "write", [](const Camera& c, const std::string& path) { write_camera(path, c); }, py::arg("path"))
      .def_static(
          "preset",
          [](const std::string& name, py::handle bounds, double view_angle) {
            return camera_preset(name, bounds_of(bounds), view_angle);
          },
          py::arg("name"), py::arg("bounds"), py::arg("view_angle") = 30.0,
          "ParaView's view buttons framed on a Dataset or bounds: +x -x +y -y +z -z iso")
      .def_static(
          "default", [](py::handle bounds, double view_angle) { return default_camera(bounds_of(bounds), view_angle); },
          py::arg("bounds"), py::arg("view_angle") = 30.0, "`ugvr render`'s first view of a Dataset or bounds")
      .def("validate", [](const Camera& c) { camera_from_json(camera_to_json(c), "camera"); })
      .def("__eq__", [](const Camera& a, const Camera& b) { return a == b; })
      .def("__repr__", [](const Camera& c) { return "ugvr.Camera.from_json(" + camera_to_json(c).dump() + ")"; });

  // ---- transfer function
  py::class_<PyTransferFunction>(m, "TransferFunction",
                                 "A ParaView colour map + opacity map (render/transfer_function.h); points are "
                                 "[(x, r, g, b), ...] and [(x, opacity), ...]")
      .def(py::init<>())
      .def_readwrite("name", &PyTransferFunction::name)
      .def_readwrite("color_space", &PyTransferFunction::color_space)
      .def_property(
          "color_points", [](const PyTransferFunction& t) { return color_points_list(t); },
          [](PyTransferFunction& t, py::handle points) {
            std::vector<ColorPoint> v;
            for (py::handle p : points) {
              const std::vector<double> d = to_doubles(p, "color_points", 4, 4);
              v.push_back({d[0], {d[1], d[2], d[3]}});
            }
            TransferFunction check = t;
            check.color_points = v;
            check.validate("color_points");
            t.color_points = std::move(v);
          })
      .def_property(
          "opacity_points", [](const PyTransferFunction& t) { return opacity_points_list(t); },
          [](PyTransferFunction& t, py::handle points) {
            std::vector<OpacityPoint> v;
            for (py::handle p : points) {
              const std::vector<double> d = to_doubles(p, "opacity_points", 2, 2);
              v.push_back({d[0], d[1]});
            }
            TransferFunction check = t;
            check.opacity_points = v;
            check.validate("opacity_points");
            t.opacity_points = std::move(v);
          })
      .def_property(
          "nan_color", [](const PyTransferFunction& t) { return tuple3(t.nan_color); },
          [](PyTransferFunction& t, py::handle v) { t.nan_color = to_vec3(v, "nan_color"); })
      .def_property(
          "opacity_unit_distance",
          [](const PyTransferFunction& t) -> py::object {
            return t.unit_set ? py::object(py::float_(t.opacity_unit_distance)) : py::object(py::none());
          },
          [](PyTransferFunction& t, py::object v) {
            if (v.is_none()) {
              t.unit_set = false, t.opacity_unit_distance = 1;
              return;
            }
            const double d = to_double(v, "opacity_unit_distance");
            if (!(d > 0) || !std::isfinite(d)) fail_in("opacity_unit_distance", "must be > 0");
            t.opacity_unit_distance = d, t.unit_set = true;
          },
          "ParaView's Scalar Opacity Unit Distance; None: render() uses the bounds diagonal / 10 as `ugvr render`")
      .def("color", [](const PyTransferFunction& t, double s) { return tuple3(with_colors(t).color(s)); })
      .def("opacity", [](const PyTransferFunction& t, double s) { return t.opacity(s); })
      .def_property_readonly("range",
                             [](const PyTransferFunction& t) {
                               with_colors(t);  // before either end is read (argument order is unspecified)
                               return py::make_tuple(t.range_min(), t.range_max());
                             })
      .def("rescale",
           [](PyTransferFunction& t, double lo, double hi) {
             if (!std::isfinite(lo) || !std::isfinite(hi) || hi < lo) fail_in("rescale", "needs finite lo <= hi");
             (void)with_colors(t);
             t.rescale(lo, hi);
           })
      .def("validate", [](const PyTransferFunction& t) { t.validate("transfer function"); })
      .def("copy", [](const PyTransferFunction& t) { return t; })
      .def_static(
          "preset",
          [](const std::string& name) {
            PyTransferFunction t;
            static_cast<TransferFunction&>(t) = builtin_preset(name);
            return t;
          },
          py::arg("name"), "A built-in preset over [0, 1]: viridis, inferno, cool-warm, grayscale, rainbow")
      .def_static("presets", &builtin_preset_names)
      .def_static("read", &tf_from_file, py::arg("path"), py::arg("name") = "",
                  "A ParaView preset file's preset `name` (or its first)")
      .def_static(
          "from_json",
          [](py::handle j, const std::string& name) {
            return tf_from_json_text(py::isinstance<py::str>(j) ? j.cast<std::string>() : to_json(j).dump(), name);
          },
          py::arg("json"), py::arg("name") = "")
      .def(
          "to_json",
          [](const PyTransferFunction& t) {
            TransferFunction out = t;
            json j = json::parse(paraview_preset_json(out));
            if (!t.unit_set) j[0].erase("ScalarOpacityUnitDistance");
            return from_json(j);
          },
          "ParaView's preset JSON (a list holding one preset), as `ugvr render --save-tf` writes")
      .def(
          "write",
          [](const PyTransferFunction& t, const std::string& path) {
            if (!t.unit_set) {
              TransferFunction out = t;
              json j = json::parse(paraview_preset_json(out));
              j[0].erase("ScalarOpacityUnitDistance");
              std::ofstream(path) << j.dump(2);
              return;
            }
            write_paraview_preset(path, t);
          },
          py::arg("path"))
      .def("__eq__",
           [](const PyTransferFunction& a, const PyTransferFunction& b) {
             return static_cast<const TransferFunction&>(a) == static_cast<const TransferFunction&>(b) &&
                    a.unit_set == b.unit_set;
           })
      .def("__repr__", [](const PyTransferFunction& t) {
        return "<ugvr.TransferFunction " + (t.name.empty() ? std::string("(unnamed)") : t.name) + ": " +
               std::to_string(t.color_points.size()) + " colour points, " + std::to_string(t.opacity_points.size()) +
               " opacity points over [" + std::to_string(t.color_points.empty() ? 0 : t.range_min()) + ", " +
               std::to_string(t.color_points.empty() ? 0 : t.range_max()) + "]>";
      });

  // ---- rendering, stores, viewer, images
  m.def("_render", &render, py::arg("source"), py::arg("options"), py::arg("progress"));
  m.def("_build", &build, py::arg("source"), py::arg("output"), py::arg("options"), py::arg("progress"));
  m.def("_store_info", &store_info, py::arg("path"));
  py::class_<PyViewer>(m, "_Viewer")
      .def_property_readonly("url", &PyViewer::url)
      .def_property_readonly("port", &PyViewer::port)
      .def_property_readonly("renderer", &PyViewer::renderer)
      .def_property_readonly("running", &PyViewer::running)
      .def_property_readonly("store", &PyViewer::store)
      .def_property("camera", &PyViewer::camera, &PyViewer::set_camera)
      .def_property("tf", &PyViewer::tf, &PyViewer::set_tf)
      .def("close", &PyViewer::close);
  m.def("_view", &start_view, py::arg("source"), py::arg("store"), py::arg("options"));
  m.def("_png_bytes", [](py::handle image) {
    const std::vector<unsigned char> png = png_bytes(image_from(image, "image"));
    return py::bytes(reinterpret_cast<const char*>(png.data()), png.size());
  });
  m.def("_read_image", [](const std::string& path) {
    const Image image = [&] {
      py::gil_scoped_release release;
      return extension_lower(path) == ".pfm" ? read_pfm(path) : read_png(path);
    }();
    return image_array(image, extension_lower(path) == ".pfm");
  });
  m.def("_write_image",
        [](py::handle image, const std::string& path) { write_image(path, image_from(image, "image")); });
  m.def("_compare", [](py::handle a, py::handle b) {
    const Image ia = image_from(a, "a"), ib = image_from(b, "b");
    const ImageDifference d = compare_images(ia, ib);
    py::dict out;
    out["rms"] = d.rms;
    out["max_abs"] = d.max_abs;
    out["psnr_db"] = d.psnr_db;
    out["ssim"] = ssim(ia, ib);
    return out;
  });
  m.def("set_progress_output", &Progress::set_enabled, py::arg("enabled"),
        "Turns the library's progress lines on stderr (builds, long reads) on or off, as `ugvr --quiet` does");
  m.def("_peak_rss_bytes", &peak_rss_bytes);
  m.def("_current_rss_bytes", &current_rss_bytes);
}
