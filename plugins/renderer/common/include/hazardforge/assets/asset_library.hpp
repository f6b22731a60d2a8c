// Appearance assets: the assets.yaml index format (shared by the generator, the harvester and the renderer)
// and the in-memory library the renderer picks sprites from.
#pragma once

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace hf::render {

inline constexpr const char* kAssetIndexFile = "assets.yaml";
inline constexpr const char* kAssetFormat = "hazardforge-assets";
inline constexpr int kAssetFormatVersion = 1;

// One object picture with alpha and the geometry needed to map it onto a projected 3D box.
struct AssetSpec {
  std::string file;          // PNG (BGRA) relative to the index's folder
  std::string object_class;  // car, truck, bus, person, ...
  std::string view;          // front, front_left, left, rear_left, rear, rear_right, right, front_right
  double azimuth_deg = 0.0;  // camera direction seen from the object, object frame (see box_geometry.hpp)
  cv::Vec3d size_lwh;        // real-world size of the object's box, m
  cv::Size image_size;
  cv::Point2d anchor_px;                      // ground-contact centre (projection of the box's bottom centre)
  std::array<cv::Point2d, 8> box_corners_px;  // the box's corners in the picture (order of box_geometry.hpp)
  std::string source;                         // "generated" or "harvested"
  std::string instance;                       // model name or dataset instance token: one physical object
  std::string origin;                         // where it came from (frame, sample token), free text
};

struct AssetIndex {
  std::vector<AssetSpec> assets;
};

// Reads <dir>/assets.yaml. Throws hf::Error "file:line:col: ..." naming the field for anything malformed,
// and naming the PNG when a listed file is missing.
AssetIndex load_asset_index(const std::filesystem::path& dir);
// Writes <dir>/assets.yaml atomically (temporary file + rename). `comment` becomes the file's header.
void save_asset_index(const std::filesystem::path& dir, const AssetIndex& index, const std::string& comment);
// Writes a BGRA picture atomically.
void write_png_atomic(const std::filesystem::path& file, const cv::Mat& bgra);

// A loaded asset, prepared for fast warping: a pyramid of colour (with colours bled into transparent pixels
// so interpolation at the edge never darkens) and alpha, plus the colour statistics used for harmonisation.
struct LoadedAsset {
  AssetSpec spec;
  std::filesystem::path dir;
  bool from_fallback = false;
  // Level 0 is the file; each level is padded by `pad` pixels (colour replicated, alpha zero) so warping
  // never samples outside the picture. Pixel (x, y) of the file is at ((x + 0.5) / 2^k - 0.5 + pad) on level
  // k.
  std::vector<cv::Mat> bgr;    // CV_8UC3
  std::vector<cv::Mat> lab;    // CV_8UC3, bgr in 8-bit Lab (harmonisation works there)
  std::vector<cv::Mat> alpha;  // CV_8UC1
  int pad = 2;
  cv::Scalar lab_mean, lab_std;                  // 8-bit Lab statistics of the opaque pixels
  int level_for_height(double target_px) const;  // coarsest level still at least target_px tall
  cv::Point2d level_px(const cv::Point2d& file_px, int level) const;  // file pixel -> level pixel (with pad)
};

// Prepares one BGRA picture (tests and the harvester reuse this).
LoadedAsset prepare_asset(const AssetSpec& spec, const cv::Mat& bgra);

// All assets of a primary folder plus, optionally, the default set for classes and views it lacks. Pictures
// are decoded when loaded (so a broken file fails at open) and prepared for warping on first use.
class AssetLibrary {
 public:
  // Loads every asset of `primary` and of `fallback` (skipped when empty or the same folder).
  static AssetLibrary load(const std::filesystem::path& primary, const std::filesystem::path& fallback = {});
  // The same with fallback folders in order of preference (empty ones and repeats skipped).
  static AssetLibrary load(const std::filesystem::path& primary,
                           const std::vector<std::filesystem::path>& fallbacks);
  AssetLibrary();
  AssetLibrary(AssetLibrary&&) noexcept;
  AssetLibrary& operator=(AssetLibrary&&) noexcept;
  ~AssetLibrary();
  // Adds a picture (BGRA) described by `spec`.
  void add(const AssetSpec& spec, const cv::Mat& bgra, const std::filesystem::path& dir, bool from_fallback);

  // The asset of `object_class` whose view is nearest `azimuth_deg`. Prefers `instance` (keeps one physical
  // object through a hazard), then the primary folder, then each fallback folder in order, each when its view
  // is within `max_view_error_deg`; else the nearest view anywhere.
  // Throws hf::Error naming the class and the classes available when there is none. Thread-safe.
  const LoadedAsset& select(const std::string& object_class, double azimuth_deg, const std::string& instance,
                            double max_view_error_deg) const;
  // Prepares every asset of a class now (otherwise each is prepared when first selected). Thread-safe.
  void prepare_class(const std::string& object_class) const;
  std::vector<std::string> classes() const;
  // The instances of a class among the pictures the project generated (AssetSpec::source "generated": the
  // default set's colours), in file order.
  std::vector<std::string> generated_instances(const std::string& object_class) const;
  const std::vector<AssetSpec>& specs() const { return specs_; }
  const cv::Mat& picture(size_t i) const { return pictures_.at(i); }  // the BGRA picture of specs()[i]
  std::string describe_folders() const;

 private:
  struct Cache;
  const LoadedAsset& prepared(size_t i) const;
  void add_at(const AssetSpec& spec, const cv::Mat& bgra, const std::filesystem::path& dir, int level);
  std::vector<AssetSpec> specs_;
  std::vector<std::filesystem::path> dirs_;
  std::vector<int> level_;  // 0 = the primary folder (or added as primary), k = the k-th fallback
  std::vector<cv::Mat> pictures_;
  std::vector<std::filesystem::path> folders_;
  std::unique_ptr<Cache> cache_;
};

}  // namespace hf::render
