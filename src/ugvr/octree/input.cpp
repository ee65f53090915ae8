#include "ugvr/octree/input.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <variant>

#include "ugvr/core/error.h"
#include "ugvr/grid/structured_cells.h"

namespace ugvr {
namespace {

std::string source_of(const Dataset& ds) { return ds.sources.empty() ? std::string("dataset") : ds.sources[0]; }

ScalarRef resolve(const Dataset& ds, const Block& block, const std::string& selector) {
  try {
    return block.fields.scalar(selector);
  } catch (const Error& e) {
    const std::string where = ds.blocks.size() > 1 ? " (block '" + block.name + "')" : "";
    fail_in(source_of(ds), std::string(e.what()) + where);
  }
}

// The selector of the default: the first field that is not constant (default_field_names).
std::vector<std::string> default_selectors(const Dataset& ds, const Block& block) {
  std::vector<std::string> names = default_field_names(block, 1);
  if (names.empty()) fail_in(source_of(ds), "the dataset has no fields to voxelize");
  return names;
}

// Blocks concatenated into one mesh; each selected scalar becomes a 1-component float64 field of the merged block.
std::unique_ptr<Block> merge_blocks(const Dataset& ds, std::span<const std::string> selectors,
                                    std::vector<std::string>& names) {
  auto merged = std::make_unique<Block>();
  merged->name = "merged";
  UnstructuredMesh mesh;
  std::vector<std::vector<double>> values(selectors.size());
  std::vector<Association> associations(selectors.size());
  names.assign(selectors.size(), {});
  for (size_t b = 0; b < ds.blocks.size(); ++b) {
    const Block converted = to_unstructured_block(ds.blocks[b], StructuredCellShape::Hexahedra);
    const auto& m = std::get<UnstructuredMesh>(converted.grid);
    if (m.point_count() + mesh.point_count() > UINT32_MAX) {
      fail_in(source_of(ds), "the merged blocks have more than 2^32-1 points");
    }
    const auto base = uint32_t(mesh.point_count());
    mesh.points.insert(mesh.points.end(), m.points.begin(), m.points.end());
    std::vector<uint32_t> ids;
    for (uint64_t c = 0; c < m.cell_count(); ++c) {
      ids.assign(m.cell(c).begin(), m.cell(c).end());
      for (uint32_t& id : ids) id += base;
      mesh.add_cell(m.cell_types[c], ids);
    }
    for (size_t s = 0; s < selectors.size(); ++s) {
      const ScalarRef ref = resolve(ds, converted, selectors[s]);
      if (b == 0) {
        associations[s] = ref.field->association();
        names[s] = octree_field_name(ref);
      } else if (ref.field->association() != associations[s]) {
        fail_in(source_of(ds), "field '" + selectors[s] + "' is per " + std::string(association_name(associations[s])) +
                                   " in the first block and per " +
                                   std::string(association_name(ref.field->association())) + " in block '" +
                                   converted.name + "'");
      }
      for (uint64_t t = 0; t < ref.field->tuples(); ++t) values[s].push_back(ref.field->scalar(t, ref.component));
    }
  }
  merged->grid = std::move(mesh);
  for (size_t s = 0; s < selectors.size(); ++s) {
    merged->fields.add(Field(names[s], associations[s], DataArray::from(std::move(values[s]), 1)));
  }
  return merged;
}

}  // namespace

std::string octree_field_name(const ScalarRef& scalar) {
  const Field& f = *scalar.field;
  if (f.components() == 1) return f.name();
  if (scalar.component == kMagnitude) return f.name() + ":magnitude";
  if (f.components() <= 3) return f.name() + ":" + "xyz"[scalar.component];
  return f.name() + ":" + std::to_string(scalar.component);
}

std::vector<std::string> default_field_names(const Block& block, size_t max_fields) {
  std::vector<std::string> varying;
  const Field* first = nullptr;
  for (const Field& f : block.fields) {
    if (f.name() == "IBLANK" && f.association() == Association::Vertex) continue;
    if (!first) first = &f;
    if (varying.size() == max_fields) break;
    const Range r = f.range(kMagnitude);
    if (r.max > r.min && std::find(varying.begin(), varying.end(), f.name()) == varying.end())
      varying.push_back(f.name());
  }
  if (varying.empty() && first) varying.push_back(first->name());
  return varying;
}

OctreeInput prepare_octree_input(const Dataset& ds, std::span<const std::string> selectors) {
  if (ds.blocks.empty()) fail_in(source_of(ds), "the dataset has no blocks");
  OctreeInput in;
  std::vector<std::string> chosen(selectors.begin(), selectors.end());
  std::vector<std::string> names;  // store names, when merging renames the fields
  const Block* block = nullptr;
  if (ds.blocks.size() > 1) {
    if (chosen.empty()) chosen = default_selectors(ds, ds.blocks[0]);
    in.owned = merge_blocks(ds, chosen, names);
    block = in.owned.get();
    chosen = names;  // the merged block's fields are named after the store names
  } else if (!std::holds_alternative<UnstructuredMesh>(ds.blocks[0].grid)) {
    in.owned = std::make_unique<Block>(to_unstructured_block(ds.blocks[0], StructuredCellShape::Hexahedra));
    block = in.owned.get();
  } else {
    block = &ds.blocks[0];
  }
  if (chosen.empty()) chosen = default_selectors(ds, *block);
  in.mesh = &std::get<UnstructuredMesh>(block->grid);
  if (in.mesh->cell_count() == 0) fail_in(source_of(ds), "the dataset has no cells to voxelize");
  in.bounds = in.mesh->bounds();
  const Vec3d size = in.bounds.size();
  if (!(std::max(size.x, std::max(size.y, size.z)) > 0) || !std::isfinite(size.x + size.y + size.z)) {
    fail_in(source_of(ds), "the mesh's bounds have no extent (or are not finite): nothing to voxelize");
  }
  for (const std::string& selector : chosen) {
    const ScalarRef ref = resolve(ds, *block, selector);
    const Range r = ref.field->range(ref.component);
    if (r.nan_count > 0) {
      fail_in(source_of(ds), "field '" + octree_field_name(ref) + "' has " + std::to_string(r.nan_count) +
                                 " NaN value(s); bricks cannot store them");
    }
    if (!std::isfinite(r.min) || !std::isfinite(r.max)) {
      fail_in(source_of(ds), "field '" + octree_field_name(ref) + "' has infinite values; bricks cannot store them");
    }
    BrickStoreField f;
    f.name = names.empty() ? octree_field_name(ref) : ref.field->name();
    f.association = ref.field->association();
    f.min = r.min, f.max = r.max;
    for (const BrickStoreField& other : in.fields) {
      if (other.name == f.name) fail_in(source_of(ds), "field '" + f.name + "' is selected twice");
    }
    in.scalars.push_back(ref);
    in.fields.push_back(std::move(f));
  }
  return in;
}

}  // namespace ugvr
