// Partitioned stores (`ugvr build --pieces N`, docs/mpi.md "Partitioned stores"): the index file that names the
// pieces, their boxes and the kd-tree that made them.
//
// The index is a small JSON file (written atomically: temporary + rename), keys in this order:
//   format   "ugvr-pieces" (how `ugvr render` / `ugvr info` recognise a .json input as an index)
//   version  1 (kPieceIndexVersion; a reader refuses other versions)
//   bounds   {"lo": [x, y, z], "hi": [x, y, z]}: the whole dataset's bounds (every piece's store records these too)
//   root     the octree's root cube, the same in every piece (so their lattices line up)
//   brick    samples per brick axis
//   ghost_margin  the ghost layer's width (world units): a piece holds the cells whose bounding box meets its box
//                 grown by this much on every side
//   ghost_level   the coarsest octree level whose samples inside a piece's box are the whole store's (0: all)
//   fields   [{"name", "association": "vertex"|"cell", "min", "max"}]: global ranges, the same in every piece's
//            store, so every piece quantises and colours alike
//   tree     the kd-tree's nodes, root first: {"axis": 0|1|2, "split": s, "child": [a, b]} (below `split` on `axis`
//            goes to child a) or, for a leaf, {"piece": k}
//   pieces   [{"store": "NAME.d/piece-K.ugvr" (relative to the index's folder), "box": {"lo", "hi"} (the kd cell:
//            half-open, faces on the outside of the tree null = unbounded), "cells" (owned: centroid in the box),
//            "ghost_cells" (held beyond those), "store_bytes"}]
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "ugvr/core/vec.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

inline constexpr int kPieceIndexVersion = 1;
inline constexpr int kMaxPieces = 4096;

struct PieceInfo {
  std::string store;  // as written in the index: relative to the index's folder (or absolute)
  Bounds box;         // the kd cell (infinite faces outside the tree)
  uint64_t cells = 0, ghost_cells = 0, store_bytes = 0;
};

struct PieceIndex {
  std::string path;  // the index file (set by read_piece_index; stores resolve against its folder)
  Bounds bounds, root;
  uint32_t brick = 32;
  double ghost_margin = 0;
  int ghost_level = 0;
  std::vector<BrickStoreField> fields;
  KdTree tree;  // tree.boxes[k] == pieces[k].box
  std::vector<PieceInfo> pieces;

  int count() const { return int(pieces.size()); }
  // Piece k's store file, resolved against the index's folder.
  std::string store_path(int k) const;
};

// True for a file named *.json whose first bytes hold the index's "format" key (nothing else is read).
bool is_piece_index(const std::string& path);

// Reads and validates an index; throws ugvr::Error naming the file and what is wrong (bad JSON, another version, a
// tree that does not cover the pieces, a piece store that is missing).
PieceIndex read_piece_index(const std::string& path);
// Writes `index` to `path` atomically.
void write_piece_index(const std::string& path, const PieceIndex& index);

// N a power of two in [1, kMaxPieces]; throws ugvr::Error naming --pieces otherwise.
void check_piece_count(int pieces);

// The kd-tree cut after its top log2(groups) levels: group g is the subtree holding pieces
// [g * N/groups, (g + 1) * N/groups) (a kd subtree, so the union of its boxes is the group's box), which is what rank g
// of `groups` renders. `groups` must divide N and be a power of two (throws ugvr::Error otherwise).
KdTree group_tree(const KdTree& tree, int groups);

}  // namespace ugvr
