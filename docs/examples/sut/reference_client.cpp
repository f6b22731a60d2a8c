// Reference system under test for `hazardforge test` (line protocol version 1, see
// docs/examples/sut/sut_client.py for the bare protocol): a small monocular forward-collision
// warning system. It detects road users with YOLOv8n (ONNX, 1x3x640x640 letterboxed input,
// 1x84x8400 output, COCO classes), estimates each one's range from its box height and an
// assumed real height, follows the nearest object in the middle third of the picture, and
// warns (TTC < 2.0 s) or brakes (TTC < 1.2 s).
//
// Built with the project as build/bin/hf_sut_reference_client (alone: g++ -std=c++17 -O2
// reference_client.cpp -I/usr/include/opencv4 -lopencv_core -lopencv_imgcodecs -lopencv_imgproc
// -lopencv_dnn). Started by the tool from configs/sut/reference_client.yaml (an external_program node
// with command: [hf_sut_reference_client, yolov8n.onnx]).
// stdin: one JSON line per frame (raw mode: followed by exactly "bytes" bytes of BGR pixels);
// stdout: one JSON line per frame. Errors go to stderr.
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <iterator>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

using nlohmann::json;

namespace {

constexpr int kInput = 640;
constexpr float kScoreMin = 0.3f, kNmsIou = 0.45f;

struct Kept {
  int coco_id;
  const char* label;
  double height_m;
};
// COCO class index -> our label and the assumed real height of such an object.
constexpr Kept kKept[] = {{0, "person", 1.7},     {1, "bicycle", 1.5}, {2, "car", 1.5},
                          {3, "motorcycle", 1.5}, {5, "bus", 3.0},     {7, "truck", 3.0}};

struct Detection {
  cv::Rect2d box;
  int kept;
  float score;
};

std::vector<Detection> detect(cv::dnn::Net& net, const cv::Mat& bgr) {
  // Letterbox: scale to fit 640x640, centre, pad with grey 114.
  const double r = std::min(double(kInput) / bgr.cols, double(kInput) / bgr.rows);
  const int w = int(std::round(bgr.cols * r)), h = int(std::round(bgr.rows * r));
  const int pad_x = (kInput - w) / 2, pad_y = (kInput - h) / 2;
  cv::Mat resized, boxed;
  cv::resize(bgr, resized, cv::Size(w, h), 0, 0, cv::INTER_LINEAR);
  cv::copyMakeBorder(resized, boxed, pad_y, kInput - h - pad_y, pad_x, kInput - w - pad_x,
                     cv::BORDER_CONSTANT, cv::Scalar(114, 114, 114));
  net.setInput(cv::dnn::blobFromImage(boxed, 1.0 / 255.0, cv::Size(kInput, kInput), cv::Scalar(),
                                      /*swapRB=*/true, /*crop=*/false));
  cv::Mat out = net.forward();  // 1 x 84 x N: cx, cy, w, h, then 80 class scores
  if (out.dims != 3 || out.size[1] != 84) throw std::runtime_error("unexpected output shape");
  const int n = out.size[2];
  const cv::Mat rows(84, n, CV_32F, out.ptr<float>());

  std::vector<std::vector<cv::Rect2d>> boxes(std::size(kKept));
  std::vector<std::vector<float>> scores(std::size(kKept));
  for (int i = 0; i < n; ++i) {
    int top = 0;  // the box's most likely of the 80 classes; kept only if it is one of ours
    for (int c = 1; c < 80; ++c)
      if (rows.at<float>(4 + c, i) > rows.at<float>(4 + top, i)) top = c;
    const float best_score = rows.at<float>(4 + top, i);
    int best = -1;
    for (size_t k = 0; k < std::size(kKept); ++k)
      if (kKept[k].coco_id == top) best = int(k);
    if (best < 0 || best_score < kScoreMin) continue;
    const double cx = rows.at<float>(0, i), cy = rows.at<float>(1, i);
    const double bw = rows.at<float>(2, i), bh = rows.at<float>(3, i);
    double x0 = (cx - bw / 2 - pad_x) / r, y0 = (cy - bh / 2 - pad_y) / r;
    double x1 = (cx + bw / 2 - pad_x) / r, y1 = (cy + bh / 2 - pad_y) / r;
    x0 = std::clamp(x0, 0.0, double(bgr.cols));
    x1 = std::clamp(x1, 0.0, double(bgr.cols));
    y0 = std::clamp(y0, 0.0, double(bgr.rows));
    y1 = std::clamp(y1, 0.0, double(bgr.rows));
    if (x1 - x0 < 1.0 || y1 - y0 < 1.0) continue;
    boxes[best].emplace_back(x0, y0, x1 - x0, y1 - y0);
    scores[best].push_back(best_score);
  }
  std::vector<Detection> result;  // class-aware NMS: one pass per kept class
  for (size_t k = 0; k < std::size(kKept); ++k) {
    std::vector<cv::Rect> int_boxes;
    for (const auto& b : boxes[k]) int_boxes.emplace_back(cv::Rect(b));
    std::vector<int> keep;
    cv::dnn::NMSBoxes(int_boxes, scores[k], kScoreMin, kNmsIou, keep);
    for (int j : keep) result.push_back({boxes[k][j], int(k), scores[k][j]});
  }
  return result;
}

const auto round2 = [](double v) { return std::round(v * 100.0) / 100.0; };

// The frame's picture: decoded from the "image" path, or the "bytes" raw BGR bytes that follow the
// line (always read in full, so the next line is found). Empty when it cannot be had.
cv::Mat frame_image(const json& msg, bool raw) {
  if (!raw) {
    cv::Mat image = cv::imread(msg.value("image", ""), cv::IMREAD_COLOR);
    if (image.empty()) std::cerr << "reference_client: cannot read image " << msg.value("image", "") << "\n";
    return image;
  }
  const long long bytes = msg.value("bytes", -1LL), width = msg.value("width", 0),
                  height = msg.value("height", 0);
  if (bytes < 0) throw std::runtime_error("raw frame line without \"bytes\"");
  std::vector<unsigned char> pixels(static_cast<size_t>(bytes));
  if (!std::cin.read(reinterpret_cast<char*>(pixels.data()), std::streamsize(bytes)))
    throw std::runtime_error("stdin ended inside the pixels of frame " + msg["frame"].dump());
  if (bytes > 0 && bytes == 3 * width * height)
    return cv::Mat(int(height), int(width), CV_8UC3, pixels.data()).clone();
  std::cerr << "reference_client: " << bytes << " bytes is not " << width << "x" << height << "x3\n";
  return {};
}

}  // namespace

int main(int argc, char** argv) {
  std::ios::sync_with_stdio(false);
  if (argc < 2) {
    std::cerr << "usage: reference_client YOLOV8N.onnx  (then JSON lines on stdin)\n";
    return 2;
  }
  cv::dnn::Net net;
  try {
    net = cv::dnn::readNetFromONNX(argv[1]);
  } catch (const cv::Exception& e) {
    std::cerr << "reference_client: cannot load model " << argv[1] << ": " << e.what() << "\n";
    return 1;
  }
  if (net.empty()) {
    std::cerr << "reference_client: no model loaded from " << argv[1] << "\n";
    return 1;
  }
  std::optional<double> prev_range, prev_time;  // the nearest in-path object of the previous frame
  int prev_class = -1;
  try {
    std::string line;
    const json hello = json::parse(std::getline(std::cin, line) ? line : "", nullptr, false);
    if (!hello.is_object() || hello.value("type", "") != "hello" || hello.value("protocol", 0) != 1)
      throw std::runtime_error("the first line is not {\"type\":\"hello\",\"protocol\":1,...}");
    const bool raw = hello.value("frames", "") == "raw";
    while (std::getline(std::cin, line)) {
      if (line.empty()) continue;
      const json msg = json::parse(line, nullptr, false);
      if (!msg.is_object() || !msg.contains("frame"))
        throw std::runtime_error("not a frame line: " + line.substr(0, 200));
      const cv::Mat image = frame_image(msg, raw);
      std::vector<Detection> found;
      try {
        if (!image.empty()) found = detect(net, image);
      } catch (const std::exception& e) {
        std::cerr << "reference_client: detection failed: " << e.what() << "\n";
      }
      const double fy = msg.contains("camera") ? msg["camera"].value("fy", 0.0) : 0.0;
      const double t = msg.value("timestamp", 0.0);
      std::optional<double> range;
      int range_class = -1;
      json detections = json::array();
      for (const auto& d : found) {
        detections.push_back(
            {{"box", {round2(d.box.x), round2(d.box.y), round2(d.box.width), round2(d.box.height)}},
             {"label", kKept[d.kept].label},
             {"score", round2(d.score)}});
        const double foot_x = d.box.x + d.box.width / 2;  // bottom centre of the box
        if (fy <= 0 || foot_x < image.cols / 3.0 || foot_x > 2.0 * image.cols / 3.0) continue;
        const double r = fy * kKept[d.kept].height_m / d.box.height;  // pinhole: h_px = fy * H / Z
        if (!range || r < *range) range = r, range_class = d.kept;
      }
      json ttc = nullptr;
      bool warning = false, brake = false;
      if (range && prev_range && prev_class == range_class && t > *prev_time) {
        const double closing = (*prev_range - *range) / (t - *prev_time);
        if (closing > 0.3) {
          const double seconds = *range / closing;
          ttc = round2(seconds);
          warning = seconds < 2.0;
          brake = seconds < 1.2;
        }
      }
      prev_range = range, prev_time = t, prev_class = range ? range_class : -1;
      const json reply = {{"frame", msg["frame"]},
                          {"detections", detections},
                          {"ttc_s", ttc},
                          {"warning", warning},
                          {"brake", brake}};
      std::cout << reply.dump() << '\n' << std::flush;
    }
  } catch (const std::exception& e) {  // protocol error, or a json field of the wrong type
    std::cerr << "reference_client: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
