// Nothing left behind (issue 23): temporaries removed on SIGINT / SIGTERM by the signal handler, stale ones of dead
// processes removed on the next start, the out-of-core build's scratch folder under one name. The unit tests run the
// registry in a forked child that the signal kills; the CLI tests interrupt real `ugvr generate` and out-of-core
// `ugvr build` runs once they have started writing.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "test_data.h"
#include "ugvr/core/error.h"
#include "ugvr/core/file.h"
#include "ugvr/core/temp_files.h"

extern char** environ;

namespace ugvr {
namespace {

namespace fs = std::filesystem;
using test::ScratchDir;

void touch(const std::string& path, size_t bytes = 16) {
  std::ofstream out(path, std::ios::binary);
  out << std::string(bytes, 'x');
}

std::set<std::string> entries(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

// The id of a process that has ended and been reaped (so kill(pid, 0) fails with ESRCH, unless the id is reused in
// the few microseconds of the test).
pid_t dead_pid() {
  const pid_t pid = fork();
  if (pid == 0) _exit(0);
  int status = 0;
  waitpid(pid, &status, 0);
  return pid;
}

TEST(TempCleanup, SignalRemovesRegisteredFilesAndFolders) {
  ScratchDir dir;
  const std::string file = dir.file("out.vtu.tmp-x"), folder = dir.file("out.ugvr.cells"),
                    kept = dir.file("unregistered");
  for (int sig : {SIGTERM, SIGINT, SIGHUP}) {
    touch(kept);
    auto child = [&] {
      install_temp_cleanup_on_signals();
      TempRegistration f(file, false), d(folder, true);
      touch(file, 1 << 20);
      fs::create_directories(folder + "/sub");
      for (int i = 0; i < 100; ++i) touch(folder + "/part-" + std::to_string(i), 4096);
      touch(folder + "/sub/deeper");
      // Unregistered before the signal: its owner has finished with it, the handler leaves it alone.
      { TempRegistration done(kept, false); }
      std::raise(sig);
      std::_Exit(0);  // not reached: the default action ends the process
    };
    EXPECT_EXIT(child(), ::testing::KilledBySignal(sig), "");
    EXPECT_FALSE(fs::exists(file)) << strsignal(sig);
    EXPECT_FALSE(fs::exists(folder)) << strsignal(sig);
    EXPECT_TRUE(fs::exists(kept)) << strsignal(sig);
  }
}

TEST(TempCleanup, AtomicOutputFileTemporaryGoesOnSignal) {
  ScratchDir dir;
  const std::string out = dir.file("data.vtu");
  auto child = [&] {
    install_temp_cleanup_on_signals();
    AtomicOutputFile f(out);
    f.write(std::string(8 << 20, 'a'));  // past the buffer: on disk
    std::raise(SIGTERM);
    std::_Exit(0);
  };
  EXPECT_EXIT(child(), ::testing::KilledBySignal(SIGTERM), "");
  EXPECT_TRUE(entries(dir.file("")).empty());
}

TEST(TempCleanup, StaleTemporariesOfDeadProcessesAreRemoved) {
  ScratchDir dir;
  const std::string out = dir.file("mesh.vtu");
  const pid_t dead = dead_pid(), alive = getppid();
  ASSERT_FALSE(process_exists(dead));
  ASSERT_TRUE(process_exists(alive));
  const std::string dead_tmp = "mesh.vtu.tmp-" + std::to_string(dead) + "-0",
                    dead_cells = "mesh.vtu.cells-" + std::to_string(dead),
                    live_tmp = "mesh.vtu.tmp-" + std::to_string(alive) + "-3",
                    own_tmp = "mesh.vtu.tmp-" + std::to_string(getpid()) + "-999";  // a previous process's, same PID
  touch(dir.file(dead_tmp), 1000);
  fs::create_directories(dir.file(dead_cells));
  touch(dir.file(dead_cells) + "/root", 5000);
  touch(dir.file(live_tmp));
  touch(dir.file(own_tmp));
  // Look-alikes that are not temporaries of this output.
  for (const char* name : {"mesh.vtu.tmp-", "mesh.vtu.tmp-12x-0", "other.vtu.tmp-1-0", "mesh.vtu.cellsX", "mesh.vtu"})
    touch(dir.file(name));
  const std::vector<std::string> removed = remove_stale_temporaries(out);
  EXPECT_EQ(std::set<std::string>(removed.begin(), removed.end()),
            (std::set<std::string>{dir.file(dead_tmp), dir.file(dead_cells), dir.file(own_tmp)}));
  EXPECT_EQ(entries(dir.file("")), (std::set<std::string>{live_tmp, "mesh.vtu.tmp-", "mesh.vtu.tmp-12x-0",
                                                          "other.vtu.tmp-1-0", "mesh.vtu.cellsX", "mesh.vtu"}));
  // Opening an output does the same.
  touch(dir.file(dead_tmp));
  {
    AtomicOutputFile f(out);
    EXPECT_FALSE(fs::exists(dir.file(dead_tmp)));
    EXPECT_TRUE(fs::exists(dir.file(live_tmp)));
  }
}

TEST(TempCleanup, ScratchFolderHasOneNameAndOneOwner) {
  ScratchDir dir;
  const std::string out = dir.file("out.ugvr");
  {
    ScratchFolder s(out);
    EXPECT_EQ(s.path(), out + ".cells");
    std::ifstream owner(s.path() + "/owner");
    long pid = 0;
    owner >> pid;
    EXPECT_EQ(pid, long(getpid()));
    // A second build of the same output in this process is refused, naming the folder.
    try {
      ScratchFolder again(out);
      ADD_FAILURE() << "two builds shared a scratch folder";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(out + ".cells"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("in use by process " + std::to_string(getpid())), std::string::npos);
    }
    touch(s.path() + "/work");
  }
  EXPECT_FALSE(fs::exists(out + ".cells"));
  // Left by a dead process: removed and taken over.
  fs::create_directories(out + ".cells");
  touch(out + ".cells/stuff", 10000);
  std::ofstream(out + ".cells/owner") << dead_pid() << "\n";
  {
    ScratchFolder s(out);
    EXPECT_FALSE(fs::exists(out + ".cells/stuff"));
  }
  // Owned by another live process: refused, the folder untouched.
  fs::create_directories(out + ".cells");
  std::ofstream(out + ".cells/owner") << getppid() << "\n";
  EXPECT_THROW(ScratchFolder s(out), Error);
  EXPECT_TRUE(fs::exists(out + ".cells/owner"));
}

// ---- the ugvr binary, interrupted -------------------------------------------------------------------------------

// Starts `ugvr --quiet ARGS...` with its output in `log`; returns its pid.
pid_t spawn_ugvr(const std::vector<std::string>& args, const std::string& log) {
  std::vector<std::string> all{UGVR_BINARY, "--quiet"};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, UGVR_BINARY, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

// Bytes in the temporaries of `dir` (names with ".tmp-" or ".cells"), 0 if there are none.
uint64_t temporary_bytes(const std::string& dir) {
  uint64_t total = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const std::string p = e.path().string();
    if (e.is_regular_file() && (p.find(".tmp-") != std::string::npos || p.find(".cells") != std::string::npos))
      total += e.file_size();
  }
  return total;
}

// Waits until the job has written `bytes` of temporaries (or has ended); true if it is still running.
bool wait_until_writing(pid_t pid, const std::string& dir, uint64_t bytes) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  while (std::chrono::steady_clock::now() < deadline) {
    if (waitpid(pid, nullptr, WNOHANG) != 0) return false;
    std::error_code ec;
    if (temporary_bytes(dir) >= bytes) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class KilledJobs : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // A mesh whose out-of-core build under a 64 MiB budget runs for a few seconds, written once for the suite (no
    // ScratchDir here: it is named after the running test).
    mesh_dir_ = (fs::temp_directory_path() / ("ugvr-test-KilledJobs-" + std::to_string(getpid()))).string();
    fs::remove_all(mesh_dir_);
    fs::create_directories(mesh_dir_);
    mesh_ = mesh_dir_ + "/mesh.vtu";
    const auto r = test::run_ugvr("generate -o " + mesh_ + " --cells 300000 --kind tet");
    ASSERT_EQ(r.status, 0) << r.out;
  }
  static void TearDownTestSuite() { fs::remove_all(mesh_dir_); }
  static std::string mesh_dir_, mesh_;
  ScratchDir dir_;
};
std::string KilledJobs::mesh_dir_, KilledJobs::mesh_;

std::vector<std::string> build_args(const std::string& mesh, const std::string& out) {
  return {"build", mesh, "-o", out, "--out-of-core", "--memory", "64MiB", "--threads", "2"};
}

TEST_F(KilledJobs, InterruptedBuildLeavesNothing) {
  for (int sig : {SIGTERM, SIGINT}) {
    const std::string out = dir_.file("out.ugvr"), log = dir_.file("log-" + std::to_string(sig));
    const pid_t pid = spawn_ugvr(build_args(mesh_, out), log);
    ASSERT_GT(pid, 0);
    const bool running = wait_until_writing(pid, dir_.file(""), 1 << 20);
    if (!running) GTEST_SKIP() << "the build ended before it could be interrupted: " << read_text(log);
    EXPECT_TRUE(fs::exists(out + ".cells")) << "the scratch folder has one name";
    kill(pid, sig);
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    // Killed by the signal itself (the handler re-raises), not exiting: the shell still sees 128 + sig.
    EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == sig) << status << " " << read_text(log);
    EXPECT_EQ(entries(dir_.file("")), (std::set<std::string>{"log-" + std::to_string(sig)})) << strsignal(sig);
    fs::remove(log);
  }
}

TEST_F(KilledJobs, InterruptedGenerateLeavesNothing) {
  const std::string out = dir_.file("big.vtu"), log = dir_.file("log");
  const pid_t pid = spawn_ugvr({"generate", "-o", out, "--cells", "20000000", "--kind", "tet"}, log);
  ASSERT_GT(pid, 0);
  if (!wait_until_writing(pid, dir_.file(""), 8 << 20)) GTEST_SKIP() << "generate ended early: " << read_text(log);
  kill(pid, SIGINT);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGINT) << status;
  EXPECT_EQ(entries(dir_.file("")), (std::set<std::string>{"log"}));
}

TEST_F(KilledJobs, InterruptedConvertLeavesNothing) {
  const std::string out = dir_.file("copy.vtu"), log = dir_.file("log");
  const pid_t pid = spawn_ugvr({"convert", mesh_, out}, log);
  ASSERT_GT(pid, 0);
  if (!wait_until_writing(pid, dir_.file(""), 1 << 20)) GTEST_SKIP() << "convert ended early: " << read_text(log);
  kill(pid, SIGTERM);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  EXPECT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGTERM) << status;
  EXPECT_EQ(entries(dir_.file("")), (std::set<std::string>{"log"}));
}

TEST_F(KilledJobs, KilledBuildIsCleanedByTheNextRun) {
  const std::string out = dir_.file("out.ugvr"), log = dir_.file("log");
  const pid_t pid = spawn_ugvr(build_args(mesh_, out), log);
  ASSERT_GT(pid, 0);
  if (!wait_until_writing(pid, dir_.file(""), 1 << 20)) GTEST_SKIP() << "build ended early: " << read_text(log);
  kill(pid, SIGKILL);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL);
  // SIGKILL cannot be caught: the scratch folder (and maybe the store's temporary) stay...
  ASSERT_TRUE(fs::exists(out + ".cells"));
  EXPECT_GT(temporary_bytes(dir_.file("")), uint64_t(1) << 20);
  // ...until the next run of the same output, which removes them and says so (a small mesh, to be quick).
  const std::string small = dir_.file("small.vtu");
  ASSERT_EQ(test::run_ugvr("generate -o " + small + " --cells 10000 --kind tet").status, 0);
  const auto r = test::run_ugvr("build " + small + " -o " + out + " --out-of-core --memory 64MiB");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("ugvr: removed " + out + ".cells"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("left by process " + std::to_string(pid) + ", which is no longer running"), std::string::npos)
      << r.out;
  EXPECT_EQ(entries(dir_.file("")), (std::set<std::string>{"log", "out.ugvr", "small.vtu"}));
}

// A full disk during a job: a clean error naming the output, exit status 1, and nothing left behind. The disk is made
// "full" for the job alone with a file-size limit (ulimit -f) and SIGXFSZ ignored, so that its writes fail with
// EFBIG, through the same error path as ENOSPC.
TEST_F(KilledJobs, AFullDiskGivesACleanErrorAndNoPartialOutput) {
  struct Job {
    std::string name, args, output;
  };
  const std::vector<Job> jobs{
      {"convert", "convert " + mesh_ + " " + dir_.file("copy.vtu"), "copy.vtu"},
      {"build", "build " + mesh_ + " -o " + dir_.file("out.ugvr") + " --out-of-core --memory 64MiB", "out.ugvr"},
      {"generate", "generate -o " + dir_.file("big.vtu") + " --cells 300000 --kind tet", "big.vtu"},
  };
  for (const Job& job : jobs) {
    const std::string cmd =
        "bash -c 'trap \"\" XFSZ; ulimit -f 2048; exec " + std::string(UGVR_BINARY) + " --quiet " + job.args + "' 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::string out;
    char buf[4096];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    const int status = pclose(p);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1) << job.name << ": " << status << " " << out;
    EXPECT_NE(out.find("File too large"), std::string::npos) << job.name << ": " << out;
    EXPECT_NE(out.find(job.output), std::string::npos) << job.name << " names its output: " << out;
    EXPECT_EQ(entries(dir_.file("")), std::set<std::string>{}) << job.name << " left something behind";
  }
}

}  // namespace
}  // namespace ugvr
