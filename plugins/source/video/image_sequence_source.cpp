// ImageSequenceSource: a sorted folder of images as a frame stream.
#include "image_sequence_source.hpp"

#include "hazardforge/image_file.hpp"

#include <fnmatch.h>

#include <algorithm>

namespace hf::source {

namespace fs = std::filesystem;

std::vector<fs::path> list_matching(const fs::path& folder, const std::string& pattern) {
  if (!fs::is_directory(folder)) throw Error("image folder '" + folder.string() + "' does not exist");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_regular_file() && fnmatch(pattern.c_str(), e.path().filename().c_str(), 0) == 0)
      files.push_back(e.path());
  std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
    return a.filename().string() < b.filename().string();
  });
  return files;
}

ComponentInfo ImageSequenceSource::describe() {
  ComponentInfo i = base_info("image_sequence", "frames from a folder of images sorted by name");
  i.doc =
      "Lists the files of `path` matching `pattern`, sorted by name, and emits them at `fps` (timestamps "
      "index / fps), or at the times their names carry (13/16/18-19-digit ms/us/ns stems). Camera params as "
      "for `video`.";
  i.params = {
      ParamSpec::path("path", std::nullopt).describe("folder of images"),
      ParamSpec::string("pattern", "*.png").describe("file name glob (fnmatch), e.g. *.jpg"),
      ParamSpec::number("fps", 0.0)
          .range(0, 1000)
          .describe("frame rate for timestamps (0 = not stated: 10 fps is assumed, with a warning)"),
      ParamSpec::integer("start_frame", 0)
          .range(0, std::nullopt)
          .describe("index of the first image to emit"),
      ParamSpec::integer("max_frames", -1).range(-1, std::nullopt).describe("images to emit (-1 = all)"),
  };
  for (ParamSpec& p : CameraSetup::params()) i.params.push_back(std::move(p));
  return i;
}

void ImageSequenceSource::open(StageContext& ctx) {
  const Params& p = ctx.params();
  const fs::path folder = p.get_path("path");
  const std::string pattern = p.get_string("pattern");
  files_ = list_matching(folder, pattern);
  if (files_.empty())
    throw Error("image folder '" + folder.string() + "' has no file matching '" + pattern + "'");
  const auto start = static_cast<size_t>(p.get_int("start_frame"));
  if (start >= files_.size())
    throw Error("image folder '" + folder.string() + "' has " + std::to_string(files_.size()) +
                " images, start_frame is " + std::to_string(start));
  files_.erase(files_.begin(), files_.begin() + static_cast<std::ptrdiff_t>(start));
  if (const long long m = p.get_int("max_frames"); m >= 0 && static_cast<size_t>(m) < files_.size())
    files_.resize(static_cast<size_t>(m));
  clock_ = folder_clock(files_, p.get_double("fps"), folder.string(), "the source's fps");
  if (clock_.warning) ctx.log(LogLevel::kWarning, *clock_.warning);
  setup_.configure(ctx);
  setup_.set_frame_times(clock_.times);
  setup_.init(read(0).size(), "image '" + files_[0].string() + "'", ctx);
  setup_.estimate_from_footage(
      [this]() -> CameraSetup::FrameReader {
        auto k = std::make_shared<size_t>(0);
        return [this, k](cv::Mat& out, std::string& what) {
          if (*k >= files_.size()) return false;
          what = "image '" + files_[*k].string() + "'";
          out = read((*k)++);
          return true;
        };
      },
      static_cast<int64_t>(files_.size()), clock_.fps, ctx);
  setup_.write_reports(ctx, static_cast<int64_t>(files_.size()), clock_.fps, clock_.source);
}

cv::Mat ImageSequenceSource::read(size_t k) const {
  return read_color_image(files_[k], "image '" + files_[k].string() + "' (frame " + std::to_string(k) + ")");
}

bool ImageSequenceSource::next(StageContext& /*ctx*/, Outputs& out) {
  if (pos_ >= files_.size()) return false;
  const fs::path& file = files_[pos_];
  cv::Mat raw = read(pos_);
  Frame f;
  f.index = static_cast<int64_t>(pos_);
  f.timestamp = clock_.at(pos_);
  f.image = setup_.prepare(raw, "image '" + file.string() + "'");
  f.camera = setup_.camera_at(static_cast<int64_t>(pos_));
  f.ego = setup_.ego_at(static_cast<int64_t>(pos_));
  f.ego_track = setup_.ego_track();
  f.road_markings = setup_.road_markings();
  f.stream_end = clock_.at(files_.size() - 1);
  f.source_id = file.filename().string();
  f.origin.dataset = "images";
  f.origin.scene = file.parent_path().filename().string();
  f.meta = {{"file", file.string()}, {"intrinsics", setup_.intrinsics_source()}};
  const double ts = f.timestamp;
  out.emit_packet("frames", Packet::make<Frame>(std::move(f), ts));
  ++pos_;
  return true;
}

}  // namespace hf::source
