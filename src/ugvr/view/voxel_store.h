// A voxel volume (NRRD, raw, .vti) drawn with tricubic isosurfaces (`ugvr render VOL --iso V --interpolation
// tricubic`, `ugvr.render(VOL, settings={"interpolation": "tricubic"})`): the spline is the lod engine's, which draws
// brick stores, so the volume's store is built into the viewer's cache (view/view_store.h) once and drawn from there.
//
// The store is chosen so that its leaves' lattice holds the volume's own samples (docs/tricubic.md, "Voxel volumes
// rendered directly"): the octree's root is a cube on the data's lower corner with its largest extent L
// (octree_root), and bricks of R samples at depth D put ·2^D lattice intervals across it. When L is M voxel
// spacings (M an integer) and every axis' spacing is a whole number of the smallest, M = (R-1)·2^D keeps every
// sample: D grows from 0 while is even and above 32 (bricks of at most 33 samples, the builder's default size,
// where M has enough factors of two), and an odd M up to 64 is one brick of M + 1. Otherwise the lattice is the
// coarsest of bricks of 17 to 33 samples whose spacing is not coarser than the smallest voxel spacing, and the
// samples are resampled (the store's lattice holds the volume's trilinear interpolant).
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "ugvr/grid/structured_grid.h"
#include "ugvr/io/reader.h"

namespace ugvr::view {

struct VoxelLattice {
  uint32_t resolution = 0;     // samples per brick axis (R)
  int depth = 0;               // the leaves' level (D)
  bool keeps_samples = false;  // every voxel sample is a leaf lattice point
  std::string note;            // why the samples are resampled (empty when kept)
};

// The lattice for `grid` (point dims and spacing); throws ugvr::Error for a volume without extent.
VoxelLattice voxel_lattice(const ImageGrid& grid);

// Whether `inputs` name a voxel volume by format (one NRRD, raw or VTK XML image file), without reading it.
bool is_voxel_volume_input(std::span<const std::string> inputs);

struct VoxelStore {
  std::string path;      // the cached store to draw
  bool built = false;    // false: a store built earlier for the same file (path, size, time), options and field
  VoxelLattice lattice;  // of the build (zero when not built)
};

// The store of the voxel volume `inputs` (read with `read`) for tricubic isosurfaces of `field` (empty: the builder's
// default), built at --error 0 into the cache unless one built earlier for the same files (canonical paths, sizes,
// modification times), raw layout, time step and field opens. `say`: what it does goes to stderr (the build's
// progress is the builder's, on stderr when Progress is enabled). Throws ugvr::Error naming the input when it is not
// one image grid, or the build's error.
VoxelStore voxel_store_for_tricubic(std::span<const std::string> inputs, const ReadOptions& read,
                                    const std::string& field, bool say);

}  // namespace ugvr::view
