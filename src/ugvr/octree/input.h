// What the octree builder voxelizes: one unstructured mesh and the scalars chosen from a dataset, each with the name,
// association and value range the brick store records (store/brick_store.h).
//
// Structured blocks become hexahedra (structured_cells.h), not tetrahedra: the sampler interpolates hexahedra
// trilinearly, which is the structured grid's own interpolant, and the split criterion and the error measure look at
// vertices, which a tetrahedral split would not change. IBLANK-ed cells are dropped by that conversion, so the holes
// they leave hold no data. Several blocks are merged into one mesh (points appended, nothing welded): the builder
// needs no connectivity between cells.
#pragma once

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

struct OctreeInput {
  // The block the mesh and the scalars live in when the dataset's own could not be used as it is (structured, or
  // several blocks); null when they point into the dataset, which must then outlive this.
  std::unique_ptr<Block> owned;
  const UnstructuredMesh* mesh = nullptr;
  std::vector<ScalarRef> scalars;
  std::vector<BrickStoreField> fields;  // one per scalar, same order
  Bounds bounds;                        // of the mesh's points
};

// `selectors` as FieldSet::scalar takes them ("NAME", "NAME:x", "NAME:magnitude"); empty: the dataset's first field
// that is not constant (vectors by magnitude), skipping the IBLANK a structured conversion adds. Throws ugvr::Error
// naming the dataset's file for a field it lacks, a field with NaN values (a brick cannot store them), an empty mesh or
// one without volume.
OctreeInput prepare_octree_input(const Dataset& dataset, std::span<const std::string> selectors);

// The fields voxelized when none are named: those of `block` that are not constant (vectors by magnitude; a constant
// field, such as the oxygen post's density or spx's material, gives a one-node tree), in the block's order, at most
// `max_fields`, without the IBLANK a structured conversion appends; all constant: the first. Empty: no fields.
std::vector<std::string> default_field_names(const Block& block, size_t max_fields);

// The name a scalar gets in the store: the field's own name for a 1-component field, else "NAME:x|y|z|k" or
// "NAME:magnitude" (docs/brick-store.md).
std::string octree_field_name(const ScalarRef& scalar);

}  // namespace ugvr
