// Plugin entry for the ttc_paper risk metric.
#include "hazardforge/plugin.hpp"
#include "ttc_paper_metric.hpp"

HAZARDFORGE_PLUGIN("ttc_paper", "0.1.0", "Apache-2.0", "Time-to-collision d / (v_ego - v_obj cos psi)") {
  reg.add<hf::TtcPaperMetric>();
}
