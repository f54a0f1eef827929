// SocketCAN bus parts that need no CAN in the kernel: opening (which fails clearly on a host
// without CAN), the kernel filter and frame conversions, and error-frame decoding. The bus
// itself is tested against vcan inside a VM (tests/vm).
#include "protocol/can/socketcan_bus.hpp"

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <sys/socket.h>
#include <unistd.h>

#include "protocol/can/error_frame.hpp"

namespace drivecheck::can {
namespace {

Frame frame_from(std::string_view text) {
  auto frame = parse_candump(text);
  EXPECT_TRUE(frame) << text << ": " << (frame ? "" : frame.error());
  return frame ? *frame : Frame{};
}

bool kernel_has_can() {
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (fd < 0) return false;
  ::close(fd);
  return true;
}

// ---- open ----

TEST(SocketCanOpen, FailsClearlyWithoutCanOrInterface) {
  // Given an interface name that exists nowhere
  // When a SocketCAN port is opened on it
  // Then it fails with no_can_in_kernel on a kernel without CAN (this build host), else with
  //      no_such_interface, and the explanation names the interface and what to do
  const auto bus = SocketCanBus::open("dcnone0");
  ASSERT_FALSE(bus);
  const std::error_code expected =
      kernel_has_can() ? BusError::no_such_interface : BusError::no_can_in_kernel;
  EXPECT_EQ(bus.error(), expected) << bus.error().message();
  const std::string message = describe_open_error("dcnone0", bus.error());
  EXPECT_NE(message.find("dcnone0"), std::string::npos) << message;
  if (expected == BusError::no_can_in_kernel) {
    EXPECT_NE(message.find("modprobe can-raw"), std::string::npos) << message;
  } else {
    EXPECT_NE(message.find("type vcan"), std::string::npos) << message;
  }
}

TEST(SocketCanOpen, RejectsNamesTheKernelCannotHold) {
  // Given an empty name and one longer than IFNAMSIZ - 1 characters
  // When opened on a kernel with CAN
  // Then both are no_such_interface (without CAN the socket fails first)
  if (!kernel_has_can()) GTEST_SKIP() << "kernel without CAN: the socket fails before the name";
  for (const char* name : {"", "a-very-long-interface-name"}) {
    const auto bus = SocketCanBus::open(name);
    ASSERT_FALSE(bus) << name;
    EXPECT_EQ(bus.error(), BusError::no_such_interface) << name;
  }
}

TEST(SocketCanOpen, DescribesEveryOpenError) {
  // Given each error open() returns
  // When described for interface can7
  // Then the text names can7 and the cause
  EXPECT_NE(describe_open_error("can7", BusError::interface_down).find("ip link set can7 up"),
            std::string::npos);
  const std::string other =
      describe_open_error("can7", std::error_code(EPERM, std::system_category()));
  EXPECT_NE(other.find("can7"), std::string::npos) << other;
  EXPECT_NE(other.find(std::error_code(EPERM, std::system_category()).message()), std::string::npos)
      << other;
}

// ---- filters ----

TEST(SocketCanFilters, EmptyListPassesEverything) {
  // Given no filters
  // When converted for the kernel
  // Then there is one pass-all filter (zero kernel filters would pass nothing)
  EXPECT_EQ(to_kernel_filters({}), (std::vector<KernelFilter>{{0, 0}}));
}

TEST(SocketCanFilters, ConvertsStandardExtendedAndInverted) {
  // Given an exact 11-bit filter, an exact 29-bit filter and an inverted one
  // When converted
  // Then ids and masks carry over, EFF stays, and the inverted one has CAN_INV_FILTER set
  const Filter filters[] = {Filter::standard(0x181), Filter::extended(0x18FF0001),
                            Filter{0x700, 0x780, true}};
  const auto kernel = to_kernel_filters(filters);
  ASSERT_EQ(kernel.size(), 3u);
  EXPECT_EQ(kernel[0], (KernelFilter{0x181, CAN_EFF_FLAG | 0x7FF}));
  EXPECT_EQ(kernel[1], (KernelFilter{CAN_EFF_FLAG | 0x18FF0001, CAN_EFF_FLAG | CAN_EFF_MASK}));
  EXPECT_EQ(kernel[2], (KernelFilter{CAN_INV_FILTER | 0x700, 0x780}));
}

TEST(SocketCanFilters, ErrorFlagNeverReachesTheKernel) {
  // Given a filter that names the ERR flag in id and mask
  // When converted
  // Then bit 29 is cleared (the kernel would read it as CAN_INV_FILTER in the id)
  const Filter filter{Filter::kErrFlag | 0x40, Filter::kErrFlag | 0x40, false};
  const auto kernel = to_kernel_filters(std::span(&filter, 1));
  ASSERT_EQ(kernel.size(), 1u);
  EXPECT_EQ(kernel[0], (KernelFilter{0x40, 0x40}));
}

// linux/can.h's rule for one filter: (can_id & mask) == (filter_id & mask), inverted by
// CAN_INV_FILTER, which itself is not compared.
bool kernel_passes(std::span<const KernelFilter> filters, const Frame& frame) {
  const std::uint32_t id = socketcan_id(frame);
  for (const KernelFilter& f : filters) {
    const bool invert = (f.can_id & CAN_INV_FILTER) != 0;
    const std::uint32_t filter_id = f.can_id & ~CAN_INV_FILTER;
    if (((id & f.can_mask) == (filter_id & f.can_mask)) != invert) return true;
  }
  return false;
}

TEST(SocketCanFilters, KernelAgreesWithFilterMatchesForDataAndRemoteFrames) {
  // Given filter sets (exact, masked, inverted, extended, RTR-only) and frames of every kind
  // When the kernel's rule runs on the converted filters
  // Then it passes exactly the frames Filter::matches passes
  const std::vector<std::vector<Filter>> sets = {
      {Filter::standard(0x181)},
      {Filter{0x180, 0x780, false}},
      {Filter{0x700, 0x7FF, true}},
      {Filter::extended(0x181)},
      {Filter{Filter::kRtrFlag, Filter::kRtrFlag, false}},
      {Filter::standard(0x000), Filter{0x580, 0x780, false}, Filter{0x080, 0x7FF, true}},
  };
  const std::vector<Frame> frames = {
      frame_from("181#01"),      frame_from("182#"),      frame_from("700#05"),
      frame_from("701#05"),      frame_from("000#0100"),  frame_from("585#4300100000000000"),
      frame_from("00000181#AA"), frame_from("704#R"),     frame_from("00000700#R2"),
      frame_from("080#"),        frame_from("1FFFFFFF#"),
  };
  for (std::size_t s = 0; s < sets.size(); ++s) {
    const auto kernel = to_kernel_filters(sets[s]);
    for (const Frame& frame : frames) {
      bool expected = false;
      for (const Filter& f : sets[s])
        expected = expected || f.matches(frame);
      EXPECT_EQ(kernel_passes(kernel, frame), expected)
          << "set " << s << ", frame " << to_candump(frame);
    }
  }
}

// ---- frames ----

TEST(SocketCanFrames, ConvertsEveryShapeBothWays) {
  // Given one frame of each kind
  // When converted to the kernel layout and back
  // Then the frame is unchanged, and the kernel fields are those of linux/can.h
  for (const char* text : {"000#", "605#2341600000000000", "7FF#01", "12345678#DEADBEEF", "704#R",
                           "704#R3", "1FFFFFFF#R8", "123#1122334455667788_C"}) {
    const Frame frame = frame_from(text);
    const auto raw = to_kernel_frame(frame);
    ASSERT_TRUE(raw) << text;
    EXPECT_EQ(raw->can_id, socketcan_id(frame)) << text;
    const auto back = from_kernel_frame(*raw);
    ASSERT_TRUE(back) << text;
    EXPECT_EQ(to_candump(*back), text);
  }
}

TEST(SocketCanFrames, RemoteFrameCarriesDlcInLen) {
  // Given a remote request with DLC 3 (704#R3)
  // When converted
  // Then len is 3, the RTR flag is set, and no data is sent
  const auto raw = to_kernel_frame(frame_from("704#R3"));
  ASSERT_TRUE(raw);
  EXPECT_EQ(raw->can_id, CAN_RTR_FLAG | 0x704);
  EXPECT_EQ(raw->len, 3);
  EXPECT_EQ(raw->data, (std::array<std::uint8_t, 8>{}));
}

TEST(SocketCanFrames, DlcAboveEightUsesLen8Dlc) {
  // Given a data frame with DLC 12 (8 bytes on the wire)
  // When converted
  // Then len is 8 and len8_dlc is 12
  const auto raw = to_kernel_frame(frame_from("123#1122334455667788_C"));
  ASSERT_TRUE(raw);
  EXPECT_EQ(raw->len, 8);
  EXPECT_EQ(raw->len8_dlc, 12);
}

TEST(SocketCanFrames, RefusesFramesAPortCannotSend) {
  // Given an error frame, an 11-bit id above 7FF, a 29-bit id above 1FFFFFFF, DLC 16 and a
  //       remote request with DLC 9
  // When converted for sending
  // Then each is invalid_frame
  Frame too_big_standard = Frame::standard(0x7FF, {});
  too_big_standard.id = 0x800;
  Frame too_big_extended = Frame::extended(0x1FFFFFFF, {});
  too_big_extended.id = 0x20000000;
  Frame dlc16 = Frame::standard(0x100, {1, 2, 3, 4, 5, 6, 7, 8});
  dlc16.dlc = 16;
  Frame remote9 = Frame::remote(0x100, 8);
  remote9.dlc = 9;
  for (const Frame& frame : {frame_from("20000040#0000000000000000"), too_big_standard,
                             too_big_extended, dlc16, remote9}) {
    const auto raw = to_kernel_frame(frame);
    ASSERT_FALSE(raw);
    EXPECT_EQ(raw.error(), BusError::invalid_frame);
  }
}

TEST(SocketCanFrames, DecodesKernelErrorFrame) {
  // Given a kernel frame with CAN_ERR_FLAG | CAN_ERR_BUSOFF and 8 zero bytes
  // When converted
  // Then it is an error frame with class 0x40 that prints as 20000040#0000000000000000
  KernelFrame raw;
  raw.can_id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  raw.len = CAN_ERR_DLC;
  const auto frame = from_kernel_frame(raw);
  ASSERT_TRUE(frame);
  EXPECT_TRUE(frame->is_error());
  EXPECT_EQ(frame->id, 0x40u);
  EXPECT_EQ(to_candump(*frame), "20000040#0000000000000000");
}

TEST(SocketCanFrames, IgnoresBitsAboveTheIdentifierAndOverlongLen) {
  // Given a standard frame whose can_id has junk above bit 10, and a frame with len 9
  // When converted
  // Then the id is cut to 11 bits, and the len-9 frame is refused (no out-of-range read)
  KernelFrame junk;
  junk.can_id = 0x1FFFF123;
  junk.len = 1;
  junk.data[0] = 0xAB;
  const auto frame = from_kernel_frame(junk);
  ASSERT_TRUE(frame);
  EXPECT_EQ(to_candump(*frame), "123#AB");
  KernelFrame overlong;
  overlong.len = 9;
  EXPECT_FALSE(from_kernel_frame(overlong));
}

// ---- error frames ----

TEST(ErrorFrameDecoding, BusOff) {
  // Given an error frame with class CAN_ERR_BUSOFF (id 0x40)
  // When decoded and described
  // Then the bus-off class is set and the words say "bus-off"
  const Frame frame = frame_from("20000040#0000000000000000");
  const auto info = decode_error_frame(frame);
  ASSERT_TRUE(info);
  EXPECT_TRUE(info->has(error_class::kBusOff));
  EXPECT_FALSE(info->has(error_class::kRestarted));
  EXPECT_EQ(describe_error_frame(frame), "bus-off");
}

TEST(ErrorFrameDecoding, ControllerPassiveWithCounters) {
  // Given class CRTL | CNT (0x204), data[1] = TX_PASSIVE (0x20), tx counter 128, rx counter 5
  // When described
  // Then it names the controller problem and both counters
  // classes 0x204: controller, counters; data: -, 20 tx passive, -, -, -, -, tx 80h, rx 05h
  const Frame frame = frame_from("20000204#0020000000008005");
  const auto info = decode_error_frame(frame);
  ASSERT_TRUE(info);
  EXPECT_EQ(info->controller, controller_status::kTxPassive);
  EXPECT_EQ(info->tx_error_count, 128);
  EXPECT_EQ(info->rx_error_count, 5);
  EXPECT_EQ(describe_error_frame(frame),
            "controller problem: transmit error passive; error counters: tx 128, rx 5");
}

TEST(ErrorFrameDecoding, CountersOnlyWithTheirClass) {
  // Given a controller error frame whose data[6..7] are set but CAN_ERR_CNT is not
  // When decoded
  // Then the counters are absent
  // classes 0x004: controller; data[1] 04 rx warning, data[6..7] 60h 00h
  const auto info = decode_error_frame(frame_from("20000004#0004000000006000"));
  ASSERT_TRUE(info);
  EXPECT_FALSE(info->tx_error_count);
  EXPECT_FALSE(info->rx_error_count);
}

TEST(ErrorFrameDecoding, ProtocolViolationWithLocation) {
  // Given class PROT | BUSERROR (0x88), data[2] = STUFF | TX (0x84), data[3] = CRC_SEQ (0x08)
  // When described
  // Then type, direction, location and the bus error are all named
  const Frame frame = frame_from("20000088#0000840800000000");
  EXPECT_EQ(describe_error_frame(frame),
            "protocol violation: bit stuffing error, on transmission, at the CRC sequence; "
            "bus error");
}

TEST(ErrorFrameDecoding, AckMissingAndRestarted) {
  // Given a no-ACK error frame (0x20) and a restarted one (0x100)
  // When described
  // Then each says so
  EXPECT_EQ(describe_error_frame(frame_from("20000020#0000000000000000")),
            "no ACK: no other node acknowledged");
  EXPECT_EQ(describe_error_frame(frame_from("20000100#0000000000000000")), "controller restarted");
}

TEST(ErrorFrameDecoding, TransceiverAndArbitration) {
  // Given lost arbitration at bit 5 with a transceiver fault CAN-H short to GND (data[4] 07),
  //       and one with CAN-L not connected (data[4] 40)
  // When described
  // Then bit number and wire faults are named
  // classes 0x012: lost arbitration, transceiver; data[0] 05 bit 5, data[4] 07 CAN-H to GND
  EXPECT_EQ(describe_error_frame(frame_from("20000012#0500000007000000")),
            "lost arbitration at bit 5; transceiver: CAN-H short to GND");
  EXPECT_EQ(describe_error_frame(frame_from("20000010#0000000040000000")),
            "transceiver: CAN-L not connected");
}

TEST(ErrorFrameDecoding, UnknownBitsAreShownNotDropped) {
  // Given a controller status with an undefined bit (0x80) and an undefined class (bit 12)
  // When described
  // Then both unknowns appear in hex
  const std::string text = describe_error_frame(frame_from("20001004#0080000000000000"));
  EXPECT_EQ(text, "controller problem: unknown bits 0x80; unknown error classes 0x1000");
}

TEST(ErrorFrameDecoding, DataFramesAreNotErrorFrames) {
  // Given a data frame and an error frame without class bits
  // When decoded
  // Then the data frame has no error info and both descriptions say what they are
  const Frame data = frame_from("040#0000000000000000");
  EXPECT_FALSE(decode_error_frame(data));
  EXPECT_EQ(describe_error_frame(data), "not an error frame");
  EXPECT_EQ(describe_error_frame(frame_from("20000000#0000000000000000")),
            "error frame without error class");
}

TEST(ErrorFrameDecoding, EveryNamedLocation) {
  // Given the ACK slot (0x19), an unnamed location (0x01) and none (0x00)
  // When named
  // Then the first is named, the second shown in hex, the third unspecified
  EXPECT_EQ(describe_protocol_location(0x19), "the ACK slot");
  EXPECT_EQ(describe_protocol_location(0x01), "location 0x01");
  EXPECT_EQ(describe_protocol_location(0x00), "an unspecified location");
}

}  // namespace
}  // namespace drivecheck::can
