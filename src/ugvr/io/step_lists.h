// The time steps of the multi-step readers, listed without reading the steps (io/time_series.h builds a series'
// steps from them). Each returns the time of every step its reader's `time_step` indexes, in that order; empty when
// the input has no time steps. Errors as the readers' own (ugvr::Error naming the file).
#pragma once

#include <string>
#include <vector>

namespace ugvr {

// Exodus II: "time_whole", without reading the mesh.
std::vector<double> list_exodus_times(const std::string& path);
// CGNS: the first 3-D zone's FlowSolutionPointers, timed by BaseIterativeData's TimeValues (else the index).
std::vector<double> list_cgns_times(const std::string& path);
// EnSight: the time set with the most steps; a .sos is not listed yet (empty).
std::vector<double> list_ensight_times(const std::string& path);
// OpenFOAM: the time directories' values, sorted ("0" included).
std::vector<double> list_openfoam_times(const std::string& path);

}  // namespace ugvr
