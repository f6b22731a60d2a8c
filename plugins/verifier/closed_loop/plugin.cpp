// Plugin entry: the closed-loop verifier stage.
#include "hazardforge/plugin.hpp"
#include "closed_loop_verifier.hpp"

HAZARDFORGE_PLUGIN("closed_loop_verifier", "0.1.0", "Apache-2.0",
                   "verifies inserted hazards against the re-assessment of the augmented video") {
  reg.add<hf::ClosedLoopVerifier>();
}
