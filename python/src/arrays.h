// numpy <-> ugvr arrays for the Python module: read-only views of a Dataset's vectors (no copy; the Python object that
// owns the Dataset is the view's base, so the memory outlives every view), and the checked copies that bring
// caller-owned numpy arrays into a Dataset (Dataset.from_arrays). Every error is a ugvr::Error naming the argument
// ("cells[12]: ...", "point_data['p']: ...") so that nothing a caller passes can crash the interpreter.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/grid/data_array.h"

namespace ugvr::python {

namespace py = pybind11;

// A read-only numpy view of `count` elements (shape `shape`) at `data`, kept alive by `base`.
template <class T>
py::array readonly_view(const T* data, std::vector<py::ssize_t> shape, py::handle base) {
  // numpy wants a non-null pointer even for an empty array; it never reads it.
  static const T empty{};
  py::array a(py::dtype::of<T>(), std::move(shape), {}, data ? data : &empty, base);
  a.attr("flags").attr("writeable") = false;
  return a;
}

// The numpy view of a DataArray: (tuples,) for one component, else (tuples, components).
py::array data_array_view(const DataArray& array, py::handle base);

// `obj` as a C-contiguous numpy array (numpy.ascontiguousarray: no copy when it already is one; a list becomes an
// array). Throws ugvr::Error naming `name` when it cannot be made one, or is of an object/string dtype.
py::array as_array(py::handle obj, const std::string& name);

// A field's values copied into a DataArray of the same element type (int8 ... float64); shape (n,) or (n, k) with
// n == `tuples`. Throws naming `name` for another dtype, shape or count.
DataArray data_array_from(py::handle obj, const std::string& name, uint64_t tuples, const char* what);

}  // namespace ugvr::python
