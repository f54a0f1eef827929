#include "reference_drive/ethercat/coe_deviations.hpp"

#include <type_traits>
#include <utility>
#include <variant>

namespace drivecheck::reference_drive::ethercat {

namespace ecat = drivecheck::ethercat;
using Kind = SdoRequestView::Kind;
using AnswerKind = SdoAnswerView::Kind;

namespace {

SdoRequestView request_view(const ecat::CoeSdoRequest* request) {
  SdoRequestView r;
  if (request == nullptr) {
    r.kind = Kind::invalid;
    return r;
  }
  std::visit(
      [&r](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, ecat::CoeDownloadInitiate>) {
          r.index = m.mux.index;
          r.sub = m.mux.sub_index;
          if (m.complete_access) return;
          r.kind = Kind::download;
          r.expedited = m.expedited;
          if (m.expedited) r.data = m.data;
        } else if constexpr (std::is_same_v<T, ecat::CoeUploadInitiate>) {
          r.index = m.mux.index;
          r.sub = m.mux.sub_index;
          if (!m.complete_access) r.kind = Kind::upload;
        } else if constexpr (std::is_same_v<T, ecat::CoeDownloadSegment>) {
          r.kind = Kind::download_segment;
        } else if constexpr (std::is_same_v<T, ecat::CoeUploadSegmentRequest>) {
          r.kind = Kind::upload_segment;
        } else {
          r.index = m.mux.index;
          r.sub = m.mux.sub_index;
          r.kind = Kind::abort;
        }
      },
      *request);
  return r;
}

SdoAnswerView answer_view(const ecat::CoeSdoResponse& response) {
  SdoAnswerView a;
  std::visit(
      [&a](const auto& m) {
        using T = std::decay_t<decltype(m)>;
        if constexpr (std::is_same_v<T, ecat::CoeAbort>) {
          a = SdoAnswerView::abort_of(m.mux.index, m.mux.sub_index, m.code);
        } else if constexpr (std::is_same_v<T, ecat::CoeDownloadInitiateResponse>) {
          a = SdoAnswerView::confirmed(m.mux.index, m.mux.sub_index);
        } else if constexpr (std::is_same_v<T, ecat::CoeUploadInitiateResponse>) {
          if (m.expedited && m.size_indicated && !m.complete_access && !m.data.empty() &&
              m.data.size() <= 4) {
            a = SdoAnswerView::upload(m.mux.index, m.mux.sub_index, m.data);
          }
        } else if constexpr (std::is_same_v<T, ecat::CoeUploadSegment>) {
          a.kind = AnswerKind::upload_segment;
          a.toggle = m.toggle;
        }
      },
      response);
  return a;
}

ecat::CoeSdoResponse response_of(const SdoAnswerView& a, ecat::CoeSdoResponse original) {
  const cia301::Multiplexer mux{a.index, a.sub};
  switch (a.kind) {
    case AnswerKind::abort:
      return ecat::CoeAbort{mux, a.code};
    case AnswerKind::download_confirmed:
      return ecat::CoeDownloadInitiateResponse{mux};
    case AnswerKind::expedited_upload: {
      ecat::CoeUploadInitiateResponse r;
      r.mux = mux;
      r.expedited = true;
      r.size_indicated = true;
      r.complete_size = static_cast<std::uint32_t>(a.data.size());
      r.data = a.data;
      return r;
    }
    case AnswerKind::upload_segment:
      if (auto* segment = std::get_if<ecat::CoeUploadSegment>(&original)) {
        segment->toggle = a.toggle;
      }
      return original;
    case AnswerKind::other:
      break;
  }
  return original;
}

}  // namespace

std::optional<ecat::CoeSdoResponse> CoeDeviationHook::before(ecat::CoeSdoRequest* request) {
  const SdoRequestView view = request_view(request);
  SdoBefore decided = deviations_.before(view, od_);
  if (decided.answer) return response_of(*decided.answer, ecat::CoeSdoResponse{});
  if (decided.replaced && request != nullptr) {
    if (auto* download = std::get_if<ecat::CoeDownloadInitiate>(request)) {
      download->data = std::move(*decided.replaced);
      download->size_indicated = true;
      download->complete_size = static_cast<std::uint32_t>(download->data.size());
    }
  }
  return std::nullopt;
}

std::optional<ecat::CoeSdoResponse> CoeDeviationHook::after(const ecat::CoeSdoRequest* request,
                                                            ecat::CoeSdoResponse response) {
  const SdoAnswerView answer = answer_view(response);
  if (answer.kind == AnswerKind::other) return response;
  const auto changed = deviations_.after(request_view(request), answer, od_);
  if (!changed) return std::nullopt;
  if (*changed == answer) return response;
  return response_of(*changed, std::move(response));
}

}  // namespace drivecheck::reference_drive::ethercat
