#include "protocol/ethercat/sii.hpp"

#include <fmt/format.h>

#include <algorithm>

namespace drivecheck::ethercat {
namespace {

class Writer {
 public:
  void u8(std::uint8_t v) { bytes.push_back(v); }
  void u16(std::uint16_t v) {
    u8(static_cast<std::uint8_t>(v));
    u8(static_cast<std::uint8_t>(v >> 8));
  }
  void u32(std::uint32_t v) {
    u16(static_cast<std::uint16_t>(v));
    u16(static_cast<std::uint16_t>(v >> 16));
  }
  void pad_to_word() {
    if (bytes.size() % 2 != 0) u8(0);
  }
  std::vector<std::uint8_t> bytes;
};

class Reader {
 public:
  explicit Reader(std::span<const std::uint8_t> data) : data_(data) {}
  bool has(std::size_t n) const { return data_.size() - at_ >= n; }
  std::uint8_t u8() { return data_[at_++]; }
  std::uint16_t u16() {
    const auto v = static_cast<std::uint16_t>(data_[at_] | (data_[at_ + 1] << 8));
    at_ += 2;
    return v;
  }
  std::uint32_t u32() {
    const std::uint32_t low = u16();
    return low | (static_cast<std::uint32_t>(u16()) << 16);
  }
  void skip(std::size_t n) { at_ += n; }
  std::size_t at() const { return at_; }
  std::size_t left() const { return data_.size() - at_; }

 private:
  std::span<const std::uint8_t> data_;
  std::size_t at_ = 0;
};

void write_category(Writer& out, std::uint16_t type, const std::vector<std::uint8_t>& data) {
  out.u16(type);
  out.u16(static_cast<std::uint16_t>((data.size() + 1) / 2));
  out.bytes.insert(out.bytes.end(), data.begin(), data.end());
  out.pad_to_word();
}

std::vector<std::uint8_t> pdo_category(const std::vector<SiiPdo>& pdos) {
  Writer w;
  for (const SiiPdo& pdo : pdos) {
    w.u16(pdo.index);
    w.u8(static_cast<std::uint8_t>(pdo.entries.size()));
    w.u8(pdo.sync_manager);
    w.u8(pdo.synchronization);
    w.u8(pdo.name_index);
    w.u16(pdo.flags);
    for (const SiiPdoEntry& entry : pdo.entries) {
      w.u16(entry.index);
      w.u8(entry.subindex);
      w.u8(entry.name_index);
      w.u8(entry.data_type);
      w.u8(entry.bit_length);
      w.u16(entry.flags);
    }
  }
  return w.bytes;
}

class SiiCategoryImpl final : public std::error_category {
 public:
  const char* name() const noexcept override { return "ethercat-sii"; }
  std::string message(int value) const override {
    switch (static_cast<SiiError>(value)) {
      case SiiError::too_short:
        return "SII image shorter than its 64-word header";
      case SiiError::odd_length:
        return "SII image is not a whole number of 16-bit words";
      case SiiError::checksum_mismatch:
        return "SII checksum (word 07h) does not match the configuration area";
      case SiiError::category_past_end:
        return "SII category length runs past the end of the image";
      case SiiError::no_end_marker:
        return "SII category list has no end marker FFFFh";
      case SiiError::malformed_strings:
        return "SII Strings category is malformed";
      case SiiError::malformed_general:
        return "SII General category is shorter than 32 bytes";
      case SiiError::malformed_sync_manager:
        return "SII SyncM category length is not a multiple of 8 bytes";
      case SiiError::malformed_pdo:
        return "SII TxPDO/RxPDO category is malformed";
      case SiiError::duplicate_category:
        return "SII category appears twice";
      case SiiError::too_long:
        return "SII image or string too long";
    }
    return fmt::format("unknown ethercat-sii error {}", value);
  }
};

SiiParseError fail(SiiError code, std::size_t word, std::string detail = {}) {
  return SiiParseError{make_error_code(code), word, std::move(detail)};
}

std::optional<SiiParseError> parse_pdos(std::span<const std::uint8_t> data, std::size_t word,
                                        std::vector<SiiPdo>& out) {
  Reader r(data);
  while (r.left() > 0) {
    if (!r.has(8)) {
      // A trailing pad byte (odd category data) is not a PDO.
      if (r.left() == 1) break;
      return fail(SiiError::malformed_pdo, word, fmt::format("PDO header at byte {}", r.at()));
    }
    SiiPdo pdo;
    pdo.index = r.u16();
    const std::uint8_t count = r.u8();
    pdo.sync_manager = r.u8();
    pdo.synchronization = r.u8();
    pdo.name_index = r.u8();
    pdo.flags = r.u16();
    if (!r.has(static_cast<std::size_t>(count) * 8)) {
      return fail(
          SiiError::malformed_pdo, word,
          fmt::format("PDO {:04X}h: {} entries, {} bytes left", pdo.index, count, r.left()));
    }
    for (std::uint8_t i = 0; i < count; ++i) {
      SiiPdoEntry entry;
      entry.index = r.u16();
      entry.subindex = r.u8();
      entry.name_index = r.u8();
      entry.data_type = r.u8();
      entry.bit_length = r.u8();
      entry.flags = r.u16();
      pdo.entries.push_back(entry);
    }
    out.push_back(std::move(pdo));
  }
  return std::nullopt;
}

}  // namespace

const std::error_category& sii_category() {
  static const SiiCategoryImpl category;
  return category;
}

std::error_code make_error_code(SiiError error) {
  return {static_cast<int>(error), sii_category()};
}

std::string SiiParseError::message() const {
  if (detail.empty()) return fmt::format("SII word {:04X}h: {}", word, code.message());
  return fmt::format("SII word {:04X}h: {} ({})", word, code.message(), detail);
}

std::uint8_t sii_checksum(std::span<const std::uint8_t> first_14_bytes) {
  std::uint8_t crc = 0xFF;
  for (std::size_t i = 0; i < 14 && i < first_14_bytes.size(); ++i) {
    crc ^= first_14_bytes[i];
    for (int bit = 0; bit < 8; ++bit) {
      crc = (crc & 0x80) != 0 ? static_cast<std::uint8_t>((crc << 1) ^ 0x07)
                              : static_cast<std::uint8_t>(crc << 1);
    }
  }
  return crc;
}

Expected<std::vector<std::uint8_t>, std::error_code> build_sii(const SiiImage& image) {
  const SiiHeader& h = image.header;
  Writer w;
  w.u16(h.pdi_control);
  w.u16(h.pdi_configuration);
  w.u16(h.sync_impulse_length);
  w.u16(h.pdi_configuration2);
  w.u16(h.station_alias);
  w.u16(0);
  w.u16(0);
  w.u16(sii_checksum(w.bytes));
  w.u32(h.vendor_id);
  w.u32(h.product_code);
  w.u32(h.revision);
  w.u32(h.serial);
  w.u16(h.execution_delay);
  w.u16(h.port0_delay);
  w.u16(h.port1_delay);
  w.u16(0);
  for (const SiiMailbox& m :
       {h.bootstrap_receive, h.bootstrap_send, h.standard_receive, h.standard_send}) {
    w.u16(m.offset);
    w.u16(m.size);
  }
  w.u16(h.mailbox_protocols);
  w.bytes.resize(0x3E * 2, 0);
  w.u16(h.size);
  w.u16(h.version);

  if (!image.strings.empty()) {
    Writer s;
    if (image.strings.size() > 255) return Unexpected(make_error_code(SiiError::too_long));
    s.u8(static_cast<std::uint8_t>(image.strings.size()));
    for (const std::string& text : image.strings) {
      if (text.size() > 255) return Unexpected(make_error_code(SiiError::too_long));
      s.u8(static_cast<std::uint8_t>(text.size()));
      s.bytes.insert(s.bytes.end(), text.begin(), text.end());
    }
    write_category(w, static_cast<std::uint16_t>(SiiCategoryType::strings), s.bytes);
  }
  if (image.general) {
    const SiiGeneral& g = *image.general;
    Writer c;
    for (std::uint8_t b : {g.group_index, g.image_index, g.order_index, g.name_index,
                           std::uint8_t{0}, g.coe_details, g.foe_details, g.eoe_details,
                           g.soe_channels, g.ds402_channels, g.sysman_class, g.flags}) {
      c.u8(b);
    }
    c.u16(static_cast<std::uint16_t>(g.ebus_current));
    c.u8(g.group_index);
    c.u8(0);
    c.u16(g.physical_port);
    c.u16(g.physical_memory_address);
    c.bytes.resize(32, 0);
    write_category(w, static_cast<std::uint16_t>(SiiCategoryType::general), c.bytes);
  }
  if (!image.fmmus.empty()) {
    write_category(w, static_cast<std::uint16_t>(SiiCategoryType::fmmu), image.fmmus);
  }
  if (!image.sync_managers.empty()) {
    Writer c;
    for (const SiiSyncManager& sm : image.sync_managers) {
      c.u16(sm.start);
      c.u16(sm.length);
      c.u8(sm.control);
      c.u8(sm.status);
      c.u8(sm.enable);
      c.u8(static_cast<std::uint8_t>(sm.type));
    }
    write_category(w, static_cast<std::uint16_t>(SiiCategoryType::sync_manager), c.bytes);
  }
  if (!image.tx_pdos.empty()) {
    write_category(w, static_cast<std::uint16_t>(SiiCategoryType::tx_pdo),
                   pdo_category(image.tx_pdos));
  }
  if (!image.rx_pdos.empty()) {
    write_category(w, static_cast<std::uint16_t>(SiiCategoryType::rx_pdo),
                   pdo_category(image.rx_pdos));
  }
  for (const SiiRawCategory& raw : image.other)
    write_category(w, raw.type, raw.data);
  w.u16(static_cast<std::uint16_t>(SiiCategoryType::end));
  if (w.bytes.size() > 0xFFFF * 2) return Unexpected(make_error_code(SiiError::too_long));
  return std::move(w.bytes);
}

Expected<SiiImage, SiiParseError> parse_sii(std::span<const std::uint8_t> bytes,
                                            SiiParseOptions options) {
  if (bytes.size() % 2 != 0) {
    return Unexpected(
        fail(SiiError::odd_length, bytes.size() / 2, fmt::format("{} bytes", bytes.size())));
  }
  if (bytes.size() < kSiiFirstCategoryWord * 2) {
    return Unexpected(
        fail(SiiError::too_short, bytes.size() / 2, fmt::format("{} words", bytes.size() / 2)));
  }
  SiiImage image;
  SiiHeader& h = image.header;
  Reader r(bytes);
  h.pdi_control = r.u16();
  h.pdi_configuration = r.u16();
  h.sync_impulse_length = r.u16();
  h.pdi_configuration2 = r.u16();
  h.station_alias = r.u16();
  r.skip(4);
  const std::uint16_t checksum = r.u16();
  const std::uint8_t expected = sii_checksum(bytes.first(14));
  if (options.check_checksum && (checksum & 0xFF) != expected) {
    return Unexpected(
        fail(SiiError::checksum_mismatch, 7,
             fmt::format("stored {:02X}h, computed {:02X}h", checksum & 0xFF, expected)));
  }
  h.vendor_id = r.u32();
  h.product_code = r.u32();
  h.revision = r.u32();
  h.serial = r.u32();
  h.execution_delay = r.u16();
  h.port0_delay = r.u16();
  h.port1_delay = r.u16();
  r.skip(2);
  for (SiiMailbox* m :
       {&h.bootstrap_receive, &h.bootstrap_send, &h.standard_receive, &h.standard_send}) {
    m->offset = r.u16();
    m->size = r.u16();
  }
  h.mailbox_protocols = r.u16();
  r.skip((0x3E - 0x1D) * 2);
  h.size = r.u16();
  h.version = r.u16();

  bool seen_strings = false;
  bool seen_fmmu = false;
  bool seen_sync = false;
  for (;;) {
    const std::size_t word = r.at() / 2;
    if (!r.has(2)) return Unexpected(fail(SiiError::no_end_marker, word));
    const std::uint16_t type = r.u16();
    if (type == static_cast<std::uint16_t>(SiiCategoryType::end)) break;
    if (!r.has(2)) {
      return Unexpected(fail(SiiError::category_past_end, word,
                             fmt::format("category {} has no length word", type)));
    }
    const std::size_t length_words = r.u16();
    if (!r.has(length_words * 2)) {
      return Unexpected(
          fail(SiiError::category_past_end, word,
               fmt::format("category {}: {} words, {} left", type, length_words, r.left() / 2)));
    }
    const auto data = bytes.subspan(r.at(), length_words * 2);
    r.skip(length_words * 2);
    switch (static_cast<SiiCategoryType>(type)) {
      case SiiCategoryType::strings: {
        if (seen_strings) return Unexpected(fail(SiiError::duplicate_category, word, "Strings"));
        seen_strings = true;
        Reader s(data);
        if (!s.has(1)) return Unexpected(fail(SiiError::malformed_strings, word, "empty"));
        const std::uint8_t count = s.u8();
        for (std::uint8_t i = 0; i < count; ++i) {
          if (!s.has(1)) {
            return Unexpected(fail(SiiError::malformed_strings, word,
                                   fmt::format("string {} of {} missing", i + 1, count)));
          }
          const std::uint8_t length = s.u8();
          if (!s.has(length)) {
            return Unexpected(fail(SiiError::malformed_strings, word,
                                   fmt::format("string {} runs past the category", i + 1)));
          }
          const auto text = data.subspan(s.at(), length);
          image.strings.emplace_back(text.begin(), text.end());
          s.skip(length);
        }
        break;
      }
      case SiiCategoryType::general: {
        if (image.general) return Unexpected(fail(SiiError::duplicate_category, word, "General"));
        if (data.size() < 32) {
          return Unexpected(
              fail(SiiError::malformed_general, word, fmt::format("{} bytes", data.size())));
        }
        Reader g(data);
        SiiGeneral general;
        general.group_index = g.u8();
        general.image_index = g.u8();
        general.order_index = g.u8();
        general.name_index = g.u8();
        g.skip(1);
        general.coe_details = g.u8();
        general.foe_details = g.u8();
        general.eoe_details = g.u8();
        general.soe_channels = g.u8();
        general.ds402_channels = g.u8();
        general.sysman_class = g.u8();
        general.flags = g.u8();
        general.ebus_current = static_cast<std::int16_t>(g.u16());
        g.skip(2);
        general.physical_port = g.u16();
        general.physical_memory_address = g.u16();
        image.general = general;
        break;
      }
      case SiiCategoryType::fmmu: {
        if (seen_fmmu) return Unexpected(fail(SiiError::duplicate_category, word, "FMMU"));
        seen_fmmu = true;
        image.fmmus.assign(data.begin(), data.end());
        break;
      }
      case SiiCategoryType::sync_manager: {
        if (seen_sync) return Unexpected(fail(SiiError::duplicate_category, word, "SyncM"));
        seen_sync = true;
        if (data.size() % 8 != 0) {
          return Unexpected(
              fail(SiiError::malformed_sync_manager, word, fmt::format("{} bytes", data.size())));
        }
        Reader s(data);
        while (s.left() > 0) {
          SiiSyncManager sm;
          sm.start = s.u16();
          sm.length = s.u16();
          sm.control = s.u8();
          sm.status = s.u8();
          sm.enable = s.u8();
          sm.type = static_cast<SiiSyncManagerType>(s.u8());
          image.sync_managers.push_back(sm);
        }
        break;
      }
      case SiiCategoryType::tx_pdo:
      case SiiCategoryType::rx_pdo: {
        auto& list = static_cast<SiiCategoryType>(type) == SiiCategoryType::tx_pdo ? image.tx_pdos
                                                                                   : image.rx_pdos;
        if (auto error = parse_pdos(data, word, list)) return Unexpected(std::move(*error));
        break;
      }
      default:
        image.other.push_back({type, {data.begin(), data.end()}});
        break;
    }
  }
  return image;
}

}  // namespace drivecheck::ethercat
