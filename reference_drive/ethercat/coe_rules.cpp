#include "reference_drive/ethercat/coe_rules.hpp"

#include <type_traits>
#include <utility>
#include <variant>

namespace drivecheck::reference_drive::ethercat {

namespace ecat = drivecheck::ethercat;
using cia301::SdoAbort;

namespace {

ecat::CoeAbort abort_response(const cia301::Multiplexer& mux, SdoAbort code) {
  return ecat::CoeAbort{mux, static_cast<std::uint32_t>(code)};
}

}  // namespace

std::optional<ecat::CoeSdoResponse> CoeRulesHook::before(ecat::CoeSdoRequest* request) {
  if (request != nullptr) {
    std::optional<ecat::CoeAbort> refused;
    std::visit(
        [&](const auto& m) {
          using T = std::decay_t<decltype(m)>;
          if constexpr (std::is_same_v<T, ecat::CoeDownloadInitiate> ||
                        std::is_same_v<T, ecat::CoeUploadInitiate>) {
            if (rules_.is_absent(m.mux.index)) {
              refused = abort_response(m.mux, SdoAbort::object_does_not_exist);
              return;
            }
          }
          if constexpr (std::is_same_v<T, ecat::CoeDownloadInitiate>) {
            if (rules_.max_sdo_size && !m.expedited && m.size_indicated &&
                m.complete_size > *rules_.max_sdo_size) {
              refused = abort_response(m.mux, SdoAbort::length_too_high);
            }
          }
        },
        *request);
    if (refused) {
      if (reset_server_) reset_server_();  // the refused initiate replaces a transfer
      return ecat::CoeSdoResponse{std::move(*refused)};
    }
  }
  return inner_ != nullptr ? inner_->before(request) : std::nullopt;
}

std::optional<ecat::CoeSdoResponse> CoeRulesHook::after(const ecat::CoeSdoRequest* request,
                                                        ecat::CoeSdoResponse response) {
  if (rules_.max_sdo_size) {
    if (const auto* upload = std::get_if<ecat::CoeUploadInitiateResponse>(&response)) {
      const std::size_t size = upload->size_indicated ? upload->complete_size : upload->data.size();
      if (!upload->expedited && size > *rules_.max_sdo_size) {
        if (reset_server_) reset_server_();  // the server began a segmented upload
        response = abort_response(upload->mux, SdoAbort::unsupported_access);
      }
    }
  }
  if (inner_ != nullptr) return inner_->after(request, std::move(response));
  return response;
}

}  // namespace drivecheck::reference_drive::ethercat
