#include "protocol/ethercat/master_process_data.hpp"

#include <algorithm>

#include "protocol/ethercat/esc.hpp"

namespace drivecheck::ethercat {

ProcessImage::ProcessImage(const std::vector<SlaveLayout>& slaves, std::uint32_t logical_base,
                           std::size_t size)
    : image_(size, 0), base_(logical_base) {
  for (const SlaveLayout& slave : slaves) {
    ranges_.push_back(
        {slave.output_offset, slave.output_bytes, slave.input_offset, slave.input_bytes});
    expected_wkc_ = static_cast<std::uint16_t>(expected_wkc_ + slave.expected_wkc());
  }
}

std::span<std::uint8_t> ProcessImage::outputs(std::size_t slave) {
  if (slave >= ranges_.size()) return {};
  return std::span(image_).subspan(ranges_[slave].output_offset, ranges_[slave].output_size);
}

std::span<const std::uint8_t> ProcessImage::outputs_view(std::size_t slave) const {
  if (slave >= ranges_.size()) return {};
  return std::span(image_).subspan(ranges_[slave].output_offset, ranges_[slave].output_size);
}

std::span<const std::uint8_t> ProcessImage::inputs(std::size_t slave) const {
  if (slave >= ranges_.size()) return {};
  return std::span(image_).subspan(ranges_[slave].input_offset, ranges_[slave].input_size);
}

Expected<CycleResult, MasterError> ProcessImage::cycle(MasterPort& port) {
  std::vector<Datagram> frame;
  if (!image_.empty()) frame.push_back(Datagram::logical(Command::lrw, 0, base_, image_));
  frame.push_back(Datagram::physical(Command::brd, 0, 0, reg::kAlStatus, {0, 0}));
  auto back = port.exchange(std::move(frame), ExchangeOptions{0});
  if (!back) return Unexpected(back.error());
  CycleResult result;
  result.expected_wkc = expected_wkc_;
  const Datagram& status = back->back();
  result.al_wkc = status.working_counter;
  result.al_status = get_le16(status.data, 0);
  if (!image_.empty()) {
    const Datagram& lrw = back->front();
    result.wkc = lrw.working_counter;
    // Take the inputs only: the outputs stay what the application set.
    for (const Range& range : ranges_) {
      std::copy_n(lrw.data.begin() + static_cast<std::ptrdiff_t>(range.input_offset),
                  range.input_size,
                  image_.begin() + static_cast<std::ptrdiff_t>(range.input_offset));
    }
  }
  return result;
}

}  // namespace drivecheck::ethercat
