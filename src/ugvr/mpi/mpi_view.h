// `mpirun -np N ugvr view INPUT`: the browser viewer on a cluster (docs/mpi.md, "The viewer on a cluster"). Rank 0
// serves the page as the single-process viewer does; every frame of every tab is drawn by all ranks together with the
// compositing renderer of mpi_renderer.h (each rank its kd part, IceT blends).
//
// Protocol between the ranks, on MPI_COMM_WORLD, driven by rank 0's render thread (the others wait in follow_view):
//   1. MPI_Bcast of one uint64: the length L of the frame's request; 0 means quit (every follower returns).
//   2. MPI_Bcast of L bytes: the FrameRequest as JSON (encode_frame_request), the one every rank draws, rank 0
//      included (it draws the decoded bytes, not its own struct, so that every rank sees the same numbers).
//   3. The compositing renderer's collectives (mpi_renderer.cpp: its figures, then the compositor). A resting frame
//      (the viewer's keep_going, sent as "interruptible": true) is first agreed on (mpi_frame_stop.h): when rank 0's
//      tab moves on meanwhile, every rank drops the frame (FrameInterrupted) and steps 3 and 4 are skipped by all.
//   4. MPI_Allreduce(MAX) of each rank's wall time for the frame: what the leader's frame-rate controller sees.
// Between frames rank 0 may instead ask for the visible box (Renderer::visible_bounds, for the framed first view of
// the auto transfer function): step 2's text is then {"visible_bounds": {field, tf, threshold}}, and step 3 is the
// compositing renderer's reduction of the ranks' boxes (mpi_renderer.cpp), whose answer every rank shares.
// A request rank 0 can tell is unsupported (MIP, a time step) is refused before step 1: the page gets the error and
// the ranks never hear of it. A failure after step 1, on any rank, ends the job (abort_job): the others are waiting
// in a collective that will not complete.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "ugvr/io/reader.h"
#include "ugvr/render/renderer.h"
#include "ugvr/render/renderer_factory.h"

namespace ugvr::mpi {

// The request's JSON form between the ranks: camera, transfer function (ParaView preset form with its unit
// distance), settings (size, field, mode ...), step_voxels, full_quality, and whether the frame may be cut short
// (keep_going: decoded as a function that always says go on, the flag the ranks > 0 draw with). Doubles round-trip
// exactly.
std::string encode_frame_request(const FrameRequest& request);
FrameRequest decode_frame_request(const std::string& bytes);  // throws ugvr::Error naming what is wrong

// Rank 0: opens `inputs` as mpi::open_renderer does (on the calling thread: the render thread, whose GL context the
// LOD engine then uses) and returns the renderer every tab draws with. Its render() broadcasts the request and draws
// it collectively; while the view moves (a target_fps and not full_quality: the viewer asks for full quality once a
// tab's view rests) it draws at a reduced scale chosen from the slowest rank's time, magnified to the requested size
// (FrameStats::scale, converged false), and at full scale once the view rests. Destroying it tells the followers to
// quit. `fields` receives the fields the page may pick, `opened` the reader's warnings and a mesh's dataset
// (mpi::open_renderer). Throws ugvr::Error when MPI cannot be called from this thread (no MPI_THREAD_SERIALIZED).
std::unique_ptr<Renderer> open_view_leader(const std::vector<std::string>& inputs, const ReadOptions& read,
                                           const RendererOptions& options, std::vector<std::string>* fields,
                                           OpenedInput* opened = nullptr);

// Ranks > 0: opens `inputs` the same way and draws every request rank 0 broadcasts, until it says quit. What fails
// here throws (the caller ends the job with abort_job).
void follow_view(const std::vector<std::string>& inputs, const ReadOptions& read, const RendererOptions& options);

}  // namespace ugvr::mpi
