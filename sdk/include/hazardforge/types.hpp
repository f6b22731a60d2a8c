// SDK-owned payload types that flow between stages, with their JSON forms for sinks and reports.
//
// Coordinate conventions (used everywhere):
//  * ego frame: x forward, y left, z up; origin on the ground below the rear axle (as nuScenes' ego frame).
//  * camera (optical) frame: x right, y down, z forward.
//  * world frame: whatever the dataset's global frame is; only used through EgoState::T_world_ego.
#pragma once

#include "hazardforge/abi.hpp"
#include "hazardforge/refusal.hpp"

#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

HF_SDK_BEGIN
namespace hf {

using Json = nlohmann::json;
inline constexpr double kInf = std::numeric_limits<double>::infinity();
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Pinhole intrinsics, distortion and the camera's mounting on the ego vehicle.
struct CameraModel {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<double> distortion;  // OpenCV order k1 k2 p1 p2 [k3 ...]; empty = none / already undistorted
  // Camera pose in the ego frame: p_ego = R_ego_cam * p_cam + t_ego_cam.
  cv::Matx33d R_ego_cam = cv::Matx33d(0, 0, 1, -1, 0, 0, 0, -1, 0);
  cv::Vec3d t_ego_cam = cv::Vec3d(1.5, 0.0, 1.5);

  bool valid() const { return width > 0 && height > 0 && fx > 0 && fy > 0; }
  cv::Matx33d K() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }
  double height_above_ground() const { return t_ego_cam[2]; }
  // Downward pitch of the optical axis (rad, positive = looking down), derived from R_ego_cam.
  double pitch() const;
  // Roll about the optical axis (rad, positive = the camera turned clockwise as seen from behind it, so the
  // horizon in the image rises to the right), derived from R_ego_cam.
  double roll() const;
  // Image row where the ground plane's horizon crosses column x (the vanishing line of the ego's x-y plane);
  // nullopt when the camera looks straight up or down.
  std::optional<double> horizon_y(double x) const;

  cv::Vec3d ego_to_cam(const cv::Vec3d& p_ego) const;
  cv::Vec3d cam_to_ego(const cv::Vec3d& p_cam) const;
  // Pixel of a camera-frame point; nullopt when it is behind the camera (z <= 1 cm).
  std::optional<cv::Point2d> project_cam(const cv::Vec3d& p_cam) const;
  std::optional<cv::Point2d> project_ego(const cv::Vec3d& p_ego) const;
  // Ray through a pixel intersected with the ground plane (z = 0 in the ego frame); nullopt above the horizon.
  std::optional<cv::Vec3d> pixel_to_ground(const cv::Point2d& px) const;
  // Same camera for an image resized to (w, h).
  CameraModel scaled_to(int w, int h) const;

  // A camera mounted `height` m above the ground, `forward` m ahead of the rear axle, looking along the ego's
  // x axis pitched down by `pitch_rad` and rolled by `roll_rad` (conventions of pitch() and roll()).
  static CameraModel pinhole(int w, int h, double fx, double fy, double cx, double cy, double height = 1.5,
                             double pitch_rad = 0.0, double forward = 1.5, double roll_rad = 0.0);
};

// What is known about the ego vehicle at a frame.
struct EgoState {
  std::optional<double> speed_mps;                   // from dataset poses / the video / a param
  std::optional<double> yaw_rate;                    // rad/s, positive = turning left
  std::optional<cv::Matx44d> T_world_ego;            // ego pose in the dataset's world frame
  std::optional<cv::Vec3d> velocity_world;           // m/s in the world frame
  std::string source;  // where speed_mps and yaw_rate came from: "dataset", "video", "param"; "" = unknown
};

// One sample of the ego's motion.
struct EgoTrackSample {
  double t = 0;         // stream seconds
  double x = 0, y = 0;  // position on the ground plane of the track's frame, m
  double yaw = 0;       // heading in that frame, rad
  double speed_mps = 0;
  double yaw_rate = 0;  // rad/s, positive = turning left
};

// The ego's motion over the whole recording, shared by all its frames: the dataset's poses, the motion
// estimated from the video, or a stated constant speed. The planner, the renderer, the corridor and the
// exporter read it.
struct EgoTrack {
  std::string source;                   // "dataset", "video" or "param" (as EgoState::source)
  std::vector<EgoTrackSample> samples;  // increasing t
  // Throws hf::Error naming `where` and the sample when t does not increase or a value is not finite.
  void validate(const std::string& where) const;
  // Linear interpolation of position, heading (unwrapped), speed and yaw rate; clamped at the ends.
  EgoTrackSample at(double t) const;
  // The heading change (rad, positive = left) from t0 to t1 (clamped to the samples): the turns between
  // neighbouring samples added up, so a heading crossing +-180 deg is no turn and a bend of more than
  // 180 deg counts in full. Negative when t1 < t0 reverses a left turn.
  double heading_change(double t0, double t1) const;
};

// One side of the ego lane as the footage's lane markings show it.
struct LaneMarkingSide {
  // Lanes beyond the ego lane's line on this side that the markings show (a dashed line bounds a lane you may
  // change into; each further dashed line one more); -1 = the side was not seen well enough to say.
  int lanes = -1;
  std::string boundary;   // the ego lane's line on this side: "dashed", "solid" or "none"; "" = not seen
  std::string colour;     // its paint: "white" or "yellow" ("" = not seen); yellow parts opposing traffic
  double seen_share = 0;  // share of the frames analysed in which that line was found
};

// The road's lane markings over a recording, measured from the footage (a video source's self-calibration):
// how many lanes lie on each side of the ego's and of what kind its lines are. Stages read it for what the
// scene block does not state (hazard::RoadModel::with_markings).
struct RoadMarkings {
  std::string source;  // "video"
  int frames = 0;      // frames analysed
  LaneMarkingSide left, right;
  std::string note;  // how it was measured, for reports
};

// What one fact of a RoadLayout rests on.
struct RoadFactSource {
  std::string from = "default";  // "stated" (the scene block, a param), "measured" (the footage), "default"
  std::string why;               // the evidence, for logs, reports and the prompt
};

// The road a hazard is designed on, settled once from what the scene states and what the footage shows (lane
// markings, traffic, people, the scene's words). Road coordinates follow the ego's path: the ego lane is
// centred on it, lanes and kerbs run beside it. The generator's rules and prompt, the hazard templates, the
// planner and the scenario export all read this one road.
struct RoadLayout {
  static constexpr const char* kTypeName = "RoadLayout";
  static constexpr int kTypeVersion = 1;
  double lane_width_m = 3.5;
  int lanes_left = 1;  // lanes beside the ego lane on its left, either direction
  int lanes_right = 1;
  // Of the lanes on the side away from driving_side (the left when traffic keeps right), how many carry
  // oncoming traffic: the outermost ones, beyond any lanes going the ego's way. 0 = every lane goes its way.
  int oncoming_lanes = 0;
  std::string driving_side = "right";  // the side traffic keeps to
  double kerb_offset_m = 0.5;          // where pedestrians wait, beyond the road edge (m)
  bool sidewalks = false;
  double sidewalk_width_m = 3.0;
  bool pedestrians_without_sidewalks = false;  // people may walk on the shoulder where there are no sidewalks
  bool intersection = false;                   // vehicles may cross the ego path
  bool multi_lane = false;                     // a lane beside the ego's goes its way
  std::string road_type = "unknown";
  std::string environment;  // the scene's words for its surroundings
  // What each fact rests on, by field name ("lanes_left", "driving_side", "sidewalks", ...); a fact not
  // listed is a default.
  std::map<std::string, RoadFactSource> sources;

  // +1 / -1: the side oncoming traffic passes on (left when traffic keeps right).
  int oncoming_side() const { return driving_side == "left" ? -1 : 1; }
  int lanes(int side) const { return side > 0 ? lanes_left : lanes_right; }
  // |y| of the road edge on a side (+1 = left, -1 = right).
  double edge(int side) const { return lane_width_m * (0.5 + lanes(side)); }
  // Lanes on a side going the ego's way (next to the ego lane) and with oncoming traffic (beyond them).
  int oncoming_lanes_on(int side) const { return side == oncoming_side() ? oncoming_lanes : 0; }
  int same_direction_lanes(int side) const { return lanes(side) - oncoming_lanes_on(side); }
  // The lane a lateral offset lies in: 0 = the ego lane, +-k = the k-th lane to the left/right; beyond the road
  // edge the lane count + 1 (kerb side).
  int lane_at(double y) const;
  // Whether traffic in the lane at offset y goes the ego's way (the ego lane and same-direction lanes).
  bool same_direction_at(double y) const;
  // What a fact rests on (a default when `sources` does not list it).
  RoadFactSource source(const std::string& field) const;
  // Throws hf::Error naming `where` and the field when a count or width is out of range or oncoming_lanes
  // exceeds the lanes on its side.
  void validate(const std::string& where) const;
};

struct AnnotatedObject {
  std::string instance_id;
  std::string category;  // dataset category, e.g. "vehicle.car"
  std::string label;     // road-user class used by the project: car, truck, bus, person, bicycle, motorcycle
  cv::Vec3d center_ego;  // box centre
  cv::Vec3d size_lwh;    // length (along heading), width, height in m
  double yaw_ego = 0.0;  // heading in the ego frame (rad)
  std::optional<cv::Vec3d> velocity_ego;  // absolute velocity expressed in ego axes (m/s), if derivable
  int num_points = -1;                    // lidar+radar points in the box (nuScenes), -1 unknown
  std::optional<cv::Rect2d> box2d;        // image box if the dataset gives one (KITTI)
  // Share of the object the dataset says is hidden, 0 = fully visible .. 1 (nuScenes: the middle of its
  // visibility bin, e.g. 0.1 for 80-100 % visible; KITTI: 0 / 0.4 / 0.8 for fully / partly / largely
  // occluded, 1 for unknown); 0 when the dataset does not say.
  double occlusion = 0.0;
};

struct Annotations {
  static constexpr const char* kTypeName = "Annotations";
  static constexpr int kTypeVersion = 1;
  std::vector<AnnotatedObject> objects;
  std::optional<cv::Vec3d> ego_velocity_ego;  // ego velocity in its own axes (m/s), if derivable
};

// Where a frame comes from: what stages that name the recording, look up its other data or describe it read.
struct FrameOrigin {
  std::string dataset;      // "nuscenes", "kitti", "video", "images"; "" = unknown
  std::string scene;        // the dataset's scene, sequence or drive, or the file's name
  std::string description;  // the dataset's own words for the scene; "" = none
  std::optional<int64_t> dataset_frame;  // the frame's number in the dataset's files (KITTI's 10-digit name)
};

struct Frame {
  static constexpr const char* kTypeName = "Frame";
  static constexpr int kTypeVersion = 2;
  int64_t index = 0;       // 0-based position in the source's stream
  double timestamp = 0.0;  // seconds since the start of the stream
  cv::Mat image;           // BGR 8-bit
  CameraModel camera;
  EgoState ego;
  std::string source_id;  // file name / dataset token
  FrameOrigin origin;
  std::shared_ptr<const EgoTrack> ego_track;  // the whole recording's ego motion, when known
  std::shared_ptr<const RoadMarkings> road_markings;  // the recording's lane markings, when measured
  std::optional<double> stream_end;           // timestamp of the stream's last frame, when the source knows it
  // Source-specific details for the run's records (sample tokens, file names); no stage reads them, what stages
  // share is typed (origin, ego_track, road_markings, annotations).
  Json meta = Json::object();
  std::shared_ptr<const Annotations> annotations;  // dataset ground truth, when the source carries it
};

// How messages name a frame: "frame 12 (t=6.000000 s)".
std::string frame_name(const Frame& f);

struct Detection {
  cv::Rect2f box;  // pixels, in the frame's image
  int class_id = -1;
  std::string label;  // car, truck, bus, person, bicycle, motorcycle, ...
  float score = 0.f;
  int annotation_index = -1;  // for ground-truth detections: index into Frame::annotations
  unsigned truncated = 0;     // hf::truncation flags: box edges on the image border (geometry.hpp)
};

struct Detections {
  static constexpr const char* kTypeName = "Detections";
  static constexpr int kTypeVersion = 1;
  int64_t frame_index = 0;
  cv::Size image_size;
  std::string detector;  // stage + model, for reports
  std::vector<Detection> items;
};

struct Track {
  int64_t id = -1;  // persistent across frames
  cv::Rect2f box;
  std::string label;
  float score = 0.f;
  int age = 0;     // frames since the track was born
  int hits = 0;    // frames in which it was matched
  int misses = 0;  // consecutive frames without a match (box is then predicted/held)
  cv::Point2f velocity_px;  // image-plane velocity of the box centre, px/s
  int detection_index = -1;  // index into this frame's Detections, -1 when not matched this frame
  int annotation_index = -1;
  unsigned truncated = 0;  // hf::truncation flags of the last matched detection
};

struct Tracks {
  static constexpr const char* kTypeName = "Tracks";
  static constexpr int kTypeVersion = 1;
  int64_t frame_index = 0;
  std::string tracker;
  std::vector<Track> items;
};

// Metric state of one tracked object, in the ego frame.
struct ObjectState {
  int64_t track_id = -1;
  std::string label;
  float score = 0.f;
  cv::Rect2f box;
  double distance_m = kInf;     // longitudinal distance d along ego x (camera-to-object for the pinhole model)
  double lateral_m = 0.0;       // y in the ego frame, positive left
  double width_m = 0.0;         // assumed/annotated object width, for corridor tests
  double length_m = 0.0;
  std::optional<cv::Vec2d> velocity_rel;  // (vx, vy) relative to ego, m/s
  std::optional<double> speed_mps;        // v_obj: absolute speed estimate
  std::optional<double> heading_rad;      // psi: object's motion direction relative to ego heading
  std::optional<double> scale_rate;       // (dh/dt)/h of the box height, 1/s
  double box_height_px = 0.0;
  int age = 0;
  int misses = 0;
  bool in_path = false;
  // "pinhole", "ground", "fused", "annotation"; "bearing" (no range this frame, only the sideways position
  // from the box's column), "predicted" (nothing measured this frame), "rejected" (the measurement was gated)
  std::string distance_method;
  int annotation_index = -1;
  unsigned truncated = 0;  // hf::truncation flags of the box (its height/bottom did not measure range)
  // Covariance of (distance_m, lateral_m, velocity_rel.x, velocity_rel.y) in m and m/s, from estimators that
  // filter the state; absent for those that do not.
  std::optional<cv::Matx44d> covariance;
};

struct ObjectStates {
  static constexpr const char* kTypeName = "ObjectStates";
  static constexpr int kTypeVersion = 1;
  int64_t frame_index = 0;
  double timestamp = 0.0;
  std::optional<double> ego_speed_mps;
  std::optional<double> ego_yaw_rate;  // rad/s, positive = turning left (drives the corridor's path)
  double distance_origin_x = 0.0;      // ego x (m) that every distance_m is measured from
  std::vector<ObjectState> objects;
};

enum class SafetyLabel { kSafe, kUnsafe };
const char* to_string(SafetyLabel l);

struct ObjectRisk {
  int64_t track_id = -1;
  double value = kInf;
  bool in_path = false;
  // Interval of the value (about 90 %: value +- 1.645 sigma, mapped through the metric) when the metric
  // propagates the state's uncertainty; NaN when it does not.
  double low = std::numeric_limits<double>::quiet_NaN();
  double high = std::numeric_limits<double>::quiet_NaN();
};

// One metric's verdict on a frame. For TTC-like metrics lower is riskier; for DRAC higher is riskier.
struct RiskAssessment {
  static constexpr const char* kTypeName = "RiskAssessment";
  static constexpr int kTypeVersion = 1;
  int64_t frame_index = 0;
  std::string metric;     // node id, e.g. "ttc" or "ttc_scale"
  std::string stage;      // stage name
  std::string unit;       // "s", "m/s2"
  bool lower_is_riskier = true;
  double threshold = 1.5;
  std::vector<ObjectRisk> objects;
  double scene_value = kInf;  // min (or max) over in-path objects
  int64_t critical_track = -1;
  SafetyLabel label = SafetyLabel::kSafe;
  std::string label_rule = "value";  // which bound decided the label: value | riskier_bound | safer_bound
};

// The number a RiskAssessment's label compares with a threshold: over the in-path objects, the riskiest of
// each one's value or, under label_rule riskier_bound / safer_bound, of its interval's end on that side (an
// object without an interval gives its value). Equal to scene_value under "value". The label is Unsafe when
// it is below the threshold (above it when higher is riskier); re-thresholding an assessment uses it too.
double deciding_value(const RiskAssessment& r);

// The hazard the generator asks for (mirrors share/schemas/hazard_spec.schema.json).
struct HazardSpec {
  static constexpr const char* kTypeName = "HazardSpec";
  static constexpr int kTypeVersion = 1;
  std::string schema_version = "1.1";
  std::string kind;           // pedestrian_crossing, cut_in, sudden_stop, or a third-party kind
  std::string object_class;   // person, car, truck, ...
  double initial_distance_m = 0.0;  // longitudinal, ego frame, at start_time
  double lateral_offset_m = 0.0;    // y at start, positive left
  std::string side;                 // left / right / center
  double speed_mps = 0.0;           // object's speed at start
  double heading_deg = 0.0;         // motion direction relative to ego heading, positive = to the left
  std::string motion;               // free text: "crossing left to right", ...
  double start_time_s = 0.0;        // stream time at which the hazard appears
  std::optional<double> deceleration_mps2;  // sudden_stop
  std::optional<double> target_ttc_s;       // TTC the hazard is designed to reach
  // A tracked object of the recording the hazard takes over (the renderer removes the real one and draws the
  // hazard in its place): its track id. Any kind may take one over where the scene's rules allow it.
  std::optional<int64_t> track_id;
  // How long the manoeuvre has already been under way when the hazard appears at start_time_s (a lead already
  // braking, a lane change already started); the position and speed fields then describe its start, that
  // long before. At most max_under_way_s.
  std::optional<double> under_way_s;
  // The fields the kind declares (HazardKindInfo::extra_fields), read by that kind alone (SpecField).
  Json extra = Json::object();
  std::string rationale;
  // The road the hazard was designed on (the generator's); the planner plans on it and the export lays it out.
  // Absent (hand-written specs): the templates' own road.
  std::optional<RoadLayout> road;
  Json provenance = Json::object();  // for the record (backend, model, prompt hash, retries); no stage reads it
  // The bounds the generator designed and checked the hazard under (not part of an LLM's reply): how long it
  // is planned for from its start, and how long it may already be under way when it appears. The planner plans
  // within the same bounds, so they are stated once, on the generator.
  std::optional<double> horizon_s;
  std::optional<double> max_under_way_s;
};

struct TrajectoryPoint {
  double t = 0.0;  // stream time, s
  double x = 0.0, y = 0.0;  // position of the object's ground-contact centre in the anchor frame
  double heading = 0.0;     // rad, anchor frame
  double speed = 0.0;
  double accel = 0.0;
};

// Object motion over time in the *anchor frame*: the ego frame at `anchor_time` (fixed in the world).
struct HazardTrajectory {
  static constexpr const char* kTypeName = "HazardTrajectory";
  static constexpr int kTypeVersion = 1;
  std::string kind;
  std::string object_class;
  cv::Vec3d size_lwh{4.5, 1.8, 1.5};
  double anchor_time = 0.0;
  std::vector<TrajectoryPoint> points;  // increasing t, regular spacing
  std::vector<TrajectoryPoint> ego;     // planned ego motion in the same frame (for replay/export)
  double intended_min_ttc_s = kInf;
  HazardSpec spec;
  // Linear interpolation; nullopt outside [front.t, back.t].
  std::optional<TrajectoryPoint> at(double t) const;
  // The same within the plan; past its last point the object carries on as it ended, so that it does not
  // vanish mid-road: along the curvature of its last second of travel (heading change over distance, 0 under
  // 0.5 m), at its final speed, or braking on at its final deceleration to a standstill (never speeding up).
  // nullopt before the first point. Whether the ego has reached it by then is the caller's question.
  std::optional<TrajectoryPoint> continued_at(double t) const;
};

// How one object looks in one picture: the quantities that tell an inserted object from the real ones of its
// class (computed by the realism kit, plugins/renderer/common, hazardforge/realism/*.hpp). NaN = not measured.
struct AppearanceStats {
  std::string label;  // class of the object (inserted: the hazard's; real: the detector's or the dataset's)
  // Where a real object's box came from: "detection" (the recording's detections or tracks) or "annotation"
  // (the dataset's 3D box projected into the picture); empty for the inserted object.
  std::string source;
  cv::Rect2f box;     // its box in the picture
  // Mean |L* inside - L* outside| across the silhouette (bands 2 px wide on either side), L* 0..100.
  double edge_contrast = kNaN;
  // Mean |L* just outside the silhouette (0-2 px) - L* farther out (5-9 px)|: a halo of the cut-out's old
  // background, a dark or light fringe; on natural boundaries only the background's own texture.
  double halo = kNaN;
  // Variance of the Laplacian of L* inside the object over that of the background ring around it.
  double sharpness = kNaN;
  // Sensor noise (grey levels, Immerkaer's estimator on the flattest pixels) inside the object, and over that
  // of the background ring.
  double noise_sigma = kNaN;
  double noise_ratio = kNaN;
  cv::Vec3d lab_mean{kNaN, kNaN, kNaN};  // L* a* b* of the object's pixels
  cv::Vec3d lab_std{kNaN, kNaN, kNaN};
  // Size for its distance: the box's height and width in metres at the camera depth of the road point under
  // the box's bottom centre (flat road), and the box's width / height.
  double ground_depth_m = kNaN;
  double height_m = kNaN;
  double width_m = kNaN;
  double aspect = kNaN;
};

// A recorded object the hazard took over (HazardSpec::track_id): the renderer removed it from the picture
// and drew the hazard in its place.
struct TakenOver {
  int64_t track_id = -1;
  cv::Rect2f box;                  // the real object's box in this frame (from the recording's tracks)
  bool seen = false;               // the recording's tracks had it in this frame (else its last box, predicted)
  double uncovered_fraction = 0;   // share of that box the drawn hazard does not hide: filled by inpainting
  double lateral_shift_m = 0;      // sideways correction keeping the hazard in the real one's lane
};

// Where the renderer put the hazard in one frame (the intent that verification checks against).
struct HazardInstance {
  static constexpr const char* kTypeName = "HazardInstance";
  static constexpr int kTypeVersion = 6;
  int64_t frame_index = 0;
  bool visible = false;
  std::string kind;
  std::string object_class;
  cv::Rect2f box;  // projected 3D box of the inserted object, clipped to the picture
  // What a detector can see of it: the bounds of the drawn silhouette (alpha >= 1/2) left by nearer objects,
  // empty when nothing of it shows (or the renderer does not say).
  cv::Rect2f drawn_box;
  double distance_m = kInf;     // longitudinal distance in the current ego frame
  double lateral_m = 0.0;
  double intended_ttc_s = kInf;
  // Its 3D box in the current ego frame (the labels of a dataset export): the ground-contact centre (z = 0),
  // heading (rad, 0 = the ego's forward axis, positive = to the left), length, width, height. Set while drawn.
  cv::Vec3d centre_ego{kNaN, kNaN, 0.0};
  double heading_ego = kNaN;
  cv::Vec3d size_lwh{kNaN, kNaN, kNaN};
  double occluded_fraction = 0.0;    // share of its silhouette in the picture that nearer objects hide
  double in_picture_fraction = 1.0;  // share of its whole silhouette inside the picture (1 - truncation)
  // Share of the whole silhouette a camera sees: in the picture and not hidden.
  double visible_share() const { return in_picture_fraction * (1.0 - occluded_fraction); }
  // Realism: the inserted object as drawn in this frame, and real road users measured the same way on the
  // original picture of this frame (the recording's own objects, for comparison).
  std::optional<AppearanceStats> appearance;
  std::vector<AppearanceStats> references;
  std::optional<TakenOver> taken_over;  // set while a taken-over real object is being removed
  // The picture drawn: its file and where it came from ("footage": cut from this recording; "harvested":
  // from a dataset's annotated objects; "generated": the project's default renders); empty when not drawn.
  std::string picture_file;
  std::string picture_source;
};

// Codes of a scenario's verification failures (VerificationOutcome::reasons), by what failed.
namespace verdict {
inline constexpr const char* kNoHazard = "no_hazard";          // no planned trajectory arrived
inline constexpr const char* kNeverVisible = "never_visible";  // never drawn in view, or never enough of it
inline constexpr const char* kNotRedetected = "not_redetected";  // re-detected in too few frames
inline constexpr const char* kNeverUnsafe = "never_unsafe";      // the re-assessment never says Unsafe
inline constexpr const char* kNotHazardCritical = "not_hazard_critical";  // Unsafe, but never for the hazard
inline constexpr const char* kTakeover = "takeover";  // the taken-over real object not found or not hidden
inline constexpr const char* kTtcError = "ttc_error";  // the achieved minimum TTC far from the intended one
}  // namespace verdict

// A scenario's verdict after its re-assessment (the closed-loop verifier's), with the numbers the campaign,
// reports and a test of a system read. Its JSON form is the head of verification.json ("reasons" the texts,
// "reason_codes" their codes).
struct VerificationOutcome {
  static constexpr const char* kTypeName = "VerificationOutcome";
  static constexpr int kTypeVersion = 1;
  bool passed = false;
  std::vector<Refusal> reasons;  // why it did not pass (verdict::k* codes); empty when it passed
  std::string kind, object_class;
  std::optional<double> intended_min_ttc_s;  // the plan's lowest TTC while the hazard is visible
  std::optional<double> achieved_min_ttc_s;  // the re-assessment's lowest TTC while it is visible
  std::optional<int64_t> achieved_at_frame;
  int hazard_critical_frames = 0;       // Unsafe frames attributed to the hazard
  std::vector<int64_t> spurious_frames;  // Unsafe frames not attributed to it
  std::optional<double> redetection_rate;
};

// What a system under test answered for one frame (an external program's reply, or a graph's detections and
// risk read as one): its detections, its TTC of the most critical object, and its warning and brake request.
struct SystemResponse {
  static constexpr const char* kTypeName = "SystemResponse";
  static constexpr int kTypeVersion = 1;
  int64_t frame_index = 0;
  std::vector<Detection> detections;
  std::optional<double> ttc_s;  // nullopt: the system names no time to collision
  bool warning = false;         // a collision warning is given
  bool brake = false;           // braking is requested
};

// Generic per-frame record (verification, evaluation) for sinks.
struct Record {
  static constexpr const char* kTypeName = "Record";
  static constexpr int kTypeVersion = 1;
  std::string kind;
  Json data = Json::object();
};

// ---- JSON forms (ADL) --------------------------------------------------------------------------------------
void to_json(Json& j, const CameraModel& v);
void from_json(const Json& j, CameraModel& v);
void to_json(Json& j, const Detection& v);
void to_json(Json& j, const Detections& v);
// Read back what to_json wrote (a recorded stream replayed); image_size is not recorded. Throws hf::Error
// naming the field.
void from_json(const Json& j, Detection& v);
void from_json(const Json& j, Detections& v);
void to_json(Json& j, const Track& v);
void to_json(Json& j, const Tracks& v);
void to_json(Json& j, const ObjectState& v);
void to_json(Json& j, const ObjectStates& v);
void to_json(Json& j, const RiskAssessment& v);
void to_json(Json& j, const HazardSpec& v);
void from_json(const Json& j, HazardSpec& v);
void to_json(Json& j, const TrajectoryPoint& v);
void to_json(Json& j, const HazardTrajectory& v);
void to_json(Json& j, const AppearanceStats& v);
void to_json(Json& j, const HazardInstance& v);
void to_json(Json& j, const Record& v);
void to_json(Json& j, const SystemResponse& v);
void to_json(Json& j, const LaneMarkingSide& v);
void to_json(Json& j, const RoadMarkings& v);
void to_json(Json& j, const RoadFactSource& v);
void to_json(Json& j, const RoadLayout& v);
void from_json(const Json& j, RoadLayout& v);
void to_json(Json& j, const FrameOrigin& v);
// The fields above, in verification.json's layout (ttc.*, unsafe.*, redetection.rate); from_json reads a
// verification.json (files without reason_codes: the reasons without codes). Throws hf::Error naming the field.
void to_json(Json& j, const VerificationOutcome& v);
void from_json(const Json& j, VerificationOutcome& v);
void to_json(Json& j, const AnnotatedObject& v);
void to_json(Json& j, const Annotations& v);
void to_json(Json& j, const Frame& v);  // metadata only, not pixels

// The tracked object a hazard spec's JSON takes over (HazardSpec::track_id: top level since schema 1.1, inside
// `extra` in 1.0), read from a spec that may be partial (a campaign's feedback); nullopt when it names none.
// Throws hf::Error when it is not a non-negative whole number.
std::optional<int64_t> spec_track_id(const Json& spec);

// JSON has no infinity: non-finite numbers are written as null.
Json finite_or_null(double v);

}  // namespace hf
HF_SDK_END
