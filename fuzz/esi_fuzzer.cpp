// Fuzz target: ESI files (ETG.2000 EtherCAT Slave Information, XML; protocol/ethercat/esi.hpp).
//
// Input: the text of an ESI. Oracles:
//   - reading never crashes, and an error names a line of the input (or 0 for the whole input)
//     and the file;
//   - a file that reads has at least one device; within a device every object index is there
//     once, every structured object's entries have sub-indices in file order of its DataType,
//     and every entry's DefaultData (where given) is at most 8 octets longer than its BitSize
//     says (a reader that mixes up defaults and entries shows here); the default assignment is
//     the PDOs with an Sm; find_esi_device finds each device by its own identity;
//   - every Flags/PdoMapping read gives a direction (R and/or T) and is one of the schema's
//     values, with a line in the input; every Slot has MinInstances <= MaxInstances and names
//     a module or a class; every Module's ModuleIdent is there once and find_module finds it.
#include <cstddef>
#include <cstdint>
#include <set>
#include <string>
#include <string_view>

#include "fuzz/support/fuzz_check.hpp"
#include "fuzz/support/fuzz_input.hpp"
#include "protocol/ethercat/esi.hpp"

namespace {

using namespace drivecheck;

// Lines of the input (LF-separated, as the reader counts them). Oracle bookkeeping: not
// instrumented.
DRIVECHECK_FUZZ_ORACLE_CODE std::size_t count_lines(std::string_view text) {
  std::size_t count = 1;
  for (const char c : text)
    count += c == '\n' ? 1 : 0;
  return count;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text = fuzz::as_text({data, size});
  const auto esi = ethercat::read_esi(text, "fuzz.xml");
  const std::size_t lines = count_lines(text);
  if (!esi) {
    const TextError& error = esi.error();
    DRIVECHECK_FUZZ_CHECK_DETAIL(error.line >= 0 && static_cast<std::size_t>(error.line) <= lines,
                                 "the error names a line past the end of the input",
                                 error.to_string());
    DRIVECHECK_FUZZ_CHECK_DETAIL(error.file == "fuzz.xml" && !error.message.empty(),
                                 "the error names no file or says nothing", error.to_string());
    return 0;
  }
  DRIVECHECK_FUZZ_CHECK(!esi->devices.empty(), "an ESI that reads describes no device");
  for (const ethercat::EsiDevice& device : esi->devices) {
    std::set<std::uint16_t> indices;
    for (const ethercat::EsiObject& object : device.objects) {
      DRIVECHECK_FUZZ_CHECK_DETAIL(indices.insert(object.index).second,
                                   "an object index is there twice", std::to_string(object.index));
      DRIVECHECK_FUZZ_CHECK(!object.entries.empty(), "an object without entries");
      DRIVECHECK_FUZZ_CHECK(object.structured || object.entries.size() == 1,
                            "a VAR with more than one entry");
      for (const ethercat::EsiSubItem& entry : object.entries) {
        DRIVECHECK_FUZZ_CHECK(entry.line >= 1 && static_cast<std::size_t>(entry.line) <= lines,
                              "an entry's line is outside the input");
        if (const auto& mapping = entry.pdo_mapping) {
          const std::set<std::string> values{"R", "T", "RT", "TR", "r", "t", "rt", "tr"};
          DRIVECHECK_FUZZ_CHECK_DETAIL(
              values.contains(mapping->text) && (mapping->rx || mapping->tx),
              "a PdoMapping outside the schema's values, or no "
              "direction",
              mapping->text);
          DRIVECHECK_FUZZ_CHECK(
              mapping->line >= 1 && static_cast<std::size_t>(mapping->line) <= lines,
              "a PdoMapping's line is outside the input");
        }
      }
    }
    std::size_t with_sm = 0;
    for (const ethercat::EsiPdo& pdo : device.rx_pdos)
      with_sm += pdo.sm ? 1 : 0;
    DRIVECHECK_FUZZ_CHECK(device.default_rx_assignment().size() == with_sm,
                          "the default RxPDO assignment is not the RxPdos with an Sm");
    DRIVECHECK_FUZZ_CHECK(
        ethercat::find_esi_device(*esi, device.product_code, device.revision_number) != nullptr,
        "a device is not found by its own identity");
    if (const auto& slots = device.slots) {
      for (const ethercat::EsiSlot& slot : slots->slots) {
        DRIVECHECK_FUZZ_CHECK(slot.min_instances <= slot.max_instances,
                              "a slot with more minimum than maximum instances");
        DRIVECHECK_FUZZ_CHECK(!slot.module_idents.empty() || !slot.module_classes.empty(),
                              "a slot that names no module");
      }
    }
  }
  std::set<std::uint32_t> idents;
  for (const ethercat::EsiModule& module : esi->modules) {
    DRIVECHECK_FUZZ_CHECK_DETAIL(idents.insert(module.ident).second, "a ModuleIdent is there twice",
                                 std::to_string(module.ident));
    DRIVECHECK_FUZZ_CHECK(esi->find_module(module.ident) == &module,
                          "a module is not found by its own ModuleIdent");
  }
  return 0;
}
