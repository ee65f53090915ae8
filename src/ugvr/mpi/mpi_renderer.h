// `mpirun -np N ugvr render ...`: data-parallel rendering with sort-last compositing (docs/mpi.md).
//
// Every rank opens the whole input (a .pvtu or Exodus: only its part, mpi_part_read.h), builds the same kd-tree
// over the cells' centroids (kd_partition.h) and renders only the stretch of each ray inside its own box, into a
// premultiplied image over a transparent background with early ray termination off (a rank cannot know what lies in
// front of it). The images are blended front to back in the tree's visibility order (mpi_compositor.h) and the
// background applied once, on rank 0, which alone gets the frame. Emission-absorption splits exactly at the boxes'
// faces, so the result is the one-rank image up to rounding.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "ugvr/io/reader.h"
#include "ugvr/render/renderer.h"
#include "ugvr/render/renderer_factory.h"

namespace ugvr::mpi {

// How a mesh's ranks get their parts: a .pvtu or an Exodus file read piece by piece, each piece by one rank, each
// rank keeping the cells its box needs (mpi_part_read.h; other formats are read whole on every rank), or every input
// read whole on every rank (the
// viewer: its histograms are counted from rank 0's copy of the whole mesh).
enum class MeshRead { PartWherePossible, Whole };

// Opens `inputs` on every rank as open_renderer_default_field does (the same default field), wrapped in the
// compositing renderer. Exact engine on the CPU only (options.device "gpu" is an OptionError("device")); the LOD
// engine for a store, one cut per frame. Interactive sessions (OptionError("fps")) and MIP (OptionError("mode"), thrown
// by render) are not supported yet.
// A request with keep_going (the viewer's resting frames) may be cut short: every rank must then pass one, for the same
// frames (mpi_view.cpp sends the flag with the request); rank 0's is the question, the others' only the flag. The
// ranks agree (mpi_frame_stop.h) and either all composite or all throw FrameInterrupted.
// UGVR_MPI_FAIL_RANK=k makes rank k throw in its first render (the tests' failing rank); UGVR_MPI_SLOW_RANK=k:S[:FILE]
// makes rank k start its part of a full-quality frame S seconds late (the tests' slow rank, mpi_renderer.cpp).
// `fields` (when given) receives the fields a frame may bind (settings.field): a partitioned store's or a brick
// store's, or a mesh's default ones (default_field_names, at most 4; the first is bound when options.field is empty).
std::unique_ptr<Renderer> open_renderer(const std::vector<std::string>& inputs, const ReadOptions& read,
                                        RendererOptions options, OpenedInput* opened = nullptr,
                                        std::vector<std::string>* fields = nullptr,
                                        MeshRead mesh_read = MeshRead::PartWherePossible);

}  // namespace ugvr::mpi
