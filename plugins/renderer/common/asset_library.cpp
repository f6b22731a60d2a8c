// Appearance assets: reading and writing assets.yaml, preparing sprites for warping, and choosing one per
// view.
#include "hazardforge/assets/asset_library.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf::render {

namespace fs = std::filesystem;

namespace {

class IndexReader {
 public:
  explicit IndexReader(const YamlDocument& doc) : doc_(doc) {}

  [[noreturn]] void fail(const std::string& ptr, const std::string& what) const {
    throw Error(doc_.at(ptr), what);
  }
  const Json& field(const Json& obj, const std::string& ptr, const std::string& name) const {
    if (!obj.contains(name)) fail(ptr, "field '" + name + "' is missing");
    return obj.at(name);
  }
  double number(const Json& obj, const std::string& ptr, const std::string& name) const {
    const Json& v = field(obj, ptr, name);
    if (!v.is_number()) fail(ptr + "/" + name, "field '" + name + "' must be a number");
    return v.get<double>();
  }
  std::string text(const Json& obj, const std::string& ptr, const std::string& name,
                   bool required = true) const {
    if (!required && !obj.contains(name)) return {};
    const Json& v = field(obj, ptr, name);
    if (!v.is_string()) fail(ptr + "/" + name, "field '" + name + "' must be a string");
    return v.get<std::string>();
  }
  std::vector<double> numbers(const Json& obj, const std::string& ptr, const std::string& name,
                              size_t n) const {
    const Json& v = field(obj, ptr, name);
    if (!v.is_array() || v.size() != n)
      fail(ptr + "/" + name, "field '" + name + "' must be a list of " + std::to_string(n) + " numbers");
    std::vector<double> out;
    for (size_t i = 0; i < n; ++i) {
      if (!v[i].is_number()) fail(ptr + "/" + name + "/" + std::to_string(i), "expected a number");
      out.push_back(v[i].get<double>());
    }
    return out;
  }

 private:
  const YamlDocument& doc_;
};

std::string quoted(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// Fills the colour of transparent pixels from their opaque neighbours (normalised convolution), so bilinear
// warping never pulls black from outside the object into its edge.
void bleed_colours(cv::Mat& bgr, const cv::Mat& alpha) {
  cv::Mat a, c;
  alpha.convertTo(a, CV_32F, 1.0 / 255);
  bgr.convertTo(c, CV_32FC3);
  cv::Mat a3;
  cv::merge(std::vector<cv::Mat>{a, a, a}, a3);
  cv::Mat pre = c.mul(a3);
  cv::Mat pre_b, a_b;
  const double sigma = 3.0;
  cv::GaussianBlur(pre, pre_b, cv::Size(), sigma);
  cv::GaussianBlur(a, a_b, cv::Size(), sigma);
  cv::Scalar mean_col = cv::mean(bgr, alpha > 127);
  for (int y = 0; y < bgr.rows; ++y) {
    auto* out = bgr.ptr<cv::Vec3b>(y);
    const auto* al = alpha.ptr<uint8_t>(y);
    const auto* pb = pre_b.ptr<cv::Vec3f>(y);
    const auto* ab = a_b.ptr<float>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      if (al[x] == 255) continue;
      const float w = ab[x];
      cv::Vec3f fill = w > 1e-3f ? pb[x] / w
                                 : cv::Vec3f(static_cast<float>(mean_col[0]), static_cast<float>(mean_col[1]),
                                             static_cast<float>(mean_col[2]));
      if (al[x] == 0) {
        out[x] = cv::Vec3b(cv::saturate_cast<uint8_t>(fill[0]), cv::saturate_cast<uint8_t>(fill[1]),
                           cv::saturate_cast<uint8_t>(fill[2]));
      }
    }
  }
}

}  // namespace

AssetIndex load_asset_index(const fs::path& dir) {
  const fs::path file = dir / kAssetIndexFile;
  if (!fs::exists(file))
    throw Error(
        file.string() + ": error: asset index not found (assets_dir '" + dir.string() + "' holds no " +
        kAssetIndexFile + "; write one with `hazardforge assets harvest -o " + dir.string() +
        " --config configs/harvest_assets.yaml`, or leave scene.assets.dir unset for the default set)");
  const YamlDocument doc = load_yaml_file(file.string());
  IndexReader r(doc);
  const Json& root = doc.value;
  if (!root.is_object()) r.fail("", "expected a mapping with 'format', 'version' and 'assets'");
  if (r.text(root, "", "format") != kAssetFormat)
    r.fail("/format", std::string("format must be '") + kAssetFormat + "'");
  if (static_cast<int>(r.number(root, "", "version")) != kAssetFormatVersion)
    r.fail("/version",
           "unsupported version (this build reads version " + std::to_string(kAssetFormatVersion) + ")");
  const Json& list = r.field(root, "", "assets");
  if (!list.is_array()) r.fail("/assets", "'assets' must be a list");
  AssetIndex idx;
  std::set<std::string> files;
  for (size_t i = 0; i < list.size(); ++i) {
    const std::string p = "/assets/" + std::to_string(i);
    const Json& e = list[i];
    if (!e.is_object()) r.fail(p, "asset entry must be a mapping");
    AssetSpec s;
    s.file = r.text(e, p, "file");
    s.object_class = r.text(e, p, "class");
    s.view = r.text(e, p, "view");
    if (!is_view_name(s.view)) {
      try {
        (void)view_azimuth_deg(s.view);
      } catch (const Error& err) {
        r.fail(p + "/view", err.what());
      }
    }
    s.azimuth_deg = r.number(e, p, "azimuth_deg");
    auto sz = r.numbers(e, p, "size_lwh", 3);
    for (int k = 0; k < 3; ++k)
      if (!(sz[k] > 0)) r.fail(p + "/size_lwh", "sizes must be positive");
    s.size_lwh = cv::Vec3d(sz[0], sz[1], sz[2]);
    auto is = r.numbers(e, p, "image_size", 2);
    s.image_size = cv::Size(static_cast<int>(is[0]), static_cast<int>(is[1]));
    auto an = r.numbers(e, p, "anchor_px", 2);
    s.anchor_px = cv::Point2d(an[0], an[1]);
    const Json& bc = r.field(e, p, "box_corners_px");
    if (!bc.is_array() || bc.size() != 8)
      r.fail(p + "/box_corners_px", "box_corners_px must list 8 [x, y] pairs");
    for (size_t k = 0; k < 8; ++k) {
      const std::string pk = p + "/box_corners_px/" + std::to_string(k);
      if (!bc[k].is_array() || bc[k].size() != 2 || !bc[k][0].is_number() || !bc[k][1].is_number())
        r.fail(pk, "corner must be [x, y]");
      s.box_corners_px[k] = cv::Point2d(bc[k][0].get<double>(), bc[k][1].get<double>());
    }
    s.source = r.text(e, p, "source", false);
    s.instance = r.text(e, p, "instance", false);
    s.origin = r.text(e, p, "origin", false);
    if (s.instance.empty()) s.instance = s.file;
    if (!files.insert(s.file).second) r.fail(p + "/file", "file '" + s.file + "' is listed twice");
    if (!fs::exists(dir / s.file))
      r.fail(p + "/file", "asset picture '" + (dir / s.file).string() + "' not found");
    idx.assets.push_back(std::move(s));
  }
  return idx;
}

void save_asset_index(const fs::path& dir, const AssetIndex& index, const std::string& comment) {
  std::ostringstream os;
  std::istringstream cs(comment);
  for (std::string line; std::getline(cs, line);) os << "# " << line << "\n";
  os << "format: " << kAssetFormat << "\nversion: " << kAssetFormatVersion
     << "\nassets:" << (index.assets.empty() ? " []" : "") << "\n";
  for (const AssetSpec& s : index.assets) {
    os << "  - file: " << quoted(s.file) << "\n";
    os << "    class: " << s.object_class << "\n";
    os << "    view: " << s.view << "\n";
    os << "    azimuth_deg: " << fixed_text(s.azimuth_deg, 1) << "\n";
    os << "    size_lwh: [" << fixed_text(s.size_lwh[0], 3) << ", " << fixed_text(s.size_lwh[1], 3) << ", "
       << fixed_text(s.size_lwh[2], 3) << "]\n";
    os << "    image_size: [" << s.image_size.width << ", " << s.image_size.height << "]\n";
    os << "    anchor_px: [" << fixed_text(s.anchor_px.x, 2) << ", " << fixed_text(s.anchor_px.y, 2) << "]\n";
    os << "    box_corners_px: [";
    for (int k = 0; k < 8; ++k)
      os << (k ? ", " : "") << "[" << fixed_text(s.box_corners_px[k].x, 2) << ", "
         << fixed_text(s.box_corners_px[k].y, 2) << "]";
    os << "]\n";
    if (!s.source.empty()) os << "    source: " << s.source << "\n";
    if (!s.instance.empty()) os << "    instance: " << quoted(s.instance) << "\n";
    if (!s.origin.empty()) os << "    origin: " << quoted(s.origin) << "\n";
  }
  fs::create_directories(dir);
  write_file_atomic(dir / kAssetIndexFile, os.str());
}

void write_png_atomic(const fs::path& file, const cv::Mat& bgra) {
  fs::create_directories(file.parent_path());
  std::vector<uchar> png;
  if (!cv::imencode(".png", bgra, png, {cv::IMWRITE_PNG_COMPRESSION, 9}))
    throw Error("cannot encode '" + file.string() + "'");
  write_file_atomic(file, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
}

int LoadedAsset::level_for_height(double target_px) const {
  int level = 0;
  while (level + 1 < static_cast<int>(bgr.size()) && bgr[level + 1].rows - 2 * pad >= target_px) ++level;
  return level;
}

cv::Point2d LoadedAsset::level_px(const cv::Point2d& p, int level) const {
  const double f = std::ldexp(1.0, -level);
  return {(p.x + 0.5) * f - 0.5 + pad, (p.y + 0.5) * f - 0.5 + pad};
}

LoadedAsset prepare_asset(const AssetSpec& spec, const cv::Mat& bgra) {
  if (bgra.empty() || bgra.type() != CV_8UC4)
    throw Error("asset '" + spec.file + "': expected an 8-bit picture with an alpha channel (BGRA)");
  LoadedAsset a;
  a.spec = spec;
  a.spec.image_size = bgra.size();
  std::vector<cv::Mat> ch;
  cv::split(bgra, ch);
  cv::Mat alpha = ch[3].clone();
  cv::Mat bgr;
  cv::merge(std::vector<cv::Mat>{ch[0], ch[1], ch[2]}, bgr);
  if (cv::countNonZero(alpha > 127) == 0) throw Error("asset '" + spec.file + "' is fully transparent");
  bleed_colours(bgr, alpha);
  cv::Mat lab;
  cv::cvtColor(bgr, lab, cv::COLOR_BGR2Lab);
  cv::meanStdDev(lab, a.lab_mean, a.lab_std, alpha > 127);
  a.bgr.push_back(bgr);
  a.alpha.push_back(alpha);
  // Pyramid on premultiplied colour so a distant object is filtered, not aliased, when warped small.
  while (a.bgr.back().rows >= 24 && a.bgr.back().cols >= 12) {
    cv::Mat al_f, col_f;
    a.alpha.back().convertTo(al_f, CV_32F, 1.0 / 255);
    a.bgr.back().convertTo(col_f, CV_32FC3);
    cv::Mat a3;
    cv::merge(std::vector<cv::Mat>{al_f, al_f, al_f}, a3);
    cv::Mat pre = col_f.mul(a3), pre_d, al_d;
    cv::pyrDown(pre, pre_d);
    cv::pyrDown(al_f, al_d);
    cv::Mat a3d;
    cv::merge(std::vector<cv::Mat>{al_d, al_d, al_d}, a3d);
    cv::Mat col_d;
    cv::divide(pre_d, cv::max(a3d, 1e-4), col_d);
    cv::Mat col8, al8;
    col_d.convertTo(col8, CV_8UC3);
    al_d.convertTo(al8, CV_8U, 255.0);
    bleed_colours(col8, al8);
    a.bgr.push_back(col8);
    a.alpha.push_back(al8);
  }
  for (size_t k = 0; k < a.bgr.size(); ++k) {
    cv::copyMakeBorder(a.bgr[k], a.bgr[k], a.pad, a.pad, a.pad, a.pad, cv::BORDER_REPLICATE);
    cv::copyMakeBorder(a.alpha[k], a.alpha[k], a.pad, a.pad, a.pad, a.pad, cv::BORDER_CONSTANT,
                       cv::Scalar(0));
    cv::Mat l;
    cv::cvtColor(a.bgr[k], l, cv::COLOR_BGR2Lab);
    a.lab.push_back(l);
  }
  return a;
}

struct AssetLibrary::Cache {
  std::mutex mutex;
  std::map<size_t, std::unique_ptr<LoadedAsset>> prepared;
};

AssetLibrary::AssetLibrary() = default;
AssetLibrary::AssetLibrary(AssetLibrary&&) noexcept = default;
AssetLibrary& AssetLibrary::operator=(AssetLibrary&&) noexcept = default;
AssetLibrary::~AssetLibrary() = default;

void AssetLibrary::add(const AssetSpec& spec, const cv::Mat& bgra, const fs::path& dir, bool from_fallback) {
  add_at(spec, bgra, dir, from_fallback ? 1 : 0);
}

void AssetLibrary::add_at(const AssetSpec& spec, const cv::Mat& bgra, const fs::path& dir, int level) {
  if (bgra.empty() || bgra.type() != CV_8UC4)
    throw Error("asset '" + spec.file + "': expected an 8-bit picture with an alpha channel (BGRA)");
  if (!cache_) cache_ = std::make_unique<Cache>();
  specs_.push_back(spec);
  specs_.back().image_size = bgra.size();
  dirs_.push_back(dir);
  level_.push_back(level);
  pictures_.push_back(bgra);
}

AssetLibrary AssetLibrary::load(const fs::path& primary, const fs::path& fallback) {
  return load(primary, fallback.empty() ? std::vector<fs::path>{} : std::vector<fs::path>{fallback});
}

AssetLibrary AssetLibrary::load(const fs::path& primary, const std::vector<fs::path>& fallbacks) {
  AssetLibrary lib;
  auto load_dir = [&](const fs::path& dir, int level) {
    const AssetIndex idx = load_asset_index(dir);
    lib.folders_.push_back(dir);
    for (const AssetSpec& s : idx.assets) {
      const fs::path file = dir / s.file;
      cv::Mat img = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
      if (img.empty()) throw Error(file.string() + ": error: cannot decode the picture");
      if (img.type() != CV_8UC4) throw Error(file.string() + ": error: the picture has no alpha channel");
      if (img.size() != s.image_size)
        throw Error((dir / kAssetIndexFile).string() + ": error: asset '" + s.file + "': image_size [" +
                    std::to_string(s.image_size.width) + ", " + std::to_string(s.image_size.height) +
                    "] does not match the picture's " + std::to_string(img.cols) + "x" +
                    std::to_string(img.rows));
      lib.add_at(s, img, dir, level);
    }
  };
  load_dir(primary, 0);
  std::vector<fs::path> loaded{primary};
  int level = 1;
  for (const fs::path& f : fallbacks) {
    std::error_code ec;
    if (f.empty() || std::any_of(loaded.begin(), loaded.end(),
                                 [&](const fs::path& d) { return fs::equivalent(d, f, ec); }))
      continue;
    load_dir(f, level++);
    loaded.push_back(f);
  }
  return lib;
}

std::vector<std::string> AssetLibrary::classes() const {
  std::set<std::string> s;
  for (const auto& a : specs_) s.insert(a.object_class);
  return {s.begin(), s.end()};
}

std::vector<std::string> AssetLibrary::generated_instances(const std::string& cls) const {
  std::vector<std::string> out;
  for (const auto& a : specs_)
    if (a.object_class == cls && a.source == "generated" &&
        std::find(out.begin(), out.end(), a.instance) == out.end())
      out.push_back(a.instance);
  return out;
}

std::string AssetLibrary::describe_folders() const {
  std::string s;
  for (const auto& f : folders_) s += (s.empty() ? "" : ", ") + f.string();
  if (s.empty()) s = "(no folder)";
  return s;
}

const LoadedAsset& AssetLibrary::select(const std::string& cls, double az, const std::string& instance,
                                        double max_err) const {
  // Tiers: the same instance, then each folder in order (primary, fallbacks), each taken when its nearest
  // view is within max_err; else the nearest view anywhere.
  const int levels = level_.empty() ? 1 : *std::max_element(level_.begin(), level_.end()) + 1;
  std::vector<long> best(static_cast<size_t>(levels + 2), -1);
  std::vector<double> err(best.size(), 1e9);
  const size_t anywhere = best.size() - 1;
  for (size_t i = 0; i < specs_.size(); ++i) {
    const AssetSpec& a = specs_[i];
    if (a.object_class != cls) continue;
    const double e = angle_diff_deg(a.azimuth_deg, az);
    for (size_t t : {(!instance.empty() && a.instance == instance) ? size_t{0} : anywhere,
                     static_cast<size_t>(level_[i] + 1), anywhere})
      if (e < err[t] - 1e-9) {
        err[t] = e;
        best[t] = static_cast<long>(i);
      }
  }
  long pick = best[anywhere];
  for (size_t t = 0; t < anywhere; ++t)
    if (best[t] >= 0 && err[t] <= max_err) {
      pick = best[t];
      break;
    }
  if (pick < 0) {
    std::string have;
    for (const auto& c : classes()) have += (have.empty() ? "" : ", ") + c;
    throw Error("no appearance asset for class '" + cls + "' in " + describe_folders() +
                " (classes available: " + (have.empty() ? "none" : have) + ")");
  }
  return prepared(static_cast<size_t>(pick));
}

const LoadedAsset& AssetLibrary::prepared(size_t i) const {
  std::lock_guard<std::mutex> lock(cache_->mutex);
  auto& slot = cache_->prepared[i];
  if (!slot) {
    slot = std::make_unique<LoadedAsset>(prepare_asset(specs_[i], pictures_[i]));
    slot->dir = dirs_[i];
    slot->from_fallback = level_[i] > 0;
  }
  return *slot;
}

void AssetLibrary::prepare_class(const std::string& cls) const {
  for (size_t i = 0; i < specs_.size(); ++i)
    if (specs_[i].object_class == cls) (void)prepared(i);
}

}  // namespace hf::render
