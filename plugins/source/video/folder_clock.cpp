// Internal: per-frame times from an image folder's file names, else a stated or assumed frame rate.
#include "folder_clock.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>

namespace hf::source {

std::optional<NamedTimes> times_from_names(const std::vector<std::filesystem::path>& files) {
  if (files.size() < 2) return std::nullopt;
  std::vector<int64_t> ticks;
  size_t digits = 0;
  for (const auto& f : files) {
    const std::string stem = f.stem().string();
    size_t b = stem.size();
    while (b > 0 && std::isdigit(static_cast<unsigned char>(stem[b - 1]))) --b;
    const size_t n = stem.size() - b;
    if (n != 13 && n != 16 && n != 18 && n != 19) return std::nullopt;
    if (digits != 0 && n != digits) return std::nullopt;
    digits = n;
    int64_t v = 0;
    for (size_t i = b; i < stem.size(); ++i) {
      const int d = stem[i] - '0';
      if (v > (INT64_MAX - d) / 10) return std::nullopt;
      v = v * 10 + d;
    }
    if (!ticks.empty() && v <= ticks.back()) return std::nullopt;
    ticks.push_back(v);
  }
  const double per_s = digits == 13 ? 1e3 : digits == 16 ? 1e6 : 1e9;  // 18 digits: ns since 1980 (GPS)
  NamedTimes out;
  out.unit = digits == 13 ? "ms" : digits == 16 ? "us" : "ns";
  std::vector<double> iv;
  for (size_t k = 0; k < ticks.size(); ++k) {
    out.seconds.push_back(static_cast<double>(ticks[k] - ticks[0]) / per_s);
    if (k > 0) iv.push_back(out.seconds[k] - out.seconds[k - 1]);
  }
  std::nth_element(iv.begin(), iv.begin() + static_cast<std::ptrdiff_t>(iv.size() / 2), iv.end());
  out.median_interval_s = iv[iv.size() / 2];
  if (!(out.median_interval_s >= 1e-3 && out.median_interval_s <= 10.0)) return std::nullopt;
  return out;
}

FolderClock folder_clock(const std::vector<std::filesystem::path>& files, double stated_fps,
                         const std::string& folder, const std::string& fps_param) {
  FolderClock c;
  const auto named = times_from_names(files);
  std::string names;
  if (named) {
    double lo = named->seconds[1], hi = lo;
    for (size_t k = 1; k < named->seconds.size(); ++k) {
      const double d = named->seconds[k] - named->seconds[k - 1];
      lo = std::min(lo, d);
      hi = std::max(hi, d);
    }
    auto s3 = [](double v) { return std::to_string(std::round(v * 1000) / 1000).substr(0, 5); };
    names = "per-frame times from the file names (" + named->unit + " timestamps; intervals " + s3(lo) + "-" +
            s3(hi) + " s, median " + s3(named->median_interval_s) + " s)";
  }
  if (stated_fps > 0) {
    c.fps = stated_fps;
    c.source = "stated";
    if (named) {
      const double rate = 1.0 / named->median_interval_s;
      if (std::abs(rate - stated_fps) <= 0.05 * rate) {
        c.times = named->seconds;
        c.source = "stated; " + names;
      } else {
        c.warning = "image folder '" + folder + "': the file names carry times at " + std::to_string(rate) +
                    " fps (" + names + "), the stated frame rate is " + std::to_string(stated_fps) +
                    " fps; timing the frames at the stated rate";
        c.source = "stated (the file names' times disagree: " + names + ")";
      }
    }
    return c;
  }
  if (named) {
    c.fps = 1.0 / named->median_interval_s;
    c.times = named->seconds;
    c.source = names;
    return c;
  }
  c.fps = 10.0;
  c.source = "assumed 10 fps: an image folder has no frame rate (state " + fps_param + ")";
  c.warning = "image folder '" + folder + "': no frame rate stated; ASSUMING 10 fps. Every speed, TTC and time "
              "in this run scales with it: set " + fps_param;
  return c;
}

}  // namespace hf::source
