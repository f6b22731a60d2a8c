// Shared geometry for risk metrics and renderers: per-class size priors, box truncation, annotated boxes in
// the image, the share folder (and, through corridor.hpp, the in-path corridor).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/abi.hpp"
#include "hazardforge/corridor.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/types.hpp"

HF_SDK_BEGIN
namespace hf {

// Typical real-world size of a road-user class (m), read from share/class_sizes.yaml.
struct ClassSize {
  double height = 1.5;
  double width = 1.8;
  double length = 4.5;
};

class ClassPriors {
 public:
  // YAML mapping label -> {height, width, length}. Throws hf::Error naming the file and field.
  static ClassPriors load(const std::string& path);
  bool has(const std::string& label) const { return sizes_.count(label) != 0; }
  // Throws hf::Error naming the label and file when the class has no prior.
  const ClassSize& at(const std::string& label) const;
  const std::map<std::string, ClassSize>& all() const { return sizes_; }
  void set(const std::string& label, ClassSize s) { sizes_[label] = s; }

 private:
  std::map<std::string, ClassSize> sizes_;
  std::string file_;
};

// Intersection over union of two image boxes (0 when either is empty).
inline double box_iou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const double inter = (a & b).area();
  const double uni = double(a.area()) + double(b.area()) - inter;
  return uni > 0.0 ? inter / uni : 0.0;
}

// Edges of a box that lie on (within `margin_px` of) the image border: a truncated box's extent on that side
// is not the object's. Bit flags, 0 = fully inside.
namespace truncation {
inline constexpr unsigned kLeft = 1, kTop = 2, kRight = 4, kBottom = 8;
}
unsigned truncation_flags(const cv::Rect2f& box, const cv::Size& image, double margin_px = 2.0);

// The image rectangle of an annotated 3D box (AnnotatedObject: centre, size, heading in the ego frame): the
// bounding rectangle of its corners' pixels (with the camera's distortion), edges that cross the plane
// `near_m` in front of the camera cut there, not clipped to the image; nullopt when the whole box is behind
// that plane. The ground-truth detector's boxes and the renderer's annotated realism references.
std::optional<cv::Rect2d> annotation_image_box(const CameraModel& cam, const AnnotatedObject& obj,
                                               double near_m = 0.1);

// The folder holding the project's shared files (prompts, priors, schemas, assets): $HAZARDFORGE_SHARE,
// else the install's share/hazardforge, else the source tree's share/ (set at build time).
std::string share_dir();

}  // namespace hf
HF_SDK_END
