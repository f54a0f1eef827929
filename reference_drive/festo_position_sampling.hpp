// Festo CMMP position sampling (personality key `position_sampling: festo`,
// reference_drive/personality.hpp). Manual 000_33c1d912b8b6010a.txt §5.15 L4705-4816: the
// actual position is saved at the rising or falling edge of a digital input (the "sample
// input", chosen with the FCT software, L4713; here the simulated input `sample-input`).
//
// 204Ah sample_data, RECORD, sub 0 = 6 (UNSIGNED8 ro):
//   01h sample_mode          UNSIGNED16 rw  0 continuous, 1 autolock (L4737-4748); 0..1
//   02h sample_status        UNSIGNED8  ro  PDO  bit 0 falling_edge_occurred, bit 1
//                                            rising_edge_occurred (L4752-4763)
//   03h sample_status_mask   UNSIGNED8  rw  PDO  statusword bit 15 (L4765-4780)
//   04h sample_control       UNSIGNED8  wo  PDO  bit 0 falling_edge_enable, bit 1
//                                            rising_edge_enable (L4782-4795)
//   05h sample_position_rising_edge   INTEGER32 ro PDO  position units (L4799-4806)
//   06h sample_position_falling_edge  INTEGER32 ro PDO  position units (L4808-4815)
// Sub 1 and 3 are parameters (the dictionary's store group); 2, 4, 5, 6 are not stored and
// read 0 after a reset node.
//
// Behaviour (each point with its lines; where the manual leaves a choice, the choice made):
//   - edge: a 0 -> 1 change of the input is a rising edge, 1 -> 0 a falling edge (L4709).
//     Setting the level the input already has is no edge.
//   - enabling: "sample_control controls enabling of the sample event" (L4711) with the bits
//     falling_edge_enable / rising_edge_enable (L4793-4795). Writing a bit as 1 enables that
//     edge and clears its sample_status bit (L4782); a bit written as 0 leaves that edge as
//     it is (the object is write-only: "setting of the respective bit" is the action).
//     Choice: after power on and reset node no edge is enabled until sample_control enables
//     it (the manual gives no start state; the vectors write sample_control first, so they
//     hold for a drive that samples from power on as well). Bits 2-7 are ignored.
//   - at an enabled edge: the sample_position of that edge := the actual position (6064h, in
//     the position units of the factor group, L4804/L4813), the sample_status bit of that
//     edge := 1 (L4750-4763). Continuous (sample_mode 0): every enabled edge samples again,
//     the bit stays 1 until sample_control clears it. Autolock (1): after a sample event that
//     edge is blocked "until sampling is approved again" (L4733), i.e. until its
//     sample_control bit is written (L4782). Choice: the lock is per edge, as the release is
//     per bit ("even just one bounce can trigger both edges", L4733).
//   - position units: the latched position is kept in increments and shown in the position
//     units the factor group gives when read (Festo keeps values internally and converts
//     them on reading, §5.3 L2594), the same conversion and rounding as 6064h.
//   - statusword bit 15 = 1 while (sample_status AND sample_status_mask) != 0 (L4765).
//     Contradictions, both readings and the choice:
//       * the mask table names bit 0 rising_edge_visible, bit 1 falling_edge_visible
//         (L4776-4780), the status bits are bit 0 falling, bit 1 rising (L4761-4763); the text
//         says the mask selects "the bits of the object sample_status" (L4765). Chosen: a mask
//         bit by bit over sample_status (mask bit 0 = falling, bit 1 = rising), as the name
//         and the text say; the vectors use masks 00h and 03h, which both readings agree on.
//       * Tab. 6.9 gives statusword bit 15 "drive referenced" (§6.1.3 L5594-5597). The
//         reference drive does not show "drive referenced" (deviation
//         statusword-manufacturer-bits), so bit 15 is the sample bit alone.
//   - sample_mode and sample_status_mask take effect at the next edge and at once for bit 15.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "protocol/cia301/nmt.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/common/expected.hpp"
#include "reference_drive/cia402_application.hpp"

namespace drivecheck::reference_drive {

class FestoPositionSampling {
 public:
  static constexpr std::uint16_t kIndex = 0x204A;
  static constexpr std::uint8_t kModeSub = 1;
  static constexpr std::uint8_t kStatusSub = 2;
  static constexpr std::uint8_t kMaskSub = 3;
  static constexpr std::uint8_t kControlSub = 4;
  static constexpr std::uint8_t kRisingPositionSub = 5;
  static constexpr std::uint8_t kFallingPositionSub = 6;
  // sample_status / sample_status_mask / sample_control bits.
  static constexpr std::uint8_t kFallingBit = 0x01;
  static constexpr std::uint8_t kRisingBit = 0x02;
  static constexpr std::uint16_t kStatuswordSampleBit = 0x8000;
  // The name of the simulated input (ServoDrive::simulate, the vectors' `simulate` step).
  static constexpr std::string_view kInputName = "sample-input";

  // `application` must outlive this object.
  explicit FestoPositionSampling(Cia402Application& application) : application_(application) {}

  // Adds 204Ah with its hooks. Errors: the dictionary has 204Ah already.
  Expected<void, std::string> add_objects(cia301::ObjectDictionary& od);
  // Reset node (application): nothing enabled, sample_status 0, positions 0, bit 15 off. The
  // input keeps its level (it is wired, not a parameter).
  void on_reset(cia301::ObjectDictionary& od, cia301::ResetKind kind);
  // Each control cycle: the sampled positions in the current position units (for the TPDOs)
  // and statusword bit 15.
  void refresh(cia301::ObjectDictionary& od);
  // The drive is gone: forget its dictionary.
  void detach() { od_ = nullptr; }

  // The sample input: 0 low, 1 high (other values: an error naming the valid ones).
  Expected<void, std::string> set_input(std::int64_t level);

  bool input() const { return input_; }
  std::uint8_t status() const { return status_; }
  bool enabled(std::uint8_t edge_bit) const { return (enabled_ & edge_bit) != 0; }

 private:
  void on_control_write(cia301::ObjectDictionary& od, std::uint8_t bits);
  void sample(std::uint8_t edge_bit);
  void publish(cia301::ObjectDictionary& od);
  std::int32_t position_units(double increments) const;

  Cia402Application& application_;
  cia301::ObjectDictionary* od_ = nullptr;
  bool input_ = false;
  std::uint8_t enabled_ = 0;  // kFallingBit | kRisingBit
  std::uint8_t status_ = 0;
  std::optional<double> rising_;  // latched actual position, increments
  std::optional<double> falling_;
};

}  // namespace drivecheck::reference_drive
