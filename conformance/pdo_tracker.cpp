// The DUT's PDO configuration followed from the bus, and PDO frames decoded into samples
// (pdo_tracker.hpp).
#include "conformance/pdo_tracker.hpp"

#include <algorithm>
#include <variant>

#include "conformance/samples.hpp"
#include "protocol/cia301/data_type.hpp"

namespace drivecheck::conformance {
namespace {

using cia301::PdoDirection;

constexpr std::uint32_t kCobIdNotValid = 0x80000000U;
constexpr std::uint32_t kCobIdExtended = 0x20000000U;
constexpr std::array<std::uint8_t, 4> kSave{0x73, 0x61, 0x76, 0x65};  // "save"
constexpr std::array<std::uint8_t, 4> kLoad{0x6C, 0x6F, 0x61, 0x64};  // "load"

// The PDO an object index belongs to: direction, number 1..512, and whether it is the mapping
// record (else the communication record).
struct PdoObject {
  PdoDirection direction = PdoDirection::transmit;
  std::uint16_t number = 0;
  bool mapping = false;
};
std::optional<PdoObject> pdo_object(std::uint16_t index) {
  struct Range {
    std::uint16_t base;
    PdoDirection direction;
    bool mapping;
  };
  constexpr std::array<Range, 4> kRanges{{
      {cia301::kRpdoCommunicationBase, PdoDirection::receive, false},
      {cia301::kRpdoMappingBase, PdoDirection::receive, true},
      {cia301::kTpdoCommunicationBase, PdoDirection::transmit, false},
      {cia301::kTpdoMappingBase, PdoDirection::transmit, true},
  }};
  for (const auto& range : kRanges) {
    if (index >= range.base && index < range.base + cia301::kMaxPdoNumber)
      return PdoObject{range.direction, static_cast<std::uint16_t>(index - range.base + 1),
                       range.mapping};
  }
  return std::nullopt;
}

bool is_command(std::span<const std::uint8_t> data, const std::array<std::uint8_t, 4>& word) {
  return data.size() == 4 && std::equal(word.begin(), word.end(), data.begin());
}

}  // namespace

bool decode_pdo_samples(const cia301::PdoMapping& mapping, std::span<const std::uint8_t> payload,
                        can::TimePoint at, SampleOrigin origin, std::vector<Sample>& out) {
  const auto values = cia301::unpack_pdo(mapping, payload);
  if (!values) return false;
  for (const auto& value : *values) {
    const SignalInfo* signal = signal_of(value.entry.index, value.entry.sub_index);
    if (signal == nullptr) continue;
    out.push_back(Sample{at, std::string(signal->name),
                         signal_value(value.raw, value.entry.bits, signal->is_signed), origin});
  }
  return true;
}

PdoTracker::PdoTracker(const profile::DriveProfile& profile, std::uint8_t node) : node_(node) {
  for (const auto& pdo : profile.pdo_defaults) {
    const auto direction =
        pdo.kind == profile::PdoKind::tpdo ? PdoDirection::transmit : PdoDirection::receive;
    TrackedPdo tracked;
    tracked.cob_id = pdo.cob_id.resolve(node);
    if (pdo.mapping.size() <= tracked.entries.size()) {
      tracked.count = static_cast<std::uint8_t>(pdo.mapping.size());
      for (std::size_t i = 0; i < pdo.mapping.size(); ++i)
        tracked.entries[i] = pdo.mapping[i];
    }
    defaults_[{direction, pdo.number}] = tracked;
  }
  stored_ = defaults_;
  current_ = defaults_;
}

TrackedPdo PdoTracker::state(PdoDirection direction, std::uint16_t number) const {
  const auto it = current_.find({direction, number});
  return it == current_.end() ? TrackedPdo{} : it->second;
}

std::optional<std::uint32_t> PdoTracker::can_id(PdoDirection direction,
                                                std::uint16_t number) const {
  std::optional<std::uint32_t> cob_id = state(direction, number).cob_id;
  if (!cob_id) {
    // Never configured nor read: the pre-defined connection set (CiA 301 §7.3.5), PDOs 1-4.
    if (number < 1 || number > 4) return std::nullopt;
    const std::uint32_t base = direction == PdoDirection::transmit ? 0x180U : 0x200U;
    return base + 0x100U * (number - 1U) + node_;
  }
  if ((*cob_id & (kCobIdNotValid | kCobIdExtended)) != 0) return std::nullopt;
  if ((*cob_id & 0x1FFFFFFFU) > can::kMaxStandardId) return std::nullopt;
  return *cob_id & can::kMaxStandardId;
}

std::optional<cia301::PdoMapping> PdoTracker::mapping(PdoDirection direction,
                                                      std::uint16_t number) const {
  const TrackedPdo tracked = state(direction, number);
  if (!tracked.count || *tracked.count > tracked.entries.size()) return std::nullopt;
  cia301::PdoMapping result;
  for (std::size_t i = 0; i < *tracked.count; ++i) {
    if (!tracked.entries[i]) return std::nullopt;
    const auto entry = cia301::decode_pdo_mapping_entry(*tracked.entries[i]);
    if (!entry) return std::nullopt;
    result.entries.push_back(*entry);
  }
  if (!result.validate()) return std::nullopt;
  return result;
}

void PdoTracker::apply(cia301::Multiplexer mux, std::span<const std::uint8_t> data) {
  if ((mux.index == 0x1010 || mux.index == 0x1011) && (mux.sub_index == 1 || mux.sub_index == 2)) {
    if (mux.index == 0x1010 && is_command(data, kSave)) stored_ = current_;
    if (mux.index == 0x1011 && is_command(data, kLoad)) stored_ = defaults_;
    return;
  }
  const auto object = pdo_object(mux.index);
  if (!object || data.empty()) return;
  const std::uint64_t value =
      cia301::load_unsigned(data.first(std::min<std::size_t>(data.size(), 8)));
  TrackedPdo& tracked = current_[{object->direction, object->number}];
  if (!object->mapping) {
    if (mux.sub_index == cia301::pdo_sub::kCobId)
      tracked.cob_id = static_cast<std::uint32_t>(value);
    return;
  }
  if (mux.sub_index == 0) {
    tracked.count = static_cast<std::uint8_t>(value);
  } else if (mux.sub_index <= tracked.entries.size()) {
    tracked.entries[mux.sub_index - 1U] = static_cast<std::uint32_t>(value);
  }
}

void PdoTracker::forget(cia301::Multiplexer mux) {
  const auto object = pdo_object(mux.index);
  if (!object) {
    // A segmented "save"/"load" is unusual but possible: what a reset brings back is unknown.
    if ((mux.index == 0x1010 || mux.index == 0x1011) && mux.sub_index != 0) stored_.clear();
    return;
  }
  TrackedPdo& tracked = current_[{object->direction, object->number}];
  if (!object->mapping) {
    if (mux.sub_index == cia301::pdo_sub::kCobId) tracked.cob_id.reset();
  } else if (mux.sub_index == 0) {
    tracked.count.reset();
  } else if (mux.sub_index <= tracked.entries.size()) {
    tracked.entries[mux.sub_index - 1U].reset();
  }
}

void PdoTracker::reset() {
  current_ = stored_;
  download_.reset();
  upload_.reset();
}

void PdoTracker::on_sdo_request(const can::Frame& frame) {
  const auto message = cia301::decode_client_message(frame);
  download_.reset();
  upload_.reset();
  if (const auto* download = std::get_if<cia301::InitiateDownloadRequest>(&message)) {
    Pending pending;
    pending.mux = download->mux;
    pending.expedited = download->expedited;
    if (download->expedited) {
      const auto data = download->expedited_data();
      pending.data.emplace(data.begin(), data.end());
    }
    download_ = std::move(pending);
  } else if (const auto* upload = std::get_if<cia301::InitiateUploadRequest>(&message)) {
    upload_ = upload->mux;
  }
}

void PdoTracker::on_sdo_response(const can::Frame& frame) {
  const auto message = cia301::decode_server_message(frame);
  if (const auto* confirmed = std::get_if<cia301::InitiateDownloadResponse>(&message)) {
    if (download_ && download_->mux == confirmed->mux) {
      if (download_->expedited && download_->data)
        apply(download_->mux, *download_->data);
      else
        forget(download_->mux);
    }
    download_.reset();
  } else if (const auto* read = std::get_if<cia301::InitiateUploadResponse>(&message)) {
    if (upload_ && *upload_ == read->mux) {
      if (read->expedited) apply(read->mux, read->expedited_data());
      // A segmented upload of a PDO object: the value is not followed, but it is not changed.
    }
    upload_.reset();
  } else if (std::holds_alternative<cia301::AbortTransfer>(message)) {
    download_.reset();
    upload_.reset();
  }
}

void PdoTracker::decode(const can::Frame& frame, PdoDirection direction, can::TimePoint at,
                        std::vector<Sample>& samples) {
  // Few PDOs are ever configured: a linear look over the known ones.
  const auto try_pdo = [&](std::uint16_t number) {
    const auto id = can_id(direction, number);
    if (!id || *id != frame.id) return false;
    const auto map = mapping(direction, number);
    if (!map) return true;  // this PDO, mapping unknown: no sample
    const auto origin =
        direction == PdoDirection::transmit ? SampleOrigin::tpdo : SampleOrigin::rpdo;
    if (!decode_pdo_samples(*map, frame.payload(), at, origin, samples)) ++short_frames_;
    return true;
  };
  // (A PDO never configured nor read has no known mapping: nothing to decode.)
  for (const auto& [key, tracked] : current_) {
    if (key.first == direction && try_pdo(key.second)) return;
  }
}

void PdoTracker::on_frame(const can::Frame& frame, bool from_harness, can::TimePoint at,
                          std::vector<Sample>& samples) {
  if (frame.is_error() || frame.is_extended()) return;
  if (from_harness) {
    if (frame.is_remote()) return;
    if (frame.id == 0 && frame.length() == 2 && (frame.data[0] == 0x81 || frame.data[0] == 0x82) &&
        (frame.data[1] == 0 || frame.data[1] == node_)) {
      reset();  // NMT reset node / reset communication
      return;
    }
    if (frame.id == cia301::kSdoRequestBase + node_) {
      on_sdo_request(frame);
      return;
    }
    decode(frame, PdoDirection::receive, at, samples);
    return;
  }
  if (frame.id == 0x700U + node_ && frame.length() == 1 && frame.data[0] == 0) {
    reset();  // boot-up: the DUT has reset its communication
    return;
  }
  if (frame.id == cia301::kSdoResponseBase + node_) {
    on_sdo_response(frame);
    return;
  }
  if (frame.is_remote()) return;
  decode(frame, PdoDirection::transmit, at, samples);
}

}  // namespace drivecheck::conformance
