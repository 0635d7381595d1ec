// Output files written whole through a temporary file and a rename (output_file.h).
#include "irgrid/io/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>

#include <fmt/format.h>

#include "irgrid/error.h"

namespace irgrid {
namespace {

[[noreturn]] void fail(const std::string& path, const char* what, int error) {
  throw Error(ErrorCode::io, fmt::format("{}: {}: {}", path, what, std::strerror(error)));
}

/// Writes all of `bytes` to `fd`, retrying short writes; false (errno set) on failure.
bool write_all(int fd, std::string_view bytes) {
  while (!bytes.empty()) {
    const ssize_t written = ::write(fd, bytes.data(), bytes.size());
    if (written < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    if (written == 0) {
      errno = ENOSPC;
      return false;
    }
    bytes.remove_prefix(std::size_t(written));
  }
  return true;
}

/// Closes `fd` when destroyed unless released.
struct FileDescriptor {
  int fd = -1;
  ~FileDescriptor() {
    if (fd >= 0) ::close(fd);
  }
  int release() {
    const int out = fd;
    fd = -1;
    return out;
  }
};

void write_in_place(const std::string& path, std::string_view bytes) {
  FileDescriptor file{::open(path.c_str(), O_WRONLY | O_CLOEXEC)};
  if (file.fd < 0) fail(path, "cannot open", errno);
  if (!write_all(file.fd, bytes)) fail(path, "write failed", errno);
  if (::close(file.release()) != 0) fail(path, "write failed", errno);
}

}  // namespace

void write_file_whole(const std::string& path, std::string_view bytes) {
  struct stat existing {};
  if (::stat(path.c_str(), &existing) == 0 && !S_ISREG(existing.st_mode)) {
    if (S_ISDIR(existing.st_mode)) fail(path, "cannot write", EISDIR);
    write_in_place(path, bytes);
    return;
  }
  std::string temporary = path + ".tmp-XXXXXX";
  FileDescriptor file{::mkstemp(temporary.data())};
  if (file.fd < 0) fail(path, "cannot create a temporary file beside it", errno);
  const auto remove_temporary = [&] { ::unlink(temporary.c_str()); };
  // mkstemp makes the file private (0600); an output file gets the usual mode.
  const mode_t mask = ::umask(0);
  ::umask(mask);
  if (::fchmod(file.fd, 0666 & ~mask) != 0 || !write_all(file.fd, bytes) || ::fsync(file.fd) != 0) {
    const int error = errno;
    remove_temporary();
    fail(path, "write failed", error);
  }
  if (::close(file.release()) != 0) {
    const int error = errno;
    remove_temporary();
    fail(path, "write failed", error);
  }
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    const int error = errno;
    remove_temporary();
    fail(path, "cannot replace", error);
  }
}

}  // namespace irgrid
