// Cyclic process data: one frame per cycle with an LRW over the whole process image (the
// logical ranges master_config.hpp assigned) and a BRD of AL status (0130h), whose working
// counter counts the slaves that answer and whose data is the OR of their AL status words.
// Sources: ESC datasheet Section I §2.5 Table 5 (LRW: +1 per slave that read, +2 per slave that
// wrote, +3 both), §6 (FMMU), §8.3 (a buffered SM with the watchdog trigger bit restarts the
// process data watchdog when written, which every cycle's LRW does in SAFEOP and OP).
//
// The check of a cycle: the LRW working counter must equal the sum of the slaves' expected
// counts (SlaveLayout::expected_wkc); the BRD working counter the number of slaves; the OR of
// AL status the state the master holds the slaves in without error indication. Each mismatch
// is reported as such (CycleResult), and the facade turns them into errors naming the slave.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "protocol/ethercat/master_config.hpp"
#include "protocol/ethercat/master_link.hpp"

namespace drivecheck::ethercat {

struct CycleResult {
  std::uint16_t wkc = 0;           // LRW working counter
  std::uint16_t expected_wkc = 0;  // sum over the slaves
  std::uint16_t al_wkc = 0;        // BRD 0130h working counter
  std::uint16_t al_status = 0;     // OR of every slave's AL status
  bool wkc_ok() const { return wkc == expected_wkc; }
};

class ProcessImage {
 public:
  ProcessImage() = default;
  ProcessImage(const std::vector<SlaveLayout>& slaves, std::uint32_t logical_base,
               std::size_t size);

  std::span<std::uint8_t> outputs(std::size_t slave);
  std::span<const std::uint8_t> inputs(std::size_t slave) const;
  std::span<const std::uint8_t> outputs_view(std::size_t slave) const;
  std::uint16_t expected_wkc() const { return expected_wkc_; }
  std::uint32_t logical_base() const { return base_; }
  std::size_t size() const { return image_.size(); }
  std::size_t slaves() const { return ranges_.size(); }

  // Runs one cycle (no retry: a lost frame is a lost cycle, no_response).
  Expected<CycleResult, MasterError> cycle(MasterPort& port);

 private:
  struct Range {
    std::size_t output_offset = 0;
    std::size_t output_size = 0;
    std::size_t input_offset = 0;
    std::size_t input_size = 0;
  };
  std::vector<std::uint8_t> image_;
  std::vector<Range> ranges_;
  std::uint32_t base_ = 0;
  std::uint16_t expected_wkc_ = 0;
};

}  // namespace drivecheck::ethercat
