// The scenario package: what a hazard run leaves for testing a system and for dataset export (RUN/scenario/):
// the augmented and the original frames as pictures, and per frame the camera, the ego's motion and the
// labels of the inserted object (and of the recording's own objects where the dataset knows them). Written by
// the scenario_package sink; read by the scenario source, `hazardforge test` and `hazardforge export`.
//
//   scenario.json    {"schema": "hazardforge-scenario/1", kind, object_class, origin, image_format, frames}
//   frames.jsonl     one PackageFrame per line
//   augmented/NNNNNN.<ext>, original/NNNNNN.<ext>
#pragma once

#include "hazardforge/abi.hpp"

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/types.hpp"

HF_SDK_BEGIN
namespace hf::scenario {

inline constexpr const char* kSchema = "hazardforge-scenario/1";

// A 3D box in the camera's axes by the KITTI conventions (x right, y down, z forward): the bottom face's
// centre, height/width/length, and the rotation about the camera's y axis (0 = facing the camera's x axis,
// -pi/2 = driving away from the camera), with the same box in the ego frame.
struct Box3d {
  cv::Vec3d location_cam;
  cv::Vec3d dimensions_hwl;
  double rotation_y = 0.0;
  cv::Vec3d centre_ego;  // ground-contact centre (the bottom face's), ego frame
  cv::Vec3d size_lwh;
  double heading_ego = 0.0;
};
// The box whose bottom face is centred at `bottom_centre_ego` with the heading and size given.
Box3d box3d(const CameraModel& cam, const cv::Vec3d& bottom_centre_ego, double heading_ego,
            const cv::Vec3d& size_lwh);
// KITTI's observation angle of a box: rotation_y less the azimuth of its location, in [-pi, pi].
double observation_angle(const Box3d& b);

struct LabelledObject {
  int64_t track_id = 0;  // 0: the inserted object; the recording's objects from 1
  std::string label;     // car, truck, bus, person, bicycle, motorcycle
  bool inserted = false;
  std::string kind;         // the inserted object's hazard kind
  std::string instance_id;  // the dataset's identity of a recorded object
  bool visible = false;     // the inserted object: drawn in view (its box is then the label box)
  cv::Rect2f box;           // what shows in the picture: the drawn silhouette's bounds (clipped)
  double truncation = 0.0;  // share outside the picture, 0..1
  double occlusion = 0.0;   // share hidden by nearer objects, 0..1
  std::optional<Box3d> box3d;
  double distance_m = kNaN;     // longitudinal, ego frame
  std::optional<double> ttc_s;  // ground truth: the planned time to collision (nullopt: not closing)
};

struct PackageFrame {
  int64_t frame = 0;
  double timestamp = 0.0;
  std::string augmented, original;  // picture files relative to the package folder
  CameraModel camera;
  std::optional<double> ego_speed_mps, ego_yaw_rate;
  std::optional<LabelledObject> hazard;  // while the renderer places it (visible or not)
  std::vector<LabelledObject> objects;   // the recording's own objects the dataset annotates in view
};

struct PackageHeader {
  std::string kind, object_class;
  FrameOrigin origin;
  std::string image_format = "jpg";
  int64_t frames = 0;
};

Json to_json(const LabelledObject& o);
Json to_json(const PackageFrame& f);
Json to_json(const PackageHeader& h);
// Throw hf::Error naming `where` and the field.
LabelledObject labelled_object_from_json(const Json& j, const std::string& where);
PackageFrame package_frame_from_json(const Json& j, const std::string& where);

struct Package {
  std::filesystem::path dir;
  PackageHeader header;
  std::vector<PackageFrame> frames;
  std::filesystem::path picture(const PackageFrame& f, bool augmented) const {
    return dir / (augmented ? f.augmented : f.original);
  }
};
// The package in `dir` (a package folder, or a run folder holding scenario/). Throws hf::Error naming the
// file, line and field of the first fault; frames must be in increasing order.
Package read_package(const std::filesystem::path& dir);
// The package folder for a package or run folder; nullopt when neither holds one.
std::optional<std::filesystem::path> find_package(const std::filesystem::path& dir);

}  // namespace hf::scenario
HF_SDK_END
