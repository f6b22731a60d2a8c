// YAML (yaml-cpp) to JSON conversion that remembers where every value was written.
#include "hazardforge/yaml_json.hpp"

#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <vector>

namespace hf {

namespace {

std::string escape_pointer_token(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '~') out += "~0";
    else if (c == '/') out += "~1";
    else out += c;
  }
  return out;
}

Json scalar(const YAML::Node& n) {
  const std::string& s = n.Scalar();
  if (n.Tag() == "!") return s;  // quoted: always a string
  static const std::regex kInt(R"(^[-+]?[0-9]+$)");
  static const std::regex kHex(R"(^0x[0-9a-fA-F]+$)");
  static const std::regex kFloat(R"(^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?$)");
  if (s.empty() || s == "~" || s == "null" || s == "Null" || s == "NULL") return nullptr;
  if (s == "true" || s == "True" || s == "TRUE") return true;
  if (s == "false" || s == "False" || s == "FALSE") return false;
  try {
    if (std::regex_match(s, kInt)) return std::stoll(s);
    if (std::regex_match(s, kHex)) return std::stoll(s, nullptr, 16);
    if (std::regex_match(s, kFloat)) return std::stod(s);
  } catch (const std::out_of_range&) {
    return s;
  }
  if (s == ".inf" || s == ".Inf" || s == "+.inf") return std::numeric_limits<double>::infinity();
  if (s == "-.inf" || s == "-.Inf") return -std::numeric_limits<double>::infinity();
  return s;
}

// yaml-cpp shares an anchored node among its aliases; converting copies it once per alias, so nested aliases
// ("billion laughs": ten anchors of ten aliases each, 10^10 values) would take all memory. A text of N bytes
// states fewer than N values and N bytes of keys and scalars itself; what conversion makes beyond that,
// aliases made, and that is bounded.
struct Expansion {
  std::string file;
  size_t max_values = 0, max_bytes = 0;
  size_t values = 0, bytes = 0;
};

constexpr size_t kMaxAliasValues = 100000;
constexpr size_t kMaxAliasBytes = 10 * 1000 * 1000;

void count(const YAML::Node& n, size_t bytes, Expansion& ex) {
  ++ex.values;
  ex.bytes += bytes;
  if (ex.values > ex.max_values || ex.bytes > ex.max_bytes) {
    const YAML::Mark m = n.Mark();
    throw Error(SourceLocation{ex.file, m.line + 1, m.column + 1},
                "YAML aliases expand to more than " + std::to_string(kMaxAliasValues) + " values or " +
                    std::to_string(kMaxAliasBytes) +
                    " bytes beyond what the text states (nested aliases multiply; this anchor's copies among "
                    "them): write the values out or use fewer levels of aliases");
  }
}

Json convert(const YAML::Node& n, const std::string& ptr, const std::string& file, LocationMap& locs,
             Expansion& ex) {
  const YAML::Mark m = n.Mark();
  locs[ptr] = SourceLocation{file, m.line + 1, m.column + 1};
  count(n, n.IsScalar() ? n.Scalar().size() : 0, ex);
  switch (n.Type()) {
    case YAML::NodeType::Null:
    case YAML::NodeType::Undefined: return nullptr;
    case YAML::NodeType::Scalar: return scalar(n);
    case YAML::NodeType::Sequence: {
      Json a = Json::array();
      size_t i = 0;
      for (const YAML::Node& e : n) a.push_back(convert(e, ptr + "/" + std::to_string(i++), file, locs, ex));
      return a;
    }
    case YAML::NodeType::Map: {
      Json o = Json::object();
      std::vector<YAML::Node>
          merged;  // "<<: *anchor" (or a list of them): the anchors' keys, unless stated here
      for (const auto& kv : n) {
        const std::string key = kv.first.as<std::string>();
        const YAML::Mark km = kv.first.Mark();
        const SourceLocation at{file, km.line + 1, km.column + 1};
        if (key == "<<" && kv.first.Tag() != "!") {
          if (kv.second.IsMap()) {
            merged.push_back(kv.second);
          } else if (kv.second.IsSequence()) {
            for (const YAML::Node& e : kv.second) {
              if (!e.IsMap())
                throw Error(at, "'<<' merges mappings only (an alias like *name, or a list of them)");
              merged.push_back(e);
            }
          } else {
            throw Error(at, "'<<' merges mappings only (an alias like *name, or a list of them)");
          }
          continue;
        }
        const std::string child = ptr + "/" + escape_pointer_token(key);
        locs[child + "#key"] = at;
        if (o.contains(key)) throw Error(at, "duplicate key '" + key + "'");
        ex.bytes += key.size();
        o[key] = convert(kv.second, child, file, locs, ex);
        // A null value has no useful mark of its own: point at its key.
        if (kv.second.IsNull()) locs[child] = locs[child + "#key"];
      }
      // Merged keys keep the positions where the anchor states them: one fact, one place.
      for (const YAML::Node& m : merged)
        for (const auto& kv : m) {
          const std::string key = kv.first.as<std::string>();
          if (o.contains(key)) continue;  // stated here, or by an earlier anchor of the list
          ex.bytes += key.size();
          const std::string child = ptr + "/" + escape_pointer_token(key);
          const YAML::Mark km = kv.first.Mark();
          locs[child + "#key"] = SourceLocation{file, km.line + 1, km.column + 1};
          o[key] = convert(kv.second, child, file, locs, ex);
          if (kv.second.IsNull()) locs[child] = locs[child + "#key"];
        }
      return o;
    }
  }
  return nullptr;
}

}  // namespace

SourceLocation YamlDocument::at(const std::string& pointer) const {
  std::string p = pointer;
  while (true) {
    auto it = locations.find(p);
    if (it != locations.end()) return it->second;
    if (p.empty()) break;
    const auto slash = p.rfind('/');
    p = slash == std::string::npos ? std::string() : p.substr(0, slash);
  }
  return {};
}

YamlDocument parse_yaml(const std::string& text, const std::string& file_name) {
  YamlDocument doc;
  try {
    YAML::Node root = YAML::Load(text);
    Expansion ex;
    ex.file = file_name;
    ex.max_values = text.size() + kMaxAliasValues;
    ex.max_bytes = text.size() + kMaxAliasBytes;
    doc.value = convert(root, "", file_name, doc.locations, ex);
  } catch (const YAML::Exception& e) {
    throw Error(SourceLocation{file_name, e.mark.line + 1, e.mark.column + 1}, e.msg);
  }
  return doc;
}

YamlDocument load_yaml_file(const std::string& path) {
  // A FIFO or a socket blocks on open until someone writes: refused before opening.
  std::error_code ec;
  const auto type = std::filesystem::status(path, ec).type();
  if (type == std::filesystem::file_type::fifo || type == std::filesystem::file_type::socket)
    throw Error(path + ": error: a FIFO or socket, not a file; a config is read from a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": error: cannot open file");
  // Read in pieces up to the limit: a device (/dev/zero) or a huge file is refused, not read into memory.
  std::string text;
  char buf[65536];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) {
    text.append(buf, static_cast<size_t>(in.gcount()));
    if (text.size() > kMaxYamlFileBytes)
      throw Error(path + ": error: larger than " + std::to_string(kMaxYamlFileBytes) +
                  " bytes, more than a YAML config holds; is it the file you meant?");
  }
  if (in.bad()) throw Error(path + ": error: cannot read file");
  return parse_yaml(text, path);
}

}  // namespace hf
