#include "ugvr/mpi/piece_build.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>

#include "ugvr/core/error.h"
#include "ugvr/mpi/mesh_part.h"

namespace ugvr {
namespace {

// Calls f(piece) for every piece whose closed box meets `b` (a cell's bounding box already grown by the margin).
template <class F>
void for_each_piece_meeting(const KdTree& tree, int node, const Bounds& b, F&& f) {
  const KdNode& n = tree.nodes[size_t(node)];
  if (n.axis < 0) {
    f(n.part);
    return;
  }
  if (b.lo[n.axis] <= n.split) for_each_piece_meeting(tree, n.child[0], b, f);
  if (b.hi[n.axis] >= n.split) for_each_piece_meeting(tree, n.child[1], b, f);
}

Bounds grown(Bounds b, double margin) {
  b.lo = b.lo - Vec3d{margin, margin, margin};
  b.hi = b.hi + Vec3d{margin, margin, margin};
  return b;
}

}  // namespace

PiecePlan plan_frame(const Bounds& bounds, uint32_t resolution, int ghost_level) {
  if (ghost_level < 0 || ghost_level > kMaxOctreeLevel)
    throw Error("--ghost-level must be between 0 and " + std::to_string(kMaxOctreeLevel) + " (got " +
                std::to_string(ghost_level) + ")");
  PiecePlan plan;
  plan.bounds = bounds;
  plan.root = octree_root(bounds);
  plan.ghost_level = ghost_level;
  plan.ghost_margin = std::ldexp(2 * plan.root.size().x / double(resolution - 1), -ghost_level);
  return plan;
}

bool piece_holds(const PiecePlan& plan, int k, const Bounds& cell) {
  const Bounds& box = plan.tree.boxes[size_t(k)];
  const Bounds b = grown(cell, plan.ghost_margin);
  return b.lo.x <= box.hi.x && b.hi.x >= box.lo.x && b.lo.y <= box.hi.y && b.hi.y >= box.lo.y && b.lo.z <= box.hi.z &&
         b.hi.z >= box.lo.z;
}

PiecePlan plan_pieces(const OctreeInput& input, int pieces, uint32_t resolution, int ghost_level, const KdTree* tree) {
  check_piece_count(pieces);
  const UnstructuredMesh& mesh = *input.mesh;
  PiecePlan plan = plan_frame(input.bounds, resolution, ghost_level);
  if (tree) {
    if (tree->parts() != pieces)
      throw Error("internal: a given kd-tree of " + std::to_string(tree->parts()) + " boxes for " +
                  std::to_string(pieces) + " pieces");
    plan.tree = *tree;
  } else {
    std::vector<Vec3d> centroids(mesh.cell_count());
    tbb::parallel_for(uint64_t(0), mesh.cell_count(), [&](uint64_t c) { centroids[c] = cell_centroid(mesh, c); });
    plan.tree = build_kd_tree(std::move(centroids), pieces);
  }
  std::vector<std::atomic<uint64_t>> owned(static_cast<size_t>(pieces)), held(static_cast<size_t>(pieces));
  tbb::parallel_for(uint64_t(0), mesh.cell_count(), [&](uint64_t c) {
    owned[size_t(plan.tree.part_of(cell_centroid(mesh, c)))].fetch_add(1, std::memory_order_relaxed);
    for_each_piece_meeting(plan.tree, 0, grown(cell_bounds(mesh, c), plan.ghost_margin),
                           [&](int k) { held[size_t(k)].fetch_add(1, std::memory_order_relaxed); });
  });
  for (int k = 0; k < pieces; ++k) {
    plan.cells.push_back(owned[size_t(k)].load());
    plan.ghost_cells.push_back(held[size_t(k)].load() - owned[size_t(k)].load());
  }
  return plan;
}

std::vector<uint64_t> piece_cells(const OctreeInput& input, const PiecePlan& plan, int k) {
  const UnstructuredMesh& mesh = *input.mesh;
  if (k < 0 || k >= plan.tree.parts()) throw Error("internal: piece " + std::to_string(k) + " is not in the plan");
  std::vector<uint64_t> out;
  for (uint64_t c = 0; c < mesh.cell_count(); ++c)
    if (piece_holds(plan, k, cell_bounds(mesh, c))) out.push_back(c);
  return out;
}

OctreeBuildStats build_piece(const OctreeInput& input, const PiecePlan& plan, int k, const OctreeBuildOptions& options,
                             const std::string& path) {
  const UnstructuredMesh& mesh = *input.mesh;
  const std::vector<uint64_t> cells = piece_cells(input, plan, k);
  // The piece's mesh: its cells in id order, their vertices renumbered in id order; each scalar as a 1-component
  // field of the values the whole mesh's scalar gives (magnitudes computed by the same function), so the sampler
  // reads the very same numbers.
  OctreeInput piece;
  piece.owned = std::make_unique<Block>();
  UnstructuredMesh sub;
  std::vector<uint32_t> new_id(mesh.point_count(), UINT32_MAX);
  std::vector<uint32_t> old_point;
  std::vector<uint32_t> ids;
  for (uint64_t c : cells) {
    ids.clear();
    for (uint32_t v : mesh.cell(c)) {
      if (new_id[v] == UINT32_MAX) {
        new_id[v] = uint32_t(old_point.size());
        old_point.push_back(v);
      }
      ids.push_back(new_id[v]);
    }
    sub.add_cell(mesh.cell_types[c], ids);
  }
  // Vertices in id order (renumbered again), so that nothing depends on the order cells met them.
  std::vector<uint32_t> order(old_point);
  std::sort(order.begin(), order.end());
  for (size_t i = 0; i < order.size(); ++i) new_id[order[i]] = uint32_t(i);
  for (uint32_t& v : sub.connectivity) v = new_id[old_point[v]];
  sub.points.reserve(order.size());
  for (uint32_t v : order) sub.points.push_back(mesh.points[v]);
  for (size_t s = 0; s < input.scalars.size(); ++s) {
    const ScalarRef& ref = input.scalars[s];
    std::vector<double> values;
    if (ref.field->association() == Association::Vertex) {
      values.reserve(order.size());
      for (uint32_t v : order) values.push_back(ref.field->scalar(v, ref.component));
    } else {
      values.reserve(cells.size());
      for (uint64_t c : cells) values.push_back(ref.field->scalar(c, ref.component));
    }
    piece.owned->fields.add(
        Field(input.fields[s].name, ref.field->association(), DataArray::from(std::move(values), 1)));
  }
  piece.owned->grid = std::move(sub);
  piece.mesh = &std::get<UnstructuredMesh>(piece.owned->grid);
  for (size_t s = 0; s < input.scalars.size(); ++s) piece.scalars.push_back({&piece.owned->fields[s], kMagnitude});
  piece.fields = input.fields;  // the global names and ranges
  piece.bounds = input.bounds;  // the global root cube and bounds
  if (piece.mesh->cell_count() == 0)
    fail_in(path, "piece " + std::to_string(k) + " holds no cells (more pieces than the mesh can fill)");
  return build_octree(piece, options, path);
}

std::string piece_folder(const std::string& index_path) {
  std::filesystem::path p(index_path);
  return (p.parent_path() / (p.stem().string() + ".d")).string();
}

std::string piece_store_name(const std::string& index_path, int k) {
  return (std::filesystem::path(std::filesystem::path(index_path).stem().string() + ".d") /
          ("piece-" + std::to_string(k) + ".ugvr"))
      .string();
}

PieceIndex make_piece_index(const OctreeInput& input, const PiecePlan& plan, const std::string& index_path,
                            uint32_t resolution) {
  return make_piece_index(input.fields, plan, index_path, resolution);
}

PieceIndex make_piece_index(const std::vector<BrickStoreField>& fields, const PiecePlan& plan,
                            const std::string& index_path, uint32_t resolution) {
  PieceIndex index;
  index.path = index_path;
  index.bounds = plan.bounds;
  index.root = plan.root;
  index.brick = resolution;
  index.ghost_margin = plan.ghost_margin;
  index.ghost_level = plan.ghost_level;
  index.fields = fields;
  index.tree = plan.tree;
  for (int k = 0; k < plan.tree.parts(); ++k) {
    PieceInfo p;
    p.store = piece_store_name(index_path, k);
    p.box = plan.tree.boxes[size_t(k)];
    p.cells = plan.cells[size_t(k)];
    p.ghost_cells = plan.ghost_cells[size_t(k)];
    index.pieces.push_back(std::move(p));
    index.pieces.back().store_bytes = std::filesystem::file_size(index.store_path(k));
  }
  return index;
}

}  // namespace ugvr
