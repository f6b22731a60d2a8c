// Trimap, information-flow matting (cv::alphamat) and colour decontamination for cut-outs.
#include "hazardforge/realism/matting.hpp"

#include <algorithm>

#include <opencv2/alphamat.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/error.hpp"

namespace hf::realism {

namespace {

// Normalised Gaussian average of `bgr` over the pixels where `weight` (CV_32F 0..1) is set: colours pushed
// into the pixels around them. Also returns the accumulated weight.
cv::Mat spread_colours(const cv::Mat& bgr_f, const cv::Mat& weight, double sigma, cv::Mat& wsum) {
  cv::Mat w3, num;
  cv::merge(std::vector<cv::Mat>{weight, weight, weight}, w3);
  cv::multiply(bgr_f, w3, num);
  cv::GaussianBlur(num, num, cv::Size(), sigma);
  cv::GaussianBlur(weight, wsum, cv::Size(), sigma);
  cv::Mat den;
  cv::merge(std::vector<cv::Mat>{wsum, wsum, wsum}, den);
  cv::divide(num, cv::max(den, 1e-6), num);
  return num;
}

}  // namespace

cv::Mat trimap_from_mask(const cv::Mat& mask, int band_px) {
  if (mask.empty() || mask.type() != CV_8UC1) throw Error("trimap_from_mask: expected an 8-bit mask");
  cv::Mat bin;
  cv::threshold(mask, bin, 127, 255, cv::THRESH_BINARY);
  const int b = std::max(1, band_px);
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * b + 1, 2 * b + 1));
  cv::Mat fg, grown;
  cv::erode(bin, fg, k);
  cv::dilate(bin, grown, k);
  cv::Mat tri(mask.size(), CV_8U, cv::Scalar(kTrimapBackground));
  tri.setTo(kTrimapUnknown, grown);
  tri.setTo(kTrimapForeground, fg);
  return tri;
}

cv::Mat matte(const cv::Mat& bgr, const cv::Mat& trimap) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("matte: expected a BGR 8-bit picture");
  if (trimap.type() != CV_8UC1 || trimap.size() != bgr.size())
    throw Error("matte: the trimap must be 8-bit and " + std::to_string(bgr.cols) + "x" + std::to_string(bgr.rows));
  if (cv::countNonZero(trimap == kTrimapForeground) == 0 || cv::countNonZero(trimap == kTrimapBackground) == 0)
    throw Error("matte: the trimap needs both definite foreground and definite background");
  cv::Mat alpha;
  if (cv::countNonZero(trimap == kTrimapUnknown) == 0) return trimap.clone();
  try {
    cv::alphamat::infoFlow(bgr, trimap, alpha);
  } catch (const cv::Exception& e) {
    throw Error(std::string("matte: alphamat failed: ") + e.what());
  }
  if (alpha.type() != CV_8U) alpha.convertTo(alpha, CV_8U);
  alpha.setTo(255, trimap == kTrimapForeground);
  alpha.setTo(0, trimap == kTrimapBackground);
  return alpha;
}

cv::Mat decontaminate(const cv::Mat& bgr, const cv::Mat& alpha, double radius_px) {
  if (bgr.empty() || bgr.type() != CV_8UC3) throw Error("decontaminate: expected a BGR 8-bit picture");
  if (alpha.type() != CV_8UC1 || alpha.size() != bgr.size()) throw Error("decontaminate: alpha must match the picture");
  cv::Mat I, a;
  bgr.convertTo(I, CV_32F);
  alpha.convertTo(a, CV_32F, 1.0 / 255);
  cv::Mat bw = a < 0.05f, fw = a > 0.95f;
  bw.convertTo(bw, CV_32F, 1.0 / 255);
  fw.convertTo(fw, CV_32F, 1.0 / 255);
  const double sigma = std::max(1.0, radius_px);
  cv::Mat bsum, fsum;
  const cv::Mat B = spread_colours(I, bw, sigma, bsum);
  const cv::Mat F0 = spread_colours(I, fw, sigma, fsum);
  // Foreground extrapolation that reaches farther, for edge pixels no near foreground pixel covers.
  cv::Mat fsum_wide;
  const cv::Mat F_wide = spread_colours(I, fw, 4 * sigma, fsum_wide);
  cv::Mat out = bgr.clone();
  for (int y = 0; y < bgr.rows; ++y) {
    const float* ap = a.ptr<float>(y);
    const auto* ip = I.ptr<cv::Vec3f>(y);
    const auto* bp = B.ptr<cv::Vec3f>(y);
    const auto* fp = F0.ptr<cv::Vec3f>(y);
    const auto* fwp = F_wide.ptr<cv::Vec3f>(y);
    const float* bs = bsum.ptr<float>(y);
    const float* fs = fsum.ptr<float>(y);
    auto* op = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < bgr.cols; ++x) {
      const float al = ap[x];
      if (al >= 0.995f) continue;
      const cv::Vec3f fext = fs[x] > 1e-3f ? fp[x] : fwp[x];
      // The solved colour amplifies the background estimate's error by (1 - a) / a: below a = 0.6 it is
      // blended towards the extrapolated foreground, below 0.25 replaced by it.
      cv::Vec3f F = fext;
      if (al >= 0.25f && bs[x] > 1e-3f) {
        const float w = std::min(1.f, (al - 0.25f) / 0.35f);
        F = w * ((ip[x] - (1.f - al) * bp[x]) / al) + (1.f - w) * fext;
      }
      for (int k = 0; k < 3; ++k) op[x][k] = cv::saturate_cast<uint8_t>(F[k]);
    }
  }
  return out;
}

cv::Mat largest_component(const cv::Mat& bin) {
  cv::Mat labels, stats, cents;
  const int n = cv::connectedComponentsWithStats(bin, labels, stats, cents, 8);
  int best = -1, area = 0;
  for (int i = 1; i < n; ++i)
    if (stats.at<int>(i, cv::CC_STAT_AREA) > area) {
      area = stats.at<int>(i, cv::CC_STAT_AREA);
      best = i;
    }
  cv::Mat out(bin.size(), CV_8U, cv::Scalar(0));
  if (best < 0) return out;
  out = labels == best;
  cv::Mat padded;
  cv::copyMakeBorder(~out, padded, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(255));
  cv::floodFill(padded, cv::Point(0, 0), cv::Scalar(0));
  out |= padded(cv::Rect(1, 1, out.cols, out.rows));
  return out;
}

}  // namespace hf::realism
