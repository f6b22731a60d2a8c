// Plugin entry: the closed-loop verifier stage.
#include "closed_loop_verifier.hpp"
#include "hazardforge/plugin.hpp"

HAZARDFORGE_PLUGIN("closed_loop_verifier", "0.1.0", "Apache-2.0",
                   "verifies inserted hazards against the re-assessment of the augmented video") {
  reg.add<hf::ClosedLoopVerifier>();
}
