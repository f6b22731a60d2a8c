// YOLO object detector on OpenCV DNN for ONNX models: YOLOv8 (Ultralytics) and YOLOX (Megvii) output layouts.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/dnn.hpp>

#include <hazardforge/class_groups.hpp>
#include <hazardforge/geometry.hpp>
#include <hazardforge/stage.hpp>

namespace hf {

// The 80 COCO class names in the order both model families use.
const std::vector<std::string>& coco_class_names();

// Stage "yolo" (detector).
// Ports: frames (Frame) -> detections (Detections), one packet per frame, stamped with the frame's timestamp.
// Params: model (path), model_type (auto|yolov8|yolox), input_width/input_height (0 = `_WxH` in the
//   file name, else 640x640), conf_threshold, nms_threshold, classes (COCO names kept), min_box_height (px),
//   threads.
// Pre/post-processing per family:
//   yolov8: letterbox centred, pad 114, RGB, /255; output [1, 4+C, N] transposed to N rows of cx,cy,w,h + C
//     class scores (no objectness).
//   yolox:  resize keeping aspect, placed top-left, pad 114 bottom/right, BGR, raw 0..255; output [1, N, 5+C]
//     decoded on the stride 8/16/32 grids: xy = (raw + grid) * stride, wh = exp(raw) * stride,
//     score = objectness x class score.
// Then confidence threshold, class-aware NMS, letterbox undone, boxes clipped to the image.
// Timings reported per frame: "preprocess", "forward" (net.forward() alone), "postprocess".
class YoloDetector : public Detector {
 public:
  enum class ModelType { kAuto, kYolov8, kYolox };

  struct Config {
    std::filesystem::path model;
    ModelType type = ModelType::kAuto;
    int input_width = 0;  // 0 = from the file name, else 640
    int input_height = 0;
    float conf_threshold = 0.25f;
    float nms_threshold = 0.45f;
    std::vector<std::string> classes = {"person", "bicycle", "car", "motorcycle", "bus", "truck"};
    float min_box_height = 0.f;
    int threads = 0;  // 0 = OpenCV's default
    // Duplicate boxes across the labels of one group (one SUV seen as car and truck) above this IoU keep only
    // the higher-scoring one; 1 = off.
    std::vector<std::string> merge_groups = default_class_groups();
    float merge_iou = 0.6f;
    double border_margin_px = 2.0;        // boxes this close to the image border are marked truncated ...
    double border_margin_input_px = 5.0;  // ... or this close in the network input's px, whichever is wider
  };

  // How the network input was made from the image: input = image * scale + (pad_x, pad_y).
  struct Letterbox {
    double scale = 1.0;
    double pad_x = 0.0, pad_y = 0.0;
    cv::Size image;
  };

  // Class-agnostic suppression within each merge group: over score-sorted detections, a box is dropped when a
  // kept box of another label in its group overlaps it at `iou` or more (iou >= 1: nothing is merged).
  static std::vector<Detection> merge_duplicates(std::vector<Detection> dets, const ClassGroups& groups,
                                                 float iou);

  struct StepTimes {
    double preprocess = 0, forward = 0, postprocess = 0;  // seconds
  };

  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  Detections detect(StageContext& ctx, const Frame& frame) override;

  // Loads the model and checks its output layout with one forward pass on a grey image. Throws hf::Error
  // naming the model path and OpenCV's message when the file is missing, unreadable or of another layout.
  void load(const Config& cfg);

  // The pieces of detect(), public so tools and benchmarks can time them separately.
  cv::Mat preprocess(const cv::Mat& bgr, Letterbox& lb) const;
  cv::Mat forward(const cv::Mat& blob);  // net.forward() on a blob from preprocess()
  std::vector<Detection> postprocess(const cv::Mat& output, const Letterbox& lb) const;

  // preprocess + forward + postprocess on one BGR image.
  std::vector<Detection> detect_image(const cv::Mat& bgr, StepTimes* times = nullptr);
  // Seconds taken by net.forward() alone on this image's blob (preprocessing done before the clock starts).
  double time_forward(const cv::Mat& bgr);

  ModelType model_type() const { return type_; }
  cv::Size input_size() const { return input_; }
  const Config& config() const { return cfg_; }
  std::string model_name() const;

  static ModelType parse_model_type(const std::string& s);
  // Input size given in the file name as `_<W>x<H>` (last occurrence); nullopt when absent.
  static std::optional<cv::Size> size_from_file_name(const std::filesystem::path& p);

 private:
  void decode_yolov8(const cv::Mat& out, const Letterbox& lb, std::vector<cv::Rect2d>& boxes,
                     std::vector<float>& scores, std::vector<int>& ids) const;
  void decode_yolox(const cv::Mat& out, const Letterbox& lb, std::vector<cv::Rect2d>& boxes,
                    std::vector<float>& scores, std::vector<int>& ids) const;
  std::string where() const;

  Config cfg_;
  cv::dnn::Net net_;
  ModelType type_ = ModelType::kAuto;
  cv::Size input_;
  int num_classes_ = 80;
  std::vector<char> keep_class_;  // by class id
};

}  // namespace hf
