// YOLOv8 / YOLOX inference with OpenCV DNN: letterboxing, output decoding, class-aware NMS, box mapping.
#include "yolo_detector.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <regex>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

namespace hf {

namespace {
constexpr int kStrides[] = {8, 16, 32};
constexpr double kPadValue = 114.0;
constexpr int kDefaultInput = 640;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Number of prediction rows a stride-8/16/32 head produces for this input size.
int grid_cells(cv::Size in) {
  int n = 0;
  for (int s : kStrides) n += (in.width / s) * (in.height / s);
  return n;
}

std::string shape_str(const cv::Mat& m) {
  std::string s = "[";
  for (int i = 0; i < m.dims; ++i) s += (i ? "," : "") + std::to_string(m.size[i]);
  return s + "]";
}
}  // namespace

const std::vector<std::string>& coco_class_names() {
  // clang-format off
  static const std::vector<std::string> names = {
      "person",        "bicycle",      "car",           "motorcycle",    "airplane",     "bus",
      "train",         "truck",        "boat",          "traffic light", "fire hydrant", "stop sign",
      "parking meter", "bench",        "bird",          "cat",           "dog",          "horse",
      "sheep",         "cow",          "elephant",      "bear",          "zebra",        "giraffe",
      "backpack",      "umbrella",     "handbag",       "tie",           "suitcase",     "frisbee",
      "skis",          "snowboard",    "sports ball",   "kite",          "baseball bat", "baseball glove",
      "skateboard",    "surfboard",    "tennis racket", "bottle",        "wine glass",   "cup",
      "fork",          "knife",        "spoon",         "bowl",          "banana",       "apple",
      "sandwich",      "orange",       "broccoli",      "carrot",        "hot dog",      "pizza",
      "donut",         "cake",         "chair",         "couch",         "potted plant", "bed",
      "dining table",  "toilet",       "tv",            "laptop",        "mouse",        "remote",
      "keyboard",      "cell phone",   "microwave",     "oven",          "toaster",      "sink",
      "refrigerator",  "book",         "clock",         "vase",          "scissors",     "teddy bear",
      "hair drier",    "toothbrush"};
  // clang-format on
  return names;
}

ComponentInfo YoloDetector::describe() {
  ComponentInfo i = Detector::base_info("yolo", "YOLOv8 / YOLOX ONNX detector on OpenCV DNN");
  i.doc =
      "Runs a COCO-80 YOLOv8 (Ultralytics layout [1,84,N]) or YOLOX (Megvii layout [1,N,85]) ONNX model with "
      "OpenCV DNN on the CPU. Emits one Detections packet per frame, stamped with the frame's timestamp, "
      "with boxes in the frame's pixels. Reports the inner timings preprocess, forward (net.forward() alone) "
      "and postprocess, and records the model file in the run manifest.";
  i.params = {
      ParamSpec::path("model", "${HAZARDFORGE_SHARED}/models/yolov8n/yolov8n_deq_640x384.onnx")
          .describe("ONNX model file"),
      ParamSpec::string("model_type", "auto")
          .one_of({"auto", "yolov8", "yolox"})
          .describe("output layout; auto decides from the output shape ([1,4+C,N] yolov8, [1,N,5+C] yolox)"),
      ParamSpec::integer("input_width", 0)
          .range(0, 8192)
          .describe("network input width, multiple of 32; 0 = `_WxH` in the model file name, else 640"),
      ParamSpec::integer("input_height", 0)
          .range(0, 8192)
          .describe("network input height, multiple of 32; 0 = `_WxH` in the model file name, else 640"),
      ParamSpec::number("conf_threshold", 0.25).range(0, 1).describe("minimum detection score"),
      ParamSpec::number("nms_threshold", 0.45)
          .range(0, 1)
          .describe("IoU above which NMS suppresses a box (per class)"),
      ParamSpec::string_list("classes", {"person", "bicycle", "car", "motorcycle", "bus", "truck"})
          .describe("COCO class names to keep; empty = all 80"),
      ParamSpec::number("min_box_height", 0.0).range(0, 100000).describe("drop boxes shorter than this (px)"),
      ParamSpec::string_list("merge_groups", default_class_groups())
          .describe(
              "comma-separated labels of one kind of object: after the per-class NMS, overlapping boxes "
              "of different labels in one group (an SUV seen as car and truck) are merged into the "
              "higher-scoring one"),
      ParamSpec::number("merge_iou", 0.6)
          .range(0, 1)
          .describe("IoU at or above which boxes of one merge group are duplicates; 1 = never merge"),
      ParamSpec::number("border_margin_px", 2.0)
          .range(0, 1000)
          .describe("a box edge within this many image px of the image border marks the box truncated there"),
      ParamSpec::number("border_margin_input_px", 5.0)
          .range(0, 1000)
          .describe(
              "... or within this many px of the network's input (the box is regressed on that grid: an "
              "object cut by the border ends a few input px inside it), whichever is wider"),
      ParamSpec::integer("threads", 0)
          .range(0, 1024)
          .describe(
              "cv::setNumThreads for the process (OpenCV's setting is global); 0 = leave OpenCV's default"),
  };
  return i;
}

YoloDetector::ModelType YoloDetector::parse_model_type(const std::string& s) {
  if (s == "auto") return ModelType::kAuto;
  if (s == "yolov8") return ModelType::kYolov8;
  if (s == "yolox") return ModelType::kYolox;
  throw Error("yolo: model_type '" + s + "' is not one of auto, yolov8, yolox");
}

std::optional<cv::Size> YoloDetector::size_from_file_name(const std::filesystem::path& p) {
  static const std::regex re("_([0-9]+)x([0-9]+)");
  const std::string name = p.stem().string();
  std::optional<cv::Size> found;
  for (auto it = std::sregex_iterator(name.begin(), name.end(), re); it != std::sregex_iterator(); ++it)
    found = cv::Size(std::stoi((*it)[1].str()), std::stoi((*it)[2].str()));
  return found;
}

std::string YoloDetector::where() const {
  return "yolo: model '" + cfg_.model.string() + "'";
}

std::string YoloDetector::model_name() const {
  return cfg_.model.filename().string();
}

void YoloDetector::open(StageContext& ctx) {
  const Params& p = ctx.params();
  Config c;
  c.model = p.get_path("model");
  c.type = parse_model_type(p.get_string("model_type"));
  c.input_width = static_cast<int>(p.get_int("input_width"));
  c.input_height = static_cast<int>(p.get_int("input_height"));
  c.conf_threshold = static_cast<float>(p.get_double("conf_threshold"));
  c.nms_threshold = static_cast<float>(p.get_double("nms_threshold"));
  c.classes = p.get_strings("classes");
  c.min_box_height = static_cast<float>(p.get_double("min_box_height"));
  c.merge_groups = p.get_strings("merge_groups");
  c.merge_iou = static_cast<float>(p.get_double("merge_iou"));
  c.border_margin_px = p.get_double("border_margin_px");
  c.border_margin_input_px = p.get_double("border_margin_input_px");
  c.threads = static_cast<int>(p.get_int("threads"));
  load(c);
  ctx.record_resource(cfg_.model);
  ctx.log(LogLevel::kInfo, "yolo: " + model_name() + " as " +
                               (type_ == ModelType::kYolov8 ? "yolov8" : "yolox") + " at " +
                               std::to_string(input_.width) + "x" + std::to_string(input_.height));
}

void YoloDetector::load(const Config& cfg) {
  cfg_ = cfg;
  if (cfg_.model.empty()) throw Error("yolo: parameter 'model' is empty");
  if (!std::filesystem::is_regular_file(cfg_.model))
    throw Error(where() + " does not exist or is not a file");

  // Classes to keep, validated against COCO so a typo is reported instead of silently detecting nothing.
  const auto& names = coco_class_names();
  keep_class_.assign(names.size(), cfg_.classes.empty() ? 1 : 0);
  for (const std::string& c : cfg_.classes) {
    auto it = std::find(names.begin(), names.end(), c);
    if (it == names.end()) {
      const std::string near = nearest_name(c, names);
      throw Error("yolo: parameter 'classes': '" + c + "' is not a COCO class name" +
                  (near.empty() ? "" : "; did you mean '" + near + "'?"));
    }
    keep_class_[it - names.begin()] = 1;
  }

  if ((cfg_.input_width == 0) != (cfg_.input_height == 0))
    throw Error("yolo: set both input_width and input_height, or neither (got " +
                std::to_string(cfg_.input_width) + "x" + std::to_string(cfg_.input_height) + ")");
  if (cfg_.input_width > 0)
    input_ = cv::Size(cfg_.input_width, cfg_.input_height);
  else
    input_ = size_from_file_name(cfg_.model).value_or(cv::Size(kDefaultInput, kDefaultInput));
  if (input_.width <= 0 || input_.height <= 0 || input_.width % 32 || input_.height % 32)
    throw Error(where() + ": input size " + std::to_string(input_.width) + "x" +
                std::to_string(input_.height) + " is not a positive multiple of 32");

  if (cfg_.threads > 0) cv::setNumThreads(cfg_.threads);
  try {
    net_ = cv::dnn::readNetFromONNX(cfg_.model.string());
  } catch (const cv::Exception& e) {
    throw Error(where() + " cannot be loaded by OpenCV " CV_VERSION ": " + e.what());
  }
  if (net_.empty()) throw Error(where() + " loaded as an empty network");
  net_.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net_.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);

  // One pass on a grey image: fails early on graphs OpenCV cannot run and tells the output layout.
  cv::Mat out;
  try {
    const cv::Mat grey(input_, CV_8UC3, cv::Scalar::all(kPadValue));
    net_.setInput(cv::dnn::blobFromImage(grey, 1.0 / 255.0));
    out = net_.forward();
  } catch (const cv::Exception& e) {
    throw Error(where() + " fails in forward() at " + std::to_string(input_.width) + "x" +
                std::to_string(input_.height) + ": " + e.what());
  }
  if (out.dims != 3 || out.size[0] != 1)
    throw Error(where() + ": output shape " + shape_str(out) +
                " is neither [1,4+C,N] (yolov8) nor [1,N,5+C] (yolox)");
  const int d1 = out.size[1], d2 = out.size[2];
  type_ = cfg_.type;
  if (type_ == ModelType::kAuto) type_ = d1 < d2 ? ModelType::kYolov8 : ModelType::kYolox;
  const int rows = type_ == ModelType::kYolov8 ? d2 : d1;
  num_classes_ = type_ == ModelType::kYolov8 ? d1 - 4 : d2 - 5;
  const char* tname = type_ == ModelType::kYolov8 ? "yolov8 [1,4+C,N]" : "yolox [1,N,5+C]";
  if (num_classes_ != static_cast<int>(names.size()))
    throw Error(where() + ": output shape " + shape_str(out) + " read as " + tname + " gives " +
                std::to_string(num_classes_) + " classes; only COCO-80 models are supported");
  if (rows != grid_cells(input_))
    throw Error(where() + ": output shape " + shape_str(out) + " has " + std::to_string(rows) +
                " predictions, but a stride 8/16/32 head at " + std::to_string(input_.width) + "x" +
                std::to_string(input_.height) + " makes " + std::to_string(grid_cells(input_)) +
                " (wrong input_width/input_height for this model, or wrong model_type)");
}

cv::Mat YoloDetector::preprocess(const cv::Mat& bgr, Letterbox& lb) const {
  lb.image = bgr.size();
  lb.scale = std::min(double(input_.width) / bgr.cols, double(input_.height) / bgr.rows);
  cv::Mat resized, padded;
  if (type_ == ModelType::kYolov8) {
    // Ultralytics LetterBox: rounded new size, padding split around it.
    const int nw = static_cast<int>(std::lround(bgr.cols * lb.scale));
    const int nh = static_cast<int>(std::lround(bgr.rows * lb.scale));
    if (nw != bgr.cols || nh != bgr.rows)
      cv::resize(bgr, resized, cv::Size(nw, nh), 0, 0, cv::INTER_LINEAR);
    else
      resized = bgr;
    const double dw = (input_.width - nw) / 2.0, dh = (input_.height - nh) / 2.0;
    const int top = static_cast<int>(std::lround(dh - 0.1)), left = static_cast<int>(std::lround(dw - 0.1));
    cv::copyMakeBorder(resized, padded, top, input_.height - nh - top, left, input_.width - nw - left,
                       cv::BORDER_CONSTANT, cv::Scalar::all(kPadValue));
    lb.pad_x = left;
    lb.pad_y = top;
    return cv::dnn::blobFromImage(padded, 1.0 / 255.0, cv::Size(), cv::Scalar(), /*swapRB=*/true, false);
  }
  // YOLOX preproc: truncated new size, image at the top-left, BGR, no normalisation.
  const int nw = static_cast<int>(bgr.cols * lb.scale), nh = static_cast<int>(bgr.rows * lb.scale);
  cv::resize(bgr, resized, cv::Size(nw, nh), 0, 0, cv::INTER_LINEAR);
  cv::copyMakeBorder(resized, padded, 0, input_.height - nh, 0, input_.width - nw, cv::BORDER_CONSTANT,
                     cv::Scalar::all(kPadValue));
  lb.pad_x = lb.pad_y = 0;
  return cv::dnn::blobFromImage(padded, 1.0, cv::Size(), cv::Scalar(), /*swapRB=*/false, false);
}

cv::Mat YoloDetector::forward(const cv::Mat& blob) {
  net_.setInput(blob);
  return net_.forward();
}

double YoloDetector::time_forward(const cv::Mat& bgr) {
  Letterbox lb;
  const cv::Mat blob = preprocess(bgr, lb);
  net_.setInput(blob);
  const auto t0 = std::chrono::steady_clock::now();
  const cv::Mat out = net_.forward();
  return seconds_since(t0);
}

void YoloDetector::decode_yolov8(const cv::Mat& out, const Letterbox& lb, std::vector<cv::Rect2d>& boxes,
                                 std::vector<float>& scores, std::vector<int>& ids) const {
  const int ch = out.size[1], n = out.size[2];
  const cv::Mat m(ch, n, CV_32F, const_cast<float*>(out.ptr<float>()));
  cv::Mat rows;
  cv::transpose(m, rows);  // n x (4 + C): one prediction per row
  for (int k = 0; k < n; ++k) {
    const float* r = rows.ptr<float>(k);
    const float* cls = r + 4;
    const int id = static_cast<int>(std::max_element(cls, cls + num_classes_) - cls);
    const float score = cls[id];
    if (score < cfg_.conf_threshold || !keep_class_[id]) continue;
    const double x1 = (r[0] - r[2] / 2 - lb.pad_x) / lb.scale, y1 = (r[1] - r[3] / 2 - lb.pad_y) / lb.scale;
    boxes.emplace_back(x1, y1, r[2] / lb.scale, r[3] / lb.scale);
    scores.push_back(score);
    ids.push_back(id);
  }
}

void YoloDetector::decode_yolox(const cv::Mat& out, const Letterbox& lb, std::vector<cv::Rect2d>& boxes,
                                std::vector<float>& scores, std::vector<int>& ids) const {
  const int width = out.size[2];
  const float* base = out.ptr<float>();
  int k = 0;
  for (int s : kStrides) {
    const int gw = input_.width / s, gh = input_.height / s;
    for (int gy = 0; gy < gh; ++gy)
      for (int gx = 0; gx < gw; ++gx, ++k) {
        const float* r = base + static_cast<size_t>(k) * width;
        const float obj = r[4];
        if (obj < cfg_.conf_threshold) continue;  // score = obj * cls <= obj
        const float* cls = r + 5;
        const int id = static_cast<int>(std::max_element(cls, cls + num_classes_) - cls);
        const float score = obj * cls[id];
        if (score < cfg_.conf_threshold || !keep_class_[id]) continue;
        const double cx = (r[0] + gx) * s, cy = (r[1] + gy) * s;
        const double w = std::exp(r[2]) * s, h = std::exp(r[3]) * s;
        boxes.emplace_back((cx - w / 2 - lb.pad_x) / lb.scale, (cy - h / 2 - lb.pad_y) / lb.scale,
                           w / lb.scale, h / lb.scale);
        scores.push_back(score);
        ids.push_back(id);
      }
  }
}

std::vector<Detection> YoloDetector::postprocess(const cv::Mat& output, const Letterbox& lb) const {
  std::vector<cv::Rect2d> boxes;
  std::vector<float> scores;
  std::vector<int> ids;
  if (type_ == ModelType::kYolov8)
    decode_yolov8(output, lb, boxes, scores, ids);
  else
    decode_yolox(output, lb, boxes, scores, ids);

  // OpenCV 4.6 has no NMSBoxesBatched (added in 4.7), so NMS runs once per class.
  std::map<int, std::vector<int>> by_class;
  for (size_t k = 0; k < ids.size(); ++k) by_class[ids[k]].push_back(static_cast<int>(k));
  const cv::Rect2d frame(0, 0, lb.image.width, lb.image.height);
  const auto& names = coco_class_names();
  // A box edge this close to the border is the border's, not the object's (in image px).
  const double margin =
      std::max(cfg_.border_margin_px, cfg_.border_margin_input_px / std::max(lb.scale, 1e-6));
  std::vector<Detection> dets;
  for (const auto& [id, members] : by_class) {
    std::vector<cv::Rect2d> b;
    std::vector<float> s;
    for (int k : members) {
      b.push_back(boxes[k]);
      s.push_back(scores[k]);
    }
    std::vector<int> keep;
    cv::dnn::NMSBoxes(b, s, cfg_.conf_threshold, cfg_.nms_threshold, keep);
    for (int k : keep) {
      const cv::Rect2d clipped = b[k] & frame;
      if (clipped.area() <= 0.0 || clipped.height < cfg_.min_box_height) continue;
      Detection d;
      d.box = cv::Rect2f(static_cast<float>(clipped.x), static_cast<float>(clipped.y),
                         static_cast<float>(clipped.width), static_cast<float>(clipped.height));
      d.class_id = id;
      d.label = names[id];
      d.score = s[k];
      d.truncated = truncation_flags(d.box, lb.image, margin);
      dets.push_back(std::move(d));
    }
  }
  std::sort(dets.begin(), dets.end(),
            [](const Detection& a, const Detection& b) { return a.score > b.score; });
  return merge_duplicates(std::move(dets), ClassGroups(cfg_.merge_groups), cfg_.merge_iou);
}

std::vector<Detection> YoloDetector::merge_duplicates(std::vector<Detection> dets, const ClassGroups& groups,
                                                      float iou) {
  // Same-label duplicates were already removed by the per-class NMS.
  if (iou >= 1.f) return dets;
  std::vector<Detection> kept;
  kept.reserve(dets.size());
  for (Detection& d : dets) {
    bool duplicate = false;
    for (const Detection& k : kept) {
      if (k.label == d.label || !groups.same(k.label, d.label)) continue;
      const float inter = (k.box & d.box).area();
      const float uni = k.box.area() + d.box.area() - inter;
      if (uni > 0.f && inter / uni >= iou) {
        duplicate = true;
        break;
      }
    }
    if (!duplicate) kept.push_back(std::move(d));
  }
  return kept;
}

std::vector<Detection> YoloDetector::detect_image(const cv::Mat& bgr, StepTimes* times) {
  if (net_.empty()) throw Error("yolo: detect_image() called before load()");
  if (bgr.empty() || bgr.type() != CV_8UC3)
    throw Error("yolo: image is " + std::string(bgr.empty() ? "empty" : "not 8-bit BGR") + " (type " +
                std::to_string(bgr.type()) + ")");
  auto t0 = std::chrono::steady_clock::now();
  Letterbox lb;
  const cv::Mat blob = preprocess(bgr, lb);
  net_.setInput(blob);
  const double t_pre = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const cv::Mat out = net_.forward();
  const double t_fwd = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  std::vector<Detection> dets = postprocess(out, lb);
  const double t_post = seconds_since(t0);
  if (times) *times = {t_pre, t_fwd, t_post};
  return dets;
}

Detections YoloDetector::detect(StageContext& ctx, const Frame& frame) {
  if (frame.image.empty() || frame.image.type() != CV_8UC3)
    throw Error("yolo: frame " + std::to_string(frame.index) + " (" + frame.source_id + ") has " +
                (frame.image.empty() ? "no image" : "an image that is not 8-bit BGR"));
  StepTimes t;
  Detections d;
  d.frame_index = frame.index;
  d.image_size = frame.image.size();
  d.detector = "yolo:" + model_name();
  d.items = detect_image(frame.image, &t);
  ctx.record_timing("preprocess", t.preprocess);
  ctx.record_timing("forward", t.forward);
  ctx.record_timing("postprocess", t.postprocess);
  return d;
}

}  // namespace hf
