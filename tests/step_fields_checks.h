// Checks that a fields-only step read (io/step_fields.h) gives what the whole read gives, for the tests of every format
// with such reads (.vtu/.pvtu/.vtk in test_step_fields.cpp, OpenFOAM, EnSight, PLOT3D, CGNS).
#pragma once

#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "ugvr/grid/dataset.h"
#include "ugvr/io/step_fields.h"
#include "ugvr/io/time_series.h"

namespace ugvr::test {

// Field sets equal bit for bit: names, associations, types, shapes and stored bytes, in order.
inline void expect_same_bits(const FieldSet& a, const FieldSet& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    SCOPED_TRACE(a[i].name());
    EXPECT_EQ(a[i].name(), b[i].name());
    EXPECT_EQ(a[i].association(), b[i].association());
    ASSERT_EQ(a[i].data().type(), b[i].data().type());
    ASSERT_EQ(a[i].data().tuples(), b[i].data().tuples());
    ASSERT_EQ(a[i].data().components(), b[i].data().components());
    EXPECT_EQ(std::memcmp(a[i].data().bytes(), b[i].data().bytes(), a[i].data().byte_size()), 0);
  }
}

// A fields-only read of step k equals read_time_step(k) but for the grids: fields, format, sources, warnings.
inline void expect_whole_read(const TimeSeries& series, const StepFields& fields, size_t k) {
  SCOPED_TRACE("step " + std::to_string(k));
  const Dataset whole = read_time_step(series, k);
  ASSERT_EQ(fields.blocks.size(), whole.blocks.size());
  for (size_t b = 0; b < whole.blocks.size(); ++b) expect_same_bits(fields.blocks[b], whole.blocks[b].fields);
  EXPECT_EQ(fields.format, whole.format);
  EXPECT_EQ(fields.sources, whole.sources);
  EXPECT_EQ(fields.warnings, whole.warnings);
}

}  // namespace ugvr::test
