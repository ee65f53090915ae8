// What a store's boundary faces (format version 4, octree/boundary_faces.h) cost and cover:
//   bench_boundary_faces STORE.ugvr [CAMERA.json TF.json CUT]
// prints one JSON line: the store's bytes and the section's (node entries, references, triangles), the triangles, the
// nodes the boundary crosses, how many of them list their faces and how many are over the cap (the stencil decides
// there), for all nodes and for the leaves; with a camera, a transfer function and a cut spec (as `ugvr render
// --save-camera / --save-tf` write them), also for that cut's nodes (512², the render command's defaults).
#include <algorithm>
#include <cstdio>
#include <string>

#include "ugvr/render/camera.h"
#include "ugvr/render/lod/lod_cut.h"
#include "ugvr/render/transfer_function.h"
#include "ugvr/store/brick_store.h"

using namespace ugvr;

int main(int argc, char** argv) {
  if (argc != 2 && argc != 5) {
    std::fprintf(stderr, "usage: bench_boundary_faces STORE.ugvr [CAMERA.json TF.json CUT]\n");
    return 2;
  }
  const BrickStoreReader store(argv[1]);
  const StoreBoundary& b = store.boundary();
  struct Count {
    uint64_t crossed = 0, listed = 0, overflow = 0, max_listed = 0, nodes = 0;
    void add(const store_format::BoundaryNodeEntry& e) {
      ++nodes;
      if (e.count == store_format::kBoundaryOverflow) {
        ++crossed, ++overflow;
      } else if (e.count > 0) {
        ++crossed, ++listed;
        max_listed = std::max<uint64_t>(max_listed, e.count);
      }
    }
    std::string json() const {
      char s[256];
      std::snprintf(s, sizeof s,
                    "{\"nodes\":%llu,\"crossed\":%llu,\"listed\":%llu,\"overflow\":%llu,\"max_listed\":%llu}",
                    (unsigned long long)nodes, (unsigned long long)crossed, (unsigned long long)listed,
                    (unsigned long long)overflow, (unsigned long long)max_listed);
      return s;
    }
  } all, leaves, cut;
  for (uint64_t id = 0; id < std::min<uint64_t>(b.nodes.size(), store.node_count()); ++id) {
    all.add(b.nodes[id]);
    if (store.node(id).is_leaf()) leaves.add(b.nodes[id]);
  }
  std::string cut_json = "null";
  if (argc == 5 && store.has_boundary()) {
    const Camera camera = read_camera(argv[2]);
    const TransferFunction tf = read_paraview_preset(argv[3]);
    const Cut c = select_cut(store, parse_cut_spec(argv[4]), camera, 512, 512, tf);
    for (uint64_t id : c.nodes) cut.add(b.nodes[id]);
    cut_json = cut.json();
  }
  std::printf(
      "{\"bench\":\"boundary_faces\",\"store\":\"%s\",\"store_bytes\":%llu,\"section_bytes\":%llu,\"triangles\":%zu,"
      "\"references\":%zu,\"max_per_node\":%u,\"virtual_nodes\":%llu,\"all\":%s,\"leaves\":%s,\"cut\":%s}\n",
      argv[1], (unsigned long long)store.file_size(), (unsigned long long)b.bytes(), b.triangles.size(), b.refs.size(),
      b.max_per_node, (unsigned long long)(b.nodes.size() - std::min<uint64_t>(b.nodes.size(), store.node_count())),
      all.json().c_str(), leaves.json().c_str(), cut_json.c_str());
  return 0;
}
