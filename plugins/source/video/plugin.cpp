// Plugin entry: the OpenCV-backed frame sources (video files, live cameras, image folders).
#include "hazardforge/plugin.hpp"
#include "image_sequence_source.hpp"
#include "video_source.hpp"

HAZARDFORGE_PLUGIN("video", "0.1.0", "Apache-2.0",
                   "frame sources: video files, live cameras, image folders") {
  reg.add<hf::source::VideoSource>();
  reg.add<hf::source::CameraSource>();
  reg.add<hf::source::ImageSequenceSource>();
}
