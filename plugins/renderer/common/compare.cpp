// Comparison of an inserted object's appearance with the real objects of its class: spreads and ranks.
#include "hazardforge/realism/compare.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/class_groups.hpp"

namespace hf::realism {

namespace {

double at_fraction(const std::vector<double>& sorted, double q) {
  const double pos = q * static_cast<double>(sorted.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(pos));
  const size_t j = std::min(i + 1, sorted.size() - 1);
  return sorted[i] + (pos - static_cast<double>(i)) * (sorted[j] - sorted[i]);
}

Json num(double v) { return std::isfinite(v) ? Json(v) : Json(); }

std::vector<double> values(const std::vector<AppearanceStats>& v, double (*get)(const AppearanceStats&)) {
  std::vector<double> out;
  for (const auto& s : v) out.push_back(get(s));
  return out;
}

}  // namespace

const std::vector<MetricDef>& metric_defs() {
  static const std::vector<MetricDef> defs = {
      {"edge_contrast", [](const AppearanceStats& s) { return s.edge_contrast; },
       "mean |L* inside - L* outside| across the silhouette"},
      {"halo", [](const AppearanceStats& s) { return s.halo; },
       "mean |L* 0-2 px outside - L* 5-9 px outside|: a fringe around the silhouette"},
      {"sharpness", [](const AppearanceStats& s) { return s.sharpness; },
       "variance of the Laplacian inside / in the background ring"},
      {"noise_ratio", [](const AppearanceStats& s) { return s.noise_ratio; },
       "sensor noise inside / in the background ring"},
      {"noise_sigma", [](const AppearanceStats& s) { return s.noise_sigma; }, "sensor noise inside (grey levels)"},
      {"lab_mean_L", [](const AppearanceStats& s) { return s.lab_mean[0]; }, "mean L*"},
      {"lab_mean_a", [](const AppearanceStats& s) { return s.lab_mean[1]; }, "mean a*"},
      {"lab_mean_b", [](const AppearanceStats& s) { return s.lab_mean[2]; }, "mean b*"},
      {"lab_std_L", [](const AppearanceStats& s) { return s.lab_std[0]; }, "spread of L*"},
      {"lab_std_a", [](const AppearanceStats& s) { return s.lab_std[1]; }, "spread of a*"},
      {"lab_std_b", [](const AppearanceStats& s) { return s.lab_std[2]; }, "spread of b*"},
      {"height_m", [](const AppearanceStats& s) { return s.height_m; },
       "box height in metres at its road distance"},
      {"width_m", [](const AppearanceStats& s) { return s.width_m; }, "box width in metres at its road distance"},
      {"aspect", [](const AppearanceStats& s) { return s.aspect; }, "box width / height"},
  };
  return defs;
}

Spread spread(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  Spread s;
  s.n = static_cast<int>(v.size());
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.median = at_fraction(v, 0.5);
  s.p10 = at_fraction(v, 0.1);
  s.p90 = at_fraction(v, 0.9);
  s.min = v.front();
  s.max = v.back();
  return s;
}

double percentile_rank(const std::vector<double>& real, double v) {
  if (!std::isfinite(v)) return kNaN;
  double below = 0;
  int n = 0;
  for (double r : real) {
    if (!std::isfinite(r)) continue;
    ++n;
    below += r < v ? 1.0 : r == v ? 0.5 : 0.0;
  }
  return n > 0 ? below / n : kNaN;
}

const ClassGroups& reference_groups() {
  static const ClassGroups groups({"car,truck,bus,van", "bicycle,motorcycle", "person,pedestrian"});
  return groups;
}

std::vector<AppearanceStats> references_for(const std::string& object_class, const std::vector<AppearanceStats>& real,
                                            size_t min_same, std::vector<std::string>* used) {
  const ClassGroups& groups = reference_groups();
  std::vector<AppearanceStats> same, group;
  for (const auto& r : real) {
    if (r.label == object_class)
      same.push_back(r);
    else if (groups.same(r.label, object_class))
      group.push_back(r);
  }
  std::vector<std::string> labels{object_class};
  if (same.size() < min_same && !group.empty()) {
    for (const auto& g : group) {
      if (std::find(labels.begin(), labels.end(), g.label) == labels.end()) labels.push_back(g.label);
      same.push_back(g);
    }
  }
  if (used) *used = labels;
  return same;
}

Json to_json(const Spread& s) {
  return {{"n", s.n}, {"median", num(s.median)}, {"p10", num(s.p10)}, {"p90", num(s.p90)},
          {"min", num(s.min)}, {"max", num(s.max)}};
}

Json compare(const std::vector<AppearanceStats>& inserted, const std::vector<AppearanceStats>& real) {
  Json out = Json::object();
  Json outside = Json::array();
  for (const MetricDef& d : metric_defs()) {
    const std::vector<double> rv = values(real, d.get);
    const Spread si = spread(values(inserted, d.get)), sr = spread(rv);
    Json j = {{"inserted", to_json(si)}, {"real", to_json(sr)}, {"rank", num(percentile_rank(rv, si.median))}};
    if (si.n > 0 && sr.n > 0) {
      const double lo = sr.n >= 5 ? sr.p10 : sr.min, hi = sr.n >= 5 ? sr.p90 : sr.max;
      const bool within = si.median >= lo && si.median <= hi;
      j["within"] = within;
      if (!within) outside.push_back(d.name);
    } else {
      j["within"] = nullptr;
    }
    out[d.name] = std::move(j);
  }
  out["outside"] = outside;
  return out;
}

}  // namespace hf::realism
