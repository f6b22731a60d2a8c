// Compares an inserted object's appearance over its visible frames with the real objects of its class in the
// same recording: per metric, where the inserted median lies in the real objects' spread.
#pragma once

#include <string>
#include <vector>

#include "hazardforge/class_groups.hpp"
#include "hazardforge/types.hpp"

namespace hf::realism {

// One compared quantity of AppearanceStats.
struct MetricDef {
  const char* name;  // JSON key, e.g. "halo", "lab_mean_L"
  double (*get)(const AppearanceStats&);
  const char* doc;
};
// edge_contrast, halo, sharpness, noise_ratio, noise_sigma, lab_mean_L/a/b, lab_std_L/a/b, height_m, width_m,
// aspect — in that order.
const std::vector<MetricDef>& metric_defs();

// Order statistics of a sample (NaNs dropped): n, median, 10th/90th percentiles (linear interpolation), min, max.
struct Spread {
  int n = 0;
  double median = kNaN, p10 = kNaN, p90 = kNaN, min = kNaN, max = kNaN;
};
Spread spread(std::vector<double> values);
// Share of `real` values below `v` (ties count half), NaN when there are none.
double percentile_rank(const std::vector<double>& real, double v);

// The label groups a real reference may come from when its own class has too few samples (car/truck/bus/van,
// bicycle/motorcycle, person/pedestrian); the renderer picks its references by them too.
const ClassGroups& reference_groups();

// Real objects that count as the inserted class's reference: the same label; when fewer than `min_same` of
// those exist, also the labels of its group (car/truck/bus/van, bicycle/motorcycle, person/pedestrian). Sets
// *used to the labels taken.
std::vector<AppearanceStats> references_for(const std::string& object_class,
                                            const std::vector<AppearanceStats>& real, size_t min_same,
                                            std::vector<std::string>* used = nullptr);

// Per metric: {inserted: Spread, real: Spread, rank: percentile of the inserted median among the real values,
// within: the inserted median lies in the real [p10, p90] (with fewer than 5 real values: [min, max]); null
// when either side has no value}. Plus "outside": the names of the metrics not within.
Json compare(const std::vector<AppearanceStats>& inserted, const std::vector<AppearanceStats>& real);

Json to_json(const Spread& s);

}  // namespace hf::realism
