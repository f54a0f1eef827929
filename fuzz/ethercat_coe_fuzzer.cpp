// Fuzz target: the EtherCAT mailbox and CoE layer (protocol/ethercat/mailbox.hpp, coe*.hpp),
// both sides: hostile masters into the slave's CoE front (CoeSlave over a small dictionary with
// the CoE objects and their rules), hostile slaves into the master's parsers (MailboxMaster,
// CoeSdoClient, SdoInfoAssembler).
//
// Input (fuzz/support/ethercat_coe_input.hpp): records until the end, each: op (1 octet),
// length (1 octet), that many octets.
//   op bits 1..0  0 the octets are an SM0 write into the slave (then SM1 is drained)
//                 1 the octets are an SM1 read by the master (MailboxMaster::accept, then the
//                   CoE data into the SDO client and the SDO information reassembler)
//                 2 the octets are a CoE message straight into the SDO client
//                 3 control: bit 2 repeat request of the slave, bit 3 client timeout, bit 4
//                   slave reset (INIT), bit 5 toggles PREOP
//   op bit 6      start a client transfer first: bit 7 download (of the octets) else upload,
//                 of 2000h:00 (domain), complete access when the length is odd
// Oracles:
//   - nothing crashes, and every SM1 content the slave gives is a mailbox of exactly the SM1
//     length whose data fits it (ETG.1000.4: the master reads the whole SM);
//   - an ERR reply carries one of the nine codes of mailbox_error_codes.inc;
//   - a CoE reply of the SDO response service decodes, and an abort carries a code of
//     sdo_abort_codes.inc (the one table);
//   - a request answered with an SDO abort or a mailbox error changes no entry of the
//     dictionary (complete access writes are all or nothing);
//   - outside PREOP no entry of 1C12h/1C13h/1600h/1A00h changes (ETG.6010 / Festo 000 L1849);
//   - the client ends every transfer it aborts (busy() false), and a step that is done and
//     without error leaves no request to send but an abort.
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz/support/ethercat_coe_input.hpp"
#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/coe_objects.hpp"
#include "protocol/ethercat/coe_sdo_client.hpp"
#include "protocol/ethercat/coe_sdo_info.hpp"
#include "protocol/ethercat/coe_sdo_server.hpp"
#include "protocol/ethercat/mailbox.hpp"

namespace {

using namespace drivecheck;
using namespace drivecheck::ethercat;
using Bytes = std::vector<std::uint8_t>;

constexpr std::size_t kMailboxSize = fuzz::kEthercatCoeMailboxSize;

cia301::ObjectDictionary make_dictionary() {
  using cia301::AccessType;
  using cia301::DataType;
  using cia301::EntryDefinition;
  using cia301::ObjectCode;
  cia301::ObjectDictionary od;
  auto add = [&](cia301::ObjectDefinition def) {
    if (!od.add_object(std::move(def))) __builtin_trap();
  };
  add({0x1018,
       "Identity",
       ObjectCode::record,
       {EntryDefinition::highest_sub_index(2),
        EntryDefinition::unsigned_entry(1, "Vendor", DataType::unsigned32, AccessType::ro, 0x1D),
        EntryDefinition::unsigned_entry(2, "Product", DataType::unsigned32, AccessType::ro, 1)}});
  for (std::uint16_t index : {0x1600, 0x1A00}) {
    add({index,
         "mapping",
         ObjectCode::record,
         {EntryDefinition::unsigned_entry(0, "count", DataType::unsigned8, AccessType::rw, 1),
          EntryDefinition::unsigned_entry(1, "entry", DataType::unsigned32, AccessType::rw,
                                          0x60400010)}});
  }
  {
    EntryDefinition domain = EntryDefinition::make(0, "Blob", DataType::domain, AccessType::rw,
                                                   cia301::Value::of_bytes({}), false);
    domain.max_size = 300;
    add({0x2000, "Blob", ObjectCode::domain, {domain}});
  }
  add({0x2001,
       "Bits",
       ObjectCode::record,
       {EntryDefinition::highest_sub_index(2),
        EntryDefinition::make(1, "A", DataType::boolean, AccessType::rw,
                              cia301::Value::of_unsigned(0), false),
        EntryDefinition::unsigned_entry(2, "Word", DataType::unsigned16, AccessType::rw, 0)}});
  if (!od.add_var(0x6040, "Controlword", DataType::unsigned16, AccessType::rww,
                  cia301::Value::of_unsigned(0), true)) {
    __builtin_trap();
  }
  for (auto& def : coe_object_definitions({}))
    add(std::move(def));
  return od;
}

using Snapshot = std::vector<Bytes>;
DRIVECHECK_FUZZ_ORACLE_CODE Snapshot snapshot(const cia301::ObjectDictionary& od, bool pdo_only) {
  Snapshot out;
  for (const auto& object : od.objects()) {
    const auto i = object.index();
    if (pdo_only && !(i == 0x1C12 || i == 0x1C13 || i == 0x1600 || i == 0x1A00)) continue;
    for (const auto& entry : object.entries())
      out.emplace_back(entry.bytes().begin(), entry.bytes().end());
  }
  return out;
}

// Checks one SM1 content; returns true when it refused the request (abort or ERR).
bool check_reply(const Bytes& reply) {
  DRIVECHECK_FUZZ_CHECK_EQ(reply.size(), kMailboxSize, "SM1 content is not the SM1 length");
  const auto m = parse_mailbox(reply);
  DRIVECHECK_FUZZ_CHECK(m.has_value(), "the slave's SM1 content is no mailbox");
  if (m->header.type == static_cast<std::uint8_t>(MailboxType::err)) {
    const auto code = parse_mailbox_error_data(m->data);
    DRIVECHECK_FUZZ_CHECK(code.has_value(), "ERR reply without its 4 octets");
    DRIVECHECK_FUZZ_CHECK(find_mailbox_error(*code).has_value(), "ERR reply with an unknown code");
    return true;
  }
  DRIVECHECK_FUZZ_CHECK_EQ(m->header.type, std::uint8_t{3}, "the slave replied other than CoE");
  const auto service = peek_coe_service(m->data);
  DRIVECHECK_FUZZ_CHECK(service.has_value(), "CoE reply without a CoE header");
  if (*service == static_cast<std::uint8_t>(CoeService::sdo_response)) {
    const auto r = decode_sdo_response(m->data);
    DRIVECHECK_FUZZ_CHECK(r.has_value(), "the slave's SDO response does not decode");
    if (const auto* a = std::get_if<CoeAbort>(&*r)) {
      DRIVECHECK_FUZZ_CHECK(cia301::find_sdo_abort(a->code).has_value(),
                            "abort code outside sdo_abort_codes.inc");
      return true;
    }
    return false;
  }
  if (*service == static_cast<std::uint8_t>(CoeService::sdo_information)) return false;
  DRIVECHECK_FUZZ_CHECK(false, "the slave sent a CoE service other than SDO response/information");
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const cia301::ObjectDictionary pristine = make_dictionary();
  cia301::ObjectDictionary od = pristine;
  bool preop = true;
  if (!install_coe_object_rules(od, [&] { return preop; })) __builtin_trap();
  CoeSlave slave(od, {.write_size = kMailboxSize, .read_size = kMailboxSize},
                 {.read_size = kMailboxSize, .max_download = 300});
  MailboxMaster master({.write_size = kMailboxSize});
  CoeSdoClient client({.write_size = kMailboxSize});
  SdoInfoAssembler assembler;

  fuzz::FuzzInput in(data, size);
  while (!in.empty()) {
    const std::uint8_t op = in.u8();
    const std::size_t length = in.u8();
    const auto span = in.bytes(length);
    const Bytes octets(span.begin(), span.end());
    if (op & fuzz::kEthercatCoeStartTransfer) {
      if (op & fuzz::kEthercatCoeDownload) {
        (void)client.start_download({0x2000, 0}, octets, (length & 1) != 0);
      } else {
        (void)client.start_upload({0x2000, 0}, (length & 1) != 0);
      }
    }
    switch (static_cast<fuzz::EthercatCoeOp>(op & 3)) {
      case fuzz::EthercatCoeOp::sm0_write: {
        const Snapshot before = snapshot(od, false);
        const Snapshot pdo_before = snapshot(od, true);
        slave.on_write_mailbox(octets);
        bool refused = false;
        bool replied = false;
        while (auto reply = slave.take_reply()) {
          replied = true;
          refused = check_reply(*reply) || refused;
        }
        if (replied && refused) {
          DRIVECHECK_FUZZ_CHECK(snapshot(od, false) == before,
                                "a refused request changed the dictionary");
        }
        if (!preop) {
          DRIVECHECK_FUZZ_CHECK(snapshot(od, true) == pdo_before,
                                "PDO configuration changed outside PREOP");
        }
        break;
      }
      case fuzz::EthercatCoeOp::sm1_read: {
        const auto reply = master.accept(octets);
        if (!reply) break;
        if (reply->error) break;
        const auto step = client.on_response(reply->message.data);
        if (step.error && step.error->kind != CoeClientError::Kind::server_abort) {
          DRIVECHECK_FUZZ_CHECK(step.request.has_value(), "a client error without its abort");
        }
        if (step.done) DRIVECHECK_FUZZ_CHECK(!client.busy(), "a done transfer is still busy");
        (void)assembler.add(reply->message.data);
        break;
      }
      case fuzz::EthercatCoeOp::client_coe: {
        const auto step = client.on_response(octets);
        if (step.done) DRIVECHECK_FUZZ_CHECK(!client.busy(), "a done transfer is still busy");
        if (step.done && !step.error) {
          DRIVECHECK_FUZZ_CHECK(!step.request.has_value(), "a finished transfer sends more");
        }
        break;
      }
      case fuzz::EthercatCoeOp::control:
        if (op & fuzz::kEthercatCoeRepeat) {
          if (auto again = slave.repeat_last()) (void)check_reply(*again);
        }
        if (op & fuzz::kEthercatCoeTimeout) {
          (void)client.timeout();
          DRIVECHECK_FUZZ_CHECK(!client.busy(), "a timed out transfer is still busy");
        }
        if (op & fuzz::kEthercatCoeReset) slave.reset();
        if (op & fuzz::kEthercatCoeTogglePreop) preop = !preop;
        break;
    }
  }
  return 0;
}
