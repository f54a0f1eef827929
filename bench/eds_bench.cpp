// EDS/DCF throughput and object dictionary hot-path cost.
//
//   BM_ReadEds           parse a generated EDS: bytes/s (MB/s) and objects/s
//   BM_ReadAndLint       parse + all lint checks
//   BM_WriteEds          canonical writer
//   BM_ToDictionary      model -> cia301::ObjectDictionary
//   BM_OdExpeditedRead   one SDO-style read of a 2-byte entry (binary search + view)
//   BM_OdExpeditedWrite  one SDO-style write of a 4-byte entry
//
// The generated EDS looks like a big servo drive: 4 RPDO/TPDO pairs with 8 mapping entries,
// and `objects` manufacturer objects, every fourth a RECORD with 8 sub-objects.
#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <string>

#include "protocol/cia306/eds.hpp"
#include "protocol/cia306/eds_lint.hpp"

namespace {

using drivecheck::cia306::read_eds;

void var(std::string& out, const std::string& section, const std::string& name, int type,
         const char* access, const std::string& value, bool pdo = false) {
  out += fmt::format(
      "\n[{}]\nParameterName={}\nObjectType=0x7\nDataType=0x{:04X}\nAccessType={}\nDefaultValue={}"
      "\n"
      "PDOMapping={}\n",
      section, name, type, access, value, pdo ? 1 : 0);
}

std::string generate_eds(int objects) {
  std::string out =
      "[FileInfo]\nFileName=bench.eds\nFileVersion=1\nFileRevision=0\nEDSVersion=4.0\n"
      "Description=Generated for eds_bench\nCreationTime=12:00PM\nCreationDate=01-01-2024\n"
      "CreatedBy=eds_bench\n\n[DeviceInfo]\nVendorName=Bench\nVendorNumber=0x1\nProductName=Bench "
      "drive\nProductNumber=0x1\nRevisionNumber=0x1\nBaudRate_500=1\nBaudRate_1000=1\n"
      "NrOfRXPDO=4\nNrOfTXPDO=4\n\n[MandatoryObjects]\nSupportedObjects=3\n1=0x1000\n2=0x1001\n"
      "3=0x1018\n";
  var(out, "1000", "Device type", 7, "ro", "0x00020192");
  var(out, "1001", "Error register", 5, "ro", "0", true);
  out += "\n[1018]\nParameterName=Identity object\nObjectType=0x9\nSubNumber=2\n";
  var(out, "1018sub0", "Highest sub-index supported", 5, "ro", "1");
  var(out, "1018sub1", "Vendor-ID", 7, "ro", "0x1");
  out += "\n[OptionalObjects]\nSupportedObjects=18\n1=0x1017\n2=0x6040\n";
  int n = 3;
  for (int base : {0x1400, 0x1600, 0x1800, 0x1A00}) {
    for (int i = 0; i < 4; ++i)
      out += fmt::format("{}=0x{:04X}\n", n++, base + i);
  }
  var(out, "1017", "Producer heartbeat time", 6, "rw", "0");
  var(out, "6040", "Controlword", 6, "rww", "0", true);
  for (int i = 0; i < 4; ++i) {
    for (const int comm : {0x1400, 0x1800}) {
      const int index = comm + i;
      out += fmt::format(
          "\n[{:04X}]\nParameterName=PDO {} communication\nObjectType=0x9\nSubNumber=3\n", index,
          i + 1);
      var(out, fmt::format("{:04X}sub0", index), "Highest sub-index supported", 5, "ro", "2");
      var(out, fmt::format("{:04X}sub1", index), "COB-ID", 7, "rw",
          fmt::format("$NODEID+0x{:X}", (comm == 0x1400 ? 0x200 : 0x180) + 0x100 * i));
      var(out, fmt::format("{:04X}sub2", index), "Transmission type", 5, "rw", "0xFF");
      const int map = index + 0x200;
      out += fmt::format("\n[{:04X}]\nParameterName=PDO {} mapping\nObjectType=0x9\nSubNumber=9\n",
                         map, i + 1);
      var(out, fmt::format("{:04X}sub0", map), "Number of mapped objects", 5, "rw",
          comm == 0x1400 ? "1" : "0");
      for (int k = 1; k <= 8; ++k) {
        var(out, fmt::format("{:04X}sub{:X}", map, k), fmt::format("Mapping entry {}", k), 7, "rw",
            k == 1 && comm == 0x1400 ? "0x60400010" : "0");
      }
    }
  }
  out += fmt::format("\n[ManufacturerObjects]\nSupportedObjects={}\n", objects);
  for (int i = 0; i < objects; ++i)
    out += fmt::format("{}=0x{:04X}\n", i + 1, 0x2000 + i);
  for (int i = 0; i < objects; ++i) {
    const int index = 0x2000 + i;
    if (i % 4 == 3) {
      out += fmt::format(
          "\n[{:04X}]\nParameterName=Parameter set {}\nObjectType=0x9\nSubNumber=9\n", index, i);
      var(out, fmt::format("{:04X}sub0", index), "Highest sub-index supported", 5, "ro", "8");
      for (int k = 1; k <= 8; ++k) {
        var(out, fmt::format("{:04X}sub{:X}", index, k), fmt::format("Gain {}", k), 4, "rw",
            fmt::format("{}", k * 100 - 400), true);
      }
    } else {
      var(out, fmt::format("{:04X}", index), fmt::format("Vendor parameter {}", i), 7, "rw",
          fmt::format("0x{:08X}", i * 2654435761u));
    }
  }
  return out;
}

const std::string& bench_text() {
  static const std::string text = generate_eds(4000);
  return text;
}

void BM_ReadEds(benchmark::State& state) {
  const std::string& text = bench_text();
  std::size_t objects = 0;
  for (auto _ : state) {
    auto result = read_eds(text, "bench.eds");
    objects = result.eds.objects.size();
    benchmark::DoNotOptimize(result);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * text.size()));
  state.counters["objects/s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * objects), benchmark::Counter::kIsRate);
  state.counters["objects"] = static_cast<double>(objects);
  state.counters["MiB"] = static_cast<double>(text.size()) / (1024.0 * 1024.0);
}
BENCHMARK(BM_ReadEds)->Unit(benchmark::kMillisecond);

void BM_ReadAndLint(benchmark::State& state) {
  const std::string& text = bench_text();
  for (auto _ : state) {
    auto findings = drivecheck::cia306::lint_eds_text(text, "bench.eds");
    if (drivecheck::cia306::has_errors(findings)) state.SkipWithError("generated EDS has errors");
    benchmark::DoNotOptimize(findings);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_ReadAndLint)->Unit(benchmark::kMillisecond);

void BM_WriteEds(benchmark::State& state) {
  const auto eds = read_eds(bench_text()).eds;
  std::size_t bytes = 0;
  for (auto _ : state) {
    auto text = drivecheck::cia306::write_eds(eds);
    bytes = text.size();
    benchmark::DoNotOptimize(text);
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes));
}
BENCHMARK(BM_WriteEds)->Unit(benchmark::kMillisecond);

void BM_ToDictionary(benchmark::State& state) {
  const auto eds = read_eds(bench_text()).eds;
  for (auto _ : state) {
    auto od = drivecheck::cia306::to_object_dictionary(eds, 5);
    if (!od) state.SkipWithError("dictionary failed");
    benchmark::DoNotOptimize(od);
  }
  state.counters["objects/s"] = benchmark::Counter(
      static_cast<double>(state.iterations() * eds.objects.size()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ToDictionary)->Unit(benchmark::kMillisecond);

drivecheck::cia301::ObjectDictionary& bench_dictionary() {
  static auto od =
      std::move(*drivecheck::cia306::to_object_dictionary(read_eds(bench_text()).eds, 5));
  return od;
}

void BM_OdExpeditedRead(benchmark::State& state) {
  auto& od = bench_dictionary();
  for (auto _ : state) {
    auto bytes = od.read(0x6040, 0);
    benchmark::DoNotOptimize(bytes);
  }
}
BENCHMARK(BM_OdExpeditedRead);

void BM_OdExpeditedWrite(benchmark::State& state) {
  auto& od = bench_dictionary();
  const std::uint8_t value[] = {0x2C, 0x01, 0x00, 0x00};  // 300
  for (auto _ : state) {
    auto ok = od.write(0x2013, 3, value);
    benchmark::DoNotOptimize(ok);
  }
}
BENCHMARK(BM_OdExpeditedWrite);

}  // namespace
