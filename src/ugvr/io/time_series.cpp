#include "ugvr/io/time_series.h"

#include <fnmatch.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <pugixml.hpp>
#include <sstream>
#include <variant>

#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/json_file.h"
#include "ugvr/io/byte_hash.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/step_lists.h"

namespace fs = std::filesystem;

namespace ugvr {

std::string_view series_kind_name(SeriesKind k) {
  switch (k) {
    case SeriesKind::Single: return "single";
    case SeriesKind::Exodus: return "exodus";
    case SeriesKind::Pvd: return "pvd";
    case SeriesKind::SeriesJson: return "series";
    case SeriesKind::Numbered: return "numbered";
    case SeriesKind::Plot3d: return "plot3d";
    case SeriesKind::Cgns: return "cgns";
    case SeriesKind::EnSight: return "ensight";
    case SeriesKind::OpenFoam: return "openfoam";
  }
  return "?";
}

namespace {

std::string fmt_time(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", t);
  return buf;
}

// A path inside a collection file, relative to the collection's directory unless absolute.
std::string beside(const std::string& collection, const std::string& name) {
  const fs::path p(name);
  if (p.is_absolute()) return name;
  return (fs::path(collection).parent_path() / p).lexically_normal().string();
}

void require_file(const std::string& collection, const std::string& entry, const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) fail_in(collection, entry + ": file " + path + " does not exist");
}

bool is_pvd(const std::string& p) { return extension_lower(p) == ".pvd"; }
bool is_series_json(const std::string& p) { return extension_lower(p) == ".series"; }

// A pattern names files; a file that exists under that very name (a '%' or '*' in a real name) is itself.
bool names_a_pattern(const std::string& path) {
  std::error_code ec;
  return is_series_pattern(path) && !fs::exists(path, ec);
}

// A file a step names must be one dataset, not another series (which would nest time axes).
void refuse_nested(const std::string& collection, const std::string& entry, const std::string& path) {
  if (is_pvd(path) || is_series_json(path))
    fail_in(collection, entry + ": " + path + " is itself a series; a step must name one dataset");
}

TimeSeries list_pvd(const std::string& path) {
  const InputFile in(path);
  const std::string text = in.read_all(uint64_t(1) << 26);
  pugi::xml_document doc;
  const pugi::xml_parse_result parsed = doc.load_buffer(text.data(), text.size());
  if (!parsed) fail_at_offset(in.name(), uint64_t(parsed.offset), std::string("invalid XML: ") + parsed.description());
  const pugi::xml_node root = doc.child("VTKFile");
  if (!root || std::string_view(root.attribute("type").value()) != "Collection")
    fail_in(in.name(), "not a VTK collection: expected <VTKFile type=\"Collection\">");
  const pugi::xml_node collection = root.child("Collection");
  if (!collection) fail_in(in.name(), "no <Collection> element");
  TimeSeries s;
  s.kind = SeriesKind::Pvd;
  s.source = path;
  size_t entry = 0;
  for (const pugi::xml_node d : collection.children("DataSet")) {
    const std::string what = "DataSet " + std::to_string(entry++);
    const char* file = d.attribute("file").value();
    if (!*file) fail_at_offset(in.name(), uint64_t(d.offset_debug()), what + ": no file attribute");
    double t = 0;
    if (const pugi::xml_attribute ts = d.attribute("timestep")) {
      const std::string_view v = ts.value();
      const auto r = std::from_chars(v.data(), v.data() + v.size(), t);
      if (v.empty() || r.ec != std::errc() || r.ptr != v.data() + v.size() || !std::isfinite(t))
        fail_at_offset(in.name(), uint64_t(d.offset_debug()),
                       what + ": timestep \"" + std::string(v) + "\" is not a finite number");
    }
    const std::string full = beside(path, file);
    refuse_nested(in.name(), what, full);
    require_file(in.name(), what, full);
    // Entries of one timestep are the parts of one step (ParaView's "part" attribute); times must not go back.
    if (!s.steps.empty() && t == s.steps.back().time) {
      s.steps.back().files.push_back(full);
      continue;
    }
    if (!s.steps.empty() && t < s.steps.back().time)
      fail_at_offset(in.name(), uint64_t(d.offset_debug()),
                     what + ": timestep " + fmt_time(t) + " after " + fmt_time(s.steps.back().time) +
                         ": the times of a collection must not decrease");
    s.steps.push_back({t, {full}, -1});
  }
  if (s.steps.empty()) fail_in(in.name(), "the collection lists no <DataSet>");
  return s;
}

TimeSeries list_series_json(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  const std::string name = base_name(path);
  if (!j.is_object() || !j.contains("files") || !j["files"].is_array())
    fail_in(name, "expected a JSON object with a \"files\" array (ParaView's .series format)");
  TimeSeries s;
  s.kind = SeriesKind::SeriesJson;
  s.source = path;
  size_t i = 0;
  for (const nlohmann::json& f : j["files"]) {
    const std::string what = "files[" + std::to_string(i++) + "]";
    if (!f.is_object() || !f.contains("name") || !f["name"].is_string())
      fail_in(name, what + ": expected {\"name\": FILE, \"time\": T}");
    if (!f.contains("time") || !f["time"].is_number()) fail_in(name, what + ": \"time\" must be a number");
    const double t = f["time"].get<double>();
    if (!std::isfinite(t)) fail_in(name, what + ": \"time\" is not finite");
    if (!s.steps.empty() && !(t > s.steps.back().time))
      fail_in(name, what + ": time " + fmt_time(t) + " after " + fmt_time(s.steps.back().time) +
                        ": the times of a series must increase");
    const std::string full = beside(path, f["name"].get<std::string>());
    refuse_nested(name, what, full);
    require_file(name, what, full);
    s.steps.push_back({t, {full}, -1});
  }
  if (s.steps.empty()) fail_in(name, "the series lists no files");
  return s;
}

// A numbered-series pattern's file-name part as a matcher: printf-style %d / %0Nd (the number there is the step's),
// or a glob (the last run of digits in the name is the step's number).
struct NamePattern {
  std::string prefix, suffix;  // around %d
  size_t min_digits = 1;
  bool printf_style = false;
  std::string glob;

  static NamePattern parse(const std::string& name) {
    NamePattern p;
    const size_t pc = name.find('%');
    if (pc != std::string::npos) {
      size_t e = pc + 1;
      size_t width = 0;
      bool zero = false;
      if (e < name.size() && name[e] == '0') zero = true, ++e;
      while (e < name.size() && name[e] >= '0' && name[e] <= '9') width = width * 10 + size_t(name[e++] - '0');
      if (e >= name.size() || name[e] != 'd' || name.find('%', e) != std::string::npos)
        fail_in(name, "a numbered series pattern takes one %d or %0Nd (e.g. flow_%04d.vtu)");
      p.printf_style = true;
      p.prefix = name.substr(0, pc);
      p.suffix = name.substr(e + 1);
      p.min_digits = zero && width > 0 ? width : 1;
      return p;
    }
    p.glob = name;
    return p;
  }

  // The step number of a matching name.
  std::optional<uint64_t> match(const std::string& name) const {
    std::string_view digits;
    if (printf_style) {
      if (name.size() < prefix.size() + suffix.size() + min_digits || !name.starts_with(prefix) ||
          !name.ends_with(suffix))
        return std::nullopt;
      digits = std::string_view(name).substr(prefix.size(), name.size() - prefix.size() - suffix.size());
      if (digits.size() < min_digits) return std::nullopt;
      for (char c : digits)
        if (c < '0' || c > '9') return std::nullopt;
    } else {
      if (fnmatch(glob.c_str(), name.c_str(), FNM_PERIOD) != 0) return std::nullopt;
      size_t e = name.size();
      while (e > 0 && !(name[e - 1] >= '0' && name[e - 1] <= '9')) --e;
      size_t b = e;
      while (b > 0 && name[b - 1] >= '0' && name[b - 1] <= '9') --b;
      digits = std::string_view(name).substr(b, e - b);
      if (digits.empty()) return std::nullopt;
    }
    uint64_t v = 0;
    const auto r = std::from_chars(digits.data(), digits.data() + digits.size(), v);
    if (r.ec != std::errc()) return std::nullopt;
    return v;
  }
};

// The files of a numbered series, sorted by their number; a number that two files share is an error (ambiguous).
std::vector<std::pair<uint64_t, std::string>> numbered_files(const std::string& pattern) {
  const fs::path p(pattern);
  const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
  const std::string name = p.filename().string();
  if (is_series_pattern(dir.string()))
    fail_in(pattern, "only the file name of a numbered series may hold %d, * or ? (the directory must be literal)");
  const NamePattern np = NamePattern::parse(name);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) fail_in(pattern, "directory " + dir.string() + " does not exist");
  std::vector<std::pair<uint64_t, std::string>> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec)) {
    if (!e.is_regular_file(ec)) continue;
    const std::string n = e.path().filename().string();
    if (const auto number = np.match(n)) files.emplace_back(*number, p.has_parent_path() ? (dir / n).string() : n);
  }
  if (ec) fail_in(pattern, "cannot list directory " + dir.string() + ": " + ec.message());
  if (files.empty()) fail_in(pattern, "no file matches the numbered series pattern");
  std::sort(files.begin(), files.end());
  for (size_t i = 1; i < files.size(); ++i)
    if (files[i].first == files[i - 1].first)
      fail_in(pattern, "files " + files[i - 1].second + " and " + files[i].second + " have the same number " +
                           std::to_string(files[i].first));
  return files;
}

TimeSeries list_numbered(const std::string& pattern) {
  TimeSeries s;
  s.kind = SeriesKind::Numbered;
  s.source = pattern;
  for (auto& [number, file] : numbered_files(pattern)) {
    refuse_nested(pattern, file, file);
    s.steps.push_back({double(number), {file}, -1});
  }
  return s;
}

TimeSeries list_plot3d(std::span<const std::string> inputs) {
  TimeSeries s;
  s.kind = SeriesKind::Plot3d;
  s.source = inputs[0];
  s.geometry = SeriesGeometry::Static;
  s.geometry_reason = "one PLOT3D grid file for every solution";
  if (inputs.size() == 2 && names_a_pattern(inputs[1])) {
    for (auto& [number, file] : numbered_files(inputs[1])) s.steps.push_back({double(number), {inputs[0], file}, -1});
    return s;
  }
  for (size_t i = 1; i < inputs.size(); ++i) {
    require_file(inputs[0], "solution " + std::to_string(i - 1), inputs[i]);
    s.steps.push_back({double(i - 1), {inputs[0], inputs[i]}, -1});
  }
  return s;
}

// A multi-step file: one step per time its reader lists (none: the file read as it is).
TimeSeries list_multi_step(SeriesKind kind, const std::string& path, const std::vector<double>& times) {
  TimeSeries s;
  s.kind = times.empty() ? SeriesKind::Single : kind;
  s.source = path;
  if (times.empty()) {
    s.steps.push_back({0, {path}, -1});
    return s;
  }
  for (size_t i = 0; i < times.size(); ++i) s.steps.push_back({times[i], {path}, int64_t(i)});
  return s;
}

template <class T>
uint64_t hash_vector(const std::vector<T>& v) {
  return hash_bytes(v.data(), v.size() * sizeof(T));
}

uint64_t hash_dims(uint64_t h, const GridDims& d) {
  for (uint32_t n : d.points) h = hash_mix(h, n);
  return h;
}

}  // namespace

bool is_series_pattern(std::string_view path) {
  const size_t slash = path.rfind('/');
  const std::string_view name = slash == std::string_view::npos ? path : path.substr(slash + 1);
  if (name.find_first_of("*?") != std::string_view::npos) return true;
  const size_t pc = name.find('%');
  if (pc == std::string_view::npos) return false;
  size_t e = pc + 1;
  while (e < name.size() && name[e] >= '0' && name[e] <= '9') ++e;
  return e < name.size() && name[e] == 'd';
}

bool is_series_input(std::span<const std::string> inputs) {
  if (inputs.size() > 2) return true;  // PLOT3D grid + several solutions
  if (inputs.size() == 2) return names_a_pattern(inputs[1]);
  if (inputs.size() != 1) return false;
  return is_pvd(inputs[0]) || is_series_json(inputs[0]) || names_a_pattern(inputs[0]);
}

TimeSeries list_time_steps(std::span<const std::string> inputs, const ReadOptions& read) {
  if (inputs.empty()) throw Error("no input file given");
  TimeSeries s;
  if (inputs.size() > 2 || (inputs.size() == 2 && names_a_pattern(inputs[1]))) {
    s = list_plot3d(inputs);
  } else if (inputs.size() == 2) {  // PLOT3D grid and one solution
    s.source = inputs[0];
    s.steps.push_back({0, {inputs[0], inputs[1]}, -1});
  } else if (is_pvd(inputs[0])) {
    s = list_pvd(inputs[0]);
  } else if (is_series_json(inputs[0])) {
    s = list_series_json(inputs[0]);
  } else if (names_a_pattern(inputs[0])) {
    s = list_numbered(inputs[0]);
  } else {
    const std::string& path = inputs[0];
    switch (detect_format(inputs)) {
      case InputFormat::Exodus:
        s = list_multi_step(SeriesKind::Exodus, path, list_exodus_times(path));
        s.geometry = SeriesGeometry::Static;
        s.geometry_reason = "Exodus coordinates have no time axis";
        break;
      case InputFormat::Cgns: s = list_multi_step(SeriesKind::Cgns, path, list_cgns_times(path)); break;
      case InputFormat::EnSight: s = list_multi_step(SeriesKind::EnSight, path, list_ensight_times(path)); break;
      case InputFormat::OpenFoam: s = list_multi_step(SeriesKind::OpenFoam, path, list_openfoam_times(path)); break;
      default:
        s.kind = SeriesKind::Single;
        s.source = path;
        s.steps.push_back({0, {path}, -1});
        break;
    }
  }
  if (s.steps.size() == 1 && s.geometry == SeriesGeometry::Detect) {
    s.geometry = SeriesGeometry::Static;
    s.geometry_reason = "one step";
  } else if (s.geometry == SeriesGeometry::Detect) {
    s.geometry_reason = "compared per step (points, cells, structure)";
  }
  s.read = read;
  s.read.time_step = -1;
  return s;
}

Dataset read_time_step(const TimeSeries& series, size_t step) {
  const size_t n = series.steps.size();
  if (step >= n)
    fail_in(series.source, "time step " + std::to_string(step) + " does not exist: the series has " +
                               std::to_string(n) + " step" + (n == 1 ? "" : "s") + " (0.." +
                               std::to_string(n ? n - 1 : 0) + ")");
  const TimeStep& st = series.steps[step];
  ReadOptions read = series.read;
  read.time_step = st.reader_step;
  Dataset ds;
  switch (series.kind) {
    case SeriesKind::Plot3d: ds = read_plot3d(st.files[0], st.files[1]); break;
    case SeriesKind::Pvd:
    case SeriesKind::SeriesJson:
    case SeriesKind::Numbered:
      // Each file one dataset; the parts of a step become its blocks, in the collection's order.
      for (const std::string& f : st.files) {
        Dataset part = read_dataset(std::span<const std::string>(&f, 1), read);
        if (ds.blocks.empty()) {
          ds = std::move(part);
          continue;
        }
        ds.sources.insert(ds.sources.end(), part.sources.begin(), part.sources.end());
        for (Block& b : part.blocks) ds.blocks.push_back(std::move(b));
        ds.warnings.insert(ds.warnings.end(), part.warnings.begin(), part.warnings.end());
      }
      break;
    default: return read_dataset(st.files, read);  // a multi-step file reads its own step and names it
  }
  ds.format += series_step_label(series, step);
  return ds;
}

std::string series_step_label(const TimeSeries& series, size_t step) {
  return ", time step " + std::to_string(step) + " of " + std::to_string(series.size()) +
         " (t = " + fmt_time(series.steps[step].time) + ") of " + base_name(series.source);
}

uint64_t geometry_fingerprint(const Dataset& dataset) {
  uint64_t h = hash_mix(kFnvOffset, dataset.blocks.size());
  for (const Block& b : dataset.blocks) {
    h = hash_mix(h, b.grid.index());
    std::visit(
        [&](const auto& g) {
          using G = std::decay_t<decltype(g)>;
          if constexpr (std::is_same_v<G, UnstructuredMesh>) {
            h = hash_mix(h, hash_vector(g.points));
            h = hash_mix(h, hash_vector(g.cell_types));
            h = hash_mix(h, hash_vector(g.cell_offsets));
            h = hash_mix(h, hash_vector(g.connectivity));
          } else if constexpr (std::is_same_v<G, StructuredGrid>) {
            h = hash_dims(h, g.dims);
            h = hash_mix(h, hash_vector(g.points));
            h = hash_mix(h, hash_vector(g.iblank));
          } else if constexpr (std::is_same_v<G, ImageGrid>) {
            h = hash_dims(h, g.dims);
            for (double v : {g.origin.x, g.origin.y, g.origin.z, g.spacing.x, g.spacing.y, g.spacing.z})
              h = hash_mix(h, hash_bytes(&v, sizeof v));
          } else {
            h = hash_dims(h, g.dims);
            for (const auto& c : g.coords) h = hash_mix(h, hash_vector(c));
          }
        },
        b.grid);
  }
  return h;
}

void write_pvd(const std::string& path, const std::vector<std::pair<double, std::string>>& steps) {
  pugi::xml_document doc;
  pugi::xml_node root = doc.append_child("VTKFile");
  root.append_attribute("type") = "Collection";
  root.append_attribute("version") = "0.1";
  pugi::xml_node collection = root.append_child("Collection");
  for (const auto& [time, file] : steps) {
    pugi::xml_node d = collection.append_child("DataSet");
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", time);
    d.append_attribute("timestep") = buf;
    d.append_attribute("part") = "0";
    d.append_attribute("file") = file.c_str();
  }
  std::ostringstream text;
  doc.save(text, "  ");
  AtomicOutputFile out(path);
  out.write(text.str());
  out.commit();
}

std::vector<uint32_t> parse_step_selection(std::string_view spec, size_t count, std::string_view what) {
  auto fail = [&](const std::string& m) -> void { fail_in(what, m); };
  if (count == 0) fail("the input has no time steps");
  auto number = [&](std::string_view t) -> uint64_t {
    uint64_t v = 0;
    const auto r = std::from_chars(t.data(), t.data() + t.size(), v);
    if (t.empty() || r.ec != std::errc() || r.ptr != t.data() + t.size())
      fail("expected all, N or A:B[:S] with non-negative integers, found \"" + std::string(spec) + "\"");
    return v;
  };
  uint64_t a = 0, b = count - 1, stride = 1;
  if (spec != "all") {
    const size_t c1 = spec.find(':');
    if (c1 == std::string_view::npos) {
      a = b = number(spec);
    } else {
      const size_t c2 = spec.find(':', c1 + 1);
      a = number(spec.substr(0, c1));
      b = number(spec.substr(c1 + 1, c2 == std::string_view::npos ? std::string_view::npos : c2 - c1 - 1));
      if (c2 != std::string_view::npos) stride = number(spec.substr(c2 + 1));
      if (stride == 0) fail("the stride S of A:B:S must be at least 1");
      if (a > b) fail("A:B needs A <= B, found \"" + std::string(spec) + "\"");
    }
    if (b >= count)
      fail("step " + std::to_string(b) + " does not exist: the input has " + std::to_string(count) + " step" +
           (count == 1 ? "" : "s") + " (0.." + std::to_string(count - 1) + ")");
  }
  std::vector<uint32_t> steps;
  for (uint64_t i = a; i <= b; i += stride) steps.push_back(uint32_t(i));
  return steps;
}

}  // namespace ugvr
