#include "cloth_sim/io/bounded_file.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace cloth_sim::core {

namespace {

/// Closes a descriptor on every way out.
class FileDescriptor {
 public:
  explicit FileDescriptor(int fd) : fd_(fd) {}
  ~FileDescriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  FileDescriptor(const FileDescriptor&) = delete;
  FileDescriptor& operator=(const FileDescriptor&) = delete;
  int get() const { return fd_; }

 private:
  int fd_;
};

}  // namespace

PathKind pathKind(const std::string& path, std::string* lookup_error) {
  struct stat status {};
  if (::lstat(path.c_str(), &status) != 0) {
    if (errno == ENOENT || errno == ENOTDIR) return PathKind::kAbsent;
    if (lookup_error != nullptr) *lookup_error = std::strerror(errno);
    return PathKind::kUnreachable;
  }
  if (S_ISREG(status.st_mode)) return PathKind::kRegularFile;
  if (S_ISDIR(status.st_mode)) return PathKind::kDirectory;
  return PathKind::kOther;
}

namespace {

/// Opens a regular file (non-blocking: opening a FIFO or a device for reading returns at once instead of
/// waiting for a writer) and checks its kind on what was opened, so nothing swapped in after a stat gets
/// read. -1 with the reason in *error otherwise.
int openRegularFile(const std::string& path, struct stat* status, std::string* error) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | O_NOCTTY);
  if (fd < 0) {
    *error = errno == ENOENT ? "no such file" : std::string("cannot be opened: ") + std::strerror(errno);
    return -1;
  }
  std::string problem;
  if (::fstat(fd, status) != 0) {
    problem = std::string("cannot be read: ") + std::strerror(errno);
  } else if (S_ISDIR(status->st_mode)) {
    problem = "is a directory, not a regular file";
  } else if (!S_ISREG(status->st_mode)) {
    problem = "not a regular file";
  }
  if (problem.empty()) return fd;
  ::close(fd);
  *error = problem;
  return -1;
}

/// Reads into `buffer` from offset `held` until it is full or the file ends; the bytes it then holds, or
/// -1 (errno set).
long readFully(int fd, std::string* buffer, std::size_t held = 0) {
  while (held < buffer->size()) {
    const ssize_t n = ::read(fd, &(*buffer)[held], buffer->size() - held);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return -1;
    if (n == 0) break;
    held += static_cast<std::size_t>(n);
  }
  return static_cast<long>(held);
}

}  // namespace

bool readRegularFileStart(const std::string& path, std::size_t count, std::string* bytes, std::string* error) {
  bytes->clear();
  struct stat status {};
  const FileDescriptor file(openRegularFile(path, &status, error));
  if (file.get() < 0) return false;
  std::string read(count, '\0');
  const long held = readFully(file.get(), &read);
  if (held < 0) {
    *error = std::string("cannot be read: ") + std::strerror(errno);
    return false;
  }
  read.resize(static_cast<std::size_t>(held));
  *bytes = std::move(read);
  return true;
}

bool readBoundedRegularFile(const std::string& path, std::uintmax_t max_bytes, std::string* bytes,
                            std::string* error) {
  bytes->clear();
  struct stat status {};
  const FileDescriptor file(openRegularFile(path, &status, error));
  if (file.get() < 0) return false;
  const std::string too_big = "larger than the limit of " + std::to_string(max_bytes) + " bytes";
  const auto size = static_cast<std::uintmax_t>(status.st_size);
  if (size > max_bytes) {
    *error = std::to_string(size) + " bytes: " + too_big;
    return false;
  }
  // One byte past the size tells a file that grew since fstat (or that fstat calls empty, as /proc's)
  // from one that did not; such a file is read on, up to one byte past the limit.
  std::string read(static_cast<std::size_t>(size) + 1, '\0');
  long read_bytes = readFully(file.get(), &read);
  if (read_bytes == static_cast<long>(read.size()) && read.size() <= max_bytes) {
    read.resize(static_cast<std::size_t>(max_bytes) + 1);
    read_bytes = readFully(file.get(), &read, static_cast<std::size_t>(read_bytes));
  }
  if (read_bytes < 0) {
    *error = std::string("cannot be read: ") + std::strerror(errno);
    return false;
  }
  const auto held = static_cast<std::uintmax_t>(read_bytes);
  if (held > max_bytes) {
    *error = too_big;
    return false;
  }
  read.resize(held);
  *bytes = std::move(read);
  return true;
}

}  // namespace cloth_sim::core
