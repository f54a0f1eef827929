#include "protocol/cia301/sdo_codec.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <variant>

#include "protocol/cia301/sdo_abort.hpp"

namespace drivecheck::cia301 {
namespace {

can::Frame frame(std::string_view text) {
  auto parsed = can::parse_candump(text);
  EXPECT_TRUE(parsed) << text << ": " << parsed.error();
  return parsed ? *parsed : can::Frame{};
}

std::array<std::uint8_t, 4> bytes4(std::uint8_t a, std::uint8_t b, std::uint8_t c, std::uint8_t d) {
  return {a, b, c, d};
}

template <class T, class Variant>
const T& as(const Variant& message) {
  static const T empty{};
  const T* value = std::get_if<T>(&message);
  EXPECT_NE(value, nullptr) << "decoded to alternative " << message.index();
  return value != nullptr ? *value : empty;
}

// --- Literal frames of the manuals -----------------------------------------------------------

TEST(SdoCodecFesto, ReadRequestsDecodeAsInitiateUpload) {
  // Given the Festo read commands of Tab. 3.3 (000 L747, L751, L755), padded to 8 bytes
  // When they are decoded as client frames
  // Then each is an initiate upload request of the object the example reads
  // ccs=2, index 6061h sub 0
  EXPECT_EQ(as<InitiateUploadRequest>(decode_client_message(frame("601#4061600000000000"))).mux,
            (Multiplexer{0x6061, 0x00}));
  // ccs=2, index 6041h sub 0
  EXPECT_EQ(as<InitiateUploadRequest>(decode_client_message(frame("601#4041600000000000"))).mux,
            (Multiplexer{0x6041, 0x00}));
  // ccs=2, index 6093h sub 1
  EXPECT_EQ(as<InitiateUploadRequest>(decode_client_message(frame("601#4093600100000000"))).mux,
            (Multiplexer{0x6093, 0x01}));
}

TEST(SdoCodecFesto, ReadResponsesCarryOneTwoOrFourBytes) {
  // Given the Festo read responses 4Fh, 4Bh, 43h (000 L748, L752, L756)
  // When they are decoded as server frames
  // Then they are expedited initiate upload responses with 1, 2 and 4 data bytes
  // scs=2 n=3 e=1 s=1, index 6061h sub 0, data 01h
  const auto u8 = as<InitiateUploadResponse>(decode_server_message(frame("581#4F61600001000000")));
  EXPECT_EQ(u8.mux, (Multiplexer{0x6061, 0x00}));
  EXPECT_TRUE(u8.expedited);
  EXPECT_TRUE(u8.size_indicated);
  EXPECT_EQ(u8.size, 1u);
  EXPECT_EQ(std::vector<std::uint8_t>(u8.expedited_data().begin(), u8.expedited_data().end()),
            (std::vector<std::uint8_t>{0x01}));
  // scs=2 n=2 e=1 s=1, index 6041h sub 0, data 1234h
  const auto u16 = as<InitiateUploadResponse>(decode_server_message(frame("581#4B41600034120000")));
  EXPECT_EQ(u16.size, 2u);
  EXPECT_EQ(std::vector<std::uint8_t>(u16.expedited_data().begin(), u16.expedited_data().end()),
            (std::vector<std::uint8_t>{0x34, 0x12}));
  // scs=2 n=0 e=1 s=1, index 6093h sub 1, data 12345678h
  const auto u32 = as<InitiateUploadResponse>(decode_server_message(frame("581#4393600178563412")));
  EXPECT_EQ(u32.mux, (Multiplexer{0x6093, 0x01}));
  EXPECT_EQ(u32.size, 4u);
  EXPECT_EQ(u32.data, bytes4(0x78, 0x56, 0x34, 0x12));
}

TEST(SdoCodecFesto, WriteRequestsCarryOneTwoOrFourBytes) {
  // Given the Festo write commands 2Fh, 2Bh, 23h (000 L747, L751, L755)
  // When they are decoded as client frames
  // Then they are expedited initiate download requests with the example's object and data
  // ccs=1 n=3 e=1 s=1, index 1401h sub 2, data EFh
  const auto u8 = as<InitiateDownloadRequest>(decode_client_message(frame("601#2F011402EF000000")));
  EXPECT_EQ(u8.mux, (Multiplexer{0x1401, 0x02}));
  EXPECT_TRUE(u8.expedited);
  EXPECT_EQ(u8.size, 1u);
  EXPECT_EQ(u8.data[0], 0xEF);
  // ccs=1 n=2 e=1 s=1, index 6040h sub 0, data 03E8h
  const auto u16 =
      as<InitiateDownloadRequest>(decode_client_message(frame("601#2B406000E8030000")));
  EXPECT_EQ(u16.mux, (Multiplexer{0x6040, 0x00}));
  EXPECT_EQ(u16.size, 2u);
  EXPECT_EQ(u16.data, bytes4(0xE8, 0x03, 0x00, 0x00));
  // ccs=1 n=0 e=1 s=1, index 6093h sub 1, data 12345678h
  const auto u32 =
      as<InitiateDownloadRequest>(decode_client_message(frame("601#2393600178563412")));
  EXPECT_EQ(u32.size, 4u);
  EXPECT_EQ(u32.data, bytes4(0x78, 0x56, 0x34, 0x12));
}

TEST(SdoCodecFesto, WriteAcknowledgeIsInitiateDownloadResponse) {
  // Given the Festo write acknowledge 60h (000 L748)
  // When it is decoded as a server frame
  // Then it is an initiate download response naming 1401h:02
  // scs=3, index 1401h sub 2
  EXPECT_EQ(as<InitiateDownloadResponse>(decode_server_message(frame("581#6001140200000000"))).mux,
            (Multiplexer{0x1401, 0x02}));
}

TEST(SdoCodecFesto, AbortExampleIsWriteReadOnly) {
  // Given the Festo error response to a 32-bit write of statusword 6041h (000 L768-769)
  // When it is decoded as a server frame
  // Then it is an abort of 6041h:00 with code 06010002h, the table's write_read_only
  // cs=4, index 6041h sub 0, abort code 06010002h (LE)
  const auto abort = as<AbortTransfer>(decode_server_message(frame("581#8041600002000106")));
  EXPECT_EQ(abort.mux, (Multiplexer{0x6041, 0x00}));
  EXPECT_EQ(abort.code, static_cast<std::uint32_t>(SdoAbort::write_read_only));
}

TEST(SdoCodecFesto, EncodingGivesTheManualsBytes) {
  // Given the messages of the Festo examples
  // When they are encoded for node 1
  // Then the frames are the manual's bytes, padded with zeros to DLC 8
  EXPECT_EQ(can::to_candump(encode(InitiateUploadRequest{{0x6061, 0}}, 0x601)),
            "601#4061600000000000");
  const std::array<std::uint8_t, 1> ef{0xEF};
  EXPECT_EQ(
      can::to_candump(encode(InitiateDownloadRequest::make_expedited({0x1401, 2}, ef), 0x601)),
      "601#2F011402EF000000");
  const std::array<std::uint8_t, 2> value16{0x34, 0x12};
  EXPECT_EQ(
      can::to_candump(encode(InitiateUploadResponse::make_expedited({0x6041, 0}, value16), 0x581)),
      "581#4B41600034120000");
  EXPECT_EQ(can::to_candump(encode(InitiateDownloadResponse{{0x6093, 1}}, 0x581)),
            "581#6093600100000000");
  EXPECT_EQ(can::to_candump(encode(AbortTransfer{{0x6041, 0}, 0x06010002}, 0x581)),
            "581#8041600002000106");
}

TEST(SdoCodecFesto, FramesAsPrintedWithoutPaddingAreShort) {
  // Given the Festo frames exactly as printed: only the significant bytes (DLC 4 and 5)
  // When they are decoded
  // Then they are invalid: CiA 301 requires DLC 8 in every SDO frame
  // ccs=2, index 6061h sub 0, DLC 4
  const auto request = decode_client_message(frame("601#40616000"));
  EXPECT_EQ(as<SdoInvalid>(request).reason, SdoInvalidReason::short_frame);
  // scs=2 n=3 e=1 s=1, index 6061h sub 0, data 01h, DLC 5
  const auto response = decode_server_message(frame("581#4F61600001"));
  EXPECT_EQ(as<SdoInvalid>(response).reason, SdoInvalidReason::short_frame);
}

TEST(SdoCodecKollmorgen, ThreeByteCommandBytes) {
  // Given the Kollmorgen command bytes for 3-byte objects: 47h response (002 L836) and 27h
  // request (002 L854)
  // When frames with them are decoded
  // Then they carry 3 data bytes (n = 1)
  // scs=2 n=1 e=1 s=1, index 2000h sub 1, data 112233h
  const auto response =
      as<InitiateUploadResponse>(decode_server_message(frame("583#4700200133221100")));
  EXPECT_EQ(response.size, 3u);
  // ccs=1 n=1 e=1 s=1, index 2000h sub 1, data 112233h
  const auto request =
      as<InitiateDownloadRequest>(decode_client_message(frame("603#2700200133221100")));
  EXPECT_EQ(request.size, 3u);
  EXPECT_EQ(request.expedited_data().size(), 3u);
}

TEST(SdoCodecKollmorgen, HomingExampleFrames) {
  // Given the Kollmorgen homing example (002 §6.3.9 L7629-7636)
  // When its frames are decoded
  // Then the mode write is acknowledged and the homing speed write is aborted with 06090031h
  // ccs=1 n=3 e=1 s=1, index 6060h sub 0, data 06h (homing mode)
  const auto mode =
      as<InitiateDownloadRequest>(decode_client_message(frame("603#2F60600006000000")));
  EXPECT_EQ(mode.mux, (Multiplexer{0x6060, 0}));
  EXPECT_EQ(mode.data[0], 0x06);
  // scs=3, index 6060h sub 0
  EXPECT_EQ(as<InitiateDownloadResponse>(decode_server_message(frame("583#6060600000000000"))).mux,
            (Multiplexer{0x6060, 0}));
  // ccs=1 n=0 e=1 s=1, index 6099h sub 1, data 00011940h = 72000
  const auto speed =
      as<InitiateDownloadRequest>(decode_client_message(frame("603#2399600140190100")));
  EXPECT_EQ(speed.mux, (Multiplexer{0x6099, 1}));
  EXPECT_EQ(speed.data, bytes4(0x40, 0x19, 0x01, 0x00));
  // cs=4, index 6099h sub 1, abort code 06090031h
  const auto abort = as<AbortTransfer>(decode_server_message(frame("583#8099600131000906")));
  EXPECT_EQ(abort.code, static_cast<std::uint32_t>(SdoAbort::value_too_high));
}

// --- Every command specifier ------------------------------------------------------------------

// The alternative a client frame with command byte `b` must decode to (command framing).
std::size_t expected_client_alternative(std::uint8_t b) {
  switch (b >> 5) {
    case 0:
      return 2;  // DownloadSegmentRequest
    case 1:
      return 1;  // InitiateDownloadRequest
    case 2:
      return 3;  // InitiateUploadRequest
    case 3:
      return 4;  // UploadSegmentRequest
    case 4:
      return 12;  // AbortTransfer
    case 5:
      switch (b & 3) {
        case 0:
          return 7;  // BlockUploadInitiateRequest
        case 1:
          return 10;  // BlockUploadEndResponse
        case 2:
          return 9;  // BlockUploadAck
        default:
          return 8;  // BlockUploadStart
      }
    case 6:
      return (b & 1) ? 6 : 5;  // BlockDownloadEndRequest : BlockDownloadInitiateRequest
    default:
      return 0;  // SdoInvalid
  }
}

std::size_t expected_server_alternative(std::uint8_t b) {
  switch (b >> 5) {
    case 0:
      return 1;  // UploadSegmentResponse
    case 1:
      return 2;  // DownloadSegmentResponse
    case 2:
      return 3;  // InitiateUploadResponse
    case 3:
      return 4;  // InitiateDownloadResponse
    case 4:
      return 11;  // AbortTransfer
    case 5:
      switch (b & 3) {
        case 0:
          return 5;  // BlockDownloadInitiateResponse
        case 1:
          return 7;  // BlockDownloadEndResponse
        case 2:
          return 6;  // BlockDownloadAck
        default:
          return 0;  // reserved ss=3: SdoInvalid
      }
    case 6:
      return (b & 1) ? 9 : 8;  // BlockUploadEndRequest : BlockUploadInitiateResponse
    default:
      return 0;
  }
}

TEST(SdoCodecCommandSpecifier, EveryClientCommandByteDecodes) {
  // Given 8-byte frames with every command byte 00h..FFh
  // When each is decoded as a client frame
  // Then ccs 0..6 give their message (block sub-commands by cs) and ccs 7 is invalid
  static_assert(std::is_same_v<std::variant_alternative_t<12, SdoClientMessage>, AbortTransfer>);
  for (int b = 0; b < 256; ++b) {
    can::Frame f = make_sdo_frame(0x605, {static_cast<std::uint8_t>(b), 0x41, 0x60, 0, 1, 2, 3, 4});
    const auto message = decode_client_message(f);
    EXPECT_EQ(message.index(), expected_client_alternative(static_cast<std::uint8_t>(b)))
        << "byte 0 = " << b << ": " << to_string(message);
    if (b >> 5 == 7) {
      EXPECT_EQ(std::get<SdoInvalid>(message).reason, SdoInvalidReason::reserved_command_specifier);
    }
  }
}

TEST(SdoCodecCommandSpecifier, EveryServerCommandByteDecodes) {
  // Given 8-byte frames with every command byte 00h..FFh
  // When each is decoded as a server frame
  // Then scs 0..6 give their message, scs 5 ss 3 and scs 7 are invalid with their reason
  static_assert(std::is_same_v<std::variant_alternative_t<11, SdoServerMessage>, AbortTransfer>);
  for (int b = 0; b < 256; ++b) {
    can::Frame f = make_sdo_frame(0x585, {static_cast<std::uint8_t>(b), 0x41, 0x60, 0, 1, 2, 3, 4});
    const auto message = decode_server_message(f);
    EXPECT_EQ(message.index(), expected_server_alternative(static_cast<std::uint8_t>(b)))
        << "byte 0 = " << b << ": " << to_string(message);
    if (b >> 5 == 7) {
      EXPECT_EQ(std::get<SdoInvalid>(message).reason, SdoInvalidReason::reserved_command_specifier);
    } else if ((b >> 5) == 5 && (b & 3) == 3) {
      EXPECT_EQ(std::get<SdoInvalid>(message).reason, SdoInvalidReason::reserved_subcommand);
    }
  }
}

TEST(SdoCodecMalformed, NonDataAndShortFramesAreInvalid) {
  // Given a remote frame, an error frame and data frames with DLC 0..7 on an SDO COB-ID
  // When they are decoded from either side
  // Then each is SdoInvalid with the reason that names the defect
  const can::Frame remote = can::Frame::remote(0x605, 8);
  EXPECT_EQ(as<SdoInvalid>(decode_client_message(remote)).reason, SdoInvalidReason::remote_frame);
  EXPECT_EQ(as<SdoInvalid>(decode_server_message(remote)).reason, SdoInvalidReason::remote_frame);
  can::Frame error;
  error.kind = can::FrameKind::error;
  error.dlc = 8;
  EXPECT_EQ(as<SdoInvalid>(decode_client_message(error)).reason, SdoInvalidReason::error_frame);
  EXPECT_EQ(as<SdoInvalid>(decode_server_message(error, SdoFraming::block_segment)).reason,
            SdoInvalidReason::error_frame);
  for (std::uint8_t dlc = 0; dlc < 8; ++dlc) {
    can::Frame f = make_sdo_frame(0x605, {0x40, 0x41, 0x60, 0, 0, 0, 0, 0});
    f.dlc = dlc;
    for (std::size_t i = dlc; i < 8; ++i)
      f.data[i] = 0;
    EXPECT_EQ(as<SdoInvalid>(decode_client_message(f)).reason, SdoInvalidReason::short_frame);
    EXPECT_EQ(as<SdoInvalid>(decode_server_message(f, SdoFraming::block_segment)).reason,
              SdoInvalidReason::short_frame);
  }
  EXPECT_FALSE(describe(SdoInvalidReason::short_frame).empty());
}

TEST(SdoCodecMalformed, DlcAboveEightCarriesEightBytes) {
  // Given an SDO frame with DLC 9..15 (classic CAN: 8 data bytes)
  // When it is decoded
  // Then it decodes like the same frame with DLC 8
  // ccs=2, index 6041h sub 0, DLC 15
  const auto message = decode_client_message(frame("605#4041600000000000_F"));
  EXPECT_EQ(as<InitiateUploadRequest>(message).mux, (Multiplexer{0x6041, 0}));
}

// --- Field layouts -----------------------------------------------------------------------------

TEST(SdoCodecLayout, ExpeditedWithoutSizeCarriesFourBytes) {
  // Given an expedited initiate download with s=0 (command byte 22h)
  // When it is decoded
  // Then the size is not indicated and all 4 bytes are the data
  // ccs=1 e=1 s=0, index 2000h sub 0, data 01 02 03 04
  const auto m = as<InitiateDownloadRequest>(decode_client_message(frame("605#2200200001020304")));
  EXPECT_TRUE(m.expedited);
  EXPECT_FALSE(m.size_indicated);
  EXPECT_EQ(m.expedited_data().size(), 4u);
  EXPECT_EQ(encode_payload(m)[0], 0x22);
}

TEST(SdoCodecLayout, SegmentedInitiateCarriesSize) {
  // Given a segmented initiate download of 1000 bytes and one of unindicated size
  // When they are encoded and decoded
  // Then byte 0 is 21h / 20h and bytes 4..7 hold the size little-endian / zero
  const auto sized = InitiateDownloadRequest::make_segmented({0x1008, 0}, 1000);
  EXPECT_EQ(can::to_candump(encode(sized, 0x605)), "605#21081000E8030000");
  const auto unsized = InitiateDownloadRequest::make_segmented({0x1008, 0}, std::nullopt);
  EXPECT_EQ(can::to_candump(encode(unsized, 0x605)), "605#2008100000000000");
  // scs=2 e=0 s=1, index 1008h sub 0, size 0000001Ah
  const auto response =
      as<InitiateUploadResponse>(decode_server_message(frame("585#410810001A000000")));
  EXPECT_FALSE(response.expedited);
  EXPECT_TRUE(response.size_indicated);
  EXPECT_EQ(response.size, 26u);
}

TEST(SdoCodecLayout, SegmentBitsToggleLengthAndLast) {
  // Given segments with toggle, n and c set in different ways
  // When they are encoded and decoded
  // Then byte 0 carries t in bit 4, n = 7 - length in bits 3..1 and c in bit 0
  const std::array<std::uint8_t, 3> three{0xAA, 0xBB, 0xCC};
  // ccs=0 t=1 n=4 c=1, data AA BB CC
  EXPECT_EQ(can::to_candump(encode(DownloadSegmentRequest::make(true, true, three), 0x605)),
            "605#19AABBCC00000000");
  const std::array<std::uint8_t, 7> seven{1, 2, 3, 4, 5, 6, 7};
  // scs=0 t=0 n=0 c=0, data 01..07
  EXPECT_EQ(can::to_candump(encode(UploadSegmentResponse::make(false, false, seven), 0x585)),
            "585#0001020304050607");
  // scs=0 t=1 n=7 c=1: a last segment with no data
  const auto empty =
      as<UploadSegmentResponse>(decode_server_message(frame("585#1F00000000000000")));
  EXPECT_TRUE(empty.toggle);
  EXPECT_TRUE(empty.last);
  EXPECT_EQ(empty.length, 0);
  // ccs=3 t=1
  EXPECT_TRUE(
      as<UploadSegmentRequest>(decode_client_message(frame("605#7000000000000000"))).toggle);
  // scs=1 t=1
  EXPECT_TRUE(
      as<DownloadSegmentResponse>(decode_server_message(frame("585#3000000000000000"))).toggle);
}

TEST(SdoCodecLayout, BlockDownloadFrames) {
  // Given the frames of a block download
  // When they are encoded
  // Then each has the command byte and fields of CiA 301 §7.2.4.3.9-11
  // ccs=6 cc=1 s=1 cs=0, index 1F50h sub 1, size 00010000h
  EXPECT_EQ(can::to_candump(
                encode(BlockDownloadInitiateRequest{{0x1F50, 1}, true, true, 0x10000}, 0x605)),
            "605#C6501F0100000100");
  // scs=5 sc=1 ss=0, index 1F50h sub 1, blksize 127
  EXPECT_EQ(can::to_candump(encode(BlockDownloadInitiateResponse{{0x1F50, 1}, true, 127}, 0x585)),
            "585#A4501F017F000000");
  // c=1 seqno=5, data 01..07
  const std::array<std::uint8_t, 7> seven{1, 2, 3, 4, 5, 6, 7};
  EXPECT_EQ(can::to_candump(encode(BlockSegment::make(5, true, seven), 0x605)),
            "605#8501020304050607");
  // scs=5 ss=2, ackseq 127, blksize 64
  EXPECT_EQ(can::to_candump(encode(BlockDownloadAck{127, 64}, 0x585)), "585#A27F400000000000");
  // ccs=6 n=3 cs=1, CRC 31C3h
  EXPECT_EQ(can::to_candump(encode(BlockDownloadEndRequest{3, 0x31C3}, 0x605)),
            "605#CDC3310000000000");
  // scs=5 ss=1
  EXPECT_EQ(can::to_candump(encode(BlockDownloadEndResponse{}, 0x585)), "585#A100000000000000");
}

TEST(SdoCodecLayout, BlockUploadFrames) {
  // Given the frames of a block upload
  // When they are encoded
  // Then each has the command byte and fields of CiA 301 §7.2.4.3.13-15
  // ccs=5 cc=1 cs=0, index 1008h sub 0, blksize 127, pst 10
  EXPECT_EQ(can::to_candump(encode(BlockUploadInitiateRequest{{0x1008, 0}, true, 127, 10}, 0x605)),
            "605#A40810007F0A0000");
  // scs=6 sc=1 s=1 ss=0, index 1008h sub 0, size 26
  EXPECT_EQ(
      can::to_candump(encode(BlockUploadInitiateResponse{{0x1008, 0}, true, true, 26}, 0x585)),
      "585#C60810001A000000");
  // ccs=5 cs=3
  EXPECT_EQ(can::to_candump(encode(BlockUploadStart{}, 0x605)), "605#A300000000000000");
  // ccs=5 cs=2, ackseq 4, blksize 127
  EXPECT_EQ(can::to_candump(encode(BlockUploadAck{4, 127}, 0x605)), "605#A2047F0000000000");
  // scs=6 n=2 ss=1, CRC ABCDh
  EXPECT_EQ(can::to_candump(encode(BlockUploadEndRequest{2, 0xABCD}, 0x585)),
            "585#C9CDAB0000000000");
  // ccs=5 cs=1
  EXPECT_EQ(can::to_candump(encode(BlockUploadEndResponse{}, 0x605)), "605#A100000000000000");
}

TEST(SdoCodecLayout, BlockSegmentFraming) {
  // Given frames inside a sub-block
  // When they are decoded with block-segment framing
  // Then byte 0 is c | seqno, except 80h which is an abort
  // c=0 seqno=1
  const auto first = as<BlockSegment>(
      decode_server_message(frame("585#0111223344556677"), SdoFraming::block_segment));
  EXPECT_EQ(first.seqno, 1);
  EXPECT_FALSE(first.last);
  EXPECT_EQ(first.data[6], 0x77);
  // c=1 seqno=127
  const auto last = as<BlockSegment>(
      decode_client_message(frame("605#FF00000000000000"), SdoFraming::block_segment));
  EXPECT_EQ(last.seqno, 127);
  EXPECT_TRUE(last.last);
  // c=0 seqno=0: not allowed by CiA 301, decoded raw for the state machine to reject
  EXPECT_EQ(as<BlockSegment>(
                decode_client_message(frame("605#0000000000000000"), SdoFraming::block_segment))
                .seqno,
            0);
  // cs=4 abort, index 1008h sub 0, code 05040003h
  const auto abort = as<AbortTransfer>(
      decode_server_message(frame("585#8008100003000405"), SdoFraming::block_segment));
  EXPECT_EQ(abort.code, static_cast<std::uint32_t>(SdoAbort::invalid_sequence_number));
}

// --- Round trips -------------------------------------------------------------------------------

TEST(SdoCodecRoundTrip, EveryClientMessage) {
  // Given one message of each kind a client sends, with non-default fields
  // When each is encoded and decoded again
  // Then the decoded message equals the original
  const std::array<std::uint8_t, 3> three{9, 8, 7};
  const SdoClientMessage messages[] = {
      InitiateDownloadRequest::make_expedited({0x2000, 3}, three),
      InitiateDownloadRequest::make_segmented({0x2000, 3}, 0xDEADBEEF),
      DownloadSegmentRequest::make(true, false, three),
      InitiateUploadRequest{{0xFFFF, 0xFF}},
      UploadSegmentRequest{true},
      BlockDownloadInitiateRequest{{0x1234, 5}, true, true, 77},
      BlockDownloadInitiateRequest{{0x1234, 5}, false, false, 0},
      BlockDownloadEndRequest{6, 0xBEEF},
      BlockUploadInitiateRequest{{0x1234, 5}, true, 100, 200},
      BlockUploadStart{},
      BlockUploadAck{12, 34},
      BlockUploadEndResponse{},
      AbortTransfer{{0x6040, 0}, 0xFF030000},
  };
  for (const auto& message : messages) {
    const auto f = encode(message, 0x605);
    ASSERT_TRUE(f);
    EXPECT_EQ(f->dlc, 8);
    EXPECT_EQ(decode_client_message(*f), message) << to_string(message);
  }
  const SdoClientMessage segment = BlockSegment::make(42, true, three);
  EXPECT_EQ(decode_client_message(*encode(segment, 0x605), SdoFraming::block_segment), segment);
  EXPECT_FALSE(encode(SdoClientMessage{SdoInvalid{}}, 0x605));
}

TEST(SdoCodecRoundTrip, EveryServerMessage) {
  // Given one message of each kind a server sends, with non-default fields
  // When each is encoded and decoded again
  // Then the decoded message equals the original
  const std::array<std::uint8_t, 4> four{1, 2, 3, 4};
  const std::array<std::uint8_t, 5> five{1, 2, 3, 4, 5};
  const SdoServerMessage messages[] = {
      UploadSegmentResponse::make(true, true, five),
      DownloadSegmentResponse{true},
      InitiateUploadResponse::make_expedited({0x1018, 1}, four),
      InitiateUploadResponse::make_segmented({0x1018, 1}, 1234),
      InitiateUploadResponse::make_segmented({0x1018, 1}, std::nullopt),
      InitiateDownloadResponse{{0x1018, 1}},
      BlockDownloadInitiateResponse{{0x1018, 1}, true, 1},
      BlockDownloadAck{127, 127},
      BlockDownloadEndResponse{},
      BlockUploadInitiateResponse{{0x1018, 1}, true, true, 0xFFFFFFFF},
      BlockUploadEndRequest{7, 0x1021},
      AbortTransfer{{0x1018, 1}, 0x05040000},
  };
  for (const auto& message : messages) {
    const auto f = encode(message, 0x585);
    ASSERT_TRUE(f);
    EXPECT_EQ(decode_server_message(*f), message) << to_string(message);
  }
}

TEST(SdoCodecRoundTrip, ExtendedCobId) {
  // Given a 29-bit SDO COB-ID
  // When a message is encoded with the extended format
  // Then the frame is extended with that identifier
  const auto f = encode(InitiateUploadRequest{{0x1000, 0}}, 0x1ABCDE05, can::IdFormat::extended);
  EXPECT_TRUE(f.is_extended());
  EXPECT_EQ(f.id, 0x1ABCDE05u);
}

// --- Text --------------------------------------------------------------------------------------

TEST(SdoCodecText, MessagesPrintTheirFields) {
  // Given decoded messages
  // When they are printed
  // Then the text names the service, the multiplexer and the fields
  EXPECT_EQ(to_string(decode_server_message(frame("581#8041600002000106"))),
            "abort transfer 6041h:00 code 06010002h");
  EXPECT_EQ(to_string(decode_client_message(frame("601#2B406000E8030000"))),
            "initiate download request 6040h:00 expedited size 2 data E8 03");
  EXPECT_EQ(fmt::format("{}", Multiplexer{0x1A00, 0x04}), "1A00h:04");
  EXPECT_EQ(to_string(decode_client_message(frame("601#40616000"))),
            "invalid SDO frame: DLC below 8: CiA 301 requires 8 data bytes in every SDO frame");
}

// --- CRC ---------------------------------------------------------------------------------------

TEST(SdoCrc, CheckValue) {
  // Given the ASCII bytes "123456789"
  // When their CRC-16 CCITT (poly 1021h, init 0) is computed
  // Then it is the catalogue check value 31C3h
  const std::string_view text = "123456789";
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(text.data());
  EXPECT_EQ(crc16_ccitt({bytes, text.size()}), 0x31C3);
  EXPECT_EQ(crc16_ccitt({}), 0x0000);
}

TEST(SdoCrc, ContinuesOverPieces) {
  // Given data split in two pieces
  // When the CRC of the second piece continues from the first
  // Then it equals the CRC of the whole
  const std::string_view text = "123456789";
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(text.data());
  EXPECT_EQ(crc16_ccitt({bytes + 4, 5}, crc16_ccitt({bytes, 4})), 0x31C3);
}

}  // namespace
}  // namespace drivecheck::cia301
