// A coarse preview of an out-of-core build (the [first-image] issue 24): levels 0 .. K of the octree, every node
// there is data, sampled in one streaming pass over the cell soup (octree/soup.h) as soon as it is written, and
// written as a complete brick store that a viewer can show while the real build (octree/out_of_core.h) goes on for
// many minutes.
//
// Why this gives the final store's samples. Every node of a store holds the exact field at its lattice points
// (octree/downsample.h: interior bricks are subsamples of their children), so a level-K node's samples are what the
// brick sampler (octree/brick_sampler.h) gives at its lattice over the whole mesh, whatever the tree looks like below
// it. The soup is streamed in chunks of cells in id order; each chunk is welded into a small mesh (weld_soup_records:
// vertices by id, cells in id order) and samples the level-K nodes its cells overlap (bounding boxes widened by
// kOverlapMargin x the cell's diagonal, as the builder routes cells), and a sample keeps the first chunk that finds
// it in a cell. Within a chunk that is the sampler's own rule; across chunks, the lowest id holding the point within
// the sampler's tolerance is the first chunk's, which is the sampler's rule for a point that no cell holds well
// inside (a point on a shared face). A point that one cell holds well inside (at least interior_margin deep) lies in
// no other cell of a conforming mesh with neighbours of similar size (within interior_margin / tolerance = 1000x),
// so there too one chunk alone finds it. Samples found by two chunks are counted (CoarsePreviewStats::shared
// samples): they are the ones a nonconforming or overlapping mesh could give differently. Levels K - 1 .. 0 are then
// subsampled from level K exactly as the builder does (pad, downsample_children, pad), so every valid sample and mask
// of every preview node equals the final store's node at the same place, bit for bit for cells whose map is affine
// (tetrahedra, parallelepipeds: closed-form inverse) and for every sample on a brick border; inside a brick of
// non-affine cells Newton may start from another neighbour's prediction and end within the sampler's 1e-12, which
// float32 rounds the same nearly always: tests/test_coarse_preview.cpp found no sample differing on a mesh of prisms,
// pyramids, tetrahedra and hexahedra (on tetrahedra it finds 66 if a later chunk is let win instead). The padding of
// invalid samples (store/brick_pad.h) may differ where the final node is a leaf or an interior node of another shape:
// it is filler for the renderer's filtering, not data.
//
// What the preview store holds (the brick store format, unchanged): nodes of levels 0 .. K that hold data (a level-K
// node with a valid sample, and the ancestors of those), node ids breadth first; no boundary faces (the renderer
// then uses the stencil's boundary) and no transfer-function error table. Errors: a preview node is not a leaf of the
// real tree, so its error is unknown; each node claims the field's whole range (max and rms), the largest error any
// value inside the range can have, so that the time-critical cut refines it whenever it can and never takes it for
// exact. The provenance record is the build's.
//
// Cost: one pass over the soup, R³ samples per level-K node with data, once per chunk that overlaps the node (the
// chunk's other cells are not tested: samples outside a chunk's cells end in empty buckets). Memory: the level-K
// bricks, 8^K x R³ x (4F + 1) bytes at most (F fields; K = 3, R = 32, F = 1: 80 MiB), the coarser ones (a seventh
// of that), and one chunk of records with the sampler's working memory (about 10 times the records).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "ugvr/core/progress.h"
#include "ugvr/grid/dataset.h"
#include "ugvr/octree/brick_sampler.h"
#include "ugvr/octree/soup.h"
#include "ugvr/octree/vtu_cells.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {

// Soup records welded back into a mesh: vertices by their ids, cells in the order of their ids (so that the sampler's
// tie rule, the lowest cell id, means the lowest input id), each selected scalar a float field of it.
struct WeldedSoup {
  UnstructuredMesh mesh;
  FieldSet fields;
  std::vector<ScalarRef> refs;  // one per store field, in the store's order
  std::vector<uint64_t> cells;  // 0 .. cell count - 1
  std::vector<uint64_t> ids;    // per cell: its id in the input
};

// `records`: whole records of `layout` back to back (any order). `slots[f]` says where store field f sits in them,
// `fields[f]` names it.
std::unique_ptr<WeldedSoup> weld_soup_records(std::span<const std::byte> records, const SoupLayout& layout,
                                              std::span<const VtuCellSource::Slot> slots,
                                              std::span<const BrickStoreField> fields);

struct CoarsePreviewOptions {
  int depth = 2;                  // K: levels 0 .. K (1 .. kMaxPreviewDepth)
  size_t chunk_bytes = 64 << 20;  // records per chunk (at least one record)
  int threads = 0;                // 0: the current task arena's
  BrickSamplerOptions sampler;
  Progress::Observer progress;  // "coarse preview", the fraction of the soup's cells done
};

inline constexpr int kMaxPreviewDepth = 4;

struct CoarsePreviewStats {
  int depth = 0;
  uint64_t cells = 0;  // records streamed
  uint64_t chunks = 0;
  uint64_t nodes = 0, bricks = 0;
  uint64_t sampled = 0;         // level-K lattices sampled (a node once per chunk that overlaps it)
  uint64_t shared_samples = 0;  // valid in more than one chunk (the first kept; see the header comment)
  uint64_t store_bytes = 0;
  double seconds = 0;
};

// The preview's bytes in memory for `depth`, resolution and fields: the level-K bricks and the coarser ones.
uint64_t coarse_preview_brick_bytes(int depth, uint32_t resolution, uint32_t fields);

// The deepest preview (1 .. 3) whose bricks take at most an eighth of `memory_budget`; 0 when even depth 1 does not
// fit.
int coarse_preview_depth_for(uint64_t memory_budget, uint32_t resolution, uint32_t fields);

// Writes the store of levels 0 .. K from the level-K bricks (`deepest`: 8^K slots, place i + 2^K (j + 2^K k), null
// where a node has no data), as the preview does: the nodes with data and their ancestors, ids breadth first; each
// brick padded, levels K - 1 .. 0 subsampled as the builder does; every node's error the field's whole range (never
// taken for exact). Returns the node count. Shared by the preview and the point sketch (octree/point_sketch.h).
uint64_t write_level_store(std::vector<std::unique_ptr<BrickSamples>> deepest, int K, const BrickStoreLayout& layout,
                           const std::string& path);

// Streams the soup at `soup_path` (records in nondecreasing id order, as the out-of-core build writes its root file)
// and writes the preview of the octree over `lattice` to `path` as a store of `layout` (atomically: nothing is left
// at `path` on failure). `slots` as weld_soup_records takes them. Throws ugvr::Error for a bad depth, a soup out of id
// order (naming the file) or a failed write; a progress observer's exception stops it the same way.
CoarsePreviewStats write_coarse_preview(const std::string& soup_path, const SoupLayout& soup_layout,
                                        std::span<const VtuCellSource::Slot> slots, const BrickLattice& lattice,
                                        const BrickStoreLayout& layout, const CoarsePreviewOptions& options,
                                        const std::string& path);

}  // namespace ugvr
