// Where a node's brick is, for the level-of-detail runtime: on the GPU (a slot of the engine's atlas), in RAM (the
// session's BrickCache, background reads) or only on disk (the brick store), and the moves between these tiers.
//
// Two parts:
//  - BrickSlotTable, the GPU tier's bookkeeping without OpenGL: which atlas slot holds which node's brick, and when
//  each
//    slot was last drawn. A frame keeps resident bricks where they are and puts the missing ones into free slots first,
//    then into the slots drawn least recently. One table per atlas: the engine (lod_engine.h) owns it with the atlas
//    texture (brick_atlas.h), and every session drawing with that engine shares it (the viewer's tabs).
//  - BrickResidency, one per session: the engine's slot table plus the session's RAM tier (a BrickCache, or none for
//    single frames: bricks are then read from the store on the render thread). The controller asks it resident(n)
//    (drawing n costs no disk read) and on_gpu(n) (no upload either); the engine asks it, once a frame, for the cut's
//    slots (plan) and then for the texels of the bricks to upload (fetch), and records each upload (place).
//
// Data flows one way: the session fills its RAM tier and hands the residency to the engine's draw; nothing calls
// back. Not thread-safe: the render thread only (the BrickCache is thread-safe on its own).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

namespace ugvr {

class BrickStoreReader;
class BrickCache;

class BrickSlotTable {
 public:
  static constexpr uint64_t kNoSlot = ~uint64_t(0);

  // A new, empty atlas of `capacity` slots.
  void reset(uint64_t capacity);
  // Every slot free, the capacity kept (the engine's field changed: the bricks are another field's).
  void clear();
  uint64_t capacity() const { return slot_owner_.size(); }
  uint64_t size() const { return resident_.size(); }  // slots holding a brick
  bool contains(uint64_t node) const { return resident_.count(node) != 0; }
  uint64_t slot(uint64_t node) const;        // node's slot, or kNoSlot
  uint64_t owner(uint64_t slot) const;       // slot's node, or kNoNode (free)
  uint64_t frame() const { return frame_; }  // frames begun

  // The bricks a frame must upload: missing[i] goes into slots[i].
  struct Plan {
    std::vector<uint64_t> missing;
    std::vector<uint64_t> slots;
  };
  // Begins a frame drawing `nodes` (distinct): the resident ones are drawn this frame and keep their slots; each
  // missing one gets a free slot (never used first, by slot number), else the slot drawn least recently (ties: the
  // lower slot). Nothing is evicted until place(). Throws ugvr::Error when the nodes do not fit the table.
  Plan begin_frame(std::span<const uint64_t> nodes);
  // Records node's brick uploaded into slot (from the plan) this frame, evicting the slot's previous brick.
  void place(uint64_t node, uint64_t slot);

 private:
  std::unordered_map<uint64_t, uint64_t> resident_;  // node -> slot
  std::vector<uint64_t> slot_owner_;                 // slot -> node (kNoNode: free)
  std::vector<uint64_t> slot_frame_;                 // slot -> last frame that drew it (0: never)
  uint64_t frame_ = 0;
};

class BrickResidency {
 public:
  using Texels = std::shared_ptr<const std::vector<uint16_t>>;

  // `gpu`: the engine's table (LodEngine::gpu_slots()); `ram`: the session's cache, or null (bricks read from the
  // store). All must outlive this object.
  BrickResidency(const BrickStoreReader& store, BrickSlotTable& gpu, BrickCache* ram = nullptr);

  bool on_gpu(uint64_t node) const { return gpu_.contains(node); }
  bool in_ram(uint64_t node) const;
  // Drawing node needs no disk read: on the GPU or in RAM.
  bool resident(uint64_t node) const { return on_gpu(node) || in_ram(node); }

  BrickSlotTable& gpu() const { return gpu_; }
  BrickCache* ram() const { return ram_; }

  // The engine's frame, after it sized the atlas: the cut's resident bricks kept, the missing ones given slots
  // (BrickSlotTable::begin_frame). Zeroes sync_reads().
  BrickSlotTable::Plan plan(std::span<const uint64_t> nodes);
  // The texels (make_atlas_slot's layout, brick_atlas.h) of plan.missing[first + i], i < count: ram[i] from the RAM
  // tier where it has the brick (a use of the cache; asked in order), else null and read[i] read from the store and
  // built here, in parallel, for `field` ([lo, hi]: its range). ram and read must hold count entries.
  void fetch(const BrickSlotTable::Plan& plan, size_t first, size_t count, uint32_t field, double lo, double hi,
             std::vector<Texels>& ram, std::vector<std::vector<uint16_t>>& read);
  // Records plan.missing[i] uploaded into plan.slots[i] (BrickSlotTable::place).
  void place(uint64_t node, uint64_t slot) { gpu_.place(node, slot); }
  // Bricks of the last plan read from the store on the render thread (no RAM tier, or it lacked them: a RAM cache
  // may evict a brick between the controller's choice and the frame, late, not wrong).
  uint64_t sync_reads() const { return sync_reads_; }

 private:
  const BrickStoreReader& store_;
  BrickSlotTable& gpu_;
  BrickCache* ram_;
  uint64_t sync_reads_ = 0;
};

}  // namespace ugvr
