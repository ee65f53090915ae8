// The GPU tier's slot table (render/lod/brick_residency.h): pure bookkeeping, no OpenGL.
#include <gtest/gtest.h>

#include <vector>

#include "ugvr/core/error.h"
#include "ugvr/render/lod/brick_residency.h"
#include "ugvr/store/brick_store.h"

namespace ugvr {
namespace {

// Begins a frame drawing `nodes` and places every missing brick where the plan says, as the engine does after its
// uploads; returns the plan.
BrickSlotTable::Plan draw(BrickSlotTable& table, const std::vector<uint64_t>& nodes) {
  BrickSlotTable::Plan plan = table.begin_frame(nodes);
  EXPECT_EQ(plan.missing.size(), plan.slots.size());
  for (size_t i = 0; i < plan.missing.size(); ++i) table.place(plan.missing[i], plan.slots[i]);
  return plan;
}

TEST(BrickResidency, FreeSlotsFillInOrder) {
  BrickSlotTable table;
  table.reset(4);
  EXPECT_EQ(table.capacity(), 4u);
  const BrickSlotTable::Plan plan = draw(table, {10, 11, 12});
  EXPECT_EQ(plan.missing, (std::vector<uint64_t>{10, 11, 12}));
  EXPECT_EQ(plan.slots, (std::vector<uint64_t>{0, 1, 2}));
  EXPECT_EQ(table.slot(11), 1u);
  EXPECT_EQ(table.owner(2), 12u);
  EXPECT_EQ(table.owner(3), kNoNode);
  EXPECT_EQ(table.slot(99), BrickSlotTable::kNoSlot);
  EXPECT_EQ(table.size(), 3u);
}

TEST(BrickResidency, ResidentNodesKeepTheirSlots) {
  BrickSlotTable table;
  table.reset(4);
  draw(table, {10, 11, 12});
  // 11 and 12 stay; 13 takes the free slot, not 10's.
  const BrickSlotTable::Plan plan = draw(table, {12, 13, 11});
  EXPECT_EQ(plan.missing, (std::vector<uint64_t>{13}));
  EXPECT_EQ(plan.slots, (std::vector<uint64_t>{3}));
  EXPECT_EQ(table.slot(11), 1u);
  EXPECT_EQ(table.slot(12), 2u);
  EXPECT_TRUE(table.contains(10));  // not drawn, still resident
  // A frame of resident nodes only uploads nothing.
  EXPECT_TRUE(draw(table, {10, 11, 12, 13}).missing.empty());
}

TEST(BrickResidency, EvictsTheLeastRecentlyDrawnFirst) {
  BrickSlotTable table;
  table.reset(4);
  draw(table, {10, 11, 12, 13});  // frame 1: slots 0..3
  draw(table, {12});              // frame 2
  draw(table, {10, 13});          // frame 3
  // Oldest: 11 (frame 1, slot 1), then 12 (frame 2, slot 2); 10 and 13 are drawn this frame.
  BrickSlotTable::Plan plan = draw(table, {10, 13, 20, 21});
  EXPECT_EQ(plan.slots, (std::vector<uint64_t>{1, 2}));
  EXPECT_EQ(table.slot(20), 1u);
  EXPECT_EQ(table.slot(21), 2u);
  EXPECT_FALSE(table.contains(11));
  EXPECT_FALSE(table.contains(12));
  // Equally old slots go in slot order.
  plan = draw(table, {30, 31});
  EXPECT_EQ(plan.slots, (std::vector<uint64_t>{0, 1}));
}

TEST(BrickResidency, NothingEvictedBeforeItsUpload) {
  BrickSlotTable table;
  table.reset(2);
  draw(table, {10, 11});
  const BrickSlotTable::Plan plan = table.begin_frame(std::vector<uint64_t>{20, 21});
  EXPECT_EQ(plan.slots, (std::vector<uint64_t>{0, 1}));
  // An upload that failed after the first brick: the second slot keeps its brick.
  table.place(20, plan.slots[0]);
  EXPECT_FALSE(table.contains(10));
  EXPECT_EQ(table.slot(11), 1u);
}

TEST(BrickResidency, CutLargerThanTheAtlasIsRefused) {
  BrickSlotTable table;
  table.reset(3);
  EXPECT_THROW(table.begin_frame(std::vector<uint64_t>{1, 2, 3, 4}), Error);
  // Resident nodes of the frame count against it too: 2 drawn + 2 missing > 3.
  BrickSlotTable other;
  other.reset(3);
  draw(other, {1, 2});
  EXPECT_THROW(other.begin_frame(std::vector<uint64_t>{1, 2, 3, 4}), Error);
  EXPECT_THROW(other.place(5, 3), Error);
}

TEST(BrickResidency, FieldChangeAndNewAtlasEmptyTheTable) {
  BrickSlotTable table;
  table.reset(4);
  draw(table, {10, 11});
  table.clear();  // the engine's field changed
  EXPECT_EQ(table.capacity(), 4u);
  EXPECT_EQ(table.size(), 0u);
  EXPECT_FALSE(table.contains(10));
  EXPECT_EQ(table.owner(0), kNoNode);
  // Every slot is free again: filled in order, as in a new atlas.
  EXPECT_EQ(draw(table, {11, 12}).slots, (std::vector<uint64_t>{0, 1}));
  table.reset(8);  // the cut outgrew the atlas: a new, empty one
  EXPECT_EQ(table.capacity(), 8u);
  EXPECT_FALSE(table.contains(11));
  EXPECT_EQ(draw(table, {11}).slots, (std::vector<uint64_t>{0}));
}

}  // namespace
}  // namespace ugvr
