// Run manifest, file hashing, atomic writes and the per-stage timing table.
#include "hazardforge/core/manifest.hpp"

#include "hazardforge/redact.hpp"

#include <openssl/evp.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace hf::core {

namespace {
std::string hex(const unsigned char* d, unsigned n) {
  std::ostringstream os;
  for (unsigned i = 0; i < n; ++i) os << std::hex << std::setw(2) << std::setfill('0') << static_cast<int>(d[i]);
  return os.str();
}
struct MdCtx {
  EVP_MD_CTX* c = EVP_MD_CTX_new();
  ~MdCtx() { EVP_MD_CTX_free(c); }
};
}  // namespace

std::string sha256_file(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(file.string() + ": cannot open file to hash it");
  MdCtx ctx;
  EVP_DigestInit_ex(ctx.c, EVP_sha256(), nullptr);
  std::vector<char> buf(1 << 20);
  while (in) {
    in.read(buf.data(), static_cast<std::streamsize>(buf.size()));
    if (in.gcount() > 0) EVP_DigestUpdate(ctx.c, buf.data(), static_cast<size_t>(in.gcount()));
  }
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned len = 0;
  EVP_DigestFinal_ex(ctx.c, md, &len);
  return hex(md, len);
}

std::string sha256_text(const std::string& text) {
  MdCtx ctx;
  EVP_DigestInit_ex(ctx.c, EVP_sha256(), nullptr);
  EVP_DigestUpdate(ctx.c, text.data(), text.size());
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned len = 0;
  EVP_DigestFinal_ex(ctx.c, md, &len);
  return hex(md, len);
}

std::string iso8601_now() {
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

Json timing_json(const RunResult& r) {
  Json j = Json::array();
  for (const NodeTiming& t : r.timings) {
    Json e = {{"node", t.id},
              {"stage", t.stage},
              {"kind", t.kind},
              {"frames", t.process_s.size()},
              {"median_ms", median(t.process_s) * 1e3},
              {"median_thread_cpu_ms", median(t.process_cpu_s) * 1e3}};
    Json inner = Json::object();
    for (const auto& [label, v] : t.inner_s) inner[label] = {{"median_ms", median(v) * 1e3}, {"count", v.size()}};
    e["inner"] = inner;
    j.push_back(e);
  }
  return j;
}

std::string timing_table(const RunResult& r) {
  std::ostringstream os;
  os << std::fixed << std::setprecision(2);
  os << "| node | stage | frames | median ms | mean ms | p90 ms | median CPU ms (node thread) | inner steps "
        "(median ms) "
        "|\n";
  os << "|---|---|---:|---:|---:|---:|---:|---|\n";
  for (const NodeTiming& t : r.timings) {
    std::vector<double> v = t.process_s;
    double mean = 0;
    for (double x : v) mean += x;
    mean = v.empty() ? 0 : mean / static_cast<double>(v.size());
    std::sort(v.begin(), v.end());
    const size_t k90 = static_cast<size_t>(std::ceil(0.9 * static_cast<double>(v.size())));
    const double p90 = v.empty() ? 0 : v[std::min(v.size() - 1, k90 > 0 ? k90 - 1 : 0)];
    std::string inner;
    for (const auto& [label, x] : t.inner_s) {
      std::ostringstream s;
      s << std::fixed << std::setprecision(2) << label << " " << median(x) * 1e3;
      inner += (inner.empty() ? "" : ", ") + s.str();
    }
    os << "| " << t.id << " | " << t.stage << " | " << t.process_s.size() << " | "
       << median(t.process_s) * 1e3 << " | " << mean * 1e3 << " | " << p90 * 1e3 << " | "
       << median(t.process_cpu_s) * 1e3 << " | " << inner << " |\n";
  }
  if (r.wall_s > 0 && r.frames > 0)
    os << "\nwhole graph: " << r.frames << " frames in " << r.wall_s << " s = "
       << static_cast<double>(r.frames) / r.wall_s << " frames/s\n";
  return os.str();
}

Json make_manifest(const ManifestInput& in, const std::string& status, const RunResult* result,
                   const std::string& ended_at) {
  Json m;
  m["hazardforge_version"] = HF_SDK_VERSION;
  m["sdk_abi"] = std::to_string(HF_SDK_ABI_MAJOR) + "." + std::to_string(HF_SDK_ABI_MINOR);
  m["abi_tag"] = HF_ABI_TAG;
  m["argv"] = in.argv;
  m["status"] = status;
  m["started_at"] = in.started_at;
  if (!ended_at.empty()) m["ended_at"] = ended_at;
  if (in.config) {
    m["config_file"] = std::filesystem::absolute(in.config->file).lexically_normal().string();
    m["overrides"] = in.config->overrides;
    try {
      m["config_sha256"] = sha256_file(in.config->file);
    } catch (const Error&) {
    }
    m["config_after_overrides"] = in.config->doc.value;
  }
  if (in.graph) m["resolved_graph"] = in.graph->resolved();
  Json plugins = Json::array();
  if (in.plugins)
    for (const LoadedPlugin& p : *in.plugins)
      plugins.push_back({{"name", p.name},
                         {"version", p.version},
                         {"license", p.license},
                         {"path", p.path.string()},
                         {"components", p.components}});
  m["plugins"] = plugins;
  Json env = Json::object();
  for (const char* v : {"HAZARDFORGE_SHARED", "HAZARDFORGE_PLUGIN_PATH", "HAZARDFORGE_SHARE"})
    if (const char* e = std::getenv(v)) env[v] = e;
  env["HAZARDFORGE_SHARED (resolved)"] = shared_root();
  m["environment"] = env;
  if (in.kept) m["kept"] = *in.kept;
  if (in.outputs) m["outputs"] = *in.outputs;
  if (result) {
    Json res = Json::array();
    for (const auto& p : result->resources) {
      Json r = {{"path", p.string()}};
      std::error_code ec;
      if (std::filesystem::is_regular_file(p, ec)) {
        r["bytes"] = std::filesystem::file_size(p, ec);
        try {
          r["sha256"] = sha256_file(p);
        } catch (const Error& e) {
          r["error"] = e.what();
        }
      }
      res.push_back(r);
    }
    m["resources"] = res;
    m["frames"] = result->frames;
    m["wall_seconds"] = result->wall_s;
    m["errors"] = result->errors;
    m["warnings"] = result->log;
    if (!result->incomplete.empty()) m["incomplete"] = result->incomplete;
    if (result->failed_to_start) m["failed_to_start"] = true;
    if (!result->refusals.empty()) {
      Json refusals = Json::array();
      for (const NodeRefusal& r : result->refusals)
        refusals.push_back({{"node", r.node}, {"frame", r.frame}, {"reasons", r.reasons}});
      m["refusals"] = refusals;
    }
    m["timing"] = timing_json(*result);
  }
  // argv, the config and messages may carry URLs with credentials (an LLM host with user:pass@).
  return redact_json_urls(m);
}

}  // namespace hf::core
