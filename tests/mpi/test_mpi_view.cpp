// `mpirun -np N ugvr view INPUT` (src/ugvr/mpi/mpi_view.h, docs/mpi.md "The viewer on a cluster"), end to end: the
// job is started as a user would, a WebSocket client (Beast) asks for frames, and each converged frame is compared
// with the one-process `ugvr render` of the same view; the camera moves and the image follows; SIGTERM to rank 0
// ends every rank with status 0; a rank that fails ends the job with its message.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <unistd.h>

// clang-format off
#include <utility>  // Boost 1.74's asio needs it first (view_server.cpp says why)
#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
// clang-format on
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "mpi_fixtures.h"
#include "test_data.h"
#include "ugvr/render/camera.h"
#include "ugvr/render/image.h"

namespace ugvr {
namespace {

namespace beast = boost::beast;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr int kSide = 96;

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// `mpirun --oversubscribe -np RANKS ugvr --quiet view ARGS` in the background, its output in files.
class ViewJob {
 public:
  ViewJob(const test::ScratchDir& dir, int ranks, const std::string& args, const std::string& env = "")
      : out_(dir.file("view.out")), err_(dir.file("view.err")) {
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
    const std::string command = "exec env " + env + " timeout 300 " + std::string(UGVR_MPIEXEC) +
                                " --oversubscribe -np " + std::to_string(ranks) + " " + UGVR_BINARY + " --quiet view " +
                                args + " >" + out_ + " 2>" + err_;
    pid_ = fork();
    if (pid_ == 0) {
      setpgid(0, 0);  // a group of its own: the destructor ends mpirun and its ranks with it
      execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  // A test that failed half-way leaves the job running: SIGTERM to the group (timeout passes it to mpirun, which
  // ends its ranks), then SIGKILL. Killing timeout alone would leave mpirun and the ranks behind.
  ~ViewJob() {
    if (pid_ <= 0 || status_) return;
    kill(-pid_, SIGTERM);
    if (!exited(std::chrono::seconds(10))) {
      kill(-pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }

  // Waits for the URL's port and rank 0's pid (the job's first lines); nullopt when the job ended or 120 s passed.
  bool wait_serving() {
    const std::regex url(R"(serving http://127\.0\.0\.1:(\d+)/)"), pid(R"(rank 0 is pid (\d+))");
    for (const auto end = Clock::now() + std::chrono::seconds(120); Clock::now() < end;) {
      std::smatch m;
      const std::string out = slurp(out_), err = slurp(err_);
      if (std::regex_search(out, m, url)) port = std::stoi(m[1]);
      if (std::regex_search(err, m, pid)) rank0_pid = std::stoi(m[1]);
      if (port && rank0_pid) return true;
      if (exited(std::chrono::milliseconds(200))) return false;
    }
    return false;
  }
  // The job's exit status once it ended within `limit`.
  std::optional<int> exited(std::chrono::milliseconds limit) {
    for (const auto end = Clock::now() + limit; !status_;) {
      int st = 0;
      if (waitpid(pid_, &st, WNOHANG) == pid_) status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
      if (status_ || Clock::now() >= end) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    return status_;
  }
  std::string log() const { return slurp(out_) + slurp(err_); }

  int port = 0, rank0_pid = 0;

 private:
  std::string out_, err_;
  pid_t pid_ = -1;
  std::optional<int> status_;
};

// A tab: the WebSocket of view_protocol.h.
class Tab {
 public:
  explicit Tab(int port) : ws_(ioc_) {
    tcp::resolver resolver(ioc_);
    net::connect(ws_.next_layer(), resolver.resolve("127.0.0.1", std::to_string(port)));
    ws_.handshake("127.0.0.1:" + std::to_string(port), "/ws");
    // A frame that never comes fails the test in a minute instead of hanging it.
    const timeval limit{60, 0};
    setsockopt(ws_.next_layer().native_handle(), SOL_SOCKET, SO_RCVTIMEO, &limit, sizeof limit);
  }
  void send(const json& message) { ws_.write(net::buffer(message.dump())); }
  // The next text message (binary frames are kept in `image`).
  json next_text() {
    for (;;) {
      beast::flat_buffer buffer;
      ws_.read(buffer);
      const std::string data = beast::buffers_to_string(buffer.data());
      if (ws_.got_text()) return json::parse(data);
      image = data;
    }
  }
  // The scene message, after the progress messages a tab is sent while the ranks open the data (the viewer serves
  // before it opens: engine_host.h, pending_collective_).
  json scene() {
    for (;;) {
      json m = next_text();
      if (m["type"] != "progress") return m;
    }
  }
  // Reads until a converged frame reflecting at least `request` messages (its status, then its PNG in `image`), or
  // an error message (returned as is).
  json converged_frame(uint64_t request) {
    for (;;) {
      const json m = next_text();
      if (m["type"] == "error") return m;
      if (m["type"] != "status" || !m["converged"].get<bool>() || m["request"].get<uint64_t>() < request) continue;
      beast::flat_buffer buffer;
      ws_.read(buffer);
      image = beast::buffers_to_string(buffer.data());
      return m;
    }
  }
  Image png(const std::string& path) const {
    std::ofstream(path, std::ios::binary) << image;
    return read_png(path);
  }
  std::string image;

 private:
  net::io_context ioc_;
  websocket::stream<tcp::socket> ws_;
};

json camera(std::array<double, 3> position) {
  return {{"position", position}, {"focal_point", {8, 8, 8}},     {"view_up", {0, 1, 0}},
          {"view_angle", 30},     {"parallel_projection", false}, {"parallel_scale", 1}};
}

class MpiView : public ::testing::Test {
 protected:
  void SetUp() override {
    test::write_u_shaped_mesh(file("u.vtk"), 16);
    std::ofstream(file("cam.json")) << camera({30, 20, 44}).dump();
    // Points in data values and a unit distance: the viewer (--tf FILE) and `ugvr render --tf FILE --keep-range`
    // draw with the same function.
    std::ofstream(file("tf.json")) << R"([{"Name":"t","ColorSpace":"RGB","RGBPoints":[-1,0.1,0.2,0.9, 0.5,0.9,0.9,0.2,
      2.5,0.9,0.1,0.1],"Points":[-1,0.0,0.5,0, 2.5,0.8,0.5,0],"ScalarOpacityUnitDistance":2}])";
  }
  std::string file(const std::string& name) const { return dir_.file(name); }
  std::string view_args(const std::string& input) const {
    return input + " --port 0 --size " + std::to_string(kSide) + " --camera " + file("cam.json") + " --tf " +
           file("tf.json");
  }
  // The one-process image of the same view (`ugvr render`, early termination off as every rank's).
  Image reference(const std::string& input, const std::string& flags) {
    const test::CommandResult r = test::run_ugvr("render " + input + " " + flags + " --size " + std::to_string(kSide) +
                                                 " --camera " + file("cam.json") + " --tf " + file("tf.json") +
                                                 " --keep-range --early-termination 1 -o " + file("ref.png"));
    EXPECT_EQ(r.status, 0) << r.out;
    return read_png(file("ref.png"));
  }

  test::ScratchDir dir_;
};

TEST_F(MpiView, TwoRanksServeTheExactImageFollowTheCameraAndStopCleanly) {
  const Image ref = reference(file("u.vtk"), "--engine exact");
  ViewJob job(dir_, 2, view_args(file("u.vtk")));
  ASSERT_TRUE(job.wait_serving()) << job.log();
  {
    Tab tab(job.port);
    tab.send({{"type", "hello"}, {"width", kSide}, {"height", kSide}});
    const json scene = tab.scene();
    ASSERT_EQ(scene["type"], "scene") << scene.dump();
    EXPECT_EQ(scene["engine"], "exact");
    EXPECT_NE(scene["renderer"].get<std::string>().find("2 MPI ranks"), std::string::npos) << scene.dump();
    // The mesh's values give the transfer-function editor its histograms (rank 0 read the whole mesh).
    for (const json& f : scene["fields"]) {
      uint64_t counted = 0;
      for (const json& c : f["histogram"]) counted += c.get<uint64_t>();
      EXPECT_GT(f["histogram"].size(), 1u) << f.dump();
      EXPECT_GT(counted, 0u) << f.dump();
    }
    const json first = tab.converged_frame(1);
    ASSERT_EQ(first["type"], "status") << first.dump();
    const Image shown = tab.png(file("first.png"));
    const ImageDifference d = compare_images(shown, ref);
    std::printf("viewer on 2 ranks vs one-process render: psnr %.2f dB, max %.3g\n", d.psnr_db, d.max_abs);
    EXPECT_GE(d.psnr_db, 50) << "max " << d.max_abs;

    // A request the ranks cannot draw together is refused in the page, and the session goes on.
    tab.send({{"type", "settings"}, {"mode", "mip"}});
    const json refused = tab.converged_frame(2);
    ASSERT_EQ(refused["type"], "error") << refused.dump();
    EXPECT_NE(refused["message"].get<std::string>().find("not supported under MPI"), std::string::npos);
    tab.send({{"type", "settings"}, {"mode", "ea"}});

    json moved_camera = camera({44, 8, 10});
    moved_camera["type"] = "camera";
    tab.send(moved_camera);
    const json moved = tab.converged_frame(4);
    ASSERT_EQ(moved["type"], "status") << moved.dump();
    const ImageDifference m = compare_images(tab.png(file("moved.png")), shown);
    std::printf("after the camera moved: psnr %.2f dB against the first frame\n", m.psnr_db);
    EXPECT_LT(m.psnr_db, 30) << "the image did not follow the camera";

    // Moving at a rate no rank holds (240 fps): the frame after the first moving one is drawn smaller, from the
    // slowest rank's time, and magnified; once the view rests the frame is full scale again.
    tab.send({{"type", "settings"}, {"fps", 240}});
    json step = camera({40, 12, 30});
    step["type"] = "camera";
    tab.send(step);
    ASSERT_EQ(tab.converged_frame(6)["type"], "status");
    step = camera({36, 16, 36});
    step["type"] = "camera";
    tab.send(step);
    json reduced = tab.next_text();
    while (reduced["type"] != "status" || reduced["request"].get<uint64_t>() < 7) reduced = tab.next_text();
    EXPECT_LT(reduced["scale"].get<double>(), 1) << reduced.dump();
    ASSERT_FALSE(reduced["converged"].get<bool>()) << reduced.dump();
    EXPECT_EQ(reduced["width"], kSide) << "magnified to the canvas";
    const json rested = tab.converged_frame(7);
    ASSERT_EQ(rested["type"], "status") << rested.dump();
    EXPECT_EQ(rested["scale"].get<double>(), 1);
  }
  ASSERT_EQ(kill(job.rank0_pid, SIGTERM), 0);
  const std::optional<int> status = job.exited(std::chrono::seconds(60));
  ASSERT_TRUE(status.has_value()) << "the ranks did not stop within 60 s\n" << job.log();
  EXPECT_EQ(*status, 0) << job.log();
}

TEST_F(MpiView, APartitionedStoreOnTwoRanksEqualsItsOneProcessRender) {
  const test::CommandResult built =
      test::run_ugvr("build " + file("u.vtk") + " --brick 16 --max-depth 4 --pieces 4 -o " + file("p.json"));
  ASSERT_EQ(built.status, 0) << built.out;
  const Image ref = reference(file("p.json"), "--step-voxels 0.5");
  ViewJob job(dir_, 2, view_args(file("p.json")));
  ASSERT_TRUE(job.wait_serving()) << job.log();
  {
    Tab tab(job.port);
    tab.send({{"type", "hello"}, {"width", kSide}, {"height", kSide}});
    const json scene = tab.scene();
    ASSERT_EQ(scene["type"], "scene");
    // The pieces' coarse levels give the transfer-function editor its histogram (summed over the pieces).
    for (const json& f : scene["fields"]) {
      uint64_t counted = 0;
      for (const json& c : f["histogram"]) counted += c.get<uint64_t>();
      EXPECT_GT(f["histogram"].size(), 1u) << f.dump();
      EXPECT_GT(counted, 0u) << f.dump();
    }
    const json first = tab.converged_frame(1);
    ASSERT_EQ(first["type"], "status") << first.dump();
    EXPECT_EQ(first["engine"], "lod");
    const ImageDifference d = compare_images(tab.png(file("first.png")), ref);
    std::printf("partitioned store, viewer on 2 ranks vs one-process render: psnr %.2f dB, max %.3g\n", d.psnr_db,
                d.max_abs);
    EXPECT_GE(d.psnr_db, 50) << "max " << d.max_abs;
  }
  ASSERT_EQ(kill(job.rank0_pid, SIGTERM), 0);
  const std::optional<int> status = job.exited(std::chrono::seconds(60));
  ASSERT_TRUE(status.has_value()) << job.log();
  EXPECT_EQ(*status, 0) << job.log();
}

// No --tf, no --camera: the page starts from auto, framed on what it leaves visible. Under mpirun rank 0 alone makes
// the scene while each rank holds its part: the ranks' visible boxes are reduced (mpi_view.h), so the scene's camera
// is the one-process framing (`ugvr render`'s default camera, which the one-process viewer shares:
// python/tests/test_store_viewer.py), not the whole domain's.
TEST_F(MpiView, TheDefaultViewIsFramedOnWhatAutoLeavesVisibleAsInOneProcess) {
  ASSERT_EQ(test::run_ugvr("generate --cells 3000 --kind tet -o " + file("t.vtu")).status, 0);
  const std::string render = "render " + file("t.vtu") + " --engine exact --size 16 -o " + file("r.png");
  const test::CommandResult framed = test::run_ugvr(render + " --save-camera " + file("framed.cam"));
  ASSERT_EQ(framed.status, 0) << framed.out;
  const test::CommandResult whole = test::run_ugvr(render + " --tf viridis --save-camera " + file("whole.cam"));
  ASSERT_EQ(whole.status, 0) << whole.out;
  const Camera expected = read_camera(file("framed.cam"));
  ASSERT_NE(expected, read_camera(file("whole.cam"))) << "the generated mesh should frame closer than the domain";

  ViewJob job(dir_, 2, file("t.vtu") + " --port 0 --size 32");
  ASSERT_TRUE(job.wait_serving()) << job.log();
  {
    Tab tab(job.port);
    tab.send({{"type", "hello"}, {"width", 32}, {"height", 32}});
    const json scene = tab.scene();
    ASSERT_EQ(scene["type"], "scene") << scene.dump();
    const Camera shown = camera_from_json(scene["camera"], "the scene's camera");
    for (int a = 0; a < 3; ++a) {
      EXPECT_NEAR(shown.position[a], expected.position[a], 1e-9) << "axis " << a;
      EXPECT_NEAR(shown.focal_point[a], expected.focal_point[a], 1e-9) << "axis " << a;
      EXPECT_NEAR(shown.view_up[a], expected.view_up[a], 1e-9) << "axis " << a;
    }
    // The ranks draw together after the question: the session goes on.
    EXPECT_EQ(tab.converged_frame(1)["type"], "status");
  }
  ASSERT_EQ(kill(job.rank0_pid, SIGTERM), 0);
  const std::optional<int> status = job.exited(std::chrono::seconds(60));
  ASSERT_TRUE(status.has_value()) << job.log();
  EXPECT_EQ(*status, 0) << job.log();
}

// A move during a resting frame is answered without waiting for it: rank 0 tells every rank to drop the frame
// (mpi_frame_stop.h). Rank 1 holds its part of the resting frame that starts while the file "hold" exists
// (UGVR_MPI_SLOW_RANK, mpi_renderer.h) for 30 s unless told to stop, and removes the file when it starts: the next
// move is sent only then, so the frame is certainly under way when it comes, not raced.
TEST_F(MpiView, AMoveCutsTheRestingFrameUnderWayShortOnEveryRank) {
  ViewJob job(dir_, 2, view_args(file("u.vtk")), "UGVR_MPI_SLOW_RANK=1:30:" + file("hold"));
  ASSERT_TRUE(job.wait_serving()) << job.log();
  {
    Tab tab(job.port);
    tab.send({{"type", "hello"}, {"width", kSide}, {"height", kSide}});
    ASSERT_EQ(tab.scene()["type"], "scene");
    ASSERT_EQ(tab.converged_frame(1)["type"], "status");
    // Moving at a rate no rank holds: a move's first frame is drawn small, not converged, and a resting frame follows.
    tab.send({{"type", "settings"}, {"fps", 240}});  // request 2
    std::ofstream(file("hold")) << "hold the next resting frame\n";
    json step = camera({40, 12, 30});
    step["type"] = "camera";
    tab.send(step);  // request 3
    for (const auto end = Clock::now() + std::chrono::seconds(60); std::filesystem::exists(file("hold"));) {
      ASSERT_LT(Clock::now(), end) << "no resting frame was held\n" << job.log();
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    const Clock::time_point moved = Clock::now();
    step = camera({36, 16, 36});
    step["type"] = "camera";
    tab.send(step);  // request 4, while rank 1 holds request 3's resting frame
    std::vector<json> of_3;
    json next = tab.next_text();
    for (; next["type"] != "status" || next["request"].get<uint64_t>() < 4; next = tab.next_text())
      if (next["type"] == "status" && next["request"] == 3) of_3.push_back(next);
    const double answered = std::chrono::duration<double>(Clock::now() - moved).count();
    std::printf("a move during a held resting frame answered after %.3f s\n", answered);
    EXPECT_LT(answered, 15) << "the move waited for the held frame";
    for (const json& s : of_3) EXPECT_FALSE(s["converged"].get<bool>()) << "request 3's resting frame was sent";
    EXPECT_GE(next["interrupted"].get<uint64_t>(), 1u) << next.dump();
    // The ranks go on together: request 4 converges to the image of its view.
    const json rested = tab.converged_frame(4);
    ASSERT_EQ(rested["type"], "status") << rested.dump();
  }
  ASSERT_EQ(kill(job.rank0_pid, SIGTERM), 0);
  const std::optional<int> status = job.exited(std::chrono::seconds(60));
  ASSERT_TRUE(status.has_value()) << job.log();
  EXPECT_EQ(*status, 0) << job.log();
}

TEST_F(MpiView, ARankThatFailsEndsTheJobWithItsMessage) {
  ViewJob job(dir_, 2, view_args(file("u.vtk")), "UGVR_MPI_FAIL_RANK=1");
  ASSERT_TRUE(job.wait_serving()) << job.log();
  try {
    Tab tab(job.port);
    tab.send({{"type", "hello"}, {"width", kSide}, {"height", kSide}});
    for (;;) tab.next_text();  // until the job's end closes the socket
  } catch (const std::exception&) {
  }
  const std::optional<int> status = job.exited(std::chrono::seconds(60));
  ASSERT_TRUE(status.has_value()) << "the job did not end within 60 s\n" << job.log();
  EXPECT_NE(*status, 0) << job.log();
  EXPECT_NE(job.log().find("rank 1 fails on purpose"), std::string::npos) << job.log();
}

TEST_F(MpiView, WhatCannotRunCollectivelyIsRefusedAtStartNotHung) {
  for (const std::string& args :
       {std::string("view --demo --port 0"), "view " + file("u.vtk") + " --store " + file("s.ugvr") + " --port 0"}) {
    const test::CommandResult r = test::mpirun(2, args);
    EXPECT_NE(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("under MPI"), std::string::npos) << r.out;
    EXPECT_EQ(r.out.find("serving"), std::string::npos) << r.out;
  }
}

}  // namespace
}  // namespace ugvr
