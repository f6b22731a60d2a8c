// The hazardforge command line: run, validate, plugins, inspect, graph, bench, calibrate, eval, experiment.
#include <CLI/CLI.hpp>

#include <fstream>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "hazardforge/apps/campaign.hpp"
#include "hazardforge/apps/dataset_export.hpp"
#include "hazardforge/apps/system_test.hpp"
#include "hazardforge/apps/commands.hpp"
#include "hazardforge/core/host.hpp"
#include "hazardforge/process_memory.hpp"
#include "hazardforge/redact.hpp"

namespace {

std::atomic<bool> g_interrupt{false};

}  // namespace

int main(int argc, char** argv) {
  using namespace hf::core;
  using namespace hf::apps;
  hf::keep_freed_memory_for_reuse();
  std::vector<std::string> args(argv, argv + argc);
  CLI::App app{"HazardForge: turn real driving recordings into safety-critical test scenarios"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("hazardforge ") + HF_SDK_VERSION);
  std::vector<std::string> plugin_paths;
  app.add_option("--plugin-path", plugin_paths, "Extra plugin folder (repeatable; searched first)")
      ->type_name("DIR");

  CommonOptions common;
  auto add_config = [&](CLI::App* c) {
    c->add_option("config", common.config, "Graph config (YAML)")->required()->check(CLI::ExistingFile);
    c->add_option(
         "--set", common.overrides,
         "Override a param: node.param=value (repeatable; a relative path is relative to the current "
         "folder)")
        ->type_name("NODE.PARAM=VALUE");
    c->add_option(
         "--set-base", common.set_base,
         "Folder that relative paths in --set values refer to instead (campaigns and experiments pass "
         "their file's folder)")
        ->type_name("DIR");
  };

  auto* run = app.add_subcommand("run", "Run a graph config over its source");
  add_config(run);
  run->add_option("-o,--output", common.output_dir, "Output folder (default runs/<name>-<UTC time>)");
  run->add_option("--max-frames", common.max_frames, "Stop after N frames");
  run->add_option("--frames", common.frames,
                  "Only the recording's frames FIRST:LAST (indexes and times stay the recording's)")
      ->type_name("FIRST:LAST");
  run->add_flag("-q,--quiet", common.quiet,
                "No progress or stage info lines (warnings, errors and a verdict's reasons still show)");
  auto add_folder_flags = [&](CLI::App* c) {
    auto* resume = c->add_flag("--resume", common.resume,
                               "Run again into an output folder that holds a run of the same config");
    c->add_flag("--overwrite", common.overwrite, "Clear an output folder that holds an earlier run first")
        ->excludes(resume);
  };
  add_folder_flags(run);

  auto* validate = app.add_subcommand("validate", "Validate a graph config; print every problem at once");
  add_config(validate);
  const char* load_doc = "Also load the libraries in the config's plugin_paths (runs their code)";
  validate->add_flag("--load-config-plugins", common.load_config_plugins, load_doc);

  auto* plugins = app.add_subcommand("plugins", "List plugin libraries, their versions, paths and stages");
  bool plugins_json = false;
  plugins->add_flag("--json", plugins_json, "Machine-readable output");

  auto* inspect = app.add_subcommand("inspect", "Show a stage's ports and params with their docs");
  std::string stage_name;
  bool inspect_md = false;
  bool inspect_all = false;
  inspect->add_option("stage", stage_name, "Stage or component name (kind/name when ambiguous)");
  inspect->add_flag("--all", inspect_all, "Every registered component (with --markdown: docs/stages.md)");
  inspect->add_flag("--markdown", inspect_md, "Markdown output (for generated docs)");

  auto* graph = app.add_subcommand("graph", "Print a config's graph");
  add_config(graph);
  bool dot = false;
  graph->add_flag("--dot", dot, "Graphviz dot output")->required();
  graph->add_flag("--load-config-plugins", common.load_config_plugins, load_doc);

  auto* bench =
      app.add_subcommand("bench", "Benchmark a config: per-stage latency, graph frames/s vs bare detector");
  add_config(bench);
  BenchOptions bopt;
  bench->add_option("--repeat", bopt.repeat, "Repetitions (medians are reported)")->check(CLI::Range(1, 50));
  bench->add_option("--max-frames", bopt.max_frames, "Frames per repetition");
  bench->add_option("-o,--output", common.output_dir, "Folder for bench.md / bench.json");
  bench->add_option("--detector", bopt.detector_node, "Detector node for the bare forward() measurement");

  auto* eval = app.add_subcommand("eval", "Run an evaluation config and print its report");
  add_config(eval);
  eval->add_option("-o,--output", common.output_dir, "Output folder");
  eval->add_option("--max-frames", common.max_frames, "Stop after N frames");
  add_folder_flags(eval);

  auto* experiment = app.add_subcommand("experiment", "Run a base config under a matrix of overrides");
  ExperimentOptions eopt;
  experiment->add_option("spec", eopt.spec, "Experiment file (YAML)")->required()->check(CLI::ExistingFile);
  experiment->add_option("-o,--output", eopt.output_dir, "Experiment folder (default runs/<name>)");
  experiment->add_option("-j,--jobs", eopt.jobs, "Runs in parallel")->check(CLI::Range(1, 64));
  experiment->add_flag("--force", eopt.force, "Re-run runs that are already complete");

  auto* campaign = app.add_subcommand(
      "campaign", "Search recordings x hazard kinds in closed loop for verified scenarios (docs/campaigns.md)");
  CampaignOptions copt_campaign;
  campaign->add_option("spec", copt_campaign.spec, "Campaign file (YAML)")->check(CLI::ExistingFile);
  auto* campaign_status = campaign->add_subcommand(
      "status",
      "What a campaign folder holds now: pairs and attempts by state, failed attempts with their logs");
  std::string status_dir;
  bool status_json = false;
  campaign_status->add_option("dir", status_dir, "Campaign folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  campaign_status->add_flag("--json", status_json, "Print it as one JSON object");
  campaign->callback([&] {
    if (!*campaign_status && copt_campaign.spec.empty())
      throw CLI::RequiredError("campaign: a campaign file (or 'status DIR')");
  });
  campaign->add_option("-o,--output", copt_campaign.output_dir, "Campaign folder (default runs/<name>)");
  campaign->add_option("-j,--jobs", copt_campaign.jobs, "Attempts in parallel")->check(CLI::Range(1, 64));
  campaign->add_option("--max-attempts", copt_campaign.max_attempts,
                       "Start at most N attempts now; running the campaign again goes on from there")
      ->check(CLI::Range(0, 100000));
  campaign->add_flag("-q,--quiet", copt_campaign.quiet, "Only finished attempts and the summary");
  campaign->add_flag("!--no-perception-cache", copt_campaign.perception_cache,
                     "Attempts detect on the original frames again instead of reading back the scouting "
                     "pass's detections");
  campaign->add_option("--executor", copt_campaign.executor,
                       "Where attempts run: local (child processes) or slurm (tasks of job arrays; -j is the "
                       "number of attempts queued or running)")
      ->check(CLI::IsMember({"local", "slurm"}));
  campaign->add_option("--slurm-partition", copt_campaign.slurm.partition, "sbatch --partition");
  campaign->add_option("--slurm-account", copt_campaign.slurm.account, "sbatch --account");
  campaign->add_option("--slurm-time", copt_campaign.slurm.time, "sbatch --time, per attempt (e.g. 00:30:00)");
  campaign->add_option("--slurm-mem", copt_campaign.slurm.mem, "sbatch --mem, per attempt (e.g. 4G)");
  campaign->add_option("--slurm-cpus-per-task", copt_campaign.slurm.cpus_per_task, "sbatch --cpus-per-task")
      ->check(CLI::Range(1, 256));
  campaign->add_option("--slurm-throttle", copt_campaign.slurm.throttle,
                       "At most N tasks of one job array at once (--array=...%N)")
      ->check(CLI::Range(0, 100000));
  campaign->add_option("--slurm-arg", copt_campaign.slurm.sbatch_args, "An extra sbatch argument (repeatable)")
      ->allow_extra_args(false);

  auto* test = app.add_subcommand(
      "test", "Run systems under test over verified scenarios and score them (docs/testing-a-system.md)");
  SystemTestOptions topt;
  test->add_option("systems", topt.systems, "System files (YAML): a subgraph whose node 'system' answers")
      ->required()
      ->check(CLI::ExistingFile);
  test->add_option("--scenarios", topt.scenarios, "Campaign folders, run folders or scenario packages")
      ->required();
  test->add_option("-o,--output", topt.output_dir, "Test folder (default runs/test)");
  test->add_option("-j,--jobs", topt.jobs, "Runs in parallel")->check(CLI::Range(1, 64));
  test->add_option("--critical-ttc", topt.critical_ttc_s, "The hazard is critical below this true TTC (s)")
      ->check(CLI::Range(0.1, 20.0));
  test->add_option("--min-lead", topt.min_lead_s, "A pass warns at least this long before that (s)")
      ->check(CLI::Range(-10.0, 20.0));
  test->add_option("--match-iou", topt.match_iou, "IoU at which a detection is the hazard")
      ->check(CLI::Range(0.05, 1.0));

  auto* exp = app.add_subcommand("export", "Write verified scenarios as a KITTI tracking or COCO dataset");
  ExportOptions xopt;
  exp->add_option("scenarios", xopt.scenarios, "Campaign folders, run folders or scenario packages")->required();
  exp->add_option("--format", xopt.format, "kitti-tracking or coco")
      ->required()
      ->check(CLI::IsMember({"kitti-tracking", "coco"}));
  exp->add_option("-o,--output", xopt.output_dir, "A new folder for the dataset")->required();

  auto* calibrate = app.add_subcommand("calibrate", "Calibrate a camera from chessboard photos");
  CalibrateOptions copt;
  calibrate->add_option("folder", copt.folder, "Folder of chessboard photos")
      ->required()
      ->check(CLI::ExistingDirectory);
  calibrate->add_option("--cols", copt.cols, "Inner corners per row")->check(CLI::Range(2, 100));
  calibrate->add_option("--rows", copt.rows, "Inner corners per column")->check(CLI::Range(2, 100));
  calibrate->add_option("--square", copt.square, "Square size (any unit; only scales extrinsics)");
  calibrate->add_option("-o,--output", copt.output, "Calibration YAML to write")->required();

  auto* assets = app.add_subcommand("assets", "Appearance assets for the AR renderer");
  assets->require_subcommand(1);
  auto* harvest =
      assets->add_subcommand("harvest", "Cut real object appearances out of a dataset into an asset folder");
  HarvestOptions hopt;
  harvest->add_option("-o,--output", hopt.output_dir, "Asset folder to write")->required();
  harvest
      ->add_option("--config", hopt.config,
                   "Harvest graph: a source with annotations feeding an asset_harvester node named "
                   "`harvester` (e.g. configs/harvest_assets.yaml)")
      ->required();
  harvest->add_option("--set", hopt.overrides, "Override a param: node.param=value");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }

  install_stop_signals(&g_interrupt);
  Host host(plugin_paths);
  common.argv = args;
  common.interrupt = &g_interrupt;
  try {
    if (*run) return cmd_run(host, common);
    if (*validate) return cmd_validate(host, common);
    if (*plugins) return cmd_plugins(host, plugins_json);
    if (*inspect) {
      if (inspect_all == !stage_name.empty()) {
        std::cerr << "error: inspect takes a STAGE or --all\n";
        return 2;
      }
      return inspect_all ? cmd_inspect_all(host, inspect_md) : cmd_inspect(host, stage_name, inspect_md);
    }
    if (*graph) return cmd_graph(host, common);
    if (*bench) return cmd_bench(host, common, bopt);
    if (*eval) return cmd_eval(host, common);
    if (*experiment) {
      eopt.plugin_paths = plugin_paths;
      eopt.interrupt = &g_interrupt;
      return cmd_experiment(host, eopt);
    }
    if (*campaign_status) return cmd_campaign_status(status_dir, status_json);
    if (*campaign) {
      copt_campaign.plugin_paths = plugin_paths;
      copt_campaign.interrupt = &g_interrupt;
      return cmd_campaign(host, copt_campaign);
    }
    if (*test) {
      topt.plugin_paths = plugin_paths;
      topt.interrupt = &g_interrupt;
      return cmd_test(host, topt);
    }
    if (*exp) return cmd_export(xopt);
    if (*calibrate) return cmd_calibrate(copt);
    if (*harvest) {
      hopt.interrupt = &g_interrupt;
      hopt.argv = args;
      return cmd_assets_harvest(host, hopt);
    }
  } catch (const std::exception& e) {
    std::cerr << "error: " << hf::redact_urls(e.what()) << "\n";
    return 1;
  }
  return 2;
}
