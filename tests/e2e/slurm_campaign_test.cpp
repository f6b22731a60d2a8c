// A campaign through a real single-node Slurm cluster (munged, slurmctld, slurmd started by the test): the
// same verified pairs as a local run of the same campaign, and an attempt whose task is requeued while it
// runs (as preemption or a lost node does) runs again and is counted once.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <future>
#include <set>
#include <string>
#include <thread>

#include "command.hpp"
#include "hazardforge/types.hpp"
#include "slurm_cluster.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

std::set<std::string> verified_pairs(const fs::path& campaign) {
  std::set<std::string> v;
  const Json index = test::read_json_file(campaign / "index.json");
  for (const Json& a : index["attempts"])
    if (a["passed"].get<bool>())
      v.insert(a["recording"].get<std::string>() + "/" + a["kind"].get<std::string>());
  return v;
}

TEST(SlurmCampaign, VerifiesTheSamePairsAsALocalRunAndCountsARequeuedAttemptOnce) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/nuscenes/v1.0-mini/scene.json");
  test::SlurmCluster cluster;
  ASSERT_TRUE(cluster.ready()) << cluster.error();
  test::TempDir dir;
  std::ofstream(dir / "c.yaml")
      << "name: slurm\nkinds: [sudden_stop, pedestrian_crossing]\n"
         "budget: {attempts: 1, cpu_s: 600}\nrecordings:\n  - name: nus\n    config: "
      << (test::source_dir() / "configs/paper.yaml").string()
      << "\n    set: [scene.assets.dir=]\n";  // the default appearance set: no harvest
  const std::string cli = "HAZARDFORGE_SHARED=" + test::quote(shared) + " " + cluster.env() +
                          test::quote(HF_BINARY_DIR "/bin/hazardforge") + " campaign " +
                          test::quote(dir / "c.yaml");
  const auto local = test::run_command(cli + " -o " + test::quote(dir / "local") + " -q -j 2");
  ASSERT_EQ(local.code, 0) << local.out;

  // Through Slurm, with the first running task requeued while it runs.
  auto slurm = std::async(std::launch::async, [&] {
    return test::run_command(cli + " -o " + test::quote(dir / "slurm") + " -q -j 2 --executor slurm");
  });
  std::string requeued;
  for (int i = 0; i < 600 && requeued.empty(); ++i) {
    if (slurm.wait_for(std::chrono::milliseconds(250)) == std::future_status::ready) break;  // polling squeue
    const auto q = test::run_command(cluster.env() + "squeue -h -r -t R -o %i");
    if (q.code == 0 && !q.out.empty()) {
      requeued = q.out.substr(0, q.out.find('\n'));
      const auto r = test::run_command(cluster.env() + "scontrol requeue " + requeued);
      ASSERT_EQ(r.code, 0) << r.out;
    }
  }
  const auto s = slurm.get();
  ASSERT_EQ(s.code, 0) << s.out;
  ASSERT_FALSE(requeued.empty()) << "no task was seen running";
  EXPECT_EQ(verified_pairs(dir / "slurm"), verified_pairs(dir / "local"));
  EXPECT_FALSE(verified_pairs(dir / "local").empty()) << local.out;
  const Json index = test::read_json_file(dir / "slurm/index.json");
  EXPECT_EQ(index["attempts"].size(), 2u) << index.dump(2);  // the requeued attempt counted once
  EXPECT_TRUE(index["complete"].get<bool>());
  // The requeued task ran twice and ended on its own the second time: its exit file says so.
  const std::string task = requeued.substr(requeued.find('_') + 1);
  std::ifstream exit_file(dir / "slurm/slurm/0" / (task + ".exit"));
  int code = -1, restarts = -1;
  exit_file >> code >> restarts;
  EXPECT_EQ(code, 0);
  EXPECT_GE(restarts, 1);
  for (const Json& a : index["attempts"]) EXPECT_GT(a["cpu_s"].get<double>(), 0.0) << a.dump(2);
}

}  // namespace
}  // namespace hf
