#include "arrays.h"

#include <cstring>

namespace ugvr::python {

py::array data_array_view(const DataArray& array, py::handle base) {
  std::vector<py::ssize_t> shape{py::ssize_t(array.tuples())};
  if (array.components() != 1) shape.push_back(array.components());
  return array.visit([&](auto values) { return readonly_view(values.data(), shape, base); });
}

py::array as_array(py::handle obj, const std::string& name) {
  if (obj.is_none()) fail_in(name, "expected an array, found None");
  py::object a;
  try {
    a = py::module_::import("numpy").attr("ascontiguousarray")(obj);
  } catch (const py::error_already_set& e) {
    fail_in(name, std::string("cannot be read as an array: ") + e.what());
  }
  py::array arr = a.cast<py::array>();
  const char kind = arr.dtype().kind();
  if (kind != 'i' && kind != 'u' && kind != 'f' && kind != 'b')
    fail_in(name, "expected numbers, found dtype " + py::str(arr.dtype()).cast<std::string>());
  return arr;
}

namespace {

template <class T>
DataArray copy_as(const py::array& a, int components) {
  std::vector<T> values(size_t(a.size()));
  if (!values.empty()) std::memcpy(values.data(), a.data(), values.size() * sizeof(T));
  return DataArray::from(std::move(values), components);
}

}  // namespace

DataArray data_array_from(py::handle obj, const std::string& name, uint64_t tuples, const char* what) {
  const py::array a = as_array(obj, name);
  if (a.ndim() != 1 && a.ndim() != 2)
    fail_in(name, "expected shape (" + std::to_string(tuples) + ",) or (" + std::to_string(tuples) +
                      ", components), found " + std::to_string(a.ndim()) + " dimensions");
  if (uint64_t(a.shape(0)) != tuples)
    fail_in(name, "has " + std::to_string(a.shape(0)) + " values, expected one per " + what + " (" +
                      std::to_string(tuples) + ")");
  const py::ssize_t components = a.ndim() == 2 ? a.shape(1) : 1;
  if (components < 1 || components > 64)
    fail_in(name, "must have 1 to 64 components, found " + std::to_string(components));
  const char kind = a.dtype().kind();
  const auto size = a.itemsize();
  const int c = int(components);
  if (kind == 'f' && size == 4) return copy_as<float>(a, c);
  if (kind == 'f' && size == 8) return copy_as<double>(a, c);
  if (kind == 'i' && size == 1) return copy_as<int8_t>(a, c);
  if (kind == 'i' && size == 2) return copy_as<int16_t>(a, c);
  if (kind == 'i' && size == 4) return copy_as<int32_t>(a, c);
  if (kind == 'i' && size == 8) return copy_as<int64_t>(a, c);
  if (kind == 'u' && size == 1) return copy_as<uint8_t>(a, c);
  if (kind == 'u' && size == 2) return copy_as<uint16_t>(a, c);
  if (kind == 'u' && size == 4) return copy_as<uint32_t>(a, c);
  if (kind == 'u' && size == 8) return copy_as<uint64_t>(a, c);
  fail_in(name, "unsupported dtype " + py::str(a.dtype()).cast<std::string>() +
                    " (expected int8 ... int64, uint8 ... uint64, float32 or float64)");
}

}  // namespace ugvr::python
