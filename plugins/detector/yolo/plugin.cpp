// Plugin entry for the YOLO (v8 / X) ONNX detector.
#include <hazardforge/plugin.hpp>

#include "yolo_detector.hpp"

HAZARDFORGE_PLUGIN("yolo", "0.1.0", "Apache-2.0", "YOLOv8 / YOLOX ONNX object detector on OpenCV DNN") {
  reg.add<hf::YoloDetector>();
}
