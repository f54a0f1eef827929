// Values from the device (conformance/device_values.hpp): `$dut.<name>` found on the DUT at
// run time, so that a vector does not make a choice CiA 301/402 leave to the device.
#include "conformance/device_values.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "conformance/engine.hpp"
#include "conformance/vector_file.hpp"
#include "protocol/can/sim_bus.hpp"
#include "tests/support/scripted_peer.hpp"

namespace drivecheck::conformance {
namespace {

TEST(DeviceValues, UnsupportedModeIsTheLowestStandardModeNotListed) {
  // Given 6502h values / When the unsupported mode is chosen / Then the lowest clear mode bit
  EXPECT_EQ(unsupported_mode(0x000003ED), 2);  // pp pv tq hm ip csp csv cst: vl missing
  EXPECT_EQ(unsupported_mode(0x000003EF), 0);  // every standard mode
  EXPECT_EQ(unsupported_mode(0x00000001), 2);
  EXPECT_EQ(unsupported_mode(0x000001EF), 10);  // all but cst; bit 4 is reserved, not mode 5
  EXPECT_TRUE(is_device_value("dut.tpdo_object"));
  EXPECT_FALSE(is_device_value("dut.nothing"));
}

class PeerEngine : public ::testing::Test {
 protected:
  PeerEngine()
      : harness_(bus_.attach("harness")), peer_port_(bus_.attach("peer")), peer_(*peer_port_) {
    auto parsed = profile::parse_profile(
        "name: t\ntitle: T\nfeatures: [cia402]\n",
        {.file_name = "t.yaml", .base_dir = std::nullopt, .check_name = false});
    EXPECT_TRUE(parsed) << parsed.error().to_string();
    profile_ = *parsed;
  }
  VectorResult run(const std::string& steps) {
    const auto set = parse_vectors(
        "- id: t/x\n  title: t\n  source: \"CiA 301 §1\"\n  setup: none\n  nmt: none\n  steps:\n" +
            steps,
        "t.yaml");
    EXPECT_TRUE(set.ok()) << (set.errors.empty() ? "" : set.errors.front().to_string());
    // Scripted peers answer exactly the frames of their script: no isolation snapshot/restore.
    EngineOptions options;
    options.isolation = false;
    Engine engine(*harness_, profile_, std::move(options));
    return engine.run_vector(set.vectors.at(0));
  }

  can::SimBus bus_{{.bitrate = 1'000'000}};
  std::unique_ptr<can::SimPort> harness_;
  std::unique_ptr<can::SimPort> peer_port_;
  test_support::ScriptedPeer peer_;
  profile::DriveProfile profile_;
};

const std::string kRefusedMode =
    "    - sdo_write: {index: 0x6060, sub: 0, value: $dut.unsupported_mode, size: 1}\n"
    "      expect: {abort: [0x06090030]}\n";

TEST_F(PeerEngine, UnsupportedModeComesFromTheDevices6502h) {
  // Given a drive whose 6502h lists every standard mode but vl, and that refuses vl in 6060h
  peer_
      .expect("601#4002650000000000")  // ccs=2 upload, 6502h sub 0
      .reply("581#43026500ED030000");  // scs=2 e=1 s=1 n=0, 000003EDh
  peer_
      .expect("601#2F60600002000000")  // ccs=1 n=3 e=1 s=1, 6060h sub 0 := 2 (vl)
      .reply("581#8060600030000906");  // abort 06090030h
  // When the vector writes $dut.unsupported_mode
  const auto result = run(kRefusedMode);
  // Then it wrote vl (the mode the drive lacks) and passes
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  EXPECT_TRUE(peer_.finished());
}

TEST_F(PeerEngine, DriveWithEveryModeHasNoUnsupportedModeToTry) {
  // Given a drive whose 6502h lists every standard mode
  peer_
      .expect("601#4002650000000000")  // ccs=2 upload, 6502h sub 0
      .reply("581#43026500EF030000");  // 000003EFh
  // When the vector needs $dut.unsupported_mode
  const auto result = run(kRefusedMode);
  // Then it is not applicable, saying why
  EXPECT_EQ(result.verdict, Verdict::not_applicable) << result.message;
  EXPECT_NE(result.message.find("every mode"), std::string::npos) << result.message;
}

TEST_F(PeerEngine, TpdoObjectComesFromTheDefaultMapping) {
  // Given a device without EDS whose TPDO1 maps 6041h (16 bits) by default
  peer_
      .expect("601#40001A0000000000")  // ccs=2 upload, 1A00h sub 0
      .reply("581#4F001A0001000000");  // scs=2 n=3 e=1 s=1, 1 entry
  peer_
      .expect("601#40001A0100000000")  // ccs=2 upload, 1A00h sub 1
      .reply("581#43001A0110004160");  // 60410010h
  peer_
      .expect("601#23001A0110004160")  // ccs=1 n=0 e=1 s=1, 1A00h sub 1 := 60410010h
      .reply("581#60001A0100000000");  // download confirmed
  // When a vector maps $dut.tpdo_object
  const auto result =
      run("    - sdo_write: {index: 0x1A00, sub: 1, value: $dut.tpdo_object, size: 4}\n");
  // Then it maps the device's own default object, not 1001h
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
  EXPECT_TRUE(peer_.finished());
}

TEST_F(PeerEngine, SilencePatternAllowsAnEmptyFrameButNotData) {
  // Given a device that sends an empty frame on 1A0h, and one that sends a data byte there
  peer_.expect("123#01").reply_after(std::chrono::milliseconds(5), "1A0#");
  const auto empty =
      run("    - send: \"123#01\"\n    - expect_silence: [\"1A0#..*\"]\n      for: 20ms\n");
  peer_.expect("123#01").reply_after(std::chrono::milliseconds(5), "1A0#00");
  const auto data =
      run("    - send: \"123#01\"\n    - expect_silence: [\"1A0#..*\"]\n      for: 20ms\n");
  // When the vector wants no frame with data on 1A0h / Then the empty frame passes, data fails
  EXPECT_EQ(empty.verdict, Verdict::pass) << empty.message;
  EXPECT_EQ(data.verdict, Verdict::fail);
  EXPECT_NE(data.message.find("1A0#00"), std::string::npos) << data.message;
}

TEST_F(PeerEngine, OkOrAbortTakesEitherAnswerButNotSilence) {
  // Given a device that refuses the write, one that confirms it, and one that does not answer
  const std::string write =
      "    - sdo_write: {index: 0x1800, sub: 1, value: 0x1A0, size: 4}\n      expect: "
      "ok-or-abort\n";
  peer_.expect("601#23001801A0010000").reply("581#8000180102000106");
  const auto refused = run(write);
  peer_.expect("601#23001801A0010000").reply("581#6000180100000000");
  const auto accepted = run(write);
  peer_.expect("601#23001801A0010000");
  const auto silent = run(write);
  // When the vector accepts either answer / Then both pass, no answer fails
  EXPECT_EQ(refused.verdict, Verdict::pass) << refused.message;
  EXPECT_EQ(accepted.verdict, Verdict::pass) << accepted.message;
  EXPECT_EQ(silent.verdict, Verdict::fail);
}

TEST_F(PeerEngine, ReactionBeforeTheSdoAnswerCountsFromTheRequest) {
  // Given a drive that sends its error-reset EMCY at once on a controlword write but confirms
  // the write only 30 ms later (a late SDO server)
  peer_
      .expect("601#2B40600080000000")  // ccs=1 n=2 e=1 s=1, 6040h sub 0 := 0080h
      .reply("081#0000000000000000")   // EMCY 0000h: error reset
      .reply_after(std::chrono::milliseconds(30), "581#6040600000000000");  // confirmed
  // When the vector expects the EMCY within 20 ms after the controlword
  const auto result =
      run("    - controlword: 0x0080\n    - expect_emcy: {code: 0x0000}\n      within: 20ms\n");
  // Then it passes: the EMCY came right after the request, before the SDO answer
  EXPECT_EQ(result.verdict, Verdict::pass) << result.message;
}

}  // namespace
}  // namespace drivecheck::conformance
