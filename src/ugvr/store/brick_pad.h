// Pad (Leven et al. 2002, sections 3.1 and 4.5): the samples of a brick that lie outside the mesh hold no data, and
// trilinear interpolation between a data sample and such a filler value smears the filler into the data along the
// mesh boundary (the paper's striping, its figure 5). Padding grows the data one sample outward: every sample without
// data that has data among its 26 neighbours gets the mean of those neighbours, in every field. One layer is enough:
// a trilinear cell with one data corner has all its other corners among that corner's 26 neighbours, so any lookup
// that touches data reads only data and pad. The validity mask (the stencil) is left as it is: it says what to draw.
//
// The builder pads every brick before measuring its interpolation error (octree/node_error.h). The store does not keep
// pad values (its codec drops the values of samples without data, store/brick_codec.h), so a renderer that interpolates
// near the boundary pads the bricks it decodes with the same function.
#pragma once

#include <cstdint>

namespace ugvr {

// `values`: `fields` bricks of R³ floats back to back (x fastest); `mask`: R³ bytes, nonzero = data. Pads in place;
// samples with no data neighbour keep their values.
void pad_brick(uint32_t resolution, uint32_t fields, float* values, const uint8_t* mask);

}  // namespace ugvr
