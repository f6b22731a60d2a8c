// Velodyne scan reader, KITTI lidar/camera calibration parser and one-time archive extraction.
#include "velodyne.hpp"

#include <fcntl.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"

extern char** environ;

namespace hf::lidar {

namespace fs = std::filesystem;

cv::Vec3d LidarCalibration::velo_to_rect(const cv::Vec3d& p) const {
  const cv::Vec4d h(p[0], p[1], p[2], 1.0);
  return R0_rect * (Tr_velo_to_cam * h);
}

cv::Vec3d LidarCalibration::rect_to_cam2() const {
  // P2 = K [I | t] with K upper triangular: solve K t = P2[:, 3].
  const double fx = P2(0, 0), s = P2(0, 1), cx = P2(0, 2), fy = P2(1, 1), cy = P2(1, 2);
  const double tz = P2(2, 3);
  const double ty = (P2(1, 3) - cy * tz) / fy;
  const double tx = (P2(0, 3) - cx * tz - s * ty) / fx;
  return {tx, ty, tz};
}

LidarCalibration read_lidar_calibration(const fs::path& file) {
  if (!fs::exists(file)) throw Error("lidar calibration '" + file.string() + "' does not exist");
  std::ifstream in(file);
  if (!in) throw Error("lidar calibration '" + file.string() + "' cannot be read");
  std::map<std::string, std::vector<double>> values;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    std::string key = line.substr(0, colon);
    if (key == "P_rect_02") key = "P2";
    if (key == "R_rect_00") key = "R0_rect";
    if (key != "P2" && key != "R0_rect" && key != "Tr_velo_to_cam") continue;
    std::istringstream ss(line.substr(colon + 1));
    std::vector<double> v;
    for (std::string tok; ss >> tok;) {
      size_t used = 0;
      double x = 0;
      try {
        x = std::stod(tok, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != tok.size())
        throw Error(file.string() + ":" + std::to_string(n) + ": error: " + key + ": '" + tok +
                    "' is not a number");
      v.push_back(x);
    }
    const size_t want = key == "R0_rect" ? 9 : 12;
    if (v.size() != want)
      throw Error(file.string() + ":" + std::to_string(n) + ": error: " + key + " needs " +
                  std::to_string(want) + " numbers, got " + std::to_string(v.size()));
    values[key] = v;
  }
  for (const char* k : {"P2", "R0_rect", "Tr_velo_to_cam"})
    if (!values.count(k))
      throw Error("lidar calibration '" + file.string() + "' has no " + k +
                  " line (KITTI tracking format: P2, R0_rect, Tr_velo_to_cam)");
  LidarCalibration c;
  for (int i = 0; i < 12; ++i) {
    c.P2(i / 4, i % 4) = values["P2"][static_cast<size_t>(i)];
    c.Tr_velo_to_cam(i / 4, i % 4) = values["Tr_velo_to_cam"][static_cast<size_t>(i)];
  }
  for (int i = 0; i < 9; ++i) c.R0_rect(i / 3, i % 3) = values["R0_rect"][static_cast<size_t>(i)];
  if (!(c.P2(0, 0) > 0) || !(c.P2(1, 1) > 0))
    throw Error("lidar calibration '" + file.string() + "': P2 has a non-positive focal length");
  return c;
}

std::vector<cv::Vec4f> read_scan(const fs::path& file) {
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) throw Error("Velodyne scan '" + file.string() + "' cannot be read: " + ec.message());
  if (size % sizeof(cv::Vec4f) != 0)
    throw Error("Velodyne scan '" + file.string() + "' has " + std::to_string(size) +
                " bytes, not a multiple of 16 (float32 x, y, z, reflectance per point)");
  std::vector<cv::Vec4f> pts(size / sizeof(cv::Vec4f));
  std::ifstream in(file, std::ios::binary);
  if (!in.read(reinterpret_cast<char*>(pts.data()), static_cast<std::streamsize>(size)))
    throw Error("Velodyne scan '" + file.string() + "' cannot be read");
  return pts;
}

fs::path find_scan_folder(const fs::path& root) {
  std::set<fs::path> folders;
  std::error_code ec;
  for (auto it = fs::recursive_directory_iterator(root, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec))
    if (it->is_regular_file() && it->path().extension() == ".bin") folders.insert(it->path().parent_path());
  if (ec) throw Error("cannot list '" + root.string() + "': " + ec.message());
  if (folders.empty()) throw Error("no Velodyne scans (*.bin) below '" + root.string() + "'");
  if (folders.size() > 1) {
    std::string list;
    for (const auto& f : folders) list += (list.empty() ? "" : ", ") + f.string();
    throw Error("several folders of Velodyne scans below '" + root.string() + "': " + list);
  }
  return *folders.begin();
}

namespace {

// Holds an exclusive flock on a file for its lifetime.
class FileLock {
 public:
  explicit FileLock(const fs::path& file) {
    fd_ = ::open(file.c_str(), O_CREAT | O_RDWR | O_CLOEXEC, 0644);
    if (fd_ < 0) throw Error("cannot open lock file '" + file.string() + "': " + std::strerror(errno));
    while (::flock(fd_, LOCK_EX) != 0)
      if (errno != EINTR) {
        ::close(fd_);
        throw Error("cannot lock '" + file.string() + "': " + std::strerror(errno));
      }
  }
  ~FileLock() {
    ::flock(fd_, LOCK_UN);
    ::close(fd_);
  }
  FileLock(const FileLock&) = delete;
  FileLock& operator=(const FileLock&) = delete;

 private:
  int fd_ = -1;
};

std::string read_text(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

fs::path extract_scans(const fs::path& archive, const fs::path& dest) {
  std::error_code ec;
  if (!fs::is_regular_file(archive))
    throw Error("Velodyne archive '" + archive.string() + "' does not exist");
  fs::create_directories(dest, ec);
  if (ec) throw Error("cannot create '" + dest.string() + "': " + ec.message());
  FileLock lock(dest / ".lock");
  // The marker names the archive, its size and modification time: a different archive is extracted afresh.
  const auto mtime = fs::last_write_time(archive).time_since_epoch().count();
  const std::string id = fs::absolute(archive).lexically_normal().string() + "\n" +
                         std::to_string(fs::file_size(archive)) + "\n" + std::to_string(mtime) + "\n";
  const fs::path marker = dest / ".extracted";
  if (!(fs::exists(marker) && read_text(marker) == id)) {
    fs::remove(marker, ec);
    const fs::path log = dest / "tar.log";
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
    // tar detects xz compression itself; -f names the archive, -C the destination.
    std::vector<std::string> args = {"tar", "-xf", archive.string(), "-C", dest.string()};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    pid_t pid = 0;
    const int rc = posix_spawnp(&pid, "tar", &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) throw Error("cannot run tar to extract '" + archive.string() + "': " + std::strerror(rc));
    int status = 0;
    while (waitpid(pid, &status, 0) < 0)
      if (errno != EINTR) throw Error("waiting for tar failed: " + std::string(std::strerror(errno)));
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
      throw Error("tar could not extract '" + archive.string() + "' into '" + dest.string() +
                  "': " + read_text(log));
    write_file_atomic(marker, id);
  }
  return find_scan_folder(dest);
}

}  // namespace hf::lidar
