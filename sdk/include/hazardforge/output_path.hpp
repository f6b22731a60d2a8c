// The output-path policy: every file a run writes stays inside its run folder.
#pragma once

#include "hazardforge/abi.hpp"

#include <filesystem>
#include <string>

HF_SDK_BEGIN
namespace hf {

class StageContext;

// Resolves `relative` (a param value such as "frames.jsonl" or "stills") below `run_dir` and creates the
// folders it needs (`relative` itself too when `is_dir`). Refused with hf::Error "<what> = 'VALUE': ..." when
// it is empty, absolute, contains a '..' component, names one of the host's own files (manifest.json,
// timing.md, run.log at the top of the run folder), or when an existing folder on the way is a symlink that
// leads outside `run_dir`. `what` names where the value came from, e.g. "node 'sink': param 'file'".
std::filesystem::path resolve_output_path(const std::filesystem::path& run_dir, const std::string& relative,
                                          const std::string& what, bool is_dir = false);

// resolve_output_path() for a stage's string param, below ctx.output_dir(), named "node 'ID': param 'NAME'".
std::filesystem::path output_param_path(const StageContext& ctx, const std::string& param,
                                        bool is_dir = false);

// A name that is safe as one path component (run folder names built from a config's `name`): characters
// other than [A-Za-z0-9._-] become '_', leading dots are dropped, and it is never empty, "." or "..".
std::string safe_path_component(const std::string& name);

}  // namespace hf
HF_SDK_END
