// Writes the seed corpus and dictionary of the EtherCAT fuzz targets (fuzz/corpus/<name>/,
// fuzz/<name>.dict) from the one-source tables: datagram_commands.inc (one seed frame per
// command, the command tokens) and esc_registers.inc (register offsets as tokens), plus a
// slave configuration sequence and malformed frames. Run by scripts/generate-fuzz-corpus; the
// output is checked in. Kept apart from generate_corpus.cpp so that the CANopen generator
// does not depend on the EtherCAT library.
//
//   drivecheck_fuzz_ethercat_corpus <output dir (fuzz/)>
#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/frame.hpp"

namespace {

namespace fs = std::filesystem;
using namespace drivecheck::ethercat;
using Bytes = std::vector<std::uint8_t>;

Bytes frame_of(std::vector<Datagram> datagrams) {
  Frame frame;
  frame.source = {0x02, 0, 0, 0, 0, 1};
  frame.datagrams = std::move(datagrams);
  return *encode_frame(frame);
}

// The fuzz input format: u16 length, frame, repeated.
Bytes input_of(const std::vector<Bytes>& frames) {
  Bytes input;
  for (const Bytes& f : frames) {
    input.push_back(static_cast<std::uint8_t>(f.size()));
    input.push_back(static_cast<std::uint8_t>(f.size() >> 8));
    input.insert(input.end(), f.begin(), f.end());
  }
  return input;
}

Bytes u16(std::uint16_t v) {
  return {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8)};
}

Bytes concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts)
    out.insert(out.end(), p.begin(), p.end());
  return out;
}

void write_file(const fs::path& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
  if (!out) {
    std::fprintf(stderr, "generate_ethercat_corpus: cannot write %s\n", path.c_str());
    std::exit(1);
  }
}

std::string token(std::string_view name, const Bytes& bytes) {
  std::string text = fmt::format("{}=\"", name);
  for (std::uint8_t b : bytes)
    fmt::format_to(std::back_inserter(text), "\\x{:02X}", b);
  return text + "\"\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s <fuzz dir>\n", argv[0]);
    return 2;
  }
  const fs::path dir = argv[1];
  const std::string target = "ethercat_datagram";
  std::vector<std::pair<std::string, Bytes>> seeds;

  // One frame per command of the table, with an address that reaches something.
  for (const CommandInfo& row : command_table()) {
    Datagram d = row.addressing == Addressing::logical
                     ? Datagram::logical(row.command, 1, 0x00010000, Bytes(4, 0))
                 : row.addressing == Addressing::station
                     ? Datagram::physical(row.command, 1, 0x1001, reg::kAlStatus, Bytes(2, 0))
                     : Datagram::physical(row.command, 1, 0, reg::kAlControl, u16(2));
    seeds.emplace_back(fmt::format("command-{}", row.mnemonic), input_of({frame_of({d})}));
  }
  // A slave's configuration as a master does it, then process data and mailbox traffic.
  const Bytes sms = concat({drivecheck::ethercat::sync_manager_block(0x1000, 128, 0x26),
                            drivecheck::ethercat::sync_manager_block(0x1080, 128, 0x22),
                            drivecheck::ethercat::sync_manager_block(0x1100, 2, 0x64),
                            drivecheck::ethercat::sync_manager_block(0x1180, 2, 0x20)});
  const Bytes fmmus = concat({drivecheck::ethercat::fmmu_block(0x10000, 2, 0x1100, 2),
                              drivecheck::ethercat::fmmu_block(0x10002, 2, 0x1180, 1)});
  Bytes mailbox(128, 0);
  mailbox[0] = 10;  // mailbox header length 10 (a CoE SDO upload request follows)
  mailbox[5] = 0x03;
  seeds.emplace_back(
      "configure-and-exchange",
      input_of(
          {frame_of({Datagram::physical(Command::brd, 0, 0, reg::kType, Bytes(1)),
                     Datagram::physical(Command::apwr, 1, 0, reg::kStationAddress, u16(0x1001))}),
           frame_of({Datagram::physical(Command::fpwr, 2, 0x1001, reg::kSyncManager, sms),
                     Datagram::physical(Command::fpwr, 3, 0x1001, reg::kFmmu, fmmus)}),
           frame_of({Datagram::physical(Command::fpwr, 4, 0x1001, reg::kAlControl, u16(2)),
                     Datagram::physical(Command::fprd, 5, 0x1001, reg::kAlStatus, Bytes(6))}),
           frame_of({Datagram::physical(Command::fpwr, 6, 0x1001, 0x1000, mailbox)}),
           frame_of({Datagram::physical(Command::fprd, 7, 0x1001, 0x1080, Bytes(128))}),
           frame_of({Datagram::logical(Command::lrw, 8, 0x10000, Bytes(4, 0x0F))}),
           frame_of({Datagram::physical(Command::bwr, 9, 0, reg::kDcReceiveTimePort0, Bytes(4)),
                     Datagram::physical(Command::armw, 10, 0, reg::kDcSystemTime, Bytes(8))}),
           frame_of({Datagram::physical(Command::apwr, 11, 0, reg::kSiiAddress, {8, 0, 0, 0}),
                     Datagram::physical(Command::apwr, 12, 0, reg::kSiiControl, u16(0x0100)),
                     Datagram::physical(Command::aprd, 13, 0, reg::kSiiControl, Bytes(14))})}));
  // Malformed frames: each decode error once.
  const Bytes good = frame_of({Datagram::physical(Command::aprd, 1, 0, reg::kAlStatus, Bytes(2))});
  seeds.emplace_back("truncated-header", input_of({Bytes(good.begin(), good.begin() + 13)}));
  Bytes wrong_type = good;
  wrong_type[12] = 0x08;
  wrong_type[13] = 0x00;
  seeds.emplace_back("ipv4-ethertype", input_of({wrong_type}));
  Bytes past_end = good;
  past_end[14] = 0xFF;
  past_end[15] = 0x17;
  seeds.emplace_back("length-past-end", input_of({past_end}));
  Bytes more = good;
  more[16 + 7] |= 0x80;
  seeds.emplace_back("more-follows-on-last", input_of({more}));
  Bytes vlan = good;
  const Bytes tag = {0x81, 0x00, 0x00, 0x05};
  vlan.insert(vlan.begin() + 12, tag.begin(), tag.end());
  seeds.emplace_back("vlan-tagged", input_of({vlan}));
  Bytes unknown = good;
  unknown[16] = 0x1F;
  seeds.emplace_back("unknown-command", input_of({unknown}));

  const fs::path corpus = dir / "corpus" / target;
  fs::remove_all(corpus);
  fs::create_directories(corpus);
  for (const auto& [name, bytes] : seeds)
    write_file(corpus / name, bytes);
  std::printf("corpus/%s: %zu seeds\n", target.c_str(), seeds.size());

  std::string dict =
      "# Generated by fuzz/generate_ethercat_corpus.cpp (scripts/generate-fuzz-corpus): do not "
      "edit.\n# libFuzzer dictionary: name=\"token\" lines; the comment above each token names "
      "its source.\n";
  dict += "# EtherType 88A4h (ETG.1000.4; ESC Section I §2.1)\n" + token("ethertype", {0x88, 0xA4});
  dict += "# VLAN tag 8100h\n" + token("vlan", {0x81, 0x00});
  dict += "# EtherCAT header: type 1 (datagrams), length 12 and 14\n" +
          token("header_len12", {0x0C, 0x10}) + token("header_len14", {0x0E, 0x10});
  dict += "# datagram Len field with M (more follows) and C (circulating) bits\n" +
          token("len_more", {0x02, 0x80}) + token("len_circulating", {0x02, 0x40});
  for (const CommandInfo& row : command_table()) {
    dict += fmt::format("# command {} = {:02X}h ({})\n", row.mnemonic,
                        static_cast<unsigned>(row.command), row.source);
    dict += token(fmt::format("cmd_{}", row.mnemonic), {static_cast<std::uint8_t>(row.command)});
  }
  for (const EscRegisterInfo& row : esc_register_table()) {
    dict += fmt::format("# register {:04X}h {} (ESC Section II)\n", row.address, row.text);
    dict += token(fmt::format("reg_{}", row.name), u16(row.address));
  }
  write_file(dir / (target + ".dict"), Bytes(dict.begin(), dict.end()));
  std::printf("%s.dict\n", target.c_str());
  return 0;
}
