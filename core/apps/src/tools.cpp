// `hazardforge calibrate` and `hazardforge assets harvest`.
#include <iostream>

#include "hazardforge/apps/commands.hpp"
#include "hazardforge/geometry.hpp"

#if __has_include("hazardforge/apps/calibration.hpp")
#include "hazardforge/apps/calibration.hpp"
#define HF_HAVE_CALIBRATION 1
#endif

namespace hf::apps {

using namespace hf::core;  // the host's public interface

int cmd_calibrate(const CalibrateOptions& o) {
#ifdef HF_HAVE_CALIBRATION
  try {
    CalibrationResult r = calibrate_chessboard(o.folder, cv::Size(o.cols, o.rows), o.square, &std::cerr);
    write_calibration(r, o.output);
    std::cout << "wrote " << o.output << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
#else
  (void)o;
  std::cerr << "error: this build has no camera calibration support\n";
  return 1;
#endif
}

int cmd_assets_harvest(Host& host, const HarvestOptions& o) {
  RunRequest req;
  req.config = o.config;
  req.overrides = o.overrides;
  req.overrides.push_back("harvester.out_dir=" + std::filesystem::absolute(o.output_dir).string());
  req.output_dir = std::filesystem::path(o.output_dir) / "run";
  // The harvest's own run record is rewritten with the assets it describes.
  req.folder_use = FolderUse::kOverwrite;
  req.argv = o.argv;
  req.interrupt = o.interrupt;
  RunOutcome out = run_config(host, req);
  if (!out.message.empty()) std::cerr << out.message << "\n";
  if (out.exit_code == 0) std::cerr << "assets written to " << o.output_dir << "\n";
  return out.exit_code;
}

}  // namespace hf::apps
