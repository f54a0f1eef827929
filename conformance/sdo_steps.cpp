// SDO transfers as the engine runs them (through the DUT port, dut_port.hpp: on CAN driven by
// the engine's own receive loop, so that every frame is evidence) and the stimulus steps.
#include <fmt/format.h>

#include <algorithm>

#include "conformance/vector_run.hpp"
#include "protocol/cia301/data_type.hpp"
#include "protocol/cia301/nmt_master.hpp"
#include "protocol/cia301/object_dictionary.hpp"
#include "protocol/cia301/sdo_client.hpp"
#include "protocol/profile/vocabulary.hpp"

namespace drivecheck::conformance {
namespace {

// Little-endian bytes of `value`, `size` long.
std::vector<std::uint8_t> le_bytes(std::int64_t value, std::size_t size) {
  std::vector<std::uint8_t> bytes(size);
  cia301::store_unsigned(static_cast<std::uint64_t>(value), bytes);
  return bytes;
}

}  // namespace

SdoOutcome VectorRun::sdo_upload(cia301::Multiplexer mux, Transfer transfer,
                                 std::uint8_t block_size) {
  auto outcome =
      context_.port.upload(*this, {mux, transfer, resolve({{}, "sdo_response"}), block_size});
  if (outcome.ok) sample(mux.index, mux.sub_index, outcome.data);
  if (outcome.ok && mux.index == 0x1017 && mux.sub_index == 0 && outcome.data.size() == 2)
    heartbeat_time_ = std::chrono::milliseconds(outcome.data[0] | outcome.data[1] << 8);
  return outcome;
}

SdoOutcome VectorRun::sdo_download(cia301::Multiplexer mux, std::span<const std::uint8_t> data,
                                   Transfer transfer, std::optional<can::Duration> timeout) {
  auto outcome = context_.port.download(
      *this, {mux, transfer, timeout.value_or(resolve({{}, "sdo_response"}))}, data);
  sample(mux.index, mux.sub_index, data);
  if (outcome.ok && mux.index == 0x1017 && mux.sub_index == 0 && data.size() == 2)
    heartbeat_time_ = std::chrono::milliseconds(data[0] | data[1] << 8);
  return outcome;
}

std::size_t VectorRun::object_size(std::uint16_t index, std::uint8_t sub) const {
  for (const auto& object : context_.profile.objects) {
    if (object.index == index && object.sub == sub) {
      const auto size = cia301::info(object.type).size;
      if (size != 0) return size;
    }
  }
  if (context_.options.eds != nullptr) {
    if (const auto* entry = context_.options.eds->find(index, sub)) {
      const auto size = cia301::info(entry->type()).size;
      if (size != 0) return size;
    }
  }
  return 4;
}

std::optional<std::int64_t> VectorRun::value_of(const ValueSpec& spec, std::string& error) const {
  if (spec.saved.empty()) return spec.literal;
  const auto it = saved_.find(spec.saved);
  if (it == saved_.end()) {
    error =
        fmt::format("no value was saved as '{}' (its sdo_read failed or did not run)", spec.saved);
    return std::nullopt;
  }
  // $name*m/d+k: the product first, then the division (toward zero), then the sum.
  std::int64_t product = 0;
  std::int64_t sum = 0;
  if (__builtin_mul_overflow(it->second, spec.multiplier, &product) ||
      __builtin_add_overflow(product / spec.divisor, spec.offset, &sum)) {
    error = fmt::format("{}: {} is outside INTEGER64 on the way", to_text(spec), it->second);
    return std::nullopt;
  }
  return sum;
}

StepStatus VectorRun::write_controlword(std::uint16_t value, std::string action) {
  const std::array<std::uint8_t, 2> bytes{static_cast<std::uint8_t>(value),
                                          static_cast<std::uint8_t>(value >> 8)};
  const auto outcome = sdo_download({0x6040, 0}, bytes);
  const auto expected = fmt::format("controlword 6040h := {:04X}h ({}) accepted", value,
                                    cia402::describe_controlword(value));
  if (!outcome.ok) return fail(std::move(action), expected, outcome.describe(), outcome.observed());
  check(std::move(action), expected, "ok", true);
  return StepStatus::ok;
}

StepStatus VectorRun::run_stimulus(const Step& step) {
  const auto& action = step.action;
  const std::string name(action_name(action));
  if (const auto* request = std::get_if<SdoRequestStep>(&action)) {
    // On CAN the request is the frame 600h+N: sent as the `send` it stands for (below).
    if (context_.port.link() != LinkKind::can) return send_coe_sdo_request(request->send, name);
  }
  if (const auto* send_step = frame_sent(step)) {
    const auto frame = send_step->frame.to_frame(node());
    const bool nmt = frame.id == 0 && !frame.is_extended() && !frame.is_remote();
    // The step asks for the frame when the previous step ended; its echo tells when it went
    // out (a late one makes later timing checks `error: harness late`).
    // (An NMT frame may wait for $timing.nmt_spacing first: not tracked.)
    if (!nmt) send_asked_ = step_started_;
    const auto ec = nmt ? send_nmt(frame, true) : send(frame);
    send_asked_.reset();
    if (ec) return harness_error(name, fmt::format("cannot send {}: {}", frame, ec.message()));
    return StepStatus::ok;
  }
  if (const auto* nmt = std::get_if<NmtStep>(&action)) {
    std::uint8_t target = node();
    switch (nmt->node.kind) {
      case NodeKind::dut:
        break;
      case NodeKind::broadcast:
        target = 0;
        break;
      case NodeKind::other:
        target = static_cast<std::uint8_t>(node() % 127 + 1);
        break;
      case NodeKind::value:
        target = nmt->node.value;
        break;
    }
    cia301::NmtMaster master;
    const auto frame = master.command(nmt->command, target);
    if (auto ec = send_nmt(frame))
      return harness_error(name, fmt::format("cannot send {}: {}", frame, ec.message()));
    return StepStatus::ok;
  }
  if (const auto* write = std::get_if<SdoWriteStep>(&action)) {
    std::vector<std::uint8_t> data = write->data;
    if (write->value) {
      std::string error;
      const auto value = value_of(*write->value, error);
      if (!value) return harness_error(name, error);
      data = le_bytes(*value, write->size.value_or(object_size(write->index, write->sub)));
    }
    const auto outcome = sdo_download({write->index, write->sub}, data, write->transfer);
    const auto what = fmt::format("write {:04X}h sub {} := {:02X}", write->index, write->sub,
                                  fmt::join(data, " "));
    if (write->expect.kind == SdoExpect::Kind::abort) {
      const auto expected = fmt::format("{}: {}", what, write->expect.abort.describe());
      const bool ok = outcome.abort && write->expect.abort.accepts(*outcome.abort);
      if (!ok) return fail(name, expected, outcome.describe(), outcome.observed());
      check(name, expected, outcome.describe(), true);
      return StepStatus::ok;
    }
    if (write->expect.kind == SdoExpect::Kind::ok_or_abort) {
      const auto expected = fmt::format("{}: confirmed or aborted (either is permitted)", what);
      if (!outcome.ok && !outcome.abort) return fail(name, expected, outcome.describe());
      check(name, expected, outcome.describe(), true);
      return StepStatus::ok;
    }
    if (const auto& refusal = write->expect.or_abort) {
      const auto expected = fmt::format("{}: ok, or {}", what, refusal->describe());
      if (!outcome.ok && !(outcome.abort && refusal->accepts(*outcome.abort)))
        return fail(name, expected, outcome.describe(), outcome.observed());
      check(name, expected, outcome.describe(), true);
      return StepStatus::ok;
    }
    if (const auto& refusal = write->refused_means_not_applicable) {
      // A value CiA lets the device refuse (FORMAT.md "Values the device may refuse"): a
      // refusal in the set ends the vector as not applicable, any other answer is judged.
      const auto expected =
          fmt::format("{}: ok, or (not applicable) {}", what, refusal->describe());
      if (outcome.ok) {
        check(name, expected, "ok", true);
        return StepStatus::ok;
      }
      if (!outcome.abort || !refusal->accepts(*outcome.abort))
        return fail(name, expected, outcome.describe(), outcome.observed());
      check(name, expected, outcome.describe(), true);
      std::string value = fmt::format("{:02X}", fmt::join(data, " "));
      if (write->value) {
        std::string error;
        if (const auto resolved = value_of(*write->value, error))
          // As the manuals write values: small ones and negative ones in decimal, others in hex.
          value = *resolved < 10 ? fmt::format("{}", *resolved) : fmt::format("{:X}h", *resolved);
      }
      message_ = fmt::format(
          "device refused {:04X}h{} = {} ({:08X}h), a value it may refuse ({}): {}, "
          "{}:{}",
          write->index, write->sub == 0 ? std::string() : fmt::format(" sub {}", write->sub), value,
          *outcome.abort, step.clause, current_place(), vector_.file, step.line);
      return StepStatus::not_applicable;
    }
    const auto expected = fmt::format("{}: ok", what);
    if (!outcome.ok) return fail(name, expected, outcome.describe(), outcome.observed());
    check(name, expected, "ok", true);
    return StepStatus::ok;
  }
  if (const auto* read = std::get_if<SdoReadStep>(&action)) {
    // With relative_to the value judged is a difference: "read 6064h sub 0 - $start".
    const auto what =
        fmt::format("read {:04X}h sub {}{}", read->index, read->sub,
                    read->relative_to.empty() ? std::string() : " - $" + read->relative_to);
    if (const auto& entry = read->expect.mapping_entry) {
      std::string error;
      const auto count = value_of(ValueSpec{0, entry->count, 0}, error);
      if (!count) return harness_error(name, error);
      if (read->sub > *count) {
        check(name, fmt::format("{}: a mapping entry if in use (entries 1..{})", what, *count),
              "not in use: not read", true);
        return StepStatus::ok;
      }
      const auto outcome = sdo_upload({read->index, read->sub}, read->transfer, read->block_size);
      const auto expected = fmt::format("{}: an entry {}, or a gap", what, entry->direction);
      if (!outcome.ok || outcome.data.empty() || outcome.data.size() > 4)
        return fail(name, expected, outcome.describe(), outcome.observed());
      const auto raw = static_cast<std::uint32_t>(cia301::load_unsigned(outcome.data));
      const auto index = static_cast<std::uint16_t>(raw >> 16);
      const auto sub = static_cast<std::uint8_t>(raw >> 8);
      const bool gap = index <= 0x0007;
      const bool mappable = std::binary_search(entry->mappable.begin(), entry->mappable.end(),
                                               std::uint32_t{index} << 8 | sub);
      const auto actual =
          fmt::format("{:08X}h: {}", raw,
                      gap ? std::string("a gap")
                          : fmt::format("{:04X}h sub {} ({} bits){}", index, sub, raw & 0xFFu,
                                        mappable ? "" : ", which the ESI does not flag so"));
      if (!gap && !mappable) {
        Observation observed;
        observed.value = raw;
        return fail(name, expected, actual, observed);
      }
      check(name, expected, actual, true);
      return StepStatus::ok;
    }
    const auto outcome = sdo_upload({read->index, read->sub}, read->transfer, read->block_size);
    const auto& expect = read->expect;
    if (expect.kind == SdoExpect::Kind::abort) {
      const auto expected = fmt::format("{}: {}", what, expect.abort.describe());
      const bool ok = outcome.abort && expect.abort.accepts(*outcome.abort);
      if (!ok) {
        auto observed = outcome.observed();
        if (outcome.ok && !outcome.data.empty() && outcome.data.size() <= 8)
          observed.value = read->is_signed
                               ? cia301::load_signed(outcome.data)
                               : static_cast<std::int64_t>(cia301::load_unsigned(outcome.data));
        return fail(name, expected, outcome.describe(), observed);
      }
      check(name, expected, outcome.describe(), true);
      return StepStatus::ok;
    }
    if (expect.kind == SdoExpect::Kind::ok_or_abort) {
      const auto expected = fmt::format("{}: answered or aborted (either is permitted)", what);
      if (!outcome.ok && !outcome.abort) return fail(name, expected, outcome.describe());
      check(name, expected, outcome.describe(), true);
      return StepStatus::ok;
    }
    if (!outcome.ok && outcome.abort && expect.or_abort &&
        expect.or_abort->accepts(*outcome.abort)) {
      check(name, fmt::format("{}: a value, or {}", what, expect.or_abort->describe()),
            outcome.describe(), true);
      return StepStatus::ok;
    }
    if (!outcome.ok)
      return fail(name,
                  expect.or_abort
                      ? fmt::format("{}: a value, or {}", what, expect.or_abort->describe())
                      : fmt::format("{}: ok", what),
                  outcome.describe(), outcome.observed());
    const auto& data = outcome.data;
    const std::uint64_t raw =
        cia301::load_unsigned(std::span(data.data(), std::min<std::size_t>(data.size(), 8)));
    const std::int64_t read_value =
        read->is_signed && !data.empty()
            ? cia301::load_signed(std::span(data.data(), std::min<std::size_t>(data.size(), 8)))
            : static_cast<std::int64_t>(raw);
    auto actual =
        outcome.describe() +
        (data.size() <= 8 && !data.empty() ? fmt::format(" = {} ({:X}h)", read_value, raw) : "");
    // relative_to: the value judged and saved is the read minus a value saved before.
    std::int64_t value = read_value;
    if (!read->relative_to.empty()) {
      std::string error;
      const auto base = value_of(ValueSpec{0, read->relative_to}, error);
      if (!base) return harness_error(name, error);
      if (data.empty() || data.size() > 8 || __builtin_sub_overflow(read_value, *base, &value))
        return harness_error(name,
                             fmt::format("{}: no difference of {} and {}", what, actual, *base));
      actual += fmt::format(", minus ${} ({}) = {}", read->relative_to, *base, value);
    }
    if (!read->save.empty()) saved_[read->save] = value;
    std::string expected;
    bool ok = true;
    switch (expect.kind) {
      case SdoExpect::Kind::ok:
        expected = fmt::format("{}: ok", what);
        break;
      case SdoExpect::Kind::value: {
        std::string error;
        const auto want = value_of(expect.value, error);
        if (!want) return harness_error(name, error);
        if (expect.mask) {
          expected = fmt::format("{}: value & {:X}h == {:X}h", what, *expect.mask,
                                 static_cast<std::uint64_t>(*want) & *expect.mask);
          ok = (raw & *expect.mask) == (static_cast<std::uint64_t>(*want) & *expect.mask);
        } else {
          expected =
              fmt::format("{}: value {} ({:X}h)", what, *want, static_cast<std::uint64_t>(*want));
          if (read->is_signed) {
            ok = value == *want;
          } else {
            // Unsigned compare over the bytes received: -1 in 2 bytes is FFFFh.
            const std::uint64_t width =
                data.size() >= 8 ? ~std::uint64_t{0} : (std::uint64_t{1} << (8 * data.size())) - 1;
            const auto want_bits = static_cast<std::uint64_t>(*want);
            ok = raw == (want_bits & width) && (*want < 0 || want_bits <= width);
          }
        }
        break;
      }
      case SdoExpect::Kind::range: {
        std::string error;
        const auto low = value_of(expect.low, error);
        const auto high = low ? value_of(expect.high, error) : std::nullopt;
        if (!low || !high) return harness_error(name, error);
        // A bound from a saved value shows how it was computed: [$p+398 = 1398, ...].
        const auto bound = [](const ValueSpec& spec, std::int64_t v) {
          if (spec.saved.empty()) return fmt::format("{}", v);
          return fmt::format("{} = {}", to_text(spec), v);
        };
        expected = fmt::format("{}: value in [{}, {}]", what, bound(expect.low, *low),
                               bound(expect.high, *high));
        ok = read->is_signed
                 ? value >= *low && value <= *high
                 : raw <= static_cast<std::uint64_t>(std::max<std::int64_t>(*high, 0)) &&
                       (*low <= 0 || raw >= static_cast<std::uint64_t>(*low)) && *high >= 0;
        break;
      }
      case SdoExpect::Kind::size:
        expected = fmt::format("{}: {} byte(s)", what, expect.size);
        ok = data.size() == expect.size;
        break;
      case SdoExpect::Kind::data:
        expected = fmt::format("{}: data {:02X}", what, fmt::join(expect.data, " "));
        ok = data == expect.data;
        break;
      case SdoExpect::Kind::abort:
      case SdoExpect::Kind::ok_or_abort:
        break;
    }
    if (!ok) {
      Observation observed;
      if (!data.empty() && data.size() <= 8) observed.value = value;
      return fail(name, expected, actual, observed);
    }
    check(name, expected, actual, true);
    return StepStatus::ok;
  }
  if (const auto* wait = std::get_if<WaitStep>(&action)) {
    wait_until(now() + resolve(wait->duration));
    return StepStatus::ok;
  }
  if (const auto* cw = std::get_if<ControlwordStep>(&action))
    return write_controlword(cw->value, name);
  if (const auto* simulate = std::get_if<SimulateStep>(&action)) {
    if (context_.options.simulation == nullptr)
      return harness_error(name, "no simulation control (the vector should need `simulation`)");
    const auto error = context_.options.simulation->set_input(simulate->input, simulate->value);
    if (!error.empty())
      return harness_error(
          name, fmt::format("simulate {} = {}: {}", simulate->input, simulate->value, error));
    check(name, fmt::format("simulated input {} := {}", simulate->input, simulate->value), "set",
          true);
    return StepStatus::ok;
  }
  if (const auto* bus_off = std::get_if<BusOffStep>(&action)) {
    if (context_.options.simulation == nullptr)
      return harness_error(name, "no simulation control (the vector should be not applicable)");
    const auto duration = resolve(bus_off->duration);
    if (auto error = context_.options.simulation->set_bus_off(true); !error.empty())
      return harness_error(name, fmt::format("bus-off: {}", error));
    wait_until(now() + duration);
    if (auto error = context_.options.simulation->set_bus_off(false); !error.empty())
      return harness_error(name, fmt::format("bus-off recovery: {}", error));
    check(name,
          fmt::format("DUT's CAN controller bus-off for {}", profile::format_duration(duration)),
          "bus-off, then recovered", true);
    return StepStatus::ok;
  }
  if (const auto* mark = std::get_if<MarkStep>(&action)) {
    set_mark(mark->name, now(), received_.size());
    return StepStatus::ok;
  }
  if (const auto* cyclic = std::get_if<CyclicStep>(&action)) return run_cyclic(step, *cyclic);
  if (is_ethercat_step(action)) return run_ethercat_step(step);
  return StepStatus::ok;  // an expectation: expectations.cpp
}

}  // namespace drivecheck::conformance
