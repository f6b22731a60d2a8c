// The realism two-sample classifier test (hazardforge/realism/c2st.hpp).
#include "hazardforge/realism/c2st.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <random>

#include <opencv2/imgproc.hpp>
#include <opencv2/ml.hpp>

#include "hazardforge/realism/metrics.hpp"

namespace hf::realism {

namespace {

constexpr int kSide = 32, kCells = 2, kBins = 8, kHeight = 48;

double mean_in(const cv::Mat& m, const cv::Mat& mask) {
  return mask.empty() ? cv::mean(m)[0] : cv::mean(m, mask)[0];
}

double safe_log(double v) { return std::log(std::max(v, 1e-6)); }

}  // namespace

const std::vector<std::string>& crop_feature_names() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (int c = 0; c < kCells * kCells; ++c)
      for (int b = 0; b < kBins; ++b) n.push_back("hog_c" + std::to_string(c) + "_b" + std::to_string(b));
    for (const char* s : {"L_mean", "a_mean", "b_mean", "L_std", "a_std", "b_std", "log_sharpness_ratio",
                          "fine_gradient_share", "noise_sigma", "log_noise_ratio", "log_edge_over_inside",
                          "log_edge_over_ring"})
      n.push_back(s);
    return n;
  }();
  return names;
}

std::vector<float> crop_features(const cv::Mat& bgr, const cv::Rect2f& box_f, double margin) {
  const cv::Rect img(0, 0, bgr.cols, bgr.rows);
  const cv::Rect box0 = cv::Rect(cv::Rect2d(box_f)) & img;
  if (box0.width < 8 || box0.height < 8) return {};
  const int m = std::max(2, static_cast<int>(std::lround(margin * box0.height)));
  const cv::Rect outer0 = cv::Rect(box0.x - m, box0.y - m, box0.width + 2 * m, box0.height + 2 * m) & img;
  if (outer0.area() <= box0.area()) return {};
  // Every crop is seen at one size, the box kHeight px tall, as a person sees crops side by side: a large
  // object is not told apart by its size alone.
  const double s = static_cast<double>(kHeight) / box0.height;
  cv::Mat crop;
  cv::resize(bgr(outer0), crop,
             cv::Size(std::max(1, static_cast<int>(std::lround(outer0.width * s))),
                      std::max(1, static_cast<int>(std::lround(outer0.height * s)))),
             0, 0, s < 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  const cv::Rect inner = cv::Rect(static_cast<int>(std::lround((box0.x - outer0.x) * s)),
                                  static_cast<int>(std::lround((box0.y - outer0.y) * s)),
                                  static_cast<int>(std::lround(box0.width * s)), kHeight) &
                         cv::Rect(0, 0, crop.cols, crop.rows);
  const cv::Rect box = inner;
  if (inner.width < 4 || inner.area() >= crop.rows * crop.cols) return {};
  cv::Mat grey, gx, gy, mag, ang;
  cv::cvtColor(crop, grey, cv::COLOR_BGR2GRAY);
  cv::Sobel(grey, gx, CV_32F, 1, 0);
  cv::Sobel(grey, gy, CV_32F, 0, 1);
  cv::cartToPolar(gx, gy, mag, ang);
  std::vector<float> f;

  // Gradient orientation histograms of the box, resized to a fixed size.
  {
    cv::Mat g, sx, sy, mg, an;
    cv::resize(grey(inner), g, {kSide, kSide}, 0, 0, cv::INTER_AREA);
    cv::Sobel(g, sx, CV_32F, 1, 0);
    cv::Sobel(g, sy, CV_32F, 0, 1);
    cv::cartToPolar(sx, sy, mg, an);
    std::vector<float> h(kCells * kCells * kBins, 0.f);
    const int cell = kSide / kCells;
    for (int y = 0; y < kSide; ++y)
      for (int x = 0; x < kSide; ++x) {
        const float a = std::fmod(an.at<float>(y, x), static_cast<float>(CV_PI));  // unsigned orientation
        const int b = std::min(kBins - 1, static_cast<int>(a / CV_PI * kBins));
        h[static_cast<size_t>(((y / cell) * kCells + x / cell) * kBins + b)] += mg.at<float>(y, x);
      }
    const double norm = std::sqrt(std::inner_product(h.begin(), h.end(), h.begin(), 0.0)) + 1e-6;
    for (float v : h) f.push_back(static_cast<float>(v / norm));
  }
  // Colour of the box's central half.
  {
    const cv::Rect centre(inner.x + inner.width / 4, inner.y + inner.height / 4, std::max(1, inner.width / 2),
                          std::max(1, inner.height / 2));
    cv::Mat lab;
    cv::cvtColor(crop(centre), lab, cv::COLOR_BGR2Lab);
    cv::Scalar mean, sd;
    cv::meanStdDev(lab, mean, sd);
    for (int k = 0; k < 3; ++k) f.push_back(static_cast<float>(mean[k] / 255.0));
    for (int k = 0; k < 3; ++k) f.push_back(static_cast<float>(sd[k] / 64.0));
  }
  // Blur and noise: inside against the ring around the box.
  cv::Mat in_mask(crop.size(), CV_8U, cv::Scalar(0)), ring_mask(crop.size(), CV_8U, cv::Scalar(255));
  in_mask(inner).setTo(255);
  ring_mask(inner).setTo(0);
  {
    const double s_in = laplacian_variance(grey, in_mask), s_ring = laplacian_variance(grey, ring_mask);
    f.push_back(static_cast<float>(safe_log(s_in) - safe_log(s_ring)));
    // Share of the gradient energy at the finest scale (against twice and four times coarser).
    double e[3];
    cv::Mat g = grey(inner).clone();
    for (int k = 0; k < 3; ++k) {
      cv::Mat sx, sy;
      cv::Sobel(g, sx, CV_32F, 1, 0);
      cv::Sobel(g, sy, CV_32F, 0, 1);
      e[k] = cv::mean(sx.mul(sx) + sy.mul(sy))[0] * std::pow(4.0, k);
      if (g.cols < 4 || g.rows < 4) {
        for (int r = k + 1; r < 3; ++r) e[r] = e[k];
        break;
      }
      cv::pyrDown(g, g);
    }
    f.push_back(static_cast<float>(e[0] / (e[0] + e[1] + e[2] + 1e-6)));
    const double n_in = noise_sigma(grey, in_mask), n_ring = noise_sigma(grey, ring_mask);
    f.push_back(static_cast<float>(std::isfinite(n_in) ? n_in / 8.0 : 0.0));
    f.push_back(static_cast<float>(std::isfinite(n_in) && std::isfinite(n_ring) ? safe_log(n_in) - safe_log(n_ring)
                                                                                 : 0.0));
  }
  // Edge profile: the gradient in a band across the box's border against inside and outside.
  {
    const int band = std::max(1, box.height / 16);
    cv::Mat edge_mask(crop.size(), CV_8U, cv::Scalar(0));
    cv::rectangle(edge_mask, inner, cv::Scalar(255), 2 * band + 1);
    cv::Mat deep_in = in_mask & ~edge_mask, out_ring = ring_mask & ~edge_mask;
    const double e = mean_in(mag, edge_mask), i = mean_in(mag, deep_in), o = mean_in(mag, out_ring);
    f.push_back(static_cast<float>(safe_log(e) - safe_log(i)));
    f.push_back(static_cast<float>(safe_log(e) - safe_log(o)));
  }
  for (float& v : f)
    if (!std::isfinite(v)) v = 0.f;
  return f;
}

double roc_auc(const std::vector<double>& scores, const std::vector<int>& positive) {
  std::vector<size_t> idx(scores.size());
  std::iota(idx.begin(), idx.end(), 0);
  std::sort(idx.begin(), idx.end(), [&](size_t a, size_t b) { return scores[a] < scores[b]; });
  double rank_sum = 0;
  size_t n_pos = 0;
  for (size_t i = 0; i < idx.size();) {
    size_t j = i;
    while (j < idx.size() && scores[idx[j]] == scores[idx[i]]) ++j;
    const double avg_rank = (i + 1 + j) / 2.0;  // ranks i+1 .. j
    for (size_t k = i; k < j; ++k)
      if (positive[idx[k]]) {
        rank_sum += avg_rank;
        ++n_pos;
      }
    i = j;
  }
  const size_t n_neg = scores.size() - n_pos;
  if (n_pos == 0 || n_neg == 0) return std::nan("");
  return (rank_sum - n_pos * (n_pos + 1) / 2.0) / (static_cast<double>(n_pos) * n_neg);
}

C2stResult c2st(const std::vector<std::vector<float>>& real, const std::vector<std::vector<float>>& inserted,
                int folds, unsigned seed, int bootstrap, int min_per_class, const std::vector<int64_t>& real_objects,
                const std::vector<int64_t>& inserted_objects) {
  C2stResult r;
  r.n_real = static_cast<int>(real.size());
  r.n_inserted = static_cast<int>(inserted.size());
  r.classifier = "linear SVM (C = 1) on z-scored features";
  if (r.n_real < min_per_class || r.n_inserted < min_per_class) {
    r.auc = r.ci_low = r.ci_high = std::nan("");
    return r;
  }
  const size_t dims = real.front().size();
  std::vector<const std::vector<float>*> rows;
  std::vector<int> label;
  std::vector<int64_t> object;  // per crop: its object, numbered within its class
  auto add = [&](const std::vector<std::vector<float>>& v, const std::vector<int64_t>& ids, int cls) {
    for (size_t i = 0; i < v.size(); ++i) {
      rows.push_back(&v[i]);
      label.push_back(cls);
      object.push_back(ids.size() == v.size() ? ids[i] : -1 - static_cast<int64_t>(i));
    }
  };
  add(real, real_objects, 0);
  add(inserted, inserted_objects, 1);
  const size_t n = rows.size();
  // The objects of each class; with a single object in a class, crops are held out instead.
  std::vector<int64_t> objs[2];
  for (size_t i = 0; i < n; ++i)
    if (std::find(objs[label[i]].begin(), objs[label[i]].end(), object[i]) == objs[label[i]].end())
      objs[label[i]].push_back(object[i]);
  r.grouped = objs[0].size() >= 2 && objs[1].size() >= 2 && (!real_objects.empty() || !inserted_objects.empty());
  if (!r.grouped)
    for (size_t i = 0; i < n; ++i) object[i] = -1 - static_cast<int64_t>(i);
  for (auto& o : objs) o.clear();
  for (size_t i = 0; i < n; ++i)
    if (std::find(objs[label[i]].begin(), objs[label[i]].end(), object[i]) == objs[label[i]].end())
      objs[label[i]].push_back(object[i]);
  r.folds = static_cast<int>(std::min<size_t>({static_cast<size_t>(folds), objs[0].size(), objs[1].size()}));
  if (r.folds < 2) {
    r.auc = r.ci_low = r.ci_high = std::nan("");
    return r;
  }
  // Stratified folds: each class's objects shuffled and dealt round-robin.
  std::mt19937 rng(seed);
  std::vector<int> fold(n);
  for (int cls = 0; cls < 2; ++cls) {
    std::shuffle(objs[cls].begin(), objs[cls].end(), rng);
    std::map<int64_t, int> of;
    for (size_t k = 0; k < objs[cls].size(); ++k) of[objs[cls][k]] = static_cast<int>(k % static_cast<size_t>(r.folds));
    for (size_t i = 0; i < n; ++i)
      if (label[i] == cls) fold[i] = of[object[i]];
  }
  std::vector<double> score(n, 0.0);
  for (int k = 0; k < r.folds; ++k) {
    std::vector<size_t> train, test;
    for (size_t i = 0; i < n; ++i) (fold[i] == k ? test : train).push_back(i);
    // z-scores from the training part only.
    std::vector<double> mean(dims, 0.0), sd(dims, 0.0);
    for (size_t i : train)
      for (size_t d = 0; d < dims; ++d) mean[d] += (*rows[i])[d];
    for (double& v : mean) v /= static_cast<double>(train.size());
    for (size_t i : train)
      for (size_t d = 0; d < dims; ++d) sd[d] += std::pow((*rows[i])[d] - mean[d], 2);
    for (double& v : sd) v = std::sqrt(v / static_cast<double>(train.size())) + 1e-6;
    auto matrix = [&](const std::vector<size_t>& ids) {
      cv::Mat m(static_cast<int>(ids.size()), static_cast<int>(dims), CV_32F);
      for (size_t r2 = 0; r2 < ids.size(); ++r2)
        for (size_t d = 0; d < dims; ++d)
          m.at<float>(static_cast<int>(r2), static_cast<int>(d)) =
              static_cast<float>(((*rows[ids[r2]])[d] - mean[d]) / sd[d]);
      return m;
    };
    const cv::Mat xtr = matrix(train), xte = matrix(test);
    cv::Mat ytr(static_cast<int>(train.size()), 1, CV_32S);
    for (size_t i = 0; i < train.size(); ++i) ytr.at<int>(static_cast<int>(i)) = label[train[i]];
    auto svm = cv::ml::SVM::create();
    svm->setType(cv::ml::SVM::C_SVC);
    svm->setKernel(cv::ml::SVM::LINEAR);
    svm->setC(1.0);
    svm->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER + cv::TermCriteria::EPS, 2000, 1e-6));
    svm->train(xtr, cv::ml::ROW_SAMPLE, ytr);
    // The decision value's sign convention is the library's: orient it so that the training data's inserted
    // crops score higher.
    cv::Mat raw_tr, raw_te;
    svm->predict(xtr, raw_tr, cv::ml::StatModel::RAW_OUTPUT);
    svm->predict(xte, raw_te, cv::ml::StatModel::RAW_OUTPUT);
    std::vector<double> s_tr;
    std::vector<int> p_tr;
    for (size_t i = 0; i < train.size(); ++i) {
      s_tr.push_back(raw_tr.at<float>(static_cast<int>(i)));
      p_tr.push_back(label[train[i]]);
    }
    const double sign = roc_auc(s_tr, p_tr) < 0.5 ? -1.0 : 1.0;
    for (size_t i = 0; i < test.size(); ++i) score[test[i]] = sign * raw_te.at<float>(static_cast<int>(i));
  }
  r.auc = roc_auc(score, label);
  // Stratified bootstrap of the out-of-fold scores, drawing whole objects.
  std::map<int64_t, std::vector<size_t>> crops_of[2];
  for (size_t i = 0; i < n; ++i) crops_of[label[i]][object[i]].push_back(i);
  std::vector<const std::vector<size_t>*> groups[2];
  for (int c = 0; c < 2; ++c)
    for (const auto& [id, v] : crops_of[c]) groups[c].push_back(&v);
  std::vector<double> aucs, s;
  std::vector<int> l;
  for (int b = 0; b < bootstrap; ++b) {
    s.clear();
    l.clear();
    for (int c = 0; c < 2; ++c) {
      std::uniform_int_distribution<size_t> pick(0, groups[c].size() - 1);
      for (size_t k = 0; k < groups[c].size(); ++k)
        for (size_t i : *groups[c][pick(rng)]) {
          s.push_back(score[i]);
          l.push_back(label[i]);
        }
    }
    aucs.push_back(roc_auc(s, l));
  }
  std::sort(aucs.begin(), aucs.end());
  if (!aucs.empty()) {
    r.ci_low = aucs[static_cast<size_t>(0.025 * (aucs.size() - 1))];
    r.ci_high = aucs[static_cast<size_t>(0.975 * (aucs.size() - 1))];
  }
  return r;
}

}  // namespace hf::realism
