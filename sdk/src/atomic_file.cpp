// Atomic file replacement and record files that never end in half a record.
#include "hazardforge/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>

#include "hazardforge/error.hpp"

namespace hf {

namespace fs = std::filesystem;

namespace {

std::string cause(int err) {
  return std::strerror(err);
}

// Writes all of `bytes`; returns 0 or the errno of the failure.
int write_all(int fd, std::string_view bytes) {
  const char* p = bytes.data();
  size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  return 0;
}

// Unique among threads and processes writing into the same folder.
fs::path temp_name(const fs::path& path) {
  static std::atomic<unsigned> counter{0};
  fs::path tmp = path;
  tmp += ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
  return tmp;
}

}  // namespace

void write_file_atomic(const fs::path& path, std::string_view bytes) {
  const fs::path tmp = temp_name(path);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(path.string() + ": cannot write: " + cause(errno));
  int err = write_all(fd, bytes);
  if (err == 0 && ::fsync(fd) != 0) err = errno;
  if (::close(fd) != 0 && err == 0) err = errno;
  if (err == 0 && ::rename(tmp.c_str(), path.c_str()) != 0) err = errno;
  if (err != 0) {
    ::unlink(tmp.c_str());
    throw Error(path.string() + ": cannot write: " + cause(err));
  }
}

void claim_output_file(const fs::path& path) {
  if (::unlink(path.c_str()) != 0 && errno != ENOENT)
    throw Error(path.string() + ": cannot replace: " + cause(errno));
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw Error(path.string() + ": cannot write: " + cause(errno));
  ::close(fd);
}

RecordFile::RecordFile(RecordFile&& o) noexcept : fd_(o.fd_), end_(o.end_), path_(std::move(o.path_)) {
  o.fd_ = -1;
}

RecordFile& RecordFile::operator=(RecordFile&& o) noexcept {
  if (this != &o) {
    close();
    fd_ = o.fd_;
    end_ = o.end_;
    path_ = std::move(o.path_);
    o.fd_ = -1;
  }
  return *this;
}

RecordFile::~RecordFile() {
  close();
}

void RecordFile::open(const fs::path& path, Mode mode) {
  close();
  path_ = path;
  const int flags =
      O_WRONLY | O_CREAT | O_NOFOLLOW | O_CLOEXEC | O_APPEND | (mode == Mode::kTruncate ? O_TRUNC : 0);
  fd_ = ::open(path.c_str(), flags, 0644);
  if (fd_ < 0) {
    const int err = errno;
    throw Error(path.string() + ": cannot write: " +
                (err == ELOOP
                     ? std::string("it is a symlink (refused: it could point outside the run folder)")
                     : cause(err)));
  }
  end_ = ::lseek(fd_, 0, SEEK_END);
}

void RecordFile::write(std::string_view text) {
  if (fd_ < 0) throw Error(path_.string() + ": cannot write: the file is not open");
  if (const int err = write_all(fd_, text); err != 0) {
    // A cut record would make the whole file unreadable to line-based readers; keep only whole records.
    if (::ftruncate(fd_, end_) != 0) {
    }
    throw Error(path_.string() + ": cannot write: " + cause(err));
  }
  end_ += static_cast<off_t>(text.size());
}

void RecordFile::close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

}  // namespace hf
