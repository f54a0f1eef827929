#include "fuzz/live/case_generator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>
#include <string>

#include "protocol/can/frame.hpp"

namespace drivecheck::fuzz_live {
namespace {

constexpr std::uint8_t kNode = 5;

std::vector<FuzzObject> objects() {
  return {
      {0x1000, 0, 4, false, {}, {}}, {0x1017, 0, 2, true, 0, 65535},
      {0x1010, 1, 4, true, {}, {}},  {0x1011, 1, 4, true, {}, {}},
      {0x6040, 0, 2, true, {}, {}},  {0x6060, 0, 1, true, -128, 127},
      {0x607A, 0, 4, true, {}, {}},  {0x1008, 0, 0, false, {}, {}},
  };
}

CaseGenerator generator(std::uint64_t seed, bool allow_motion = false) {
  return CaseGenerator(GeneratorOptions{.node = kNode, .seed = seed, .allow_motion = allow_motion},
                       objects());
}

bool is_download_to(const can::Frame& frame, std::uint16_t index) {
  if (frame.id != 0x600U + kNode || frame.length() < 3) return false;
  const unsigned ccs = frame.data[0] >> 5;
  const bool download = ccs == 1 || (ccs == 6 && (frame.data[0] & 1) == 0);
  return download && (frame.data[1] | (frame.data[2] << 8)) == index;
}

TEST(LiveCaseGenerator, SameSeedGivesSameCases) {
  // Given two generators with the same seed and objects
  // When both generate cases 1..300 (the second in reverse order)
  // Then every case is the same, frame for frame and gap for gap
  const auto a = generator(42);
  const auto b = generator(42);
  for (std::uint64_t n = 300; n >= 1; --n) {
    const auto x = a.generate(n);
    const auto y = b.generate(n);
    ASSERT_EQ(x.kind, y.kind) << n;
    ASSERT_EQ(x.steps.size(), y.steps.size()) << n;
    for (std::size_t i = 0; i < x.steps.size(); ++i) {
      EXPECT_EQ(x.steps[i].frame, y.steps[i].frame) << n;
      EXPECT_EQ(x.steps[i].delay_after, y.steps[i].delay_after) << n;
    }
  }
}

TEST(LiveCaseGenerator, DifferentSeedsGiveDifferentCases) {
  // Given generators with seeds 1 and 2
  // When both generate cases 1..50
  // Then most cases differ
  const auto a = generator(1);
  const auto b = generator(2);
  int differ = 0;
  for (std::uint64_t n = 1; n <= 50; ++n) {
    const auto x = a.generate(n);
    const auto y = b.generate(n);
    bool same = x.kind == y.kind && x.steps.size() == y.steps.size();
    for (std::size_t i = 0; same && i < x.steps.size(); ++i)
      same = x.steps[i].frame == y.steps[i].frame;
    differ += same ? 0 : 1;
  }
  EXPECT_GT(differ, 40);
}

TEST(LiveCaseGenerator, ProducesEveryKind) {
  // Given a generator
  // When it generates 1000 cases
  // Then every kind of the table appears, and cases have frames
  const auto g = generator(7);
  std::set<std::string> seen;
  std::size_t frames = 0;
  for (std::uint64_t n = 1; n <= 1000; ++n) {
    const auto c = g.generate(n);
    seen.insert(c.kind);
    frames += c.steps.size();
  }
  for (auto kind : CaseGenerator::kinds())
    EXPECT_TRUE(seen.contains(std::string(kind))) << kind;
  EXPECT_GT(frames, 2000U);
}

TEST(LiveCaseGenerator, ReachesTheFatalTriggers) {
  // Given a generator for node 5
  // When it generates 500 cases
  // Then some SDO request has the reserved command specifier 7, some NMT command an unknown
  // specifier for node 5 or all nodes, and some SDO request a sub-index the objects lack
  const auto g = generator(3);
  bool ccs7 = false;
  bool unknown_nmt = false;
  bool missing_sub = false;
  for (std::uint64_t n = 1; n <= 500; ++n) {
    for (const auto& step : g.generate(n).steps) {
      const can::Frame& f = step.frame;
      if (f.id == 0x600U + kNode && f.length() >= 4) {
        if ((f.data[0] >> 5) == 7) ccs7 = true;
        const auto index = static_cast<std::uint16_t>(f.data[1] | (f.data[2] << 8));
        const auto list = objects();
        const bool index_known = std::any_of(list.begin(), list.end(),
                                             [&](const FuzzObject& o) { return o.index == index; });
        const bool sub_known = std::any_of(list.begin(), list.end(), [&](const FuzzObject& o) {
          return o.index == index && o.sub == f.data[3];
        });
        if ((f.data[0] >> 5) == 2 && index_known && !sub_known) missing_sub = true;
      }
      if (f.id == 0 && f.length() == 2 && (f.data[1] == 0 || f.data[1] == kNode)) {
        const std::uint8_t cs = f.data[0];
        if (cs != 0x01 && cs != 0x02 && cs != 0x80 && cs != 0x81 && cs != 0x82) unknown_nmt = true;
      }
    }
  }
  EXPECT_TRUE(ccs7);
  EXPECT_TRUE(unknown_nmt);
  EXPECT_TRUE(missing_sub);
}

TEST(LiveCaseGenerator, NeverCommandsMotionWithoutAllowMotion) {
  // Given writable 6040h among the objects and no --allow-motion
  // When the generator makes 3000 cases
  // Then no frame downloads to 6040h and no frame uses a PDO identifier
  const auto g = generator(11);
  for (std::uint64_t n = 1; n <= 3000; ++n) {
    for (const auto& step : g.generate(n).steps) {
      EXPECT_FALSE(is_download_to(step.frame, 0x6040)) << can::to_candump(step.frame);
      EXPECT_FALSE(step.frame.id >= 0x180 && step.frame.id <= 0x57F) << can::to_candump(step.frame);
    }
  }
}

TEST(LiveCaseGenerator, WritesTheControlwordOnlyWithAllowMotion) {
  // Given writable 6040h and --allow-motion
  // When the generator makes 3000 cases
  // Then some frame downloads to 6040h (the safety rule above is not vacuous)
  const auto g = generator(11, true);
  bool written = false;
  for (std::uint64_t n = 1; n <= 3000 && !written; ++n) {
    for (const auto& step : g.generate(n).steps)
      written = written || is_download_to(step.frame, 0x6040);
  }
  EXPECT_TRUE(written);
}

TEST(LiveCaseGenerator, NeverStoresOrRestoresParameters) {
  // Given writable 1010h and 1011h among the objects, even with --allow-motion
  // When the generator makes 3000 cases
  // Then no frame downloads to 1010h or 1011h
  const auto g = generator(13, true);
  for (std::uint64_t n = 1; n <= 3000; ++n) {
    for (const auto& step : g.generate(n).steps) {
      EXPECT_FALSE(is_download_to(step.frame, 0x1010)) << can::to_candump(step.frame);
      EXPECT_FALSE(is_download_to(step.frame, 0x1011)) << can::to_candump(step.frame);
    }
  }
}

TEST(LiveSafetyRules, AllowedFrames) {
  // Given frames for node 5
  // When the safety rules judge them
  // Then controlword downloads and PDOs pass only with allow_motion; store never passes
  // ccs=1 e=1 s=1 n=2, index 6040h sub 0, data 000Fh (enable operation)
  const auto enable = can::Frame::standard(0x605, {0x2B, 0x40, 0x60, 0x00, 0x0F, 0x00, 0, 0});
  // ccs=2 initiate upload, index 6040h sub 0
  const auto read = can::Frame::standard(0x605, {0x40, 0x40, 0x60, 0x00, 0, 0, 0, 0});
  // ccs=1 e=1 s=1 n=0, index 1010h sub 1, "save"
  const auto save = can::Frame::standard(0x605, {0x23, 0x10, 0x10, 0x01, 0x73, 0x61, 0x76, 0x65});
  // RPDO1 of node 5: controlword 000Fh
  const auto rpdo = can::Frame::standard(0x205, {0x0F, 0x00});
  EXPECT_FALSE(is_allowed_frame(enable, kNode, false));
  EXPECT_TRUE(is_allowed_frame(enable, kNode, true));
  EXPECT_TRUE(is_allowed_frame(read, kNode, false));
  EXPECT_FALSE(is_allowed_frame(save, kNode, true));
  EXPECT_FALSE(is_allowed_frame(rpdo, kNode, false));
  EXPECT_TRUE(is_allowed_frame(rpdo, kNode, true));
}

TEST(LiveCaseRules, CommunicationResetAndExpectedBootUp) {
  // Given NMT frames and SDO downloads
  // When needs_communication_reset and resets_node judge them
  // Then NMT commands and 1xxxh downloads need a reset; only resets to the node or all expect
  // a boot-up
  const auto start = can::Frame::standard(0x000, {0x01, kNode});       // NMT start node 5
  const auto reset_other = can::Frame::standard(0x000, {0x81, 0x06});  // reset node 6
  const auto reset_all = can::Frame::standard(0x000, {0x82, 0x00});    // reset comm, all
  // ccs=1 e=1 s=1 n=2, index 1017h sub 0, 100 ms
  const auto heartbeat = can::Frame::standard(0x605, {0x2B, 0x17, 0x10, 0x00, 0x64, 0, 0, 0});
  // ccs=1 e=1 s=1 n=3, index 6060h sub 0, mode 1
  const auto mode = can::Frame::standard(0x605, {0x2F, 0x60, 0x60, 0x00, 0x01, 0, 0, 0});
  const std::vector<can::Frame> sdo_only{mode};
  EXPECT_FALSE(needs_communication_reset(sdo_only));
  EXPECT_TRUE(needs_communication_reset(std::vector<can::Frame>{mode, heartbeat}));
  EXPECT_TRUE(needs_communication_reset(std::vector<can::Frame>{start}));
  EXPECT_FALSE(resets_node(std::vector<can::Frame>{start, reset_other}, kNode));
  EXPECT_TRUE(resets_node(std::vector<can::Frame>{reset_all}, kNode));
}

}  // namespace
}  // namespace drivecheck::fuzz_live
