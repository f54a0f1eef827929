#include "fuzz/live/ethercat_cases.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "fuzz/live/ethercat_fuzzer.hpp"

namespace drivecheck::fuzz_live {
namespace {

// Every object writable, the guarded ones among them.
std::vector<FuzzObject> objects() {
  return {
      {0x1000, 0, 4, false, {}, {}}, {0x1017, 0, 2, true, 0, 65535},
      {0x1010, 1, 4, true, {}, {}},  {0x1011, 1, 4, true, {}, {}},
      {0x6040, 0, 2, true, {}, {}},  {0x6060, 0, 1, true, -128, 127},
      {0x1C12, 0, 1, true, {}, {}},  {0x1600, 1, 4, true, {}, {}},
      {0x1A00, 0, 1, true, {}, {}},  {0x1F51, 1, 1, true, {}, {}},
      {0x1008, 0, 0, false, {}, {}}, {0x607A, 0, 4, true, {}, {}},
  };
}

// The index a step's download initiate names (any service, any other command bits), if any.
std::optional<std::uint16_t> download_index(const MailboxStep& step) {
  const auto& d = step.data;
  if (d.size() < 5 || (d[2] >> 5) != 1) return std::nullopt;
  return static_cast<std::uint16_t>(d[3] | (d[4] << 8));
}

TEST(EthercatCaseGenerator, SameSeedGivesSameCases) {
  // Given two generators with the same seed
  // When both generate cases 1..300 (the second in reverse order)
  // Then every case is the same: kind, state and every step's octets and header fields
  const EthercatCaseGenerator a({.seed = 7}, objects());
  const EthercatCaseGenerator b({.seed = 7}, objects());
  for (std::uint64_t n = 300; n >= 1; --n) {
    const auto x = a.generate(301 - n);
    const auto y = b.generate(301 - n);
    ASSERT_EQ(x.kind, y.kind);
    ASSERT_EQ(x.state, y.state);
    ASSERT_EQ(x.steps.size(), y.steps.size());
    for (std::size_t i = 0; i < x.steps.size(); ++i)
      EXPECT_EQ(describe_step(x.steps[i]), describe_step(y.steps[i]));
  }
}

TEST(EthercatCaseGenerator, NeverWritesGuardedObjectsOrSendsOtherProtocols) {
  // Given a generator whose objects include 1010h, 1011h, 1F51h, 6040h and the PDO and SM
  // configuration, all writable
  // When it generates 20000 cases without allow_motion
  // Then no step is a download initiate to any of them, and every step is CoE or a reserved type
  const EthercatCaseGenerator generator({.seed = 3}, objects());
  std::size_t downloads = 0;
  for (std::uint64_t n = 1; n <= 20000; ++n) {
    for (const auto& step : generator.generate(n).steps) {
      const std::uint8_t type = step.type & 0x0F;
      EXPECT_TRUE(type == 3 || type == 0 || (type >= 6 && type <= 14)) << describe_step(step);
      EXPECT_LE(step.data.size(), 128U - 6U);
      const auto index = download_index(step);
      if (!index) continue;
      ++downloads;
      EXPECT_NE(*index, 0x1010) << describe_step(step);
      EXPECT_NE(*index, 0x1011) << describe_step(step);
      EXPECT_NE(*index, 0x6040) << describe_step(step);
      EXPECT_FALSE(*index >= 0x1F50 && *index <= 0x1F5F) << describe_step(step);
      EXPECT_FALSE(*index >= 0x1600 && *index <= 0x1CFF) << describe_step(step);
    }
  }
  EXPECT_GT(downloads, 1000U);  // the filter leaves the allowed writes
}

TEST(EthercatCaseGenerator, ControlwordOnlyWithAllowMotion) {
  // Given the same objects with allow_motion
  // When 20000 cases are generated
  // Then 6040h is written, and 1010h/1011h still never
  const EthercatCaseGenerator generator({.seed = 3, .allow_motion = true}, objects());
  std::set<std::uint16_t> written;
  for (std::uint64_t n = 1; n <= 20000; ++n)
    for (const auto& step : generator.generate(n).steps)
      if (auto index = download_index(step)) written.insert(*index);
  EXPECT_TRUE(written.count(0x6040));
  EXPECT_FALSE(written.count(0x1010));
  EXPECT_FALSE(written.count(0x1011));
}

TEST(EthercatCaseGenerator, SafetyFilterRefusesWhatTheGeneratorMustNotSend) {
  // Given steps the generator must never send
  // When is_allowed_mailbox judges them
  // Then FoE/EoE/AoE/SoE/VoE and downloads to guarded objects are refused, an upload is not
  MailboxStep foe;
  foe.type = 4;
  foe.data = {0x01, 0x00};
  EXPECT_FALSE(is_allowed_mailbox(foe, true));
  for (const std::uint8_t type : {1, 2, 5, 15}) {
    MailboxStep other;
    other.type = type;
    EXPECT_FALSE(is_allowed_mailbox(other, true));
  }
  MailboxStep store;
  store.data = {0x00, 0x20, 0x23, 0x10, 0x10, 0x01, 's', 'a', 'v', 'e'};
  EXPECT_FALSE(is_allowed_mailbox(store, true));
  store.data[2] = 0x3F;  // other download initiate bits, still 1010h
  EXPECT_FALSE(is_allowed_mailbox(store, true));
  store.data[1] = 0x90;  // a service number that does not exist: still refused
  EXPECT_FALSE(is_allowed_mailbox(store, true));
  MailboxStep upload;
  upload.data = {0x00, 0x20, 0x40, 0x10, 0x10, 0x01, 0, 0, 0, 0};
  EXPECT_TRUE(is_allowed_mailbox(upload, false));
}

TEST(EthercatCaseGenerator, EveryKindStateAndCounterModeOccurs) {
  // Given the default options
  // When 2000 cases are generated
  // Then every kind, PREOP/SAFEOP/OP, every counter mode, lying Lengths and reserved types occur
  const EthercatCaseGenerator generator({.seed = 11}, objects());
  std::set<std::string> kinds;
  std::set<ethercat::AlState> states;
  std::set<CounterMode> counters;
  bool lying_length = false;
  bool reserved_type = false;
  for (std::uint64_t n = 1; n <= 2000; ++n) {
    const auto c = generator.generate(n);
    kinds.insert(c.kind);
    states.insert(c.state);
    for (const auto& step : c.steps) {
      counters.insert(step.counter);
      lying_length |= step.length && *step.length != step.data.size();
      reserved_type |= step.type != 3;
    }
  }
  EXPECT_EQ(kinds.size(), EthercatCaseGenerator::kinds().size());
  EXPECT_EQ(states.size(), 3U);
  EXPECT_EQ(counters.size(), 4U);
  EXPECT_TRUE(lying_length);
  EXPECT_TRUE(reserved_type);
}

TEST(EthercatReproducer, StepsReadBackAsWritten) {
  // Given 500 generated cases written as a text reproducer (describe_step per line)
  // When each is parsed back
  // Then the state and every step (octets, counter mode, Type, Length, Channel, Priority) match
  const EthercatCaseGenerator generator({.seed = 5}, objects());
  for (std::uint64_t n = 1; n <= 500; ++n) {
    const auto c = generator.generate(n);
    std::string text = "# anomaly: coe-no-answer: x\n# case " + std::to_string(n) + " (" + c.kind +
                       ") in " + ethercat::al_state_name(c.state) + ", seed 5, on ethercat:sim\n";
    for (const auto& step : c.steps)
      text += describe_step(step) + "\n";
    const auto parsed = parse_ethercat_reproducer(text, "r.txt");
    ASSERT_TRUE(parsed) << parsed.error() << "\n" << text;
    EXPECT_EQ(parsed->anomaly, EthercatAnomalyKind::coe_no_answer);
    EXPECT_EQ(parsed->c.state, c.state);
    ASSERT_EQ(parsed->c.steps.size(), c.steps.size()) << text;
    for (std::size_t i = 0; i < c.steps.size(); ++i) {
      const auto& a = c.steps[i];
      const auto& b = parsed->c.steps[i];
      EXPECT_EQ(a.data, b.data) << text;
      EXPECT_EQ(a.counter, b.counter);
      EXPECT_EQ(a.type, b.type);
      EXPECT_EQ(a.length.value_or(a.data.size()), b.length.value_or(b.data.size()));
      EXPECT_EQ(a.channel, b.channel);
      EXPECT_EQ(a.priority, b.priority);
    }
  }
}

}  // namespace
}  // namespace drivecheck::fuzz_live
