// drivecheck esi show FILE: what drivecheck reads of an ESI (ETG.2000 EtherCAT Slave Information,
// protocol/ethercat/esi.hpp), the counterpart of `eds dump`.
//
//   drivecheck esi show FILE
//       the vendor, each device (identity, CoE, SyncManagers, PDOs, the Dictionary's objects
//       with their access and PdoMapping flags, the distributed-clock operation modes Dc/OpMode,
//       the Slots of a modular device) and the file's Modules, each with its file:line; exit 0,
//       2 unreadable or malformed file (the reader's "file:line: message" on stderr).
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <CLI/CLI.hpp>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "protocol/ethercat/esi.hpp"

namespace drivecheck::cli {
namespace {

using ethercat::EsiDcTime;
using ethercat::EsiDevice;
using ethercat::EsiFile;
using ethercat::EsiPdo;

struct EsiOptions {
  std::string file;
};

std::string dc_time(const std::optional<EsiDcTime>& time) {
  if (!time) return "-";
  std::string out = fmt::format("{} ns", time->value);
  if (time->factor) out += fmt::format(" (Factor {})", *time->factor);
  if (time->input) out += *time->input ? " (Input)" : " (Input 0)";
  return out;
}

void print_pdos(const EsiFile& esi, const char* kind, const std::vector<EsiPdo>& pdos,
                const char* indent) {
  for (const EsiPdo& pdo : pdos) {
    fmt::print("{}{} {:04X}h '{}'{}{}{} ({}:{})\n", indent, kind, pdo.index, pdo.name,
               pdo.sm ? fmt::format(", SM{}", *pdo.sm) : std::string(), pdo.fixed ? ", fixed" : "",
               pdo.mandatory ? ", mandatory" : "", esi.file, pdo.line);
    for (const auto& e : pdo.entries) {
      if (e.index == 0) {
        fmt::print("{}  gap of {} bit(s)\n", indent, e.bit_length);
      } else {
        fmt::print("{}  {:04X}h sub {} {} bit(s) {} '{}'\n", indent, e.index, e.sub_index,
                   e.bit_length, e.data_type, e.name);
      }
    }
  }
}

void print_device(const EsiFile& esi, const EsiDevice& d) {
  fmt::print(
      "Device '{}' ({}:{}): type '{}', vendor ID {:08X}h, product code {:08X}h, revision "
      "{:08X}h\n",
      d.name, esi.file, d.line, d.type, esi.vendor_id, d.product_code, d.revision_number);
  if (d.coe) {
    fmt::print("  CoE: SdoInfo {}, PdoAssign {}, PdoConfig {}, CompleteAccess {}\n",
               d.coe->sdo_info, d.coe->pdo_assign, d.coe->pdo_config, d.coe->complete_access);
  } else {
    fmt::print("  CoE: none (no Mailbox/CoE)\n");
  }
  for (std::size_t i = 0; i < d.sync_managers.size(); ++i) {
    const auto& sm = d.sync_managers[i];
    fmt::print("  SM{} {}: start {}, default size {}, control {}, {}\n", i, sm.type,
               sm.start_address ? fmt::format("{:04X}h", *sm.start_address) : "-",
               sm.default_size ? fmt::format("{}", *sm.default_size) : "-",
               sm.control_byte ? fmt::format("{:02X}h", *sm.control_byte) : "-",
               sm.enable ? "enabled" : "disabled");
  }
  print_pdos(esi, "RxPdo", d.rx_pdos, "  ");
  print_pdos(esi, "TxPdo", d.tx_pdos, "  ");
  fmt::print("  Dictionary: {} object(s)\n", d.objects.size());
  for (const auto& o : d.objects) {
    for (const auto& e : o.entries) {
      fmt::print("    {:04X}h sub {:<3} {:<10} {:>4} bit(s) {:<2} {:<3} '{}' ({}:{})\n", o.index,
                 e.sub_index, e.type, e.bit_size,
                 e.access ? std::string(ethercat::to_string(*e.access)) : "-",
                 e.pdo_mapping ? e.pdo_mapping->text : "-", e.name, esi.file, e.line);
    }
  }
  if (d.dc_op_modes.empty()) {
    fmt::print("  Dc: no OpMode\n");
  } else {
    for (const auto& m : d.dc_op_modes) {
      fmt::print(
          "  Dc OpMode '{}'{} ({}:{}): AssignActivate {:04X}h, CycleTimeSync0 {}, "
          "ShiftTimeSync0 {}, CycleTimeSync1 {}, ShiftTimeSync1 {}\n",
          m.name, m.desc.empty() ? std::string() : fmt::format(" '{}'", m.desc), esi.file, m.line,
          m.assign_activate, dc_time(m.cycle_time_sync0), dc_time(m.shift_time_sync0),
          dc_time(m.cycle_time_sync1), dc_time(m.shift_time_sync1));
    }
  }
  if (const auto& slots = d.slots) {
    fmt::print("  Slots ({}:{}): MaxSlotCount {}, SlotPdoIncrement {}, SlotIndexIncrement {}\n",
               esi.file, slots->line,
               slots->max_slot_count ? fmt::format("{}", *slots->max_slot_count) : "-",
               slots->pdo_increment ? fmt::format("{:X}h", *slots->pdo_increment) : "-",
               slots->index_increment ? fmt::format("{:X}h", *slots->index_increment) : "-");
    for (const auto& s : slots->slots) {
      std::vector<std::string> idents;
      for (const std::uint32_t ident : s.module_idents) {
        const auto* module = esi.find_module(ident);
        idents.push_back(fmt::format(
            "{:08X}h{}{}", ident, s.default_ident == ident ? " (default)" : "",
            module != nullptr ? fmt::format(" '{}'", module->name) : " (not in this file)"));
      }
      fmt::print("    Slot '{}' ({}:{}): {}..{} instance(s){}: {}{}\n", s.name, esi.file, s.line,
                 s.min_instances, s.max_instances,
                 s.slot_group ? fmt::format(", group {}", *s.slot_group) : std::string(),
                 idents.empty() ? std::string() : fmt::format("{}", fmt::join(idents, ", ")),
                 s.module_classes.empty()
                     ? std::string()
                     : fmt::format("classes {}", fmt::join(s.module_classes, ", ")));
    }
  }
}

void run_show(const EsiOptions& options) {
  auto esi = ethercat::read_esi_file(options.file);
  if (!esi) {
    fmt::print(stderr, "{}\n", esi.error().to_string());
    exit_with(kExitUsage);
    return;
  }
  fmt::print("ESI {}: vendor '{}' ({:08X}h), {} device(s), {} module(s)\n", options.file,
             esi->vendor_name, esi->vendor_id, esi->devices.size(), esi->modules.size());
  for (const auto& device : esi->devices)
    print_device(*esi, device);
  for (const auto& m : esi->modules) {
    fmt::print("Module '{}' ({}:{}): ModuleIdent {:08X}h{}, type '{}'{}\n", m.name, esi->file,
               m.line, m.ident,
               m.module_class.empty() ? std::string() : fmt::format(", class {}", m.module_class),
               m.type,
               m.dc_op_mode_name.empty() ? std::string()
                                         : fmt::format(", Dc OpMode '{}'", m.dc_op_mode_name));
    print_pdos(*esi, "RxPdo", m.rx_pdos, "  ");
    print_pdos(*esi, "TxPdo", m.tx_pdos, "  ");
  }
}

}  // namespace

void add_esi_command(CLI::App& app) {
  auto options = std::make_shared<EsiOptions>();
  CLI::App* esi =
      app.add_subcommand("esi", "Show an EtherCAT slave's ESI file (ETG.2000 EtherCATInfo XML)");
  esi->require_subcommand(1);
  CLI::App* show = esi->add_subcommand(
      "show",
      "Print what drivecheck reads of an ESI: devices, PDOs, dictionary with access and "
      "PdoMapping, DC operation modes, slots and modules (exit 2: unreadable)");
  show->add_option("FILE", options->file, "ESI file")->required();
  show->callback([options] { run_show(*options); });
}

}  // namespace drivecheck::cli
