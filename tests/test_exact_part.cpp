// A rank's part of the mesh (ExactEngine::restrict_to_box, restrict_walk_mesh; docs/mpi.md): rendering only the
// cells that meet a kd box, entering at the faces where the mesh was cut, draws what the whole mesh clipped to that
// box draws, with fewer cells, and keeps the whole mesh's field range and bounds.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "ugvr/core/error.h"
#include "ugvr/gen/generator.h"
#include "ugvr/mpi/kd_partition.h"
#include "ugvr/render/exact/exact_engine.h"
#include "ugvr/render/exact/walk_mesh.h"
#include "ugvr/render/transfer_function.h"

namespace ugvr {
namespace {

const Dataset& mixed_mesh() {
  static const Dataset dataset = [] {
    GenerateOptions options;
    options.cells = 2000;
    options.kind = GenCellKind::Mixed;
    return generate_in_memory(options);
  }();
  return dataset;
}

float max_difference(const Image& a, const Image& b) {
  float d = 0;
  for (size_t i = 0; i < a.rgba.size(); ++i) d = std::max(d, std::abs(a.rgba[i] - b.rgba[i]));
  return d;
}

float max_alpha(const Image& a) {
  float m = 0;
  for (size_t i = 3; i < a.rgba.size(); i += 4) m = std::max(m, a.rgba[i]);
  return m;
}

TEST(ExactPart, APartDrawsWhatTheWholeMeshDrawsInItsBox) {
  const Dataset& ds = mixed_mesh();
  ExactEngine whole(ds);
  const KdTree tree = build_kd_tree(cell_centroids(whole.walk_mesh()), 4);
  for (const char* field : {"pressure", "wall_distance"}) {  // per vertex, per cell
    whole.set_field(ds, field);
    TransferFunction tf = builtin_preset("viridis");
    tf.rescale(whole.field_min(), whole.field_max());
    tf.opacity_unit_distance = length(ds.bounds().size()) / 20;
    RenderSettings settings;
    settings.width = settings.height = 64;
    settings.early_termination_opacity = 1;
    settings.background = {0, 0, 0, 0};
    for (const char* view : {"iso", "+x", "-z"}) {
      const Camera camera = camera_preset(view, ds.bounds());
      for (int b = 0; b < tree.parts(); ++b) {
        const Bounds& box = tree.boxes[size_t(b)];
        whole.set_clip_box(box);
        const Image expected = whole.render(camera, tf, settings);
        ExactEngine part(ds);
        if (b % 2) part.set_field(ds, field);  // bound before the restriction: the values are gathered
        part.restrict_to_box(box);
        if (b % 2 == 0) part.set_field(ds, field);  // bound after: read in the source numbering, then gathered
        ASSERT_TRUE(part.clip_box().has_value());
        EXPECT_LT(part.cell_count(), whole.cell_count() * 3 / 4) << "box " << b;
        EXPECT_LT(part.point_count(), whole.point_count());
        EXPECT_EQ(part.field_min(), whole.field_min());
        EXPECT_EQ(part.field_max(), whole.field_max());
        EXPECT_EQ(part.bounds().lo, whole.bounds().lo);
        EXPECT_EQ(part.bounds().hi, whole.bounds().hi);
        ExactRenderStats stats;
        const Image got = part.render(camera, tf, settings, &stats);
        EXPECT_EQ(stats.lost_rays, 0u);
        EXPECT_GT(max_alpha(expected), 0.05f) << field << " " << view << " box " << b << ": nothing drawn";
        EXPECT_LE(max_difference(got, expected), 1e-5f) << field << " " << view << " box " << b;
      }
    }
  }
}

TEST(ExactPart, TheCutFacesBecomeBoundary) {
  const Dataset& ds = mixed_mesh();
  ExactEngine whole(ds);
  const WalkMesh& m = whole.walk_mesh();
  const KdTree tree = build_kd_tree(cell_centroids(m), 2);
  const WalkMeshPart part = restrict_walk_mesh(m, tree.boxes[0]);
  const WalkMesh& p = part.mesh;
  ASSERT_GT(p.cell_count(), 0u);
  EXPECT_GT(p.boundary.size(), 0u);
  // Every kept cell's face: across a kept cell it points to that cell's new index (same local face); across a
  // dropped cell or the mesh's boundary it is boundary; and the part has more boundary than its share of the mesh's.
  uint64_t cut = 0;
  for (uint32_t c = 0; c < p.cell_count(); ++c) {
    const int k = p.type_index(c);
    const uint32_t old = part.cell_source[c];
    ASSERT_EQ(m.type_index(old), k);
    for (int f = 0; f < cell_face_count(kAllCellTypes[k]); ++f) {
      const uint32_t nb = p.cell_neighbors(c, k)[f], nb_old = m.cell_neighbors(old, k)[f];
      if (nb == kWalkBoundary) {
        cut += nb_old != kWalkBoundary;
        continue;
      }
      ASSERT_NE(nb_old, kWalkBoundary);
      EXPECT_EQ(part.cell_source[nb >> 3], nb_old >> 3);
      EXPECT_EQ(nb & 7, nb_old & 7);
    }
    for (int i = 0; i < cell_vertex_count(kAllCellTypes[k]); ++i)
      EXPECT_EQ(part.point_source[p.cell_vertices(c, k)[i]], m.cell_vertices(old, k)[i]);
  }
  EXPECT_GT(cut, 0u);
  ExactEngine twice(ds);
  twice.restrict_to_box(tree.boxes[0]);
  EXPECT_THROW(twice.restrict_to_box(tree.boxes[1]), Error);
}

}  // namespace
}  // namespace ugvr
