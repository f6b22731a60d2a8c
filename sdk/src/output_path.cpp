// The output-path policy: relative paths only, no '..', and no symlinked folder leading out of the run
// folder.
#include "hazardforge/output_path.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

#include "hazardforge/error.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

namespace fs = std::filesystem;

namespace {

bool inside(const fs::path& p, const fs::path& root) {
  const fs::path rel = p.lexically_relative(root);
  return !rel.empty() && *rel.begin() != "..";
}

}  // namespace

fs::path resolve_output_path(const fs::path& run_dir, const std::string& relative, const std::string& what,
                             bool is_dir) {
  const std::string shown = what + " = '" + relative + "'";
  if (relative.empty()) throw Error(what + " is empty; it must name a path inside the run folder");
  const fs::path rel(relative);
  if (rel.is_absolute())
    throw Error(shown + " is an absolute path; output paths must be relative to the run folder");
  for (const auto& part : rel)
    if (part == "..") throw Error(shown + " contains '..'; output paths must stay inside the run folder");
  std::error_code ec;
  const fs::path root = fs::canonical(run_dir, ec);
  if (ec) throw Error(run_dir.string() + ": cannot use the run folder: " + ec.message());
  const fs::path normal = rel.lexically_normal();
  // The host's own files in every run folder: a stage writing one would replace the run's record of itself.
  for (const char* own : {"manifest.json", "timing.md", "run.log"})
    if (!is_dir && normal == fs::path(own))
      throw Error(shown + " is a file the host writes in every run folder (manifest.json, timing.md, run.log); "
                          "choose another name");
  const fs::path target = run_dir / normal;
  // Folders are checked one by one before anything is created in them: create_directories() would follow a
  // planted symlink and make folders wherever it points.
  std::vector<fs::path> parts(normal.begin(), normal.end());
  if (!is_dir && !parts.empty()) parts.pop_back();
  fs::path cur = run_dir;
  for (const auto& part : parts) {
    if (part.empty() || part == ".") continue;
    cur /= part;
    struct stat st {};
    if (::lstat(cur.c_str(), &st) != 0) {
      if (errno != ENOENT) throw Error(shown + ": " + cur.string() + ": " + std::strerror(errno));
      if (::mkdir(cur.c_str(), 0755) != 0 && errno != EEXIST)
        throw Error(shown + ": cannot create folder " + cur.string() + ": " + std::strerror(errno));
      continue;
    }
    if (S_ISLNK(st.st_mode)) {
      const fs::path real = fs::canonical(cur, ec);
      if (ec || !inside(real, root) || !fs::is_directory(real))
        throw Error(shown + ": " + cur.string() + " is a symlink leading outside the run folder");
    } else if (!S_ISDIR(st.st_mode)) {
      throw Error(shown + ": " + cur.string() + " exists and is not a folder");
    }
  }
  return target;
}

fs::path output_param_path(const StageContext& ctx, const std::string& param, bool is_dir) {
  return resolve_output_path(ctx.output_dir(), ctx.params().get_string(param),
                             "node '" + ctx.node_id() + "': param '" + param + "'", is_dir);
}

std::string safe_path_component(const std::string& name) {
  std::string s;
  for (char c : name) {
    const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-';
    s += ok ? c : '_';
  }
  const size_t first = s.find_first_not_of('.');
  s = first == std::string::npos ? std::string() : s.substr(first);
  return s.empty() ? std::string("run") : s;
}

}  // namespace hf
