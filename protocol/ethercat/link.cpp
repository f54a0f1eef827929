#include "protocol/ethercat/link.hpp"

#include <fmt/format.h>

#include <string>

#include "protocol/ethercat/frame.hpp"

namespace drivecheck::ethercat {
namespace {

class LinkCategory final : public std::error_category {
 public:
  const char* name() const noexcept override { return "ethercat-link"; }
  std::string message(int value) const override {
    switch (static_cast<LinkError>(value)) {
      case LinkError::link_down:
        return "link is down";
      case LinkError::frame_too_short:
        return "frame shorter than an Ethernet header (14 bytes)";
      case LinkError::frame_too_long:
        return "frame longer than 1514 bytes";
      case LinkError::no_such_interface:
        return "no network interface of that name";
      case LinkError::interface_down:
        return "network interface is not up";
      case LinkError::permission_denied:
        return "raw packet sockets need root or CAP_NET_RAW";
      case LinkError::no_packet_sockets:
        return "the kernel has no AF_PACKET sockets";
      case LinkError::io_error:
        return "I/O error";
    }
    return fmt::format("unknown ethercat-link error {}", value);
  }
};

}  // namespace

const std::error_category& link_category() {
  static const LinkCategory category;
  return category;
}

std::error_code make_error_code(LinkError error) {
  return {static_cast<int>(error), link_category()};
}

std::error_code check_frame_size(std::size_t size) {
  if (size < kEthernetHeaderSize) return LinkError::frame_too_short;
  if (size > kMaxFrameSize) return LinkError::frame_too_long;
  return {};
}

}  // namespace drivecheck::ethercat
