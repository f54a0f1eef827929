// The reference drive as an emulated EtherCAT slave (reference_drive/ethercat): a master made of
// raw datagrams, MailboxMaster and CoeSdoClient on the simulated segment brings it up by hand
// (SM0/SM1, PREOP, SM2/SM3 + FMMUs, SAFEOP, OP), reads and writes its dictionary over CoE,
// drives the CiA 402 state machine through the process data, lets the SM watchdog expire, and
// shows each EtherCAT named deviation against the standard drive.
#include "reference_drive/ethercat/ethercat_drive.hpp"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iterator>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "protocol/cia301/pdo_service.hpp"
#include "protocol/cia301/sdo_abort.hpp"
#include "protocol/cia402/state_machine.hpp"
#include "protocol/ethercat/coe.hpp"
#include "protocol/ethercat/coe_sdo_client.hpp"
#include "protocol/ethercat/coe_sdo_info.hpp"
#include "protocol/ethercat/esc.hpp"
#include "protocol/ethercat/esi.hpp"
#include "protocol/ethercat/frame.hpp"
#include "protocol/ethercat/mailbox.hpp"
#include "protocol/ethercat/master.hpp"
#include "protocol/ethercat/sii.hpp"
#include "protocol/ethercat/sim_segment.hpp"
#include "protocol/profile/drive_profile.hpp"
#include "reference_drive/ethercat/esi_image.hpp"
#include "reference_drive/ethercat/sii_image.hpp"

namespace drivecheck::reference_drive::ethercat {
namespace {

namespace ecat = drivecheck::ethercat;
using namespace std::chrono_literals;
using Bytes = std::vector<std::uint8_t>;

constexpr std::uint32_t kLogical = 0x00010000;

Bytes u16(std::uint16_t v) {
  return {static_cast<std::uint8_t>(v), static_cast<std::uint8_t>(v >> 8)};
}
std::uint16_t le16(const Bytes& b, std::size_t at = 0) {
  return static_cast<std::uint16_t>(b.at(at) | (b.at(at + 1) << 8));
}

struct SdoResult {
  Bytes value;
  std::optional<std::uint32_t> abort;
};

// One drive on a segment and a hand-made master (the first slave: position address 0).
class Master {
 public:
  explicit Master(EthercatDriveOptions options = {}) {
    auto created = EthercatDrive::create(segment_, std::move(options));
    EXPECT_TRUE(created) << (created ? "" : created.error());
    drive_ = std::move(*created);
    segment_.attach(*drive_);
    drive_->power_on();
  }

  ecat::Datagram exchange(ecat::Datagram datagram) {
    ecat::Frame frame;
    frame.datagrams = {std::move(datagram)};
    EXPECT_FALSE(segment_.send(*ecat::encode_frame(frame)));
    const auto back = segment_.receive(segment_.now() + 1ms);
    EXPECT_TRUE(back);
    if (!back) return {};
    return ecat::decode_frame(back->bytes)->datagrams.at(0);
  }
  std::uint16_t write(std::uint16_t address, Bytes data) {
    return exchange(ecat::Datagram::physical(ecat::Command::apwr, 0, 0, address, std::move(data)))
        .working_counter;
  }
  Bytes read(std::uint16_t address, std::size_t n) {
    return exchange(ecat::Datagram::physical(ecat::Command::aprd, 0, 0, address, Bytes(n))).data;
  }
  // AL status (0130h) and AL status code (0134h).
  std::pair<std::uint16_t, std::uint16_t> al_status() {
    const Bytes d = read(ecat::reg::kAlStatus, 6);
    return {le16(d, 0), le16(d, 4)};
  }
  std::pair<std::uint16_t, std::uint16_t> request(std::uint16_t control) {
    write(ecat::reg::kAlControl, u16(control));
    return al_status();
  }

  // INIT -> PREOP with the SII's mailboxes.
  void to_preop() {
    Bytes sms = ecat::sync_manager_block(kMailboxOutStart, kMailboxSize, kSm0Control);
    const Bytes sm1 = ecat::sync_manager_block(kMailboxInStart, kMailboxSize, kSm1Control);
    sms.insert(sms.end(), sm1.begin(), sm1.end());
    ASSERT_EQ(write(ecat::reg::kSyncManager, sms), 1);
    ASSERT_EQ(request(0x0002), std::make_pair(std::uint16_t{0x0002}, std::uint16_t{0}));
  }
  // SM2/SM3 and FMMU 0/1 for `out`/`in` octets at logical kLogical, then SAFEOP.
  // `control` 0014h acknowledges a pending error. SM2/SM3 are disabled first (their
  // configuration is fixed while enabled).
  std::pair<std::uint16_t, std::uint16_t> to_safeop(std::uint16_t out, std::uint16_t in,
                                                    std::uint16_t control = 0x0004) {
    out_ = out;
    in_ = in;
    write(ecat::reg::sync_manager(2) + 6, {0});
    write(ecat::reg::sync_manager(3) + 6, {0});
    Bytes sms = ecat::sync_manager_block(kOutputsStart, out, kSm2Control);
    const Bytes sm3 = ecat::sync_manager_block(kInputsStart, in, kSm3Control);
    sms.insert(sms.end(), sm3.begin(), sm3.end());
    write(ecat::reg::sync_manager(2), sms);
    Bytes fmmus = ecat::fmmu_block(kLogical, out, kOutputsStart, 2);
    const Bytes f1 = ecat::fmmu_block(kLogical + out, in, kInputsStart, 1);
    fmmus.insert(fmmus.end(), f1.begin(), f1.end());
    write(ecat::reg::fmmu(0), fmmus);
    return request(control);
  }
  // One process data cycle: LRW with the outputs; returns the inputs and the working counter.
  std::pair<Bytes, std::uint16_t> cycle(const Bytes& outputs) {
    Bytes data = outputs;
    data.resize(out_ + in_);
    const auto back =
        exchange(ecat::Datagram::logical(ecat::Command::lrw, 0, kLogical, std::move(data)));
    return {Bytes(back.data.begin() + out_, back.data.end()), back.working_counter};
  }
  // The default process data: controlword + 607Ah out, statusword + 6064h in.
  Bytes outputs(std::uint16_t controlword) {
    Bytes out = u16(controlword);
    out.resize(6);
    return out;
  }
  void to_op() {
    to_preop();
    ASSERT_EQ(to_safeop(6, 6), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
    cycle(outputs(0));
    ASSERT_EQ(request(0x0008), std::make_pair(std::uint16_t{0x0008}, std::uint16_t{0}));
  }
  // Runs cycles of 1 ms with `controlword` until the statusword (masked) shows `want`.
  std::uint16_t run_until_status(std::uint16_t controlword, std::uint16_t mask, std::uint16_t want,
                                 int cycles = 100) {
    std::uint16_t status = 0;
    for (int i = 0; i < cycles; ++i) {
      segment_.run_for(1ms);
      status = le16(cycle(outputs(controlword)).first);
      if ((status & mask) == want) break;
    }
    return status;
  }

  // One CoE SDO transfer through SM0/SM1, polling SM1's mailbox-full bit.
  SdoResult sdo(const Bytes& first_request) {
    SdoResult result;
    Bytes request = first_request;
    for (int round = 0; round < 64; ++round) {
      write(kMailboxOutStart,
            mailbox_.request(ecat::MailboxType::coe, request, segment_.now().time_since_epoch()));
      std::optional<Bytes> reply;
      for (int poll = 0; poll < 20 && !reply; ++poll) {
        const Bytes status = read(ecat::reg::sync_manager(1) + 5, 1);
        if ((status.at(0) & ecat::sm::kStatusMailboxFull) != 0) {
          reply = read(kMailboxInStart, kMailboxSize);
        } else {
          segment_.run_for(100us);
        }
      }
      if (!reply) {
        ADD_FAILURE() << "no reply in SM1";
        return result;
      }
      auto accepted = mailbox_.accept(*reply);
      if (!accepted) {
        ADD_FAILURE() << "SM1 holds no mailbox";
        return result;
      }
      const auto step = client_.on_response(accepted->message.data);
      if (step.ignored) {
        replies_ignored_++;
        continue;
      }
      mailbox_.reply_matched();
      if (step.done) {
        if (step.error) result.abort = step.error->code;
        result.value = client_.value();
        return result;
      }
      if (!step.request) return result;
      request = *step.request;
    }
    return result;
  }
  SdoResult upload(std::uint16_t index, std::uint8_t sub) {
    return sdo(client_.start_upload({index, sub}));
  }
  SdoResult download(std::uint16_t index, std::uint8_t sub, const Bytes& value) {
    return sdo(client_.start_download({index, sub}, value));
  }

  std::uint64_t dictionary_value(std::uint16_t index, std::uint8_t sub) {
    return drive_->dictionary().find(index, sub)->as_unsigned();
  }
  ecat::SimSegment& segment() { return segment_; }
  EthercatDrive& drive() { return *drive_; }
  ecat::MailboxMaster& mailbox() { return mailbox_; }
  ecat::CoeSdoClient& client() { return client_; }

 private:
  ecat::SimSegment segment_;
  std::unique_ptr<EthercatDrive> drive_;
  ecat::MailboxMaster mailbox_{{.write_size = kMailboxSize, .address = 0, .reply_timeout = 100ms}};
  ecat::CoeSdoClient client_{{.write_size = kMailboxSize, .expedited = true}};
  std::uint16_t out_ = 0;
  std::uint16_t in_ = 0;
  int replies_ignored_ = 0;
};

// Disables every SyncManager (activate 0), so that they can be configured again.
void write_zeros_to_sync_managers(Master& master) {
  for (unsigned n = 0; n < 8; ++n)
    master.write(ecat::reg::sync_manager(n) + 6, {0});
}

EthercatDriveOptions deviant(Deviation deviation) {
  EthercatDriveOptions options;
  options.deviations.add(deviation);
  return options;
}

std::uint32_t le32(const Bytes& b) {
  return static_cast<std::uint32_t>(b.at(0) | (b.at(1) << 8) | (b.at(2) << 16) |
                                    (static_cast<std::uint32_t>(b.at(3)) << 24));
}

// ---------------------------------------------------------------------------------------------

TEST(EthercatDriveSii, IdentityMailboxesAndDefaultPdosComeFromTheDictionary) {
  // Given the standard drive behind the ESC
  // When its SII image is parsed
  // Then identity = 1018h, mailboxes 1000h/1080h (128), CoE, SM2 6 / SM3 6 octets, and the PDO
  //      categories list 1600h (6040h, 607Ah) and 1A00h (6041h, 6064h)
  Master master;
  auto image = ecat::parse_sii(master.drive().sii());
  ASSERT_TRUE(image) << image.error().message();
  const auto& od = master.drive().dictionary();
  EXPECT_EQ(image->header.vendor_id, od.find(0x1018, 1)->as_unsigned());
  EXPECT_EQ(image->header.product_code, od.find(0x1018, 2)->as_unsigned());
  EXPECT_EQ(image->header.serial, 1u);
  EXPECT_EQ(image->header.standard_receive, (ecat::SiiMailbox{0x1000, 128}));
  EXPECT_EQ(image->header.standard_send, (ecat::SiiMailbox{0x1080, 128}));
  EXPECT_EQ(image->header.mailbox_protocols, ecat::kSiiMailboxCoe);
  ASSERT_EQ(image->sync_managers.size(), 4u);
  EXPECT_EQ(image->sync_managers[2].length, 6u);
  EXPECT_EQ(image->sync_managers[3].length, 6u);
  ASSERT_EQ(image->rx_pdos.size(), 1u);
  EXPECT_EQ(image->rx_pdos[0].index, 0x1600);
  ASSERT_EQ(image->rx_pdos[0].entries.size(), 2u);
  EXPECT_EQ(image->rx_pdos[0].entries[0].index, 0x6040);
  EXPECT_EQ(image->rx_pdos[0].entries[0].data_type, 0x06);  // UNSIGNED16
  ASSERT_EQ(image->tx_pdos.size(), 1u);
  EXPECT_EQ(image->tx_pdos[0].entries[1].index, 0x6064);
  EXPECT_EQ(image->tx_pdos[0].entries[1].bit_length, 32);
}

TEST(EthercatDriveEsm, BringUpToOpByHand) {
  // Given the drive powered on
  // When the master configures the mailboxes, PREOP, SM2/SM3 + FMMUs, SAFEOP, one cycle, OP
  // Then each state is reached without error code, and the LRW counts 3 (read + write)
  Master master;
  EXPECT_EQ(master.al_status(), std::make_pair(std::uint16_t{0x0001}, std::uint16_t{0}));
  master.to_op();
  EXPECT_EQ(master.cycle(master.outputs(0)).second, 3);
  EXPECT_EQ(master.drive().servo().device().state(), cia301::NmtState::operational);
}

TEST(EthercatDriveEsm, SafeopWithWrongSmLengthIsRefusedWith001Dh) {
  // Given the drive in PREOP with 1C12h = {1600h} (6 octets)
  // When SM2 is configured 4 octets long and SAFEOP requested
  // Then PREOP + error, AL status code 001Dh (invalid output configuration)
  Master master;
  master.to_preop();
  EXPECT_EQ(master.to_safeop(4, 6), std::make_pair(std::uint16_t{0x0012}, std::uint16_t{0x001D}));
}

TEST(EthercatDriveCoe, SdoReadsDeviceTypeAndIdentity) {
  // Given the drive in PREOP
  // When 1000h and 1018h:01..04 are uploaded over CoE
  // Then 1000h = 00020192h (CiA 402 servo) and the identity equals the SII's
  Master master;
  master.to_preop();
  const auto device_type = master.upload(0x1000, 0);
  ASSERT_FALSE(device_type.abort);
  EXPECT_EQ(le32(device_type.value), 0x00020192u);
  auto image = ecat::parse_sii(master.drive().sii());
  ASSERT_TRUE(image);
  EXPECT_EQ(le32(master.upload(0x1018, 1).value), image->header.vendor_id);
  EXPECT_EQ(le32(master.upload(0x1018, 2).value), image->header.product_code);
  EXPECT_EQ(le32(master.upload(0x1018, 4).value), image->header.serial);
  const auto name = master.upload(0x1008, 0);  // normal (segmented if long) upload
  EXPECT_FALSE(name.abort);
  EXPECT_GT(name.value.size(), 4u);
}

TEST(EthercatDriveCoe, WritesAreRefusedWithTheDictionarysAbortCodes) {
  // Given the drive in PREOP
  // When 1000h (ro) is written, and 6041h (ro), and a missing object is read
  // Then 06010002h, 06010002h and 06020000h
  Master master;
  master.to_preop();
  EXPECT_EQ(master.download(0x1000, 0, {0, 0, 0, 0}).abort, 0x06010002u);
  EXPECT_EQ(master.download(0x6041, 0, {0, 0}).abort, 0x06010002u);
  EXPECT_EQ(master.upload(0x5FFE, 0).abort, 0x06020000u);
}

TEST(EthercatDriveCoe, PdoAssignmentOnlyInPreop) {
  // Given the drive in PREOP, then in SAFEOP
  // When 1C12h:00 is written 0 (the first step of an assignment change)
  // Then it is accepted in PREOP and refused with 08000022h in SAFEOP
  Master master;
  master.to_preop();
  EXPECT_FALSE(master.download(0x1C12, 0, {0}).abort);
  EXPECT_FALSE(master.download(0x1C12, 0, {1}).abort);  // back to {1600h}
  ASSERT_EQ(master.to_safeop(6, 6), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  EXPECT_EQ(master.download(0x1C12, 0, {0}).abort, 0x08000022u);
  EXPECT_EQ(master.download(0x1600, 0, {0}).abort, 0x08000022u);
}

TEST(EthercatDriveCoe, ReassignedPdosChangeTheProcessData) {
  // Given the drive in PREOP
  // When 1C13h is set to {1A00h, 1A01h} (statusword, 6064h, 606Ch: 10 octets) and SAFEOP
  //      requested with SM3 6 octets, then 10
  // Then 001Eh first (invalid input configuration), then SAFEOP
  Master master;
  master.to_preop();
  ASSERT_FALSE(master.download(0x1C13, 0, {0}).abort);
  ASSERT_FALSE(master.download(0x1C13, 2, u16(0x1A01)).abort);
  ASSERT_FALSE(master.download(0x1C13, 0, {2}).abort);
  EXPECT_EQ(master.to_safeop(6, 6), std::make_pair(std::uint16_t{0x0012}, std::uint16_t{0x001E}));
  EXPECT_EQ(master.to_safeop(6, 10, 0x0014),
            std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  EXPECT_EQ(master.drive().inputs().bytes(), 10u);
}

TEST(EthercatDriveProcessData, ControlwordInStatuswordOutEnablesTheDrive) {
  // Given the drive in OP with the default PDOs
  // When the master sends 0006h, 0007h, 000Fh in the controlword, cycle after cycle
  // Then the statusword follows: READY TO SWITCH ON, SWITCHED ON, OPERATION ENABLED
  Master master;
  master.to_op();
  EXPECT_EQ(master.run_until_status(0x0000, 0x006F, 0x0040) & 0x006F, 0x0040);
  EXPECT_EQ(master.run_until_status(0x0006, 0x006F, 0x0021) & 0x006F, 0x0021);
  EXPECT_EQ(master.run_until_status(0x0007, 0x006F, 0x0023) & 0x006F, 0x0023);
  EXPECT_EQ(master.run_until_status(0x000F, 0x006F, 0x0027) & 0x006F, 0x0027);
  EXPECT_EQ(master.drive().servo().application().pds().state(), cia402::State::operation_enabled);
}

TEST(EthercatDriveProcessData, SafeopIgnoresOutputs) {
  // Given the drive in SAFEOP (inputs valid, outputs not taken: Festo 000 L2058)
  // When the master sends 0006h (shutdown) for 20 cycles
  // Then the statusword arrives and stays SWITCH ON DISABLED
  Master master;
  master.to_preop();
  ASSERT_EQ(master.to_safeop(6, 6), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  EXPECT_EQ(master.run_until_status(0x0006, 0x006F, 0x0021, 20) & 0x004F, 0x0040);
}

TEST(EthercatDriveWatchdog, ExpiryDropsToSafeopAndStopsTheDrive) {
  // Given the drive OPERATION ENABLED in OP (6007h = 1: fault on connection loss)
  // When the master stops sending process data for 150 ms (watchdog 100 ms)
  // Then SAFEOP + error with 001Bh, and the drive is in FAULT (6007h reaction)
  Master master;
  master.to_op();
  ASSERT_EQ(master.run_until_status(0x0006, 0x006F, 0x0021) & 0x006F, 0x0021);
  ASSERT_EQ(master.run_until_status(0x000F, 0x006F, 0x0027) & 0x006F, 0x0027);
  master.segment().run_for(150ms);
  // (before any frame: the watchdog fires on its own, not when the next frame arrives)
  const auto state = master.drive().servo().application().pds().state();
  EXPECT_TRUE(state == cia402::State::fault || state == cia402::State::fault_reaction_active)
      << static_cast<int>(state);
  EXPECT_EQ(master.drive().slave().al_status().state, ecat::AlState::safeop);
  EXPECT_EQ(master.al_status(), std::make_pair(std::uint16_t{0x0014}, std::uint16_t{0x001B}));
}

TEST(EthercatDriveWatchdog, LeavingOpStopsTheDrive) {
  // Given the drive OPERATION ENABLED in OP
  // When the master requests SAFEOP (OS)
  // Then the drive leaves OPERATION ENABLED (6007h reaction)
  Master master;
  master.to_op();
  ASSERT_EQ(master.run_until_status(0x0006, 0x006F, 0x0021) & 0x006F, 0x0021);
  ASSERT_EQ(master.run_until_status(0x000F, 0x006F, 0x0027) & 0x006F, 0x0027);
  EXPECT_EQ(master.request(0x0004), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  master.segment().run_for(20ms);
  EXPECT_NE(master.drive().servo().application().pds().state(), cia402::State::operation_enabled);
}

TEST(EthercatDriveCoe, DriveEmcyArrivesAsCoeEmergency) {
  // Given the drive in PREOP
  // When the drive raises an error (EMCY 5000h through its CiA 301 producer)
  // Then SM1 carries a CoE emergency with code 5000h and error register bit 0
  Master master;
  master.to_preop();
  master.drive().servo().device().raise_error(0x5000, 0x01);
  master.segment().run_for(1ms);
  const Bytes status = master.read(ecat::reg::sync_manager(1) + 5, 1);
  ASSERT_NE(status.at(0) & ecat::sm::kStatusMailboxFull, 0);
  const Bytes sm1 = master.read(kMailboxInStart, kMailboxSize);
  auto reply = master.mailbox().accept(sm1);  // views sm1
  ASSERT_TRUE(reply);
  auto emergency = ecat::decode_emergency(reply->message.data);
  ASSERT_TRUE(emergency) << "mailbox type " << int(reply->message.header.type) << ", "
                         << reply->message.data.size() << " octets";
  EXPECT_EQ(emergency->emcy.error_code, 0x5000);
  EXPECT_NE(emergency->emcy.error_register & 0x01, 0);
}

TEST(EthercatDriveProcessData, CspFollowsTargetsSmSynchronous) {
  // Given the drive in PREOP set to SM-synchronous (1C32h:01 = 1) and csp (6060h = 8)
  // When it is enabled in OP and 607Ah rises by 100 every 1 ms cycle for 200 cycles
  // Then statusword bit 12 (drive follows the command value) is set and 6064h in the inputs
  //      follows the targets (within 5 % of the last one: the simulated axis lags)
  Master master;
  master.to_preop();
  ASSERT_FALSE(master.download(0x1C32, 1, u16(1)).abort);
  ASSERT_FALSE(master.download(0x6060, 0, {8}).abort);
  ASSERT_EQ(master.to_safeop(6, 6), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  master.cycle(master.outputs(0));
  ASSERT_EQ(master.request(0x0008), std::make_pair(std::uint16_t{0x0008}, std::uint16_t{0}));
  ASSERT_EQ(master.run_until_status(0x0006, 0x006F, 0x0021) & 0x006F, 0x0021);
  ASSERT_EQ(master.run_until_status(0x000F, 0x006F, 0x0027) & 0x006F, 0x0027);
  std::int32_t target = 0;
  Bytes inputs;
  for (int i = 0; i < 200; ++i) {
    target += 100;
    Bytes out = u16(0x000F);
    for (int b = 0; b < 4; ++b)
      out.push_back(static_cast<std::uint8_t>(target >> (8 * b)));
    master.segment().run_for(1ms);
    inputs = master.cycle(out).first;
  }
  master.segment().run_for(5ms);
  inputs = master.cycle(master.outputs(0x000F)).first;  // (607Ah 0 now: read before it acts)
  EXPECT_NE(le16(inputs) & 0x1000, 0) << "statusword bit 12";
  const auto position = static_cast<std::int32_t>(le32(Bytes(inputs.begin() + 2, inputs.end())));
  EXPECT_NEAR(position, target, 1000);  // the simulated axis lags a few cycles
}

TEST(EthercatDriveProcessData, SmSynchronousModeLatchesAtTheSm2Event) {
  // Given the drive enabled in csp, 1600h = {6040h} only (607Ah written by SDO), once with
  //      1C32h:01 = 1 (SM-synchronous) and once with 0 (free run)
  // When 607Ah := 5000 is written by SDO and 30 ms pass without process data (watchdog 100 ms)
  // Then SM-synchronous: 6062h (position demand) stays 0 until the next SM2 write (the SM2
  //      event is the cyclic modes' SYNC), then moves; free run: it moves at once
  for (const bool synchronous : {true, false}) {
    SCOPED_TRACE(synchronous ? "SM-synchronous" : "free run");
    Master master;
    master.to_preop();
    ASSERT_FALSE(master.download(0x1C32, 1, u16(synchronous ? 1 : 0)).abort);
    ASSERT_FALSE(master.download(0x6060, 0, {8}).abort);
    ASSERT_FALSE(master.download(0x1600, 0, {0}).abort);
    ASSERT_FALSE(master.download(0x1600, 1, {0x10, 0x00, 0x40, 0x60}).abort);  // 6040h:00, 16
    ASSERT_FALSE(master.download(0x1600, 0, {1}).abort);
    ASSERT_EQ(master.to_safeop(2, 6), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
    master.cycle(master.outputs(0));
    ASSERT_EQ(master.request(0x0008), std::make_pair(std::uint16_t{0x0008}, std::uint16_t{0}));
    ASSERT_EQ(master.run_until_status(0x0006, 0x006F, 0x0021) & 0x006F, 0x0021);
    ASSERT_EQ(master.run_until_status(0x000F, 0x006F, 0x0027) & 0x006F, 0x0027);
    ASSERT_FALSE(master.download(0x607A, 0, {0x88, 0x13, 0, 0}).abort);  // 5000
    master.segment().run_for(30ms);
    const auto before = static_cast<std::int32_t>(le32(master.upload(0x6062, 0).value));
    if (synchronous) {
      EXPECT_EQ(before, 0) << "no SM2 event, no SYNC: the command waits";
    } else {
      EXPECT_GT(before, 0) << "free run: taken in the drive's cycle";
    }
    for (int i = 0; i < 5; ++i) {
      master.segment().run_for(1ms);
      master.cycle(master.outputs(0x000F));
    }
    EXPECT_GT(static_cast<std::int32_t>(le32(master.upload(0x6062, 0).value)), 0);
  }
}

TEST(EthercatDriveRobustness, RandomDatagramsNeverBreakIt) {
  // Given the drive in PREOP
  // When 3000 random APWR/APRD/LRW datagrams hit random registers, SyncManagers, the mailbox
  //      and AL control (seeded)
  // Then nothing crashes, and afterwards a fresh bring-up (INIT, mailboxes, PREOP) works
  Master master;
  master.to_preop();
  std::mt19937 random(20261127);
  const std::uint16_t hot[] = {ecat::reg::kAlControl,
                               ecat::reg::kSyncManager,
                               ecat::reg::sync_manager(2),
                               ecat::reg::fmmu(0),
                               kMailboxOutStart,
                               kMailboxInStart,
                               kOutputsStart,
                               ecat::reg::kWatchdogTimeProcessData};
  for (int i = 0; i < 3000; ++i) {
    const std::uint16_t base = hot[random() % std::size(hot)];
    const auto address = static_cast<std::uint16_t>(base + random() % 16);
    Bytes data(1 + random() % 130);
    for (auto& b : data)
      b = static_cast<std::uint8_t>(random());
    switch (random() % 3) {
      case 0:
        master.write(address, data);
        break;
      case 1:
        master.read(address, data.size());
        break;
      default:
        master.exchange(ecat::Datagram::logical(ecat::Command::lrw, 0, kLogical, data));
        break;
    }
    if (i % 50 == 0) master.segment().run_for(1ms);
  }
  master.segment().run_for(200ms);
  master.request(0x0011);  // INIT, acknowledging any error
  write_zeros_to_sync_managers(master);
  master.to_preop();
  EXPECT_FALSE(master.upload(0x1000, 0).abort);
}

// ---- Named deviations -----------------------------------------------------------------------

TEST(EthercatDriveDeviation, WrongWorkingCounter) {
  // Given the standard drive and one with wrong-working-counter, both in OP
  // When one LRW cycle runs
  // Then the standard drive counts 3, the deviant 0 (a master sees the slave as absent)
  Master standard;
  standard.to_op();
  EXPECT_EQ(standard.cycle(standard.outputs(0)).second, 3);
  Master deviant_drive(deviant(Deviation::wrong_working_counter));
  deviant_drive.to_op();
  EXPECT_EQ(deviant_drive.cycle(deviant_drive.outputs(0)).second, 0);
  EXPECT_EQ(deviant_drive.write(ecat::reg::kAlControl, u16(0x0008)), 1) << "APWR still counts";
}

TEST(EthercatDriveDeviation, AlStatusCodeMissing) {
  // Given the standard drive and one with al-status-code-missing, in INIT without mailboxes
  // When PREOP is requested
  // Then both refuse (INIT + error); the standard drive says 0016h, the deviant 0000h
  Master standard;
  EXPECT_EQ(standard.request(0x0002), std::make_pair(std::uint16_t{0x0011}, std::uint16_t{0x0016}));
  Master deviant_drive(deviant(Deviation::al_status_code_missing));
  EXPECT_EQ(deviant_drive.request(0x0002), std::make_pair(std::uint16_t{0x0011}, std::uint16_t{0}));
}

// Writes 6083h (profile acceleration) = `value` with the mailbox counter `counter` and returns
// how many replies SM1 gives within 5 ms.
int replies_to_download(Master& master, std::uint8_t counter, std::uint32_t value) {
  const Bytes data{static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8),
                   static_cast<std::uint8_t>(value >> 16), static_cast<std::uint8_t>(value >> 24)};
  const Bytes coe = master.client().start_download({0x6083, 0}, data);
  ecat::MailboxHeader header;
  header.type = static_cast<std::uint8_t>(ecat::MailboxType::coe);
  header.counter = counter;
  master.write(kMailboxOutStart, ecat::build_mailbox(header, coe, kMailboxSize));
  int replies = 0;
  for (int i = 0; i < 10; ++i) {
    master.segment().run_for(500us);
    const Bytes status = master.read(ecat::reg::sync_manager(1) + 5, 1);
    if ((status.at(0) & ecat::sm::kStatusMailboxFull) != 0) {
      master.read(kMailboxInStart, kMailboxSize);
      ++replies;
    }
  }
  return replies;
}

TEST(EthercatDriveDeviation, MailboxCounterIgnored) {
  // Given the standard drive and one with mailbox-counter-ignored, in PREOP
  // When a download of 6083h := 1000 with counter 3 is sent, its reply read, then the same
  //      counter again with 6083h := 2000 (a repeat: ETG.1000.4 says not to execute it)
  // Then the standard drive keeps 1000 (the repeat answered with the old reply); the deviant
  //      drive writes 2000
  for (const bool faulty : {false, true}) {
    Master master(faulty ? deviant(Deviation::mailbox_counter_ignored) : EthercatDriveOptions{});
    master.to_preop();
    EXPECT_EQ(replies_to_download(master, 3, 1000), 1);
    replies_to_download(master, 3, 2000);
    const auto value = master.dictionary_value(0x6083, 0);
    EXPECT_EQ(value, faulty ? 2000u : 1000u) << (faulty ? "deviant" : "standard");
  }
}

TEST(EthercatDriveDeviation, SmWatchdogIgnored) {
  // Given a drive with sm-watchdog-ignored, OPERATION ENABLED in OP
  // When the master stops sending process data for 150 ms
  // Then it stays in OP without error code and the drive stays OPERATION ENABLED (the
  //      standard drive: EthercatDriveWatchdog.ExpiryDropsToSafeopAndStopsTheDrive)
  Master master(deviant(Deviation::sm_watchdog_ignored));
  master.to_op();
  ASSERT_EQ(master.run_until_status(0x0006, 0x006F, 0x0021) & 0x006F, 0x0021);
  ASSERT_EQ(master.run_until_status(0x000F, 0x006F, 0x0027) & 0x006F, 0x0027);
  master.segment().run_for(150ms);
  EXPECT_EQ(master.al_status(), std::make_pair(std::uint16_t{0x0008}, std::uint16_t{0}));
  EXPECT_EQ(master.drive().servo().application().pds().state(), cia402::State::operation_enabled);
}

// ---- The SDO service deviations over CoE (sdo_deviations.hpp through coe_deviations.hpp) ----

TEST(EthercatDriveDeviation, SdoServiceDeviationsActOnCoe) {
  // Given the standard drive and drives with sdo-read-only-wrong-abort, device-type-wrong,
  // sdo-length-not-checked and sdo-upload-size-wrong, each in PREOP
  // When 1000h is written and read, and 6040h (2 octets) written with 4 and read
  // Then the standard drive answers as CiA 301 says and each deviant drive as its row says
  Master standard;
  standard.to_preop();
  EXPECT_EQ(standard.download(0x1000, 0, {0, 0, 0, 0}).abort, 0x06010002u);
  EXPECT_EQ(le32(standard.upload(0x1000, 0).value), 0x00020192u);
  EXPECT_EQ(standard.download(0x6040, 0, {0, 0, 0, 0}).abort, 0x06070012u);
  EXPECT_EQ(standard.upload(0x6040, 0).value.size(), 2u);

  Master wrong_abort(deviant(Deviation::sdo_read_only_wrong_abort));
  wrong_abort.to_preop();
  EXPECT_EQ(wrong_abort.download(0x1000, 0, {0, 0, 0, 0}).abort, 0x06020000u);
  Master device_type(deviant(Deviation::device_type_wrong));
  device_type.to_preop();
  EXPECT_EQ(le32(device_type.upload(0x1000, 0).value), 0u);
  Master length(deviant(Deviation::sdo_length_not_checked));
  length.to_preop();
  EXPECT_FALSE(length.download(0x6040, 0, {0, 0, 0, 0}).abort);
  Master size(deviant(Deviation::sdo_upload_size_wrong));
  size.to_preop();
  EXPECT_EQ(size.upload(0x6040, 0).value.size(), 4u);
}

TEST(EthercatDriveDeviation, StoreSignatureIgnoredStoresAnyValueOverCoe) {
  // Given a drive with store-signature-ignored in PREOP
  // When 1010h:01 is written with a value that is not "save"
  // Then the write is confirmed (it stored), where the standard drive aborts 08000020h
  Master standard;
  standard.to_preop();
  EXPECT_EQ(standard.download(0x1010, 1, {1, 2, 3, 4}).abort, 0x08000020u);
  Master deviant_drive(deviant(Deviation::store_signature_ignored));
  deviant_drive.to_preop();
  EXPECT_FALSE(deviant_drive.download(0x1010, 1, {1, 2, 3, 4}).abort);
}

TEST(EthercatDriveDeviation, CanOnlyDeviationIsRefused) {
  // Given a deviation the table marks CAN only (bootup-missing)
  // When an EtherCAT drive is created with it
  // Then creation fails and says why, instead of running a drive that is not deviant
  ecat::SimSegment segment;
  auto created = EthercatDrive::create(segment, deviant(Deviation::bootup_missing));
  ASSERT_FALSE(created);
  EXPECT_NE(created.error().find("bootup-missing"), std::string::npos) << created.error();
  EXPECT_NE(created.error().find("CAN only"), std::string::npos) << created.error();
}

// ---- Mailbox repeat request (ETG.1000.4: SM1 repeat request / repeat acknowledge) ----------

// The drive in PREOP under the drivecheck master, on a segment that loses the next frame that
// reads SM1 before device `lost_before` (0: before the drive, which never sees the read; 1: after
// it, the reply left SM1); the master reads 1018h:01, then 1000h.
void read_with_a_lost_sm1_read(std::size_t lost_before) {
  ecat::SimSegment segment;
  auto created = EthercatDrive::create(segment, {});
  ASSERT_TRUE(created) << created.error();
  EthercatDrive& drive = **created;
  segment.attach(drive);
  drive.power_on();
  ecat::MasterConfig config;
  config.scan.expected_slaves = 1;
  ecat::Master master(segment, config);
  const auto up = master.bring_up(ecat::AlState::preop);
  ASSERT_TRUE(up) << up.error().message();
  ecat::FrameFaultRule rule;
  rule.match = [](std::span<const std::uint8_t> bytes) {
    const auto frame = ecat::decode_frame(bytes);
    if (!frame) return false;
    for (const ecat::Datagram& d : frame->datagrams) {
      if (d.command == ecat::Command::fprd && d.ado() == kMailboxInStart) return true;
    }
    return false;
  };
  rule.max_count = 1;
  const ecat::FaultId fault = segment.drop(rule, lost_before);
  const auto vendor = master.sdo_upload(0, {0x1018, 1});
  EXPECT_EQ(segment.fault_hits(fault), 1u);
  ASSERT_TRUE(vendor) << vendor.error().message();
  EXPECT_EQ(le32(*vendor), drive.dictionary().find(0x1018, 1)->as_unsigned());
  EXPECT_EQ(master.mailbox(0)->repeat_requests(), 1u);
  // And the next exchange goes on normally.
  const auto device_type = master.sdo_upload(0, {0x1000, 0});
  ASSERT_TRUE(device_type) << device_type.error().message();
  EXPECT_EQ(le32(*device_type), 0x00020192u);
}

TEST(EthercatDriveMailbox, LostReplyIsSentAgainOnTheRepeatRequest) {
  // Given the drive in PREOP and a segment that loses the next SM1 read after the drive passed
  //       it (the reply left SM1 and never reached the master)
  // When the master reads 1018h:01
  // Then the value arrives through one repeat request: the drive put its last reply into SM1
  //      again and toggled the repeat acknowledge (0807h bit 1) to the request
  read_with_a_lost_sm1_read(1);
}

TEST(EthercatDriveMailbox, RepeatWhileTheReplyIsStillInSm1OnlyAcknowledges) {
  // Given the drive in PREOP and a segment that loses the next SM1 read before the drive (SM1
  //       still holds the reply)
  // When the master reads 1018h:01
  // Then one repeat request is acknowledged and the reply still in SM1 is read, once
  read_with_a_lost_sm1_read(0);
}

// ---- The profile's CoE rules (coe:, reference_drive/ethercat/coe_rules.hpp) ----------------

EthercatDriveOptions with_coe(profile::CoeRules rules) {
  EthercatDriveOptions options;
  options.coe = std::move(rules);
  return options;
}

TEST(EthercatDriveCoeRules, AbsentObjectsAnswer06020000h) {
  // Given the standard drive, and one whose coe.absent_objects is [1008h, 100Ah], in PREOP
  // When 1008h and 100Ah are uploaded and 1009h downloaded over CoE
  // Then the standard drive answers them, the other aborts 06020000h; 1000h still reads
  Master standard;
  standard.to_preop();
  EXPECT_FALSE(standard.upload(0x1008, 0).abort);
  EXPECT_FALSE(standard.upload(0x100A, 0).abort);
  profile::CoeRules rules;
  rules.absent_objects = {{0x1008, 0x100A}};
  Master festo(with_coe(rules));
  festo.to_preop();
  EXPECT_EQ(festo.upload(0x1008, 0).abort, 0x06020000u);
  EXPECT_EQ(festo.upload(0x100A, 0).abort, 0x06020000u);
  EXPECT_EQ(festo.download(0x1009, 0, {0x41}).abort, 0x06020000u);
  EXPECT_FALSE(festo.upload(0x1000, 0).abort);
}

TEST(EthercatDriveCoeRules, SdoInformationLeavesAbsentObjectsOut) {
  // Given the standard drive, and one whose coe.absent_objects is [1008h, 100Ah], in PREOP
  // When each is asked over SDO information for the list of all objects and 1009h's description
  // Then the standard drive lists 1008h-100Ah and describes 1009h; the other lists none of
  //      them (1000h still) and answers the description 06020000h, as its SDO server does
  std::uint8_t counter = 0;
  const auto ask = [&counter](Master& master, const Bytes& request) {
    ecat::MailboxHeader h;
    h.type = static_cast<std::uint8_t>(ecat::MailboxType::coe);
    counter = static_cast<std::uint8_t>(counter % 7 + 1);  // 1..7: each a new request
    h.counter = counter;
    master.drive().coe().on_write_mailbox(ecat::build_mailbox(h, request, kMailboxSize));
    ecat::SdoInfoAssembler assembler;
    while (const auto reply = master.drive().coe().take_reply()) {
      auto m = assembler.add(ecat::parse_mailbox(*reply)->data);
      if (m && *m) return **m;
    }
    ADD_FAILURE() << "no complete SDO information answer";
    return ecat::SdoInfoMessage{};
  };
  const auto list_request = ecat::sdo_info_od_list_request(ecat::OdListType::all_objects);
  const auto lists = [](const std::vector<std::uint16_t>& list, std::uint16_t index) {
    return std::find(list.begin(), list.end(), index) != list.end();
  };
  Master standard;
  standard.to_preop();
  const auto all = ecat::parse_od_list(ask(standard, list_request));
  ASSERT_TRUE(all);
  EXPECT_TRUE(lists(*all, 0x1008) && lists(*all, 0x1009) && lists(*all, 0x100A));
  EXPECT_FALSE(ecat::parse_sdo_info_error(ask(standard, ecat::sdo_info_object_request(0x1009))));
  profile::CoeRules rules;
  rules.absent_objects = {{0x1008, 0x100A}};
  Master festo(with_coe(rules));
  festo.to_preop();
  const auto some = ecat::parse_od_list(ask(festo, list_request));
  ASSERT_TRUE(some);
  EXPECT_FALSE(lists(*some, 0x1008) || lists(*some, 0x1009) || lists(*some, 0x100A));
  EXPECT_TRUE(lists(*some, 0x1000));
  const auto error = ecat::parse_sdo_info_error(ask(festo, ecat::sdo_info_object_request(0x1009)));
  ASSERT_TRUE(error);
  EXPECT_EQ(*error, 0x06020000u);
}

TEST(EthercatDriveCoeRules, TransfersAboveMaxSdoSizeAreAborted) {
  // Given the standard drive, and one with coe.max_sdo_size 4, in PREOP
  // When 1008h (a string longer than 4 octets) is uploaded, 6 octets are downloaded to 1008h
  //      (normal transfer), then 1000h (4 octets) and 6041h (2) are read
  // Then the standard drive answers the upload; the other aborts it 06010000h and the download
  //      06070012h (before the dictionary sees it: the standard drive says 06010002h, read
  //      only), and its 4- and 2-octet transfers still work after the aborts
  Master standard;
  standard.to_preop();
  const auto name = standard.upload(0x1008, 0);
  ASSERT_FALSE(name.abort);
  ASSERT_GT(name.value.size(), 4u);
  EXPECT_EQ(standard.download(0x1008, 0, {1, 2, 3, 4, 5, 6}).abort, 0x06010002u);
  profile::CoeRules rules;
  rules.max_sdo_size = 4;
  Master festo(with_coe(rules));
  festo.to_preop();
  EXPECT_EQ(festo.upload(0x1008, 0).abort, 0x06010000u);
  EXPECT_FALSE(festo.drive().coe().sdo().busy());  // no segmented upload left behind
  EXPECT_EQ(festo.download(0x1008, 0, {1, 2, 3, 4, 5, 6}).abort, 0x06070012u);
  const auto device_type = festo.upload(0x1000, 0);
  ASSERT_FALSE(device_type.abort);
  EXPECT_EQ(le32(device_type.value), 0x00020192u);
  EXPECT_EQ(festo.upload(0x6041, 0).value.size(), 2u);
  EXPECT_FALSE(festo.download(0x6083, 0, {0x10, 0x27, 0, 0}).abort);
}

TEST(EthercatDriveCoeRules, AssignmentNotEvaluatedKeepsThePreopRule) {
  // Given the standard drive, and one with coe.pdo_assignment_evaluated false, in PREOP
  // When 1C12h:01 is written while 1C12h:00 is 1, then SAFEOP is entered and 1C12h:00 and
  //      1600h:00 are written
  // Then the standard drive aborts the first write 06010003h (SI0 must be 0); the other takes
  //      it, yet still refuses both writes in SAFEOP with 08000022h (PDO configuration only in
  //      PREOP, Festo 000 L1774); with pdo_configuration_in any it takes them in SAFEOP
  Master standard;
  standard.to_preop();
  EXPECT_EQ(standard.download(0x1C12, 1, u16(0x1600)).abort, 0x06010003u);
  profile::CoeRules rules;
  rules.pdo_assignment_evaluated = false;
  Master festo(with_coe(rules));
  festo.to_preop();
  EXPECT_FALSE(festo.download(0x1C12, 1, u16(0x1600)).abort);
  EXPECT_FALSE(festo.download(0x1C12, 0, {7}).abort);  // 7 > 4 entries: not evaluated
  EXPECT_EQ(standard.download(0x1C12, 0, {7}).abort, 0x06090031u);
  ASSERT_FALSE(festo.download(0x1C12, 0, {1}).abort);
  ASSERT_EQ(festo.to_safeop(6, 6), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  EXPECT_EQ(festo.download(0x1C12, 0, {1}).abort, 0x08000022u);
  EXPECT_EQ(festo.download(0x1600, 0, {2}).abort, 0x08000022u);

  rules.pdo_configuration_in = profile::PdoConfigurationIn::any;
  Master anywhere(with_coe(rules));
  anywhere.to_preop();
  ASSERT_EQ(anywhere.to_safeop(6, 6), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
  EXPECT_FALSE(anywhere.download(0x1C12, 0, {1}).abort);
  EXPECT_FALSE(anywhere.download(0x1600, 0, {2}).abort);
}

TEST(EthercatDriveCoeRules, FestoProfileTakesItsCoeSection) {
  // Given the drive created with the shipped festo-cmmp profile (no coe override), in PREOP
  // When 1008h is uploaded, and 1C12h:01 written while 1C12h:00 is not 0
  // Then 06020000h, and accepted: the profile's coe: section reached the drive
  auto festo_profile = profile::find_profile(
      "festo-cmmp", std::filesystem::path(DRIVECHECK_SOURCE_DIR) / "vectors/drives");
  ASSERT_TRUE(festo_profile) << festo_profile.error().to_string();
  EthercatDriveOptions options;
  options.profile = &*festo_profile;
  Master festo(std::move(options));
  festo.to_preop();
  EXPECT_EQ(festo.upload(0x1008, 0).abort, 0x06020000u);
  ASSERT_NE(festo.drive().dictionary().find(0x1C12, 0)->as_unsigned(), 0u);
  EXPECT_FALSE(festo.download(0x1C12, 1, u16(0x1600)).abort);
}

// A shipped profile by name, read from vectors/drives.
profile::DriveProfile shipped_profile(const char* name) {
  auto found =
      profile::find_profile(name, std::filesystem::path(DRIVECHECK_SOURCE_DIR) / "vectors/drives");
  EXPECT_TRUE(found) << found.error().to_string();
  return found ? std::move(*found) : profile::DriveProfile{};
}

TEST(EthercatDrivePdoDefaults, PlainCia301DeviceHasOnlyItsOwnTxPdo) {
  // Given the cia301-minimal profile (one TPDO mapping 1001h, mapping records of 1 entry, no
  // RPDO at all: 1400h-17FFh absent)
  // When the drive is created as an EtherCAT slave and taken to SAFEOP
  // Then it is created (no CiA 402 default mapping forced into it), 1C12h assigns nothing,
  // 1C13h assigns 1A00h, and SAFEOP is reached with 0 octets of outputs and 1 of inputs
  const profile::DriveProfile minimal = shipped_profile("cia301-minimal");
  EthercatDriveOptions options;
  options.profile = &minimal;
  Master master(std::move(options));
  const auto& od = master.drive().dictionary();
  ASSERT_NE(od.find(0x1C12, 0), nullptr);
  EXPECT_EQ(od.find(0x1C12, 0)->as_unsigned(), 0u);
  ASSERT_NE(od.find(0x1C13, 0), nullptr);
  EXPECT_EQ(od.find(0x1C13, 0)->as_unsigned(), 1u);
  EXPECT_EQ(od.find(0x1C13, 1)->as_unsigned(), 0x1A00u);
  EXPECT_EQ(od.find(0x1600), nullptr);
  master.to_preop();
  EXPECT_EQ(master.to_safeop(0, 1), std::make_pair(std::uint16_t{0x0004}, std::uint16_t{0}));
}

TEST(EthercatDriveCoeRules, FestoLoadsSavedValuesOnEnteringInit) {
  // Given the festo-cmmp drive in PREOP, 6083h := 1000 saved (1010h:01 "save"), then := 2000
  // When the master takes it to INIT and back to PREOP
  // Then 6083h reads 1000 (Festo 000 §4.7 L2056); with init-saved-values-not-loaded 2000
  const profile::DriveProfile festo = shipped_profile("festo-cmmp");
  for (const bool deviant : {false, true}) {
    EthercatDriveOptions options;
    options.profile = &festo;
    if (deviant) options.deviations.add(Deviation::init_saved_values_not_loaded);
    Master master(std::move(options));
    master.to_preop();
    ASSERT_FALSE(master.download(0x6083, 0, {0xE8, 0x03, 0, 0}).abort);
    ASSERT_FALSE(master.download(0x1010, 1, {0x73, 0x61, 0x76, 0x65}).abort);
    ASSERT_FALSE(master.download(0x6083, 0, {0xD0, 0x07, 0, 0}).abort);
    ASSERT_EQ(master.request(0x0001), std::make_pair(std::uint16_t{0x0001}, std::uint16_t{0}));
    master.to_preop();
    EXPECT_EQ(master.dictionary_value(0x6083, 0), deviant ? 2000u : 1000u) << deviant;
  }
}

TEST(EthercatDriveCoeRules, StandardDriveKeepsUnsavedValuesOverInit) {
  // Given the standard drive (no coe.init_loads_saved_values) in PREOP, 6083h := 2000 unsaved
  // When INIT and back to PREOP
  // Then 6083h still reads 2000: only a profile that says so reloads in INIT
  Master master;
  master.to_preop();
  ASSERT_FALSE(master.download(0x6083, 0, {0xD0, 0x07, 0, 0}).abort);
  ASSERT_EQ(master.request(0x0001), std::make_pair(std::uint16_t{0x0001}, std::uint16_t{0}));
  master.to_preop();
  EXPECT_EQ(master.dictionary_value(0x6083, 0), 2000u);
}

std::string checked_in_esi() {
  std::ifstream in(DRIVECHECK_SOURCE_DIR "/reference_drive/ethercat/reference_drive.xml",
                   std::ios::binary);
  EXPECT_TRUE(in.good()) << "reference_drive/ethercat/reference_drive.xml is missing";
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(ReferenceEsi, CheckedInFileIsTheGeneratedOne) {
  // Given the standard EtherCAT drive's dictionary and SII
  // When its ESI is generated
  // Then it equals reference_drive/ethercat/reference_drive.xml byte for byte
  const auto generated = standard_drive_esi_text();
  ASSERT_TRUE(generated) << generated.error();
  EXPECT_TRUE(*generated == checked_in_esi())
      << "reference_drive/ethercat/reference_drive.xml is stale: regenerate it with\n"
         "  <build>/reference_drive/ethercat/reference_drive_esi "
         "reference_drive/ethercat/reference_drive.xml";
}

TEST(ReferenceEsi, ReadsBackAsTheDrivesIdentityAndPdos) {
  // Given the checked-in ESI, When the ESI reader reads it, Then one device with the drive's
  // 1018h identity, its SyncManagers, 1600h/1A00h assigned by default and every object
  Master master;
  const auto esi = ecat::read_esi(checked_in_esi(), "reference_drive.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  const auto& od = master.drive().dictionary();
  EXPECT_EQ(esi->vendor_id, od.find(0x1018, 1)->as_unsigned());
  ASSERT_EQ(esi->devices.size(), 1u);
  const ecat::EsiDevice& device = esi->devices[0];
  EXPECT_EQ(device.product_code, od.find(0x1018, 2)->as_unsigned());
  EXPECT_EQ(device.revision_number, od.find(0x1018, 3)->as_unsigned());
  ASSERT_EQ(device.sync_managers.size(), 4u);
  EXPECT_EQ(device.sync_managers[1].type, "MBoxIn");
  ASSERT_EQ(device.default_rx_assignment().size(), 1u);
  EXPECT_EQ(device.default_rx_assignment()[0]->index, 0x1600);
  EXPECT_EQ(device.default_rx_assignment()[0]->entries[1].mapping_value(), 0x607A0020u);
  ASSERT_EQ(device.default_tx_assignment().size(), 1u);
  EXPECT_EQ(device.objects.size(), od.objects().size());
  ASSERT_NE(device.find(0x1C12, 0), nullptr);
  EXPECT_EQ(device.find(0x1C12, 1)->default_data, (Bytes{0x00, 0x16}));
  EXPECT_FALSE(device.find(0x6041, 0)->default_data);  // a process value: no default
  EXPECT_EQ(device.find(0x6041, 0)->access, ecat::EsiAccess::ro);
}

TEST(ReferenceEsi, PdoMappingFlagsAreWhatTheDrivesMappingsAccept) {
  // Given the checked-in ESI and the drive's dictionary
  Master master;
  const auto esi = ecat::read_esi(checked_in_esi(), "reference_drive.xml");
  ASSERT_TRUE(esi) << esi.error().to_string();
  const ecat::EsiDevice& device = esi->devices[0];
  const auto& od = master.drive().dictionary();
  // When each entry's Flags/PdoMapping is compared with what the drive's PDO service accepts
  // in a mapping of each direction (an entry of its full length)
  std::size_t flagged = 0;
  for (const cia301::Object& object : od.objects()) {
    for (const cia301::Entry& entry : object.entries()) {
      const auto* esi_entry = device.find(object.index(), entry.sub_index());
      ASSERT_NE(esi_entry, nullptr)
          << fmt::format("{:04X}h sub {}", object.index(), entry.sub_index());
      const std::uint32_t value = std::uint32_t{object.index()} << 16 |
                                  std::uint32_t{entry.sub_index()} << 8 |
                                  (cia301::info(entry.type()).bit_size & 0xFFu);
      const bool rx =
          cia301::info(entry.type()).bit_size != 0 &&
          cia301::check_pdo_mapping_entry(od, cia301::PdoDirection::receive, value, false)
              .has_value();
      const bool tx =
          cia301::info(entry.type()).bit_size != 0 &&
          cia301::check_pdo_mapping_entry(od, cia301::PdoDirection::transmit, value, false)
              .has_value();
      // Then the ESI flags exactly the directions the drive accepts (none: no PdoMapping)
      const auto where = fmt::format("{:04X}h sub {}", object.index(), entry.sub_index());
      EXPECT_EQ(esi_entry->pdo_mapping.has_value(), rx || tx) << where;
      if (esi_entry->pdo_mapping) {
        ++flagged;
        EXPECT_EQ(esi_entry->pdo_mapping->rx, rx) << where;
        EXPECT_EQ(esi_entry->pdo_mapping->tx, tx) << where;
      }
    }
  }
  EXPECT_GT(flagged, 10u);
  EXPECT_EQ(device.find(0x6041, 0)->pdo_mapping->text, "T");
}

}  // namespace
}  // namespace drivecheck::reference_drive::ethercat
