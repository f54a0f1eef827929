#include "protocol/ethercat/master_sii.hpp"

#include <fmt/format.h>

#include <algorithm>

#include "protocol/ethercat/esc.hpp"

namespace drivecheck::ethercat {
namespace {

using namespace sii;  // the 0502h bits, as the ESC model sets them
constexpr std::uint16_t kErrors = kCommandError | kWriteEnableError;

std::string describe_sii_status(std::uint16_t status) {
  std::string out = fmt::format("0502h = {:04X}h", status);
  if (status & kBusy) out += " busy";
  if (status & kWriteEnableError) out += " write-enable-error";
  if (status & kCommandError) out += " command-error";
  if (status & kDeviceInfoError) out += " device-information-error";
  if (status & kChecksumError) out += " checksum-error";
  return out;
}

// Polls 0500h..050Fh until 0502h bit 15 clears; returns the 16 bytes then.
Expected<std::vector<std::uint8_t>, MasterError> wait_idle(MasterPort& port, std::uint16_t station,
                                                           std::uint32_t word,
                                                           const SiiReadOptions& options) {
  const TimePoint deadline = port.now() + options.timeout;
  for (;;) {
    auto regs = port.read(Command::fprd, station, reg::kSiiConfiguration, 16);
    if (!regs) return Unexpected(regs.error());
    const std::uint16_t status = get_le16(*regs, 2);
    if ((status & kBusy) == 0) return regs;
    if (port.now() >= deadline) {
      return master_error(
          MasterErrc::sii_timeout,
          fmt::format(
              "station {:04X}h: SII EEPROM interface busy for more than {} µs at word "
              "{:04X}h ({})",
              station,
              std::chrono::duration_cast<std::chrono::microseconds>(options.timeout).count(), word,
              describe_sii_status(status)),
          station);
    }
    port.wait(options.poll_interval);
  }
}

}  // namespace

Expected<std::vector<std::uint8_t>, MasterError> read_sii_words(MasterPort& port,
                                                                std::uint16_t station,
                                                                std::uint32_t word,
                                                                std::size_t count,
                                                                const SiiReadOptions& options) {
  // The EEPROM belongs to ECAT (0500h bit 0 = 0).
  if (auto owned = port.write(Command::fpwr, station, reg::kSiiConfiguration, {0}); !owned) {
    return Unexpected(owned.error());
  }
  std::vector<std::uint8_t> out;
  out.reserve(count * 2);
  while (out.size() < count * 2) {
    const auto at = static_cast<std::uint32_t>(word + out.size() / 2);
    auto idle = wait_idle(port, station, at, options);
    if (!idle) return Unexpected(idle.error());
    if (((*idle)[1] & 0x01) != 0) {
      return master_error(MasterErrc::sii_error,
                          fmt::format("station {:04X}h: the PDI holds the SII EEPROM (0501h bit "
                                      "0 set) at word {:04X}h",
                                      station, at),
                          station);
    }
    if ((get_le16(*idle, 2) & kErrors) != 0) {
      // A pending error from an earlier command: command 000 clears it.
      if (auto cleared = port.write(Command::fpwr, station, reg::kSiiControl, le16(0)); !cleared) {
        return Unexpected(cleared.error());
      }
    }
    std::vector<std::uint8_t> command = le16(kCommandRead);
    const auto address = le32(at);
    command.insert(command.end(), address.begin(), address.end());
    if (auto sent = port.write(Command::fpwr, station, reg::kSiiControl, std::move(command));
        !sent) {
      return Unexpected(sent.error());
    }
    auto done = wait_idle(port, station, at, options);
    if (!done) return Unexpected(done.error());
    const std::uint16_t status = get_le16(*done, 2);
    if ((status & kErrors) != 0) {
      return master_error(MasterErrc::sii_error,
                          fmt::format("station {:04X}h: SII read of word {:04X}h failed ({})",
                                      station, at, describe_sii_status(status)),
                          station);
    }
    const std::size_t got = (status & kReadEightBytes) != 0 ? 8 : 4;
    const std::size_t take = std::min(got, count * 2 - out.size());
    out.insert(out.end(), done->begin() + 8, done->begin() + 8 + static_cast<std::ptrdiff_t>(take));
  }
  return out;
}

Expected<SiiRead, MasterError> read_sii(MasterPort& port, std::uint16_t station,
                                        const SiiReadOptions& options) {
  auto header = read_sii_words(port, station, 0, kSiiFirstCategoryWord, options);
  if (!header) return Unexpected(header.error());
  SiiRead result;
  result.bytes = std::move(*header);
  std::size_t word = kSiiFirstCategoryWord;
  for (;;) {
    if (word + 2 > options.max_words) {
      return master_error(MasterErrc::sii_malformed,
                          fmt::format("station {:04X}h: SII category list has no end marker "
                                      "within {} words",
                                      station, options.max_words),
                          station);
    }
    auto head = read_sii_words(port, station, static_cast<std::uint32_t>(word), 2, options);
    if (!head) {
      MasterError error = head.error();
      if (error.code == MasterErrc::sii_error) {
        error.code = MasterErrc::sii_malformed;
        error.detail = fmt::format(
            "station {:04X}h: SII category list runs past the EEPROM at word {:04X}h without "
            "end marker ({})",
            station, word, error.detail);
      }
      return Unexpected(std::move(error));
    }
    const std::uint16_t type = get_le16(*head, 0);
    const std::uint16_t length = get_le16(*head, 2);
    if (type == static_cast<std::uint16_t>(SiiCategoryType::end)) {
      result.bytes.insert(result.bytes.end(), head->begin(), head->end());
      break;
    }
    if (word + 2 + length > options.max_words) {
      return master_error(MasterErrc::sii_malformed,
                          fmt::format("station {:04X}h: SII category {} at word {:04X}h is {} "
                                      "words long, past {} words",
                                      station, type, word, length, options.max_words),
                          station);
    }
    auto data =
        read_sii_words(port, station, static_cast<std::uint32_t>(word + 2), length, options);
    if (!data) {
      MasterError error = data.error();
      if (error.code == MasterErrc::sii_error) {
        error.code = MasterErrc::sii_malformed;
        error.detail = fmt::format(
            "station {:04X}h: SII category {} at word {:04X}h runs past the EEPROM ({})", station,
            type, word, error.detail);
      }
      return Unexpected(std::move(error));
    }
    result.bytes.insert(result.bytes.end(), head->begin(), head->end());
    result.bytes.insert(result.bytes.end(), data->begin(), data->end());
    word += 2 + length;
  }
  auto image = parse_sii(result.bytes, options.parse);
  if (!image) {
    return master_error(MasterErrc::sii_malformed,
                        fmt::format("station {:04X}h: SII image does not parse: {}", station,
                                    image.error().message()),
                        station);
  }
  result.image = std::move(*image);
  return result;
}

}  // namespace drivecheck::ethercat
