// The ground-truth detector on real calibration: KITTI tracking 3D labels (through source/kitti) projected
// with the P2 camera, compared with the 2D boxes KITTI gives for the same objects.
#include <gtest/gtest.h>

#include <iostream>

#include "ground_truth_detector.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "kitti_source.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

std::vector<Frame> sequence(const std::string& seq) {
  auto r = testing::StageRunner::create<source::KittiSource>(
      "root: " + test::shared_data("kitti-tracking").string() + "\nsequence: \"" + seq +
      "\"\nimages_required: false");
  r.run();
  return r.collect<Frame>("frames");
}

double iou(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double inter = (a & b).area();
  return inter / (a.area() + b.area() - inter);
}

// Measured: mean IoU 0.960 (0000, 711 of 711 boxes), 0.965 (0001, 3009 of 3010: the one lost is a 1 px sliver
// of a car at the right border), 0.974 (0005, 1476 of 1476); the worst boxes (~0.52) are objects cut by the
// image border, where KITTI's box and the clipped projection differ most.
TEST(KittiProjection, ProjectedLabelsMatchKittiBoxes) {
  HF_REQUIRE_SHARED(test::shared_data("kitti-tracking/training/label_02/0005.txt"));
  GroundTruthDetector projector;
  GroundTruthDetector::Config c;
  c.prefer_dataset_boxes = false;
  c.min_points = -1;
  projector.configure(c);
  for (const char* seq : {"0000", "0001", "0005"}) {
    const std::vector<Frame> frames = sequence(seq);
    ASSERT_FALSE(frames.empty()) << seq;
    double sum = 0.0;
    int n = 0, labelled = 0, lost = 0;
    for (const Frame& f : frames) {
      const cv::Rect2d image(0, 0, f.image.cols, f.image.rows);
      const Detections dets = projector.detect_frame(f);
      std::vector<char> projected(f.annotations->objects.size(), 0);
      for (const Detection& d : dets.items) {
        const AnnotatedObject& o = f.annotations->objects[d.annotation_index];
        ASSERT_TRUE(o.box2d.has_value());
        sum += iou(*o.box2d & image, cv::Rect2d(d.box));
        ++n;
        projected[d.annotation_index] = 1;
      }
      for (size_t k = 0; k < f.annotations->objects.size(); ++k) {
        const AnnotatedObject& o = f.annotations->objects[k];
        if (o.label.empty()) continue;
        ++labelled;
        // A road user KITTI shows at least 10 px wide and tall must not be lost (slivers at the border may:
        // their projection can fall just outside the image).
        const cv::Rect2d visible = *o.box2d & image;
        if (!projected[k] && visible.width >= 10 && visible.height >= 10) ++lost;
      }
    }
    const double mean = sum / n;
    std::cout << "[ measured ] KITTI " << seq << ": " << n << " of " << labelled
              << " labelled boxes projected, mean IoU with KITTI's 2D box " << mean << "\n";
    EXPECT_GT(mean, 0.93) << seq;
    EXPECT_EQ(lost, 0) << seq;
    EXPECT_GE(n, labelled - 2) << seq;
  }
}

TEST(KittiProjection, DatasetBoxesAreUsedAsGiven) {
  HF_REQUIRE_SHARED(test::shared_data("kitti-tracking/training/label_02/0001.txt"));
  GroundTruthDetector det;  // prefer_dataset_boxes by default
  const std::vector<Frame> frames = sequence("0001");
  int n = 0;
  for (const Frame& f : frames)
    for (const Detection& d : det.detect_frame(f).items) {
      const cv::Rect2d want = *f.annotations->objects[d.annotation_index].box2d & cv::Rect2d(0, 0, 1242, 375);
      EXPECT_NEAR(d.box.x, want.x, 1e-3);
      EXPECT_NEAR(d.box.width, want.width, 1e-3);
      ++n;
    }
  EXPECT_GT(n, 2000);
}

}  // namespace
}  // namespace hf
