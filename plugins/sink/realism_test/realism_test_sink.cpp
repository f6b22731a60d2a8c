// The realism_test sink: crops of the inserted object and of the recording's real objects of its class, a
// two-sample classifier test and a contact sheet.
#include "realism_test_sink.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/output_path.hpp"
#include "hazardforge/realism/c2st.hpp"
#include "hazardforge/realism/compare.hpp"

namespace hf::render {

namespace {

constexpr int kSheetHeight = 96, kSheetPerRow = 10;

cv::Mat sheet_picture(const cv::Mat& image, const cv::Rect2f& box) {
  const int m = std::max(2, static_cast<int>(0.15 * box.height));
  const cv::Rect r = cv::Rect(static_cast<int>(box.x) - m, static_cast<int>(box.y) - m,
                              static_cast<int>(box.width) + 2 * m, static_cast<int>(box.height) + 2 * m) &
                     cv::Rect(0, 0, image.cols, image.rows);
  cv::Mat out;
  const double s = static_cast<double>(kSheetHeight) / r.height;
  cv::resize(image(r), out, cv::Size(std::max(1, static_cast<int>(r.width * s)), kSheetHeight), 0, 0,
             s < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  return out;
}

// Up to n items spread evenly over a list.
template <class T>
std::vector<const T*> spread(const std::vector<const T*>& v, size_t n) {
  std::vector<const T*> out;
  if (v.empty()) return out;
  const size_t k = std::min(n, v.size());
  for (size_t i = 0; i < k; ++i) out.push_back(v[i * v.size() / k]);
  return out;
}

void caption(cv::Mat& img, const std::string& text, cv::Point org) {
  cv::putText(img, text, org, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
}

}  // namespace

ComponentInfo RealismTestSink::describe() {
  ComponentInfo i;
  i.name = "realism_test";
  i.kind = kind::kSink;
  i.summary = "two-sample classifier test of the inserted object against the recording's real ones, and a "
              "contact sheet";
  i.doc =
      "Crops the inserted object from the augmented frames and the recording's detected objects of its class "
      "from the original frames, describes each by features a person looks at (gradient shape, colour, blur "
      "and noise against its surroundings, edge profile: hazardforge/realism/c2st.hpp), and asks a "
      "cross-validated linear classifier to tell them apart: the AUC of its out-of-fold scores with a 95 % "
      "bootstrap interval (0.5: indistinguishable). Writes realism.json, the crops' features "
      "(realism/crops.jsonl, which hf_c2st pools over runs and campaigns) and a contact sheet of real and "
      "inserted crops (realism/contact_sheet.png).";
  i.inputs = {port<Frame>("original", "frames before augmentation"),
              port<Frame>("augmented", "the same frames after augmentation"),
              port<HazardInstance>("hazard", "where the inserted object is drawn"),
              port<Tracks>("tracks", "the original frames' tracks (the real objects, each with its identity)")};
  i.params = {
      ParamSpec::string("file", "realism.json").describe("the test's result, below the run's output folder"),
      ParamSpec::string("crops_file", "realism/crops.jsonl").describe("every crop's features"),
      ParamSpec::string("sheet", "realism/contact_sheet.png").describe("real and inserted crops, a PNG"),
      ParamSpec::number("min_visible_share", 0.7)
          .range(0.0, 1.0)
          .describe("an inserted crop needs this share of the object in the picture and unhidden"),
      ParamSpec::number("min_height_px", 24.0).range(8.0, 4000.0).describe("smallest crop"),
      ParamSpec::number("min_score", 0.5).range(0.0, 1.0).describe("weakest detection cropped"),
      ParamSpec::number("size_range", 3.0)
          .range(1.0, 10.0)
          .describe("real crops are kept when their height is within the inserted ones' range widened this "
                    "many times"),
      ParamSpec::integer("max_real", 300).range(5, 100000).describe("most real crops used (spread evenly)"),
      ParamSpec::integer("seed", 1).range(0, 1000000).describe("the folds' and bootstrap's seed"),
  };
  return i;
}

void RealismTestSink::open(StageContext& ctx) {
  const Params& p = ctx.params();
  file_ = output_param_path(ctx, "file");
  crops_file_ = output_param_path(ctx, "crops_file");
  sheet_ = output_param_path(ctx, "sheet");
  min_visible_ = p.get_double("min_visible_share");
  min_height_ = p.get_double("min_height_px");
  min_score_ = p.get_double("min_score");
  size_range_ = p.get_double("size_range");
  max_real_ = static_cast<int>(p.get_int("max_real"));
  seed_ = static_cast<unsigned>(p.get_int("seed"));
}

void RealismTestSink::process(StageContext& /*ctx*/, const Inputs& in, Outputs& /*out*/) {
  const Frame& orig = in.require<Frame>("original");
  const Frame& aug = in.require<Frame>("augmented");
  const HazardInstance& hz = in.require<HazardInstance>("hazard");
  const Tracks& tracks = in.require<Tracks>("tracks");
  if (orig.image.empty() || aug.image.empty() || orig.image.size() != aug.image.size())
    throw Error(frame_name(orig) + ": the original and augmented frames must both have pictures of one size");
  if (!hz.object_class.empty()) object_class_ = hz.object_class;
  if (!hz.picture_source.empty() && picture_source_.empty()) {
    picture_source_ = hz.picture_source;
    picture_file_ = hz.picture_file;
  }
  const cv::Size size = orig.image.size();
  if (hz.visible && hz.visible_share() >= min_visible_) {
    const cv::Rect2f box = hz.drawn_box.area() > 0 ? hz.drawn_box : hz.box;
    if (box.height >= min_height_ && !truncation_flags(box, size)) {
      Crop c;
      c.inserted = true;
      c.frame = orig.index;
      c.label = hz.object_class;
      c.box = box;
      c.features = realism::crop_features(aug.image, box);
      if (!c.features.empty()) {
        c.picture = sheet_picture(aug.image, box);
        crops_.push_back(std::move(c));
      }
    }
  }
  for (size_t i = 0; i < tracks.items.size(); ++i) {
    const Track& d = tracks.items[i];
    if (d.misses > 0 || d.score < min_score_ || d.box.height < min_height_ || d.truncated ||
        truncation_flags(d.box, size))
      continue;
    bool overlapped = false;
    for (size_t j = 0; j < tracks.items.size() && !overlapped; ++j)
      overlapped = j != i && (tracks.items[j].box & d.box).area() > 0.05 * d.box.area();
    if (overlapped) continue;
    Crop c;
    c.frame = orig.index;
    c.label = d.label;
    c.box = d.box;
    c.track_id = d.id;
    c.features = realism::crop_features(orig.image, d.box);
    if (c.features.empty()) continue;
    c.picture = sheet_picture(orig.image, d.box);
    crops_.push_back(std::move(c));
  }
}

void RealismTestSink::finish(StageContext& ctx, Outputs& /*out*/) {
  std::vector<const Crop*> ins, real;
  double h0 = 1e18, h1 = 0;
  for (const Crop& c : crops_)
    if (c.inserted) {
      ins.push_back(&c);
      h0 = std::min<double>(h0, c.box.height);
      h1 = std::max<double>(h1, c.box.height);
    }
  // The real objects of its class; of its class group (car, truck, bus; person, pedestrian) when the
  // recording has fewer than 5 of the class itself in the size range.
  const ClassGroups& groups = realism::reference_groups();
  auto in_range = [&](const Crop& c) { return c.box.height >= h0 / size_range_ && c.box.height <= h1 * size_range_; };
  for (const Crop& c : crops_)
    if (!c.inserted && c.label == object_class_ && in_range(c)) real.push_back(&c);
  if (real.size() < 5)
    for (const Crop& c : crops_)
      if (!c.inserted && c.label != object_class_ && groups.same(c.label, object_class_) && in_range(c))
        real.push_back(&c);
  real = spread(real, static_cast<size_t>(max_real_));
  std::vector<std::vector<float>> fr, fi;
  std::vector<int64_t> real_ids;
  for (const Crop* c : real) {
    fr.push_back(c->features);
    real_ids.push_back(c->track_id);
  }
  for (const Crop* c : ins) fi.push_back(c->features);
  // One inserted object: the folds can only hold out its crops (C2stResult::grouped false).
  const realism::C2stResult r =
      realism::c2st(fr, fi, 5, seed_, 1000, 5, real_ids, std::vector<int64_t>(fi.size(), 0));
  // The control: real against real, the recording's objects split in two by identity (alternate tracks). A
  // test that tells one real car from another measures identity, not realism: its AUC is the floor the
  // inserted object's is read against.
  std::map<int64_t, std::vector<const Crop*>> by_track;
  for (const Crop* c : real) by_track[c->track_id].push_back(c);
  std::vector<std::vector<float>> half[2];
  std::vector<int64_t> half_ids[2];
  {
    std::vector<std::pair<size_t, int64_t>> sizes;
    for (const auto& [id, v] : by_track) sizes.push_back({v.size(), id});
    std::sort(sizes.rbegin(), sizes.rend());
    size_t n[2] = {0, 0};
    for (const auto& [count, id] : sizes) {
      const int k = n[0] <= n[1] ? 0 : 1;  // the smaller half takes the next largest track
      n[k] += count;
      for (const Crop* c : by_track[id]) {
        half[k].push_back(c->features);
        half_ids[k].push_back(id);
      }
    }
  }
  const realism::C2stResult control =
      realism::c2st(half[0], half[1], 5, seed_, 1000, 5, half_ids[0], half_ids[1]);

  Json j = {{"object_class", object_class_},
            {"picture_source", picture_source_},
            {"picture_file", picture_file_},
            {"inserted_crops", r.n_inserted},
            {"real_crops", r.n_real},
            {"height_range_px", ins.empty() ? Json() : Json::array({h0 / size_range_, h1 * size_range_})},
            {"classifier", r.classifier},
            {"folds", r.folds},
            {"folds_hold_out_objects", r.grouped},
            {"features", realism::crop_feature_names()}};
  if (std::isfinite(r.auc)) {
    j["auc"] = r.auc;
    j["auc_ci95"] = {r.ci_low, r.ci_high};
  } else {
    j["auc"] = nullptr;
    j["why_no_auc"] = "fewer than 5 crops of the inserted object or of real " + object_class_ + "s";
  }
  j["real_objects"] = by_track.size();
  if (std::isfinite(control.auc)) {
    j["control_auc"] = control.auc;
    j["control_auc_ci95"] = {control.ci_low, control.ci_high};
    j["control_folds_hold_out_objects"] = control.grouped;
  } else {
    j["control_auc"] = nullptr;
  }
  j["control"] = "real against real: the recording's objects split in two by track (identity, not realism)";
  write_file_atomic(file_, j.dump(2) + "\n");

  std::string lines;
  auto line = [&](const Crop* c, const std::string& set) {
    Json l = {{"set", set},
              {"class", c->inserted ? c->label : object_class_},
              {"label", c->label},
              {"source", c->inserted ? picture_source_ : std::string("recording")},
              {"frame", c->frame},
              {"track", c->track_id},
              {"box", {c->box.x, c->box.y, c->box.width, c->box.height}},
              {"features", c->features}};
    lines += l.dump() + "\n";
  };
  for (const Crop* c : real) line(c, "real");
  for (const Crop* c : ins) line(c, "inserted");
  std::filesystem::create_directories(crops_file_.parent_path());
  write_file_atomic(crops_file_, lines);

  // Contact sheet: a row (or two) of real crops above a row (or two) of inserted ones.
  const std::vector<const Crop*> show_real = spread(real, 2 * kSheetPerRow), show_ins = spread(ins, 2 * kSheetPerRow);
  auto rows_of = [&](const std::vector<const Crop*>& v, const std::string& title) {
    std::vector<cv::Mat> rows;
    for (size_t s = 0; s < std::max<size_t>(v.size(), 1); s += kSheetPerRow) {
      std::vector<cv::Mat> cells;
      for (size_t k = s; k < std::min(v.size(), s + kSheetPerRow); ++k) {
        cells.push_back(v[k]->picture);
        cells.push_back(cv::Mat(kSheetHeight, 4, CV_8UC3, cv::Scalar(32, 32, 32)));
      }
      if (cells.empty()) cells.push_back(cv::Mat(kSheetHeight, 200, CV_8UC3, cv::Scalar(32, 32, 32)));
      cv::Mat row;
      cv::hconcat(cells, row);
      rows.push_back(row);
    }
    cv::Mat head(22, 10, CV_8UC3, cv::Scalar(32, 32, 32));
    rows.insert(rows.begin(), head);
    int w = 0;
    for (const auto& r2 : rows) w = std::max(w, r2.cols);
    for (auto& r2 : rows)
      if (r2.cols < w) cv::copyMakeBorder(r2, r2, 0, 0, 0, w - r2.cols, cv::BORDER_CONSTANT, cv::Scalar(32, 32, 32));
    cv::Mat out;
    cv::vconcat(rows, out);
    caption(out, title, {4, 16});
    return out;
  };
  const std::string auc_text =
      (std::isfinite(r.auc) ? "C2ST AUC " + num_text(r.auc, 2) + " [" + num_text(r.ci_low, 2) + ", " +
                                  num_text(r.ci_high, 2) + "]"
                            : std::string("C2ST: too few crops")) +
      (std::isfinite(control.auc) ? " (real vs real " + num_text(control.auc, 2) + ")" : std::string());
  cv::Mat a = rows_of(show_real, "real " + object_class_ + " (" + std::to_string(real.size()) + " crops)");
  cv::Mat b = rows_of(show_ins, "inserted (" + std::to_string(ins.size()) + " crops, picture: " +
                                    (picture_source_.empty() ? "none" : picture_source_) + ") - " + auc_text);
  const int w = std::max(a.cols, b.cols);
  if (a.cols < w) cv::copyMakeBorder(a, a, 0, 0, 0, w - a.cols, cv::BORDER_CONSTANT, cv::Scalar(32, 32, 32));
  if (b.cols < w) cv::copyMakeBorder(b, b, 0, 0, 0, w - b.cols, cv::BORDER_CONSTANT, cv::Scalar(32, 32, 32));
  cv::Mat sheet;
  cv::vconcat(a, b, sheet);
  std::vector<uchar> png;
  if (!cv::imencode(".png", sheet, png)) throw Error(sheet_.string() + ": cannot encode the contact sheet");
  std::filesystem::create_directories(sheet_.parent_path());
  write_file_atomic(sheet_, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  ctx.log(LogLevel::kInfo, "realism test: " + auc_text + " from " + std::to_string(r.n_inserted) +
                               " inserted and " + std::to_string(r.n_real) + " real " + object_class_ +
                               " crops (picture: " + (picture_source_.empty() ? "none" : picture_source_) + ")");
}

}  // namespace hf::render
