// Plugin entry for the external program system under test.
#include "hazardforge/plugin.hpp"
#include "external_program_stage.hpp"

HAZARDFORGE_PLUGIN("external_program", "0.1.0", "Apache-2.0",
                   "external_program: a system under test that is a program speaking a line protocol") {
  reg.add<hf::system::ExternalProgramStage>();
}
