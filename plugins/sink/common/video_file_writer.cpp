// VideoFileWriter: raw BGR frames piped to `ffmpeg -c:v libx264` (or cv::VideoWriter), .partial then rename.
#include "hazardforge/sink/video_file_writer.hpp"
#include "hazardforge/atomic_file.hpp"

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <thread>

#include "hazardforge/error.hpp"

extern char** environ;

namespace hf::sink {

namespace fs = std::filesystem;

namespace {

// ffmpeg's stderr kept for error messages (it is tiny at -loglevel error; the cap guards against chatter).
constexpr size_t kStderrKeep = 4000;
// A bigger pipe (Linux allows 1 MiB unprivileged) lets one write() hand over more of a frame per wake-up.
constexpr int kPipeBytes = 1 << 20;

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : sep) + x;
  return s;
}

// SIGPIPE from writing to an exited ffmpeg is directed at the writing thread; blocking it there (instead of
// ignoring it process-wide) turns it into EPIPE, and a pending one is consumed before unblocking.
class SigpipeBlock {
 public:
  SigpipeBlock() {
    sigemptyset(&set_);
    sigaddset(&set_, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &set_, &old_);
  }
  ~SigpipeBlock() {
    sigset_t pending;
    sigpending(&pending);
    if (sigismember(&pending, SIGPIPE) && !sigismember(&old_, SIGPIPE)) {
      const timespec zero{0, 0};
      sigtimedwait(&set_, nullptr, &zero);
    }
    pthread_sigmask(SIG_SETMASK, &old_, nullptr);
  }

 private:
  sigset_t set_, old_;
};

bool has_libx264(const std::string& program) {
  static std::mutex mu;
  static std::map<std::string, bool> cache;
  std::lock_guard lk(mu);
  if (auto it = cache.find(program); it != cache.end()) return it->second;
  std::string quoted = "'";
  for (char c : program) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  quoted += "'";
  bool found = false;
  // "e": close-on-exec, so an encoder started meanwhile by another sink cannot inherit the pipe and hold it
  // open.
  if (FILE* p = popen((quoted + " -hide_banner -nostdin -encoders 2>/dev/null").c_str(), "re")) {
    char line[512];
    while (fgets(line, sizeof line, p))
      if (std::strstr(line, " libx264 ")) found = true;
    pclose(p);
  }
  return cache[program] = found;
}

std::string fps_text(double fps) {
  char buf[32];
  if (std::abs(fps - std::round(fps)) < 1e-9)
    std::snprintf(buf, sizeof buf, "%.0f", fps);
  else
    std::snprintf(buf, sizeof buf, "%.6f", fps);
  return buf;
}

}  // namespace

const std::vector<std::string>& x264_presets() {
  static const std::vector<std::string> k = {"ultrafast", "superfast", "veryfast", "faster",   "fast",
                                             "medium",    "slow",      "slower",   "veryslow", "placebo"};
  return k;
}

std::vector<ParamSpec> encoder_params() {
  return {
      ParamSpec::string("encoder", "ffmpeg")
          .one_of({"ffmpeg", "opencv"})
          .describe("H.264 writer: the ffmpeg program (falls back to opencv with a warning when missing) or "
                    "OpenCV's VideoWriter"),
      ParamSpec::string("preset", "ultrafast")
          .one_of(x264_presets())
          .describe(
              "x264 preset (ffmpeg encoder): slower presets make smaller files and cost more CPU per frame"),
      ParamSpec::integer("threads", 1)
          .range(0, 64)
          .describe("x264 encoder threads (ffmpeg encoder; 0 = one per core)"),
      ParamSpec::integer("crf", 23).range(0, 51).describe(
          "x264 constant rate factor (ffmpeg encoder): lower = better"),
  };
}

void read_encoder_params(const Params& p, VideoWriterOptions& o) {
  o.encoder = p.get_string("encoder");
  o.preset = p.get_string("preset");
  o.threads = static_cast<int>(p.get_int("threads"));
  o.crf = static_cast<int>(p.get_int("crf"));
}

std::string find_program(const std::string& name) {
  if (name.empty()) return {};
  if (name.find('/') != std::string::npos) return ::access(name.c_str(), X_OK) == 0 ? name : std::string();
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/local/bin:/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::string dir = dirs.substr(start, end - start);
    const std::string cand = (dir.empty() ? std::string(".") : dir) + "/" + name;
    if (::access(cand.c_str(), X_OK) == 0 && !fs::is_directory(cand)) return cand;
    start = end + 1;
  }
  return {};
}

fs::path partial_path(const fs::path& file) {
  return file.parent_path() / (file.stem().string() + ".partial" + file.extension().string());
}

struct VideoFileWriter::Ffmpeg {
  std::string program;
  pid_t pid = -1;
  int in = -1;  // our end of ffmpeg's stdin
  std::thread reader;
  std::mutex mu;
  std::string err;  // ffmpeg's stderr (the last kStderrKeep bytes)

  int status = 0;

  // Closes stdin, waits for ffmpeg and its stderr; returns the wait status (again on later calls).
  int wait() {
    if (in >= 0) ::close(in);
    in = -1;
    if (pid > 0)
      while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
      }
    pid = -1;
    if (reader.joinable()) reader.join();
    return status;
  }
  std::string stderr_text() {
    std::lock_guard lk(mu);
    std::string s = err;
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' ')) s.pop_back();
    return s;
  }
};

VideoFileWriter::VideoFileWriter() = default;

VideoFileWriter::~VideoFileWriter() {
  if (ffmpeg_) ffmpeg_->wait();
  if (cv_.isOpened()) cv_.release();
}

bool VideoFileWriter::is_open() const {
  return ffmpeg_ != nullptr || cv_.isOpened();
}

void VideoFileWriter::open(const VideoWriterOptions& options, const Warn& warn) {
  if (is_open()) throw Error("video '" + partial_.string() + "' is already open");
  opt_ = options;
  partial_ = partial_path(opt_.file);
  frames_ = 0;
  if (opt_.size.width <= 0 || opt_.size.height <= 0)
    throw Error("cannot write video '" + partial_.string() + "': empty frame size");
  if (!(opt_.fps > 0) || !std::isfinite(opt_.fps))
    throw Error("cannot write video '" + partial_.string() + "': frame rate " + std::to_string(opt_.fps));
  if (opt_.encoder != "ffmpeg" && opt_.encoder != "opencv")
    throw Error("cannot write video '" + partial_.string() + "': encoder '" + opt_.encoder +
                "' is not one of ffmpeg, opencv");
  const auto& presets = x264_presets();
  if (std::find(presets.begin(), presets.end(), opt_.preset) == presets.end())
    throw Error("cannot write video '" + partial_.string() + "': preset '" + opt_.preset +
                "' is not an x264 preset (" + join(presets, ", ") + ")");
  if (opt_.crf < 0 || opt_.crf > 51)
    throw Error("cannot write video '" + partial_.string() + "': crf " + std::to_string(opt_.crf) +
                " is outside 0..51");
  if (opt_.threads < 0)
    throw Error("cannot write video '" + partial_.string() + "': threads " + std::to_string(opt_.threads) +
                " is negative");
  std::error_code ec;
  fs::create_directories(partial_.parent_path(), ec);
  if (ec) throw Error("cannot create the folder of video '" + partial_.string() + "': " + ec.message());
  // The encoder opens the file by name and would write through a symlink planted there.
  claim_output_file(partial_);

  std::vector<std::string> tried;
  for (const std::string& c : opt_.codecs) {
    if (c.size() != 4)
      throw Error("cannot write video '" + partial_.string() + "': codec '" + c + "' is not a FOURCC");
    if (c == "avc1" && opt_.encoder == "ffmpeg") {
      const std::string program = find_program(opt_.ffmpeg_program);
      if (program.empty()) {
        if (warn)
          warn("'" + opt_.ffmpeg_program + "' not found on PATH; writing '" + partial_.string() +
               "' with OpenCV's VideoWriter instead (no preset/threads control, encodes with lookahead)");
      } else if (!has_libx264(program)) {
        if (warn)
          warn("'" + program + "' has no libx264 encoder; writing '" + partial_.string() +
               "' with OpenCV's VideoWriter instead");
      } else {
        start_ffmpeg(program);
        codec_ = c;
        backend_ = "ffmpeg";
        if (!tried.empty() && warn)
          warn("no encoder for " + join(tried, ", ") + "; writing '" + partial_.string() + "' as " + c);
        return;
      }
    }
    if (cv_.open(partial_.string(), cv::CAP_FFMPEG, cv::VideoWriter::fourcc(c[0], c[1], c[2], c[3]), opt_.fps,
                 opt_.size) &&
        cv_.isOpened()) {
      codec_ = c;
      backend_ = "opencv";
      if (!tried.empty() && warn)
        warn("no encoder for " + join(tried, ", ") + "; writing '" + partial_.string() + "' as " + c);
      return;
    }
    tried.push_back(c);
  }
  throw Error("cannot write video '" + partial_.string() + "': no encoder for " + join(opt_.codecs, " or "));
}

void VideoFileWriter::start_ffmpeg(const std::string& program) {
  std::vector<std::string> args = {
      program,      "-hide_banner",
      "-nostdin",   "-loglevel",
      "error",      "-y",
      "-f",         "rawvideo",
      "-pix_fmt",   "bgr24",
      "-s",         std::to_string(opt_.size.width) + "x" + std::to_string(opt_.size.height),
      "-framerate", fps_text(opt_.fps),
      "-i",         "pipe:0",
      "-an"};
  // yuv420p needs even sides; an odd one gets one black row/column rather than failing.
  if (opt_.size.width % 2 || opt_.size.height % 2)
    args.insert(args.end(), {"-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"});
  // zerolatency: no lookahead and no B-frames, so each frame is encoded as it arrives and nothing piles up
  // for the end of the stream.
  args.insert(args.end(), {"-c:v", "libx264", "-preset", opt_.preset, "-tune", "zerolatency", "-crf",
                           std::to_string(opt_.crf), "-threads", std::to_string(opt_.threads), "-pix_fmt",
                           "yuv420p", "-movflags", "+faststart", "-f", "mp4", partial_.string()});

  int in[2], err[2];
  if (pipe2(in, O_CLOEXEC) != 0)
    throw Error("cannot write video '" + partial_.string() + "': pipe: " + std::strerror(errno));
  if (pipe2(err, O_CLOEXEC) != 0) {
    const int e = errno;
    ::close(in[0]);
    ::close(in[1]);
    throw Error("cannot write video '" + partial_.string() + "': pipe: " + std::strerror(e));
  }
  fcntl(in[1], F_SETPIPE_SZ, kPipeBytes);  // best effort: a smaller pipe only costs more wake-ups
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, in[0], 0);
  posix_spawn_file_actions_adddup2(&fa, err[1], 2);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  // Own process group: Ctrl-C in the terminal reaches only the host, which then lets the sink finish() and
  // close the pipe, so ffmpeg ends the file normally instead of being interrupted mid-write. Default signal
  // mask and dispositions, whatever the spawning thread had blocked.
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  posix_spawnattr_setpgroup(&attr, 0);
  sigset_t none, defaults;
  sigemptyset(&none);
  posix_spawnattr_setsigmask(&attr, &none);
  sigemptyset(&defaults);
  for (int sig : {SIGPIPE, SIGINT, SIGTERM}) sigaddset(&defaults, sig);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, program.c_str(), &fa, &attr, argv.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&fa);
  ::close(in[0]);
  ::close(err[1]);
  if (rc != 0) {
    ::close(in[1]);
    ::close(err[0]);
    throw Error("cannot write video '" + partial_.string() + "': cannot start '" + program +
                "': " + std::strerror(rc));
  }
  ffmpeg_ = std::make_unique<Ffmpeg>();
  ffmpeg_->program = program;
  ffmpeg_->pid = pid;
  ffmpeg_->in = in[1];
  Ffmpeg* f = ffmpeg_.get();
  const int fd = err[0];
  f->reader = std::thread([f, fd] {
    char buf[1024];
    for (;;) {
      const ssize_t n = ::read(fd, buf, sizeof buf);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) break;
      std::lock_guard lk(f->mu);
      f->err.append(buf, static_cast<size_t>(n));
      if (f->err.size() > kStderrKeep) f->err.erase(0, f->err.size() - kStderrKeep);
    }
    ::close(fd);
  });
}

void VideoFileWriter::ffmpeg_failed(const std::string& what) {
  const std::string program = ffmpeg_->program;
  const int status = ffmpeg_->wait();
  const std::string err = ffmpeg_->stderr_text();
  ffmpeg_.reset();
  const std::string how = WIFEXITED(status) ? "exited with code " + std::to_string(WEXITSTATUS(status))
                                            : "was killed by signal " + std::to_string(WTERMSIG(status));
  throw Error("cannot write video '" + partial_.string() + "': " + what + (what.empty() ? "" : "; ") +
              program + " " + how + " after " + std::to_string(frames_) + " frame(s)" +
              (err.empty() ? std::string() : ": " + err));
}

void VideoFileWriter::write(const cv::Mat& frame) {
  if (!is_open()) throw Error("video '" + partial_.string() + "' is not open");
  if (frame.type() != CV_8UC3 || frame.size() != opt_.size)
    throw Error("video '" + partial_.string() + "': frame " + std::to_string(frames_) + " is " +
                std::to_string(frame.cols) + "x" + std::to_string(frame.rows) + " type " +
                std::to_string(frame.type()) + ", expected " + std::to_string(opt_.size.width) + "x" +
                std::to_string(opt_.size.height) + " BGR 8-bit");
  if (!ffmpeg_) {
    cv_.write(frame);
    ++frames_;
    return;
  }
  const cv::Mat m = frame.isContinuous() ? frame : frame.clone();
  const auto* p = m.ptr<const char>(0);
  size_t left = m.total() * m.elemSize();
  SigpipeBlock guard;
  while (left > 0) {
    const ssize_t n = ::write(ffmpeg_->in, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      ffmpeg_failed(e == EPIPE ? std::string("the encoder stopped reading frames")
                               : std::string("writing to the encoder: ") + std::strerror(e));
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  ++frames_;
}

void VideoFileWriter::close() {
  if (!is_open()) return;
  if (ffmpeg_) {
    const int status = ffmpeg_->wait();
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) ffmpeg_failed("");
    ffmpeg_.reset();
  } else {
    cv_.release();
  }
  std::error_code ec;
  fs::rename(partial_, opt_.file, ec);
  if (ec)
    throw Error("cannot rename '" + partial_.string() + "' to '" + opt_.file.string() + "': " + ec.message());
}

std::string VideoFileWriter::description() const {
  if (backend_ == "ffmpeg")
    return codec_ + " via ffmpeg/libx264 (preset " + opt_.preset + ", " +
           (opt_.threads == 0 ? std::string("auto threads")
                              : std::to_string(opt_.threads) + (opt_.threads == 1 ? " thread" : " threads")) +
           ", crf " + std::to_string(opt_.crf) + ")";
  return codec_ + " via OpenCV";
}

}  // namespace hf::sink
