// SDK version and the ABI tag a plugin and the host must share before any C++ type crosses between them.
#pragma once

#include <opencv2/core/version.hpp>
#include <nlohmann/json.hpp>

// Major: a change that breaks plugins built for the previous version (a virtual function or a member added to
// a class or struct that crosses the boundary: vtables and layouts differ); the host refuses them. Minor:
// additions that plugins built for an older minor still work with (new free functions, new classes); a plugin
// needing a newer minor is refused by an older host. 2.0: HazardTemplate describes its kind and proposes
// plans (kind_info, propose), LlmRequest carries the generator's HazardCatalog. 3.0: ProposalRequest, which
// the generator fills and templates read, carries the scene's rules (first_seen_max_height,
// may_take_over). 4.0: HazardInstance (v3) says which real object the hazard took over and how much of it had
// to be inpainted (TakenOver); ProposalRequest says where the scene's object distances are measured from
// (distance_origin_x). 4.1: NoHazardFits, the exception a provider throws when no hazard fits the scene.
// 4.2: deciding_value, the number a RiskAssessment's label rule compares with a threshold. 4.3:
// HazardTrajectory::continued_at, the object's state past the end of its plan. 5.0: Frame and SceneContext
// carry the recording's lane markings (RoadMarkings). 6.0: SceneContext says where its objects' distances are
// measured from (distance_origin_x, moved from ProposalRequest), so the planner's templates read it too.
// 6.1: annotation_image_box, the image rectangle of an annotated 3D box. 7.0: AppearanceStats says where a
// real reference's box came from (source: detection or annotation). 8.0: HazardInstance (v4) says what a
// camera sees of the hazard: its drawn silhouette's box and the share of it inside the picture. 8.1: the
// road-user limits table (LimitsTable, from the hazard kit), EgoTrack::heading_change, angles.hpp and
// number_text.hpp. 9.0: typed contracts: Frame::origin (FrameOrigin) instead of meta keys; RoadLayout, the
// road settled once, in SceneContext and HazardSpec; HazardSpec::track_id and under_way_s as fields, kind
// fields through SpecField; refusals as typed codes (Refusal: HazardTemplate::check, HazardCatalog::check,
// HazardProposal::problem, NoHazardFits::reasons); SceneContext::meta removed. 9.1: VerificationOutcome, a
// scenario's typed verdict, with its failure codes (verdict::k*). 10.0: HazardInstance (v5) names the picture
// drawn and where it came from (picture_file, picture_source). 11.0: HazardInstance (v6) carries its 3D box in the
// ego frame (centre_ego, heading_ego, size_lwh); SystemResponse, a system under test's answer for a frame.
// 11.1: Detections read back from their JSON record (from_json), for a recorded stream replayed.
#define HF_SDK_ABI_MAJOR 11
#define HF_SDK_ABI_MINOR 1
#define HF_SDK_VERSION "0.1.0"

#define HF_STR_INNER(x) #x
#define HF_STR(x) HF_STR_INNER(x)

#if defined(__clang__)
#define HF_ABI_COMPILER "clang" HF_STR(__clang_major__)
#elif defined(__GNUC__)
#define HF_ABI_COMPILER "gcc" HF_STR(__GNUC__)
#else
#define HF_ABI_COMPILER "unknown"
#endif

#if defined(_GLIBCXX_USE_CXX11_ABI)
#define HF_ABI_CXX11 "cxx11abi" HF_STR(_GLIBCXX_USE_CXX11_ABI)
#else
#define HF_ABI_CXX11 "cxx11abi-na"
#endif

#if __cplusplus >= 202002L
#define HF_ABI_STD "c++20"
#elif __cplusplus >= 201703L
#define HF_ABI_STD "c++17"
#else
#define HF_ABI_STD "c++old"
#endif

// Types from OpenCV and nlohmann-json cross the boundary inside payloads, so their versions are part of the tag.
#define HF_ABI_TAG                                                                              \
  HF_ABI_COMPILER ";" HF_ABI_CXX11 ";" HF_ABI_STD ";opencv" HF_STR(CV_VERSION_MAJOR) "." HF_STR( \
      CV_VERSION_MINOR) ";json" HF_STR(NLOHMANN_JSON_VERSION_MAJOR) "." HF_STR(NLOHMANN_JSON_VERSION_MINOR)

#if defined(_WIN32)
#define HF_EXPORT __declspec(dllexport)
#else
#define HF_EXPORT __attribute__((visibility("default")))
#endif

// SDK classes keep default visibility even in plugins built with -fvisibility=hidden, so their type_info and
// vtables are the single copies in libhazardforge_sdk and dynamic_cast works across libraries.
#define HF_SDK_BEGIN _Pragma("GCC visibility push(default)")
#define HF_SDK_END _Pragma("GCC visibility pop")
