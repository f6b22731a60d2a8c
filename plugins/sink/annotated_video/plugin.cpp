// Plugin entry: the annotated video sink.
#include "hazardforge/plugin.hpp"
#include "annotated_video_sink.hpp"

HAZARDFORGE_PLUGIN("annotated_video", "0.1.0", "Apache-2.0",
                   "MP4 with boxes, distances, TTC and Safe/Unsafe banners") {
  reg.add<hf::sink::AnnotatedVideoSink>();
}
