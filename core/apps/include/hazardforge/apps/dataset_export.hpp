// hazardforge export: verified scenarios as datasets in standard formats (docs/testing-a-system.md).
#pragma once

#include <string>
#include <vector>

namespace hf::apps {

struct ExportOptions {
  std::vector<std::string> scenarios;  // campaign folders, run folders or scenario packages
  std::string format;                  // kitti-tracking | coco
  std::string output_dir;
};

// KITTI tracking: training/image_02/SSSS/NNNNNN.png, training/label_02/SSSS.txt, training/calib/SSSS.txt,
// training/ttc_02/SSSS.txt (frame, track id, ground-truth TTC), sequences.txt. COCO: images/SSSS_NNNNNN.jpg
// and annotations.json (with ttc_s, truncation, occlusion and the 3D box as extra fields).
int cmd_export(const ExportOptions& o);

}  // namespace hf::apps
