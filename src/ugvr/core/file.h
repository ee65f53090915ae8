// File access shared by the readers and writers.
//  - InputFile: positional reads (pread) that fail with the file name and offset on a short read, so a truncated
//    file is reported where it ends instead of yielding garbage. Safe to share between threads.
//  - AtomicOutputFile: writes to "<path>.tmp-<pid>-<n>" and renames over <path> only on commit(), so an interrupted
//    or failed write never leaves a file that looks complete; the temporary is removed if commit() is never reached,
//    by the signal handler on SIGINT / SIGTERM / SIGHUP (core/temp_files.h), and, after a SIGKILL, by the next
//    AtomicOutputFile of the same path (the stale temporaries of dead processes are removed when one is opened).
//  - BufferedFileWriter: a build's scratch file appended front to back in large blocks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <string_view>
#include <vector>

#include "ugvr/core/temp_files.h"

namespace ugvr {

class InputFile {
 public:
  explicit InputFile(std::string path);
  ~InputFile();
  InputFile(InputFile&& other) noexcept;
  InputFile& operator=(InputFile&&) = delete;
  InputFile(const InputFile&) = delete;
  InputFile& operator=(const InputFile&) = delete;

  const std::string& path() const { return path_; }
  // The path's last component, used in messages.
  std::string name() const;
  uint64_t size() const { return size_; }

  // Reads exactly n bytes at offset; throws ugvr::Error naming the file and offset if fewer are there.
  void read_at(uint64_t offset, void* dst, size_t n) const;
  // Reads up to n bytes; returns the count read (short only at end of file).
  size_t read_some_at(uint64_t offset, void* dst, size_t n) const;
  // Whole file in memory (for small text headers and fuzz-sized inputs); fails above max_bytes.
  std::string read_all(uint64_t max_bytes = uint64_t(1) << 30) const;

 private:
  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;
};

class AtomicOutputFile {
 public:
  explicit AtomicOutputFile(std::string path);
  ~AtomicOutputFile();
  AtomicOutputFile(const AtomicOutputFile&) = delete;
  AtomicOutputFile& operator=(const AtomicOutputFile&) = delete;

  void write(const void* data, size_t n);
  void write(std::string_view s) { write(s.data(), s.size()); }
  // Bytes written so far (the current end of file).
  uint64_t position() const { return position_; }
  // Overwrites bytes already written (for headers whose contents are known only at the end).
  void write_at(uint64_t offset, const void* data, size_t n);
  // Flushes, fsyncs and renames the temporary over the final path.
  void commit();
  const std::string& path() const { return path_; }

 private:
  void flush_buffer();

  std::string path_, temp_path_;
  int fd_ = -1;
  uint64_t position_ = 0;
  std::vector<char> buffer_;
  bool committed_ = false;
  TempRegistration registration_;  // the temporary, for the signal handler
};

// A scratch file of the build (not a result: no temporary-and-rename, no fsync) appended to front to back, 1 MiB at
// a time; truncates one that exists. `what` names it in errors ("temporary value file"): ugvr::Error naming the path,
// "cannot create / write / close the <what>: <reason>".
class BufferedFileWriter {
 public:
  BufferedFileWriter(std::string path, std::string what);
  ~BufferedFileWriter();  // closes without reporting errors
  BufferedFileWriter(const BufferedFileWriter&) = delete;
  BufferedFileWriter& operator=(const BufferedFileWriter&) = delete;

  void append(const void* data, size_t n);
  // Flushes and closes, reporting errors; nothing more may be appended.
  void close();
  const std::string& path() const { return path_; }

 private:
  void flush();
  std::string path_, what_;
  std::FILE* file_ = nullptr;
  std::vector<std::byte> buffer_;
};

// Writes all n bytes at offset of an open descriptor (retrying short writes and EINTR); throws ugvr::Error naming
// `name` on failure.
void pwrite_all(int fd, uint64_t offset, const void* data, size_t n, std::string_view name);

// Last path component ("dir/a.vtu" -> "a.vtu").
std::string base_name(std::string_view path);
// Directory part with trailing slash, or "" ("dir/a.vtu" -> "dir/").
std::string dir_name(std::string_view path);
// Lower-case extension with the dot (".vtu"), or "" if none.
std::string extension_lower(std::string_view path);

}  // namespace ugvr
