#include "ugvr/core/file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "ugvr/core/error.h"

namespace ugvr {

namespace {
constexpr size_t kWriteBuffer = size_t(4) << 20;
std::atomic<uint64_t> g_temp_counter{0};
}  // namespace

std::string base_name(std::string_view path) {
  const auto slash = path.find_last_of('/');
  return std::string(slash == std::string_view::npos ? path : path.substr(slash + 1));
}

std::string dir_name(std::string_view path) {
  const auto slash = path.find_last_of('/');
  return slash == std::string_view::npos ? std::string() : std::string(path.substr(0, slash + 1));
}

std::string extension_lower(std::string_view path) {
  const std::string base = base_name(path);
  const auto dot = base.find_last_of('.');
  if (dot == std::string::npos || dot == 0) return {};
  std::string ext = base.substr(dot);
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

void pwrite_all(int fd, uint64_t offset, const void* data, size_t n, std::string_view name) {
  const auto* p = static_cast<const char*>(data);
  size_t done = 0;
  while (done < n) {
    const ssize_t w = ::pwrite(fd, p + done, n - done, off_t(offset + done));
    if (w < 0) {
      if (errno == EINTR) continue;
      fail_in(name, std::string("write failed: ") + std::strerror(errno));
    }
    done += size_t(w);
  }
}

InputFile::InputFile(std::string path) : path_(std::move(path)) {
  fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) fail_in(path_, std::string("cannot open: ") + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd_);
    fd_ = -1;
    fail_in(path_, "not a regular file");
  }
  size_ = uint64_t(st.st_size);
}

InputFile::~InputFile() {
  if (fd_ >= 0) ::close(fd_);
}

InputFile::InputFile(InputFile&& other) noexcept : path_(std::move(other.path_)), fd_(other.fd_), size_(other.size_) {
  other.fd_ = -1;
}

std::string InputFile::name() const { return base_name(path_); }

size_t InputFile::read_some_at(uint64_t offset, void* dst, size_t n) const {
  size_t done = 0;
  auto* out = static_cast<char*>(dst);
  while (done < n) {
    const ssize_t r = ::pread(fd_, out + done, n - done, off_t(offset + done));
    if (r < 0) {
      if (errno == EINTR) continue;
      fail_at_offset(path_, offset + done, std::string("read failed: ") + std::strerror(errno));
    }
    if (r == 0) break;
    done += size_t(r);
  }
  return done;
}

void InputFile::read_at(uint64_t offset, void* dst, size_t n) const {
  if (offset > size_ || n > size_ - offset) {
    fail_at_offset(path_, offset,
                   "unexpected end of file: needed " + std::to_string(n) + " bytes, the file has " +
                       std::to_string(offset > size_ ? 0 : size_ - offset) + " left");
  }
  const size_t got = read_some_at(offset, dst, n);
  if (got != n) fail_at_offset(path_, offset + got, "unexpected end of file (file shrank while reading)");
}

std::string InputFile::read_all(uint64_t max_bytes) const {
  if (size_ > max_bytes) {
    fail_in(path_, "file of " + std::to_string(size_) + " bytes is larger than the " + std::to_string(max_bytes) +
                       " bytes this part of the reader keeps in memory");
  }
  std::string s(size_t(size_), '\0');
  read_at(0, s.data(), s.size());
  return s;
}

AtomicOutputFile::AtomicOutputFile(std::string path) : path_(std::move(path)) {
  temp_path_ = path_ + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(g_temp_counter++);
  remove_stale_temporaries(path_);
  // Registered before it exists, so that a signal from here on removes it.
  registration_ = TempRegistration(temp_path_, false);
  fd_ = ::open(temp_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) fail_in(path_, std::string("cannot create temporary output: ") + std::strerror(errno));
  buffer_.reserve(kWriteBuffer);
}

AtomicOutputFile::~AtomicOutputFile() {
  if (fd_ >= 0) ::close(fd_);
  if (!committed_) ::unlink(temp_path_.c_str());
  registration_.release();
}

void AtomicOutputFile::flush_buffer() {
  size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t w = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (w < 0) {
      if (errno == EINTR) continue;
      fail_in(path_, std::string("write failed: ") + std::strerror(errno));
    }
    done += size_t(w);
  }
  buffer_.clear();
}

void AtomicOutputFile::write(const void* data, size_t n) {
  const auto* p = static_cast<const char*>(data);
  position_ += n;
  if (buffer_.size() + n > kWriteBuffer) flush_buffer();
  if (n >= kWriteBuffer) {
    buffer_.assign(p, p + n);
    flush_buffer();
    return;
  }
  buffer_.insert(buffer_.end(), p, p + n);
}

void AtomicOutputFile::write_at(uint64_t offset, const void* data, size_t n) {
  flush_buffer();
  pwrite_all(fd_, offset, data, n, path_);
}

void AtomicOutputFile::commit() {
  flush_buffer();
  if (::fsync(fd_) != 0) fail_in(path_, std::string("fsync failed: ") + std::strerror(errno));
  ::close(fd_);
  fd_ = -1;
  if (::rename(temp_path_.c_str(), path_.c_str()) != 0) {
    fail_in(path_, std::string("cannot rename temporary output into place: ") + std::strerror(errno));
  }
  committed_ = true;
  registration_.release();
}

namespace {
constexpr size_t kScratchBuffer = size_t(1) << 20;

[[noreturn]] void fail_scratch(const std::string& path, const std::string& what) {
  fail_in(path, what + ": " + std::strerror(errno));
}
}  // namespace

BufferedFileWriter::BufferedFileWriter(std::string path, std::string what)
    : path_(std::move(path)), what_(std::move(what)) {
  file_ = std::fopen(path_.c_str(), "wb");
  if (!file_) fail_scratch(path_, "cannot create the " + what_);
  buffer_.reserve(kScratchBuffer);
}

BufferedFileWriter::~BufferedFileWriter() {
  if (file_) std::fclose(file_);
}

void BufferedFileWriter::append(const void* data, size_t n) {
  const auto* p = static_cast<const std::byte*>(data);
  while (n > 0) {
    const size_t take = std::min(n, kScratchBuffer - buffer_.size());
    buffer_.insert(buffer_.end(), p, p + take);
    p += take, n -= take;
    if (buffer_.size() == kScratchBuffer) flush();
  }
}

void BufferedFileWriter::flush() {
  if (!buffer_.empty() && std::fwrite(buffer_.data(), 1, buffer_.size(), file_) != buffer_.size())
    fail_scratch(path_, "cannot write the " + what_);
  buffer_.clear();
}

void BufferedFileWriter::close() {
  if (!file_) return;
  flush();
  const int rc = std::fclose(file_);
  file_ = nullptr;
  if (rc != 0) fail_scratch(path_, "cannot close the " + what_);
}

}  // namespace ugvr
