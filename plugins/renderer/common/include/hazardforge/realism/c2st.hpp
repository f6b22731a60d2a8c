// A two-sample classifier test of realism (C2ST): can a classifier tell crops of inserted objects from crops
// of real ones of the same class? Features that see what a person sees, a cross-validated linear classifier,
// the area under its ROC curve with a bootstrap interval; 0.5 = indistinguishable, 1 = always told apart.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace hf::realism {

// Features of one object in a picture (BGR 8-bit), from the box grown by `margin` of its height on every
// side (so the edge the object makes with its surroundings is part of it), resized so that the box is 48 px
// tall (crops are compared at one size, as a person sees them side by side):
//  - shape of the gradients: orientation histograms (8 bins) of 2x2 cells of the box resized to 32x32;
//  - colour: L*a*b* mean and standard deviation inside the box's central half;
//  - blur and noise: the Laplacian variance inside over that of the ring around the box (log), the share of
//    gradient energy in the finest of three scales, Immerkaer's noise sigma inside and its ratio to the ring's;
//  - edge profile: the mean gradient across the box's border band over the interior's and the ring's (log).
// Empty when the box is under 8 px or has no ring in the picture.
std::vector<float> crop_features(const cv::Mat& bgr, const cv::Rect2f& box, double margin = 0.15);
// Names of the features, in order (for reports).
const std::vector<std::string>& crop_feature_names();

struct C2stResult {
  double auc = 0.5;  // NaN when either sample is too small (fewer than `min_per_class` crops)
  double ci_low = 0.0, ci_high = 1.0;  // 95 % bootstrap percentile interval
  int n_real = 0, n_inserted = 0, folds = 0;
  // The folds held out whole objects (every crop of one object in one fold, the interval from resampling
  // objects): the classifier had to tell objects it never saw. False when a sample has a single object, and
  // the folds held out crops: then what it tells apart may be that one object's identity.
  bool grouped = false;
  std::string classifier;  // what was fitted, for the report
};

// Stratified k-fold cross-validation of a linear SVM (C = 1) on z-scored features; the AUC of the out-of-fold
// decision values, its interval from `bootstrap` stratified resamples. With object ids for the crops
// (`real_objects`, `inserted_objects`, one per crop; empty = every crop its own object) the folds hold out whole
// objects (k = min(folds, objects in either sample)) and the resamples draw objects. Deterministic for a seed.
C2stResult c2st(const std::vector<std::vector<float>>& real, const std::vector<std::vector<float>>& inserted,
                int folds = 5, unsigned seed = 1, int bootstrap = 1000, int min_per_class = 5,
                const std::vector<int64_t>& real_objects = {}, const std::vector<int64_t>& inserted_objects = {});

// Area under the ROC curve of scores where `positive` marks the class scored higher (Mann-Whitney, ties
// count half).
double roc_auc(const std::vector<double>& scores, const std::vector<int>& positive);

}  // namespace hf::realism
