// drivecheck eds lint|dump FILE: EDS/DCF files (CiA 306).
//
//   drivecheck eds lint FILE [--no-warnings]
//       every reader and linter finding as "file:line: severity: message [id]" on stdout,
//       then a summary; exit 0 no error-severity finding, 1 some, 2 unreadable file.
//   drivecheck eds dump FILE
//       the object dictionary as a table (CompactSubObj arrays expanded, values as written,
//       DCF ParameterValues in their own column); reader errors on stderr; exit 0, 1 when
//       the reader found errors (the table is then partial), 2 unreadable file.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.hpp"
#include "protocol/cia306/eds.hpp"
#include "protocol/cia306/eds_lint.hpp"

namespace drivecheck::cli {
namespace {

struct EdsOptions {
  std::string file;
  bool no_warnings = false;
};

void run_lint(const EdsOptions& options) {
  auto findings = cia306::lint_eds_file(options.file);
  if (!findings) {
    fmt::print(stderr, "{}\n", findings.error().to_string());
    exit_with(kExitUsage);
    return;
  }
  std::size_t errors = 0;
  std::size_t warnings = 0;
  for (const auto& d : *findings) {
    if (d.severity == cia306::Severity::error) {
      ++errors;
    } else {
      ++warnings;
      if (options.no_warnings) continue;
    }
    fmt::print("{}\n", d.to_string());
  }
  fmt::print("{}: {} error{}, {} warning{}\n", options.file, errors, errors == 1 ? "" : "s",
             warnings, warnings == 1 ? "" : "s");
  exit_with(errors == 0 ? kExitPass : kExitFail);
}

struct Row {
  std::string index, sub, name, object, type, access, pdo, value, parameter_value;
};

std::string type_name(const cia306::EntryKeys& keys) {
  if (const auto t = keys.basic_type()) return std::string(cia301::info(*t).name);
  if (keys.data_type) return fmt::format("0x{:04X}", *keys.data_type);
  return "";
}

Row entry_row(std::uint16_t index, std::string sub, const cia306::EntryKeys& k, std::string name) {
  return {fmt::format("{:04X}h", index),
          std::move(sub),
          std::move(name),
          std::string(cia301::to_string(k.object_type)),
          type_name(k),
          k.access_type ? std::string(cia301::to_string(*k.access_type)) : "",
          k.pdo_mapping ? "yes" : "no",
          k.default_value.value_or(""),
          k.parameter_value.value_or("")};
}

std::vector<Row> dump_rows(const cia306::Eds& eds) {
  std::vector<Row> rows;
  for (const auto& o : eds.objects) {
    const auto code = o.keys.object_type;
    if (!cia301::has_sub_entries(code)) {
      rows.push_back(entry_row(o.index, "0", o.keys, o.keys.parameter_name));
      continue;
    }
    rows.push_back({fmt::format("{:04X}h", o.index), "", o.keys.parameter_name,
                    std::string(cia301::to_string(code)), "", "", "", "", ""});
    if (o.compact_sub_obj) {
      rows.push_back({fmt::format("{:04X}h", o.index), "0", "NrOfObjects", "VAR", "UNSIGNED8", "ro",
                      "no", fmt::format("{}", *o.compact_sub_obj), ""});
      for (unsigned sub = 1; sub <= *o.compact_sub_obj; ++sub) {
        std::string name = fmt::format("{}{}", o.keys.parameter_name, sub);
        for (const auto& n : o.names) {
          if (n.sub_index == sub) name = n.text;
        }
        Row row = entry_row(o.index, fmt::format("{}", sub), o.keys, std::move(name));
        row.object = "VAR";
        row.parameter_value.clear();
        for (const auto& v : o.values) {
          if (v.sub_index == sub) row.parameter_value = v.text;
        }
        rows.push_back(std::move(row));
      }
      continue;
    }
    for (const auto& s : o.subs) {
      rows.push_back(
          entry_row(o.index, fmt::format("{}", s.sub_index), s.keys, s.keys.parameter_name));
    }
  }
  return rows;
}

void print_table(const std::vector<Row>& rows, bool dcf) {
  Row header{"Index", "Sub", "Name", "Object", "Type", "Access", "PDO", "Default", "Value"};
  std::vector<std::string Row::*> columns = {&Row::index, &Row::sub,    &Row::name, &Row::object,
                                             &Row::type,  &Row::access, &Row::pdo,  &Row::value};
  if (dcf) columns.push_back(&Row::parameter_value);
  std::vector<std::size_t> widths;
  for (const auto column : columns) {
    std::size_t w = (header.*column).size();
    for (const auto& r : rows)
      w = std::max(w, (r.*column).size());
    widths.push_back(w);
  }
  auto print_row = [&](const Row& r) {
    std::string line;
    for (std::size_t i = 0; i < columns.size(); ++i) {
      line += fmt::format("{:<{}}", r.*columns[i], widths[i]);
      if (i + 1 < columns.size()) line += "  ";
    }
    while (!line.empty() && line.back() == ' ')
      line.pop_back();
    fmt::print("{}\n", line);
  };
  print_row(header);
  for (const auto& r : rows)
    print_row(r);
}

void run_dump(const EdsOptions& options) {
  auto read = cia306::read_eds_file(options.file);
  if (!read) {
    fmt::print(stderr, "{}\n", read.error().to_string());
    exit_with(kExitUsage);
    return;
  }
  for (const auto& d : read->diagnostics) {
    if (d.severity == cia306::Severity::error) fmt::print(stderr, "{}\n", d.to_string());
  }
  const auto& eds = read->eds;
  const auto& di = eds.device_info;
  fmt::print("{} {} ({}), vendor 0x{:08X}, product 0x{:08X}, revision 0x{:08X}{}\n",
             di.vendor_name.value_or("?"), di.product_name.value_or("?"),
             eds.is_dcf() ? "DCF" : "EDS", di.vendor_number.value_or(0),
             di.product_number.value_or(0), di.revision_number.value_or(0),
             eds.is_dcf() && eds.commissioning->node_id
                 ? fmt::format(", node-ID {}", *eds.commissioning->node_id)
                 : std::string());
  print_table(dump_rows(eds), eds.is_dcf());
  exit_with(read->has_errors() ? kExitFail : kExitPass);
}

}  // namespace

void add_eds_command(CLI::App& app) {
  auto options = std::make_shared<EdsOptions>();
  CLI::App* eds = app.add_subcommand("eds", "Check or show an EDS/DCF file (CiA 306)");
  eds->require_subcommand(1);

  CLI::App* lint = eds->add_subcommand(
      "lint", "Check an EDS/DCF file: exit 0 clean, 1 findings of error severity, 2 unreadable");
  lint->add_option("FILE", options->file, "EDS or DCF file")->required();
  lint->add_flag("--no-warnings", options->no_warnings, "Print error-severity findings only");
  lint->callback([options] { run_lint(*options); });

  CLI::App* dump = eds->add_subcommand("dump", "Print the object dictionary of an EDS/DCF file");
  dump->add_option("FILE", options->file, "EDS or DCF file")->required();
  dump->callback([options] { run_dump(*options); });
}

}  // namespace drivecheck::cli
