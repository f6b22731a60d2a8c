// Image files that are cut off: decoders fill the missing part with grey and only print a warning.
#pragma once

#include "hazardforge/abi.hpp"

#include <filesystem>
#include <string>

HF_SDK_BEGIN
namespace hf {

// Throws hf::Error "<what> is truncated: <why>" when `file` is a JPEG without its end-of-image marker or a
// PNG without its IEND chunk near the end of the file. Other formats pass unchecked. `what` names the file
// and the frame, e.g. "nuScenes image 'x.jpg' (frame 3)".
void require_complete_image(const std::filesystem::path& file, const std::string& what);

}  // namespace hf
HF_SDK_END
