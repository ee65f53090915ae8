// What a partitioned build (`ugvr build ... --pieces N`) knows of a piece once its store is written, kept beside the
// store as "<piece>.ugvr.built.json", so that an interrupted build resumes (`--resume`) without building that piece
// again: a billion cells take hours in pieces of minutes each (docs/mpi.md, "Partitioned stores").
//
// The record says how the piece was made: the split (a hash of every kd box's bit patterns, which name the piece's
// place among all of them; the boxes' outer faces are infinite, so they are not written as JSON numbers), the ghost
// level and margin, the input file's path, size and modification time, the store's build options (its provenance
// record and the field selectors), and what the build counted: the piece's cells and ghost cells, the store's nodes
// and bytes, the seconds it took. A resumed build takes a piece only when its store exists with the recorded size and
// every "how it was made" entry equals its own; otherwise the piece is built again (and says why).
//
// JSON (one object): {"piece", "pieces", "split": "<16 hex digits>", "ghost_level", "ghost_margin", "input",
// "input_bytes", "input_mtime_ns", "build", "fields": [...], "cells", "ghost_cells", "nodes", "store_bytes",
// "seconds"}.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "ugvr/mpi/piece_build.h"

namespace ugvr {

struct PieceRecord {
  // How it was made.
  int piece = 0, pieces = 0;
  std::string split;  // split_signature of the plan's tree
  int ghost_level = 0;
  double ghost_margin = 0;
  std::string input;
  uint64_t input_bytes = 0;
  int64_t input_mtime_ns = 0;
  std::string build;                // the store's provenance record (octree/build_parts.h, store_layout)
  std::vector<std::string> fields;  // the field selectors as given
  // What the build counted.
  uint64_t cells = 0, ghost_cells = 0, nodes = 0, store_bytes = 0;
  double seconds = 0;
};

// A hash of every box of `tree` (FNV-1a over the doubles' bit patterns), as 16 hex digits.
std::string split_signature(const KdTree& tree);

// The record of piece k as this build would make it, before its counts: what a kept piece must match. `build` is the
// store's provenance record. Throws ugvr::Error naming `input` when it cannot be read (size, time).
PieceRecord planned_piece_record(const PiecePlan& plan, int k, const std::string& input, const std::string& build,
                                 const std::vector<std::string>& fields);

std::string piece_record_path(const std::string& store_path);
// Written atomically (core/json_file.h) once the piece's store is.
void write_piece_record(const std::string& store_path, const PieceRecord& record);

// The kept record of the piece whose store is `store_path`, when it matches `planned` and the store exists with the
// recorded size; nullopt otherwise, with `why` saying what differs (empty when there is no record at all: a piece
// never built). A damaged record is not kept (why says so).
std::optional<PieceRecord> kept_piece(const std::string& store_path, const PieceRecord& planned, std::string* why);

}  // namespace ugvr
