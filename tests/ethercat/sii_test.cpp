#include "protocol/ethercat/sii.hpp"

#include <gtest/gtest.h>

#include <vector>

namespace drivecheck::ethercat {
namespace {

using Bytes = std::vector<std::uint8_t>;

// A drive-like image: CoE mailboxes at 1000h/1080h, SM2 outputs, SM3 inputs, one RxPDO
// (controlword) and one TxPDO (statusword).
SiiImage drive_image() {
  SiiImage image;
  image.header.vendor_id = 0x0000001D;
  image.header.product_code = 0x00012345;
  image.header.revision = 0x00020001;
  image.header.serial = 42;
  image.header.station_alias = 0x0007;
  image.header.standard_receive = {0x1000, 128};
  image.header.standard_send = {0x1080, 128};
  image.header.mailbox_protocols = kSiiMailboxCoe;
  image.header.size = 15;
  image.strings = {"drivecheck", "Reference drive", "Outputs"};
  SiiGeneral general;
  general.name_index = 2;
  general.coe_details = 0x23;
  general.ds402_channels = 1;
  general.ebus_current = -100;
  general.physical_port = 0x0011;
  image.general = general;
  image.fmmus = {1, 2, 3, 0xFF};
  image.sync_managers = {
      {0x1000, 128, 0x26, 0, 1, SiiSyncManagerType::mailbox_out},
      {0x1080, 128, 0x22, 0, 1, SiiSyncManagerType::mailbox_in},
      {0x1100, 2, 0x64, 0, 1, SiiSyncManagerType::outputs},
      {0x1180, 2, 0x20, 0, 1, SiiSyncManagerType::inputs},
  };
  image.rx_pdos = {{0x1600, 2, 0, 3, 0, {{0x6040, 0, 0, 0x06, 16, 0}}}};
  image.tx_pdos = {{0x1A00, 3, 0, 0, 0, {{0x6041, 0, 0, 0x06, 16, 0}}}};
  image.other = {{60, Bytes(24, 0xAB)}};
  return image;
}

TEST(SiiImage, BuildsTheHeaderAtTheDatasheetWordAddresses) {
  // Given the drive image
  // When it is built
  // Then vendor (08h), product (0Ah), alias (04h), mailboxes (18h..1Bh), protocols (1Ch)
  // sit at the word addresses of ESC datasheet Section I Table 38, and word 40h is Strings
  const auto bytes = build_sii(drive_image());
  ASSERT_TRUE(bytes);
  const Bytes& b = *bytes;
  auto word = [&](std::size_t w) { return b[2 * w] | (b[2 * w + 1] << 8); };
  EXPECT_EQ(word(0x04), 0x0007);
  EXPECT_EQ(word(0x08), 0x001D);
  EXPECT_EQ(word(0x0A), 0x2345);
  EXPECT_EQ(word(0x0B), 0x0001);
  EXPECT_EQ(word(0x18), 0x1000);
  EXPECT_EQ(word(0x19), 128);
  EXPECT_EQ(word(0x1A), 0x1080);
  EXPECT_EQ(word(0x1C), 0x0004);
  EXPECT_EQ(word(0x3F), 1);
  EXPECT_EQ(word(0x40), 10);
  EXPECT_EQ(word(0x07), sii_checksum(std::span(b).first(14)));
  EXPECT_EQ(word(b.size() / 2 - 1), 0xFFFF);
}

TEST(SiiImage, ChecksumIsCrc8Poly07InitFF) {
  // Given 14 zero bytes and the same with one byte set
  // When their checksums are computed
  // Then they follow CRC-8 x^8+x^2+x+1 with initial FFh (computed by hand below)
  // CRC-8/07 of 14 zero bytes from FFh: FFh shifted through 112 zero bits.
  std::uint8_t crc = 0xFF;
  for (int i = 0; i < 14 * 8; ++i)
    crc = (crc & 0x80) ? ((crc << 1) ^ 0x07) & 0xFF : (crc << 1) & 0xFF;
  const Bytes zeros(14, 0);
  EXPECT_EQ(sii_checksum(zeros), crc);
  Bytes one = zeros;
  one[13] = 1;
  EXPECT_NE(sii_checksum(one), sii_checksum(zeros));
}

TEST(SiiImage, RoundTripsEveryCategory) {
  // Given the drive image with all six categories and a DC category kept raw
  // When it is built and parsed
  // Then the parsed image equals the original
  const SiiImage image = drive_image();
  const auto bytes = build_sii(image);
  ASSERT_TRUE(bytes);
  const auto parsed = parse_sii(*bytes);
  ASSERT_TRUE(parsed) << parsed.error().message();
  EXPECT_EQ(*parsed, image);
}

TEST(SiiImage, HeaderOnlyImageParses) {
  // Given an image with no category but the end marker
  // When parsed
  // Then it has the header and nothing else
  SiiImage image;
  image.header.vendor_id = 2;
  const auto bytes = build_sii(image);
  ASSERT_TRUE(bytes);
  EXPECT_EQ(bytes->size(), 0x41u * 2);
  const auto parsed = parse_sii(*bytes);
  ASSERT_TRUE(parsed) << parsed.error().message();
  EXPECT_EQ(parsed->header.vendor_id, 2u);
  EXPECT_FALSE(parsed->general);
}

struct Broken {
  const char* what;
  Bytes bytes;
  SiiError error;
};

TEST(SiiImage, MalformedImagesGiveErrors) {
  // Given images broken in each way the parser knows
  // When parsed
  // Then each gives its error code, never a crash
  const Bytes good = *build_sii(drive_image());
  const std::size_t strings = 0x40 * 2;  // first category (Strings)
  std::vector<Broken> cases;
  cases.push_back({"empty", {}, SiiError::too_short});
  cases.push_back({"odd", Bytes(129, 0), SiiError::odd_length});
  {
    Bytes b = good;
    b.at(14) ^= 0x01;  // checksum byte
    cases.push_back({"checksum", b, SiiError::checksum_mismatch});
  }
  {
    Bytes b(good.begin(), good.begin() + 0x40 * 2);
    b[14] = sii_checksum(b);
    cases.push_back({"no categories, no end", b, SiiError::no_end_marker});
  }
  {
    Bytes b = good;
    b.at(strings + 2) = 0xFF;
    b.at(strings + 3) = 0x7F;  // Strings length 7FFFh words
    cases.push_back({"category past end", b, SiiError::category_past_end});
  }
  {
    Bytes b = good;
    b.at(strings + 5) = 200;  // first string length 200 inside a short category
    cases.push_back({"string past category", b, SiiError::malformed_strings});
  }
  {
    Bytes b = good;
    b.resize(b.size() - 2);  // drop the end marker
    cases.push_back({"end marker cut", b, SiiError::no_end_marker});
  }
  {
    SiiImage image = drive_image();
    image.other = {{30, Bytes(4, 0)}};  // a second, short General
    image.general.reset();
    cases.push_back({"short general", *build_sii(image), SiiError::malformed_general});
  }
  {
    SiiImage image = drive_image();
    image.sync_managers.clear();
    image.other = {{41, Bytes(6, 0)}};  // SyncM of 6 bytes
    cases.push_back({"syncm 6 bytes", *build_sii(image), SiiError::malformed_sync_manager});
  }
  {
    SiiImage image = drive_image();
    image.tx_pdos.clear();
    image.other = {{50, Bytes{0x00, 0x1A, 5, 3, 0, 0, 0, 0}}};  // 5 entries, none present
    cases.push_back({"pdo entries", *build_sii(image), SiiError::malformed_pdo});
  }
  {
    SiiImage image = drive_image();
    image.other = {{40, Bytes{1, 2}}};  // FMMU twice
    cases.push_back({"fmmu twice", *build_sii(image), SiiError::duplicate_category});
  }
  for (const Broken& c : cases) {
    const auto parsed = parse_sii(c.bytes);
    ASSERT_FALSE(parsed) << c.what;
    EXPECT_EQ(parsed.error().code, c.error) << c.what << ": " << parsed.error().message();
  }
}

TEST(SiiImage, ChecksumCheckCanBeSwitchedOff) {
  // Given an image with a wrong checksum
  // When parsed with check_checksum off
  // Then it parses
  Bytes b = *build_sii(drive_image());
  b[14] ^= 0xFF;
  EXPECT_TRUE(parse_sii(b, {.check_checksum = false}));
}

TEST(SiiImage, EveryTruncationFailsCleanly) {
  // Given every prefix of a valid image (even lengths)
  // When parsed
  // Then only the whole image parses; the others give errors
  const Bytes good = *build_sii(drive_image());
  for (std::size_t n = 0; n < good.size(); n += 2) {
    EXPECT_FALSE(parse_sii(std::span(good).first(n))) << n;
  }
}

}  // namespace
}  // namespace drivecheck::ethercat
