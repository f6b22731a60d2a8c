// The stage harness: params validated like the host, packets delivered in timestamp order, sticky ports.
#include <gtest/gtest.h>

#include "hazardforge/testing/stage_runner.hpp"

namespace hf {
namespace {

// Scales every detection box; remembers the last sticky "hint" it saw.
class ScaleBoxes : public Stage {
 public:
  static ComponentInfo describe() {
    ComponentInfo i;
    i.name = "scale_boxes";
    i.kind = kind::kFilter;
    i.summary = "test stage";
    i.inputs = {port<Detections>("detections"), sticky(port<Record>("hint"))};
    i.outputs = {port<Detections>("detections"), port<Record>("seen")};
    i.params = {ParamSpec::number("gain", 1.0).range(0, 10)};
    return i;
  }
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override {
    Detections d = in.require<Detections>("detections");
    for (auto& it : d.items) it.box.width *= static_cast<float>(ctx.params().get_double("gain"));
    out.emit("detections", d);
    if (const Record* r = in.get<Record>("hint")) out.emit("seen", *r);
  }
};

Detections one_box(int64_t frame) {
  Detections d;
  d.frame_index = frame;
  d.items.push_back(Detection{cv::Rect2f(0, 0, 10, 10), 2, "car", 0.9f});
  return d;
}

TEST(StageRunner, RunsInTimestampOrderWithParams) {
  auto r = testing::StageRunner::create<ScaleBoxes>("gain: 2");
  r.push("detections", one_box(1), 0.2);
  r.push("detections", one_box(0), 0.1);
  r.push("hint", Record{"h", {{"n", 1}}}, 0.1);
  r.run();
  auto out = r.collect<Detections>("detections");
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].frame_index, 0);
  EXPECT_FLOAT_EQ(out[0].items[0].box.width, 20.f);
  // The sticky hint pushed at t=0.1 is offered again at t=0.2.
  EXPECT_EQ(r.outputs("seen").size(), 2u);
  EXPECT_DOUBLE_EQ(r.outputs("detections")[1].timestamp(), 0.2);
}

TEST(StageRunner, InvalidParamsRefusedLikeTheHost) {
  try {
    testing::StageRunner::create<ScaleBoxes>("gain: 20");
    FAIL();
  } catch (const DiagnosticError& e) {
    EXPECT_EQ(std::string(e.what()),
              "<params>:1:7: error: stage 'scale_boxes': parameter 'gain' = 20 is out of range [0, 10]");
  }
}

TEST(StageRunner, WrongPacketTypeRefused) {
  auto r = testing::StageRunner::create<ScaleBoxes>();
  EXPECT_THROW(r.push("detections", Record{}, 0.0), Error);
  EXPECT_THROW(r.push("nope", one_box(0), 0.0), Error);
}

}  // namespace
}  // namespace hf

namespace hf {
namespace {

class OtherStage : public ScaleBoxes {
 public:
  static ComponentInfo describe() {
    ComponentInfo i = ScaleBoxes::describe();
    i.name = "other_stage";
    return i;
  }
};

TEST(StageRunner, ComponentsRegisteredAfterBuildDoNotInvalidateTheStage) {
  auto r = testing::StageRunner::create<ScaleBoxes>("gain: 3");
  r.registrar().add<OtherStage>();  // grows the registry's storage
  EXPECT_EQ(r.info().name, "scale_boxes");
  r.push("detections", one_box(0), 0.0);
  r.run();
  EXPECT_FLOAT_EQ(r.collect<Detections>("detections").at(0).items[0].box.width, 30.f);
}

}  // namespace
}  // namespace hf
