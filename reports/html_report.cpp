// The HTML report: one self-contained page (hooks and fragments in report_writers.hpp).
//
// Everything is rendered here, on the server side: the page reads fine with scripts off. The
// inline script only filters (verdict buttons, matrix cells), honours #open=<id> and
// #filter=..., and marks <body data-js="ready">. It walks the vectors once per filter change,
// so 1000 vectors filter instantly; closed <details> cost no layout.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <iterator>
#include <map>
#include <span>
#include <string>
#include <tuple>
#include <vector>

#include "protocol/cia402/controlword.hpp"
#include "protocol/cia402/statusword.hpp"
#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

using conformance::RunResult;
using conformance::Tally;
using conformance::VectorResult;
using conformance::Verdict;

// Escaped for HTML text and attribute values (both quotes), after printable_text.
std::string esc(std::string_view text) {
  const std::string clean = printable_text(text);
  std::string out;
  out.reserve(clean.size() + clean.size() / 8);
  for (const char c : clean) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// Percent-encoding for a URL fragment value (then HTML-escaped where it is written).
std::string url_component(std::string_view text) {
  std::string out;
  for (const char c : text) {
    const auto byte = static_cast<std::uint8_t>(c);
    if ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
        c == '_' || c == '.' || c == '~') {
      out += c;
    } else {
      out += fmt::format("%{:02X}", byte);
    }
  }
  return out;
}

constexpr std::array<std::string_view, conformance::kTallyCount> kTallyLabels{
    "pass", "fail", "warning", "deviation", "n/a", "error", "interrupted"};

std::string_view label(Tally tally) {
  return kTallyLabels[static_cast<std::size_t>(tally)];
}
Tally tally_of(const VectorResult& vector) {
  return conformance::tally_of(vector.verdict, vector.warning);
}

std::string ms_text(can::Duration duration) {
  return fmt::format("{:.3f} ms", static_cast<double>(duration.count()) / 1e6);
}

constexpr std::string_view kStyle = R"css(
:root{--pass:#1a7f37;--fail:#cf222e;--deviation:#9a6700;--na:#6e7781;--error:#8250df;--warn:#bc4c00;
--bg:#fff;--fg:#1f2328;--muted:#59636e;--line:#d1d9e0;--soft:#f6f8fa}
*{box-sizing:border-box}
body{margin:0 auto;max-width:1200px;padding:16px 24px;font:14px/1.45 system-ui,-apple-system,"Segoe UI",sans-serif;color:var(--fg);background:var(--bg)}
h1{font-size:22px;margin:0 0 8px}h2{font-size:17px;margin:24px 0 8px;border-bottom:1px solid var(--line)}
code,pre,.mono{font-family:ui-monospace,"DejaVu Sans Mono",Menlo,Consolas,monospace;font-size:12.5px}
dl.run{display:grid;grid-template-columns:max-content 1fr;gap:2px 16px;margin:8px 0}
dl.run dt{color:var(--muted)}dl.run dd{margin:0;overflow-wrap:anywhere}
.banner{padding:8px 12px;border-radius:6px;background:#fff1e5;border:1px solid var(--warn);margin:8px 0}
.counts{display:flex;flex-wrap:wrap;gap:8px;margin:12px 0}
.count{padding:6px 12px;border-radius:6px;background:var(--soft);border:1px solid var(--line)}
.count b{font-size:18px;margin-right:4px}
.v-pass{color:var(--pass)}.v-fail{color:var(--fail)}.v-deviation{color:var(--deviation)}
.v-not-applicable{color:var(--na)}.v-error{color:var(--error)}.v-warning{color:var(--warn)}
table{border-collapse:collapse;width:100%;margin:6px 0}
th,td{border:1px solid var(--line);padding:3px 8px;text-align:left;vertical-align:top}
thead th{background:var(--soft)}
#matrix td{text-align:right}#matrix td a{text-decoration:none;font-weight:600}
#matrix td.zero{color:#c0c6cc}
.filters{display:flex;flex-wrap:wrap;gap:6px;align-items:center;margin:8px 0}
.filters button{font:inherit;padding:4px 10px;border:1px solid var(--line);border-radius:14px;background:var(--soft);cursor:pointer}
.filters button.on{background:var(--fg);color:var(--bg)}
#shown{color:var(--muted);margin-left:8px}
.legend{color:var(--muted);font-size:13px}
.v-interrupted{color:var(--na)}
#search{font:inherit;padding:3px 8px;border:1px solid var(--line);border-radius:14px;min-width:220px}
.matrices{display:grid;grid-template-columns:minmax(0,1fr) minmax(0,1fr);gap:0 24px;align-items:start}
@media (max-width:900px){.matrices{grid-template-columns:1fr}}
#clause-matrix td.vectors a{display:inline-block;margin:0 6px 2px 0;text-decoration:none;font-family:ui-monospace,monospace;font-size:12px}
.doc{color:var(--muted)}
.between{border:1px dashed var(--warn);border-radius:4px;padding:2px 8px;margin:6px 0}
.failmark{color:#ff7b72;font-weight:700}
/* Printing (or saving as PDF): no controls; every failure, error and warning expanded with its
   evidence (the script also opens them before printing; ::details-content does it without). */
@media print{.filters{display:none}details.vector>summary{list-style:none}
details.vector[data-print=expand]::details-content{content-visibility:visible;display:block;height:auto}
details.vector[data-print=expand]{break-inside:auto}
pre.transcript{max-height:none;white-space:pre-wrap;background:#fff;color:#000;border:1px solid var(--line)}
#clause-box::details-content{content-visibility:visible;display:block}}
details.vector{border:1px solid var(--line);border-left:4px solid var(--line);border-radius:4px;margin:4px 0}
details.vector[data-verdict=pass]{border-left-color:var(--pass)}
details.vector[data-verdict=fail]{border-left-color:var(--fail)}
details.vector[data-verdict=deviation]{border-left-color:var(--deviation)}
details.vector[data-verdict=not-applicable]{border-left-color:var(--na)}
details.vector[data-verdict=error]{border-left-color:var(--error)}
details.vector[data-warning=true]{border-left-color:var(--warn)}
details.vector[data-verdict=interrupted]{border-left-color:var(--na);border-left-style:dashed}
details.vector>summary{cursor:pointer;padding:4px 8px;list-style-position:inside}
details.vector[open]>summary{background:var(--soft)}
.badge{display:inline-block;min-width:78px;font-weight:600;text-transform:uppercase;font-size:12px}
.vbody{padding:4px 12px 12px}
.message{white-space:pre-wrap;margin:6px 0;padding:6px 8px;background:var(--soft);border-radius:4px}
pre.transcript{white-space:pre;overflow-x:auto;background:#0d1117;color:#e6edf3;padding:8px;border-radius:4px;max-height:480px}
td.ok{color:var(--pass)}td.bad{color:var(--fail);font-weight:600}
svg.timing{width:100%;height:auto;background:#fff;border:1px solid var(--line);border-radius:4px}
svg.timing text{font:11px ui-monospace,monospace;fill:#1f2328}
a.permalink{color:var(--muted);text-decoration:none;margin-left:6px}
footer{margin-top:24px;color:var(--muted);font-size:12px}
)css";

constexpr std::string_view kScript = R"js(
(function () {
  var list = document.getElementById('vectors');
  var items = list.querySelectorAll('details.vector');
  var buttons = document.querySelectorAll('.filters button[data-filter]');
  var shown = document.getElementById('shown');
  var search = document.getElementById('search');
  var texts = [];  // what a search looks in: id, title, sources, message (lower case)
  for (var t = 0; t < items.length; t++) {
    var parts = items[t].querySelectorAll('summary, .requirement, .message');
    var text = '';
    for (var p = 0; p < parts.length; p++) text += ' ' + parts[p].textContent;
    texts.push(text.toLowerCase());
  }
  var state = {filter: 'all', family: '', clause: '', search: ''};
  function apply() {
    var n = 0;
    var words = state.search.toLowerCase().split(/\s+/).filter(function (w) { return w; });
    for (var i = 0; i < items.length; i++) {
      var d = items[i];
      var ok = state.filter === 'all' || d.getAttribute('data-tally') === state.filter;
      if (state.family && d.getAttribute('data-family') !== state.family) ok = false;
      if (state.clause &&
          ('\n' + d.getAttribute('data-clauses') + '\n').indexOf('\n' + state.clause + '\n') < 0)
        ok = false;
      for (var w = 0; ok && w < words.length; w++)
        if (texts[i].indexOf(words[w]) < 0) ok = false;
      d.hidden = !ok;
      if (ok) n++;
    }
    for (var j = 0; j < buttons.length; j++)
      buttons[j].classList.toggle('on', buttons[j].getAttribute('data-filter') === state.filter);
    list.setAttribute('data-filter', state.filter);
    list.setAttribute('data-family', state.family);
    list.setAttribute('data-clause', state.clause);
    list.setAttribute('data-search', state.search);
    if (search.value !== state.search) search.value = state.search;
    shown.textContent = n + ' shown' + (state.family ? ' in ' + state.family : '') +
                        (state.clause ? ' citing ' + state.clause : '') +
                        (state.search ? ' matching "' + state.search + '"' : '');
    shown.setAttribute('data-shown', String(n));
  }
  function fromHash() {
    var params = new URLSearchParams(location.hash.replace(/^#/, ''));
    var open = params.get('open');
    if (open !== null) {
      state = {filter: 'all', family: '', clause: '', search: ''};
      apply();
      var d = document.getElementById('v:' + open);
      if (d) {
        d.open = true;
        d.setAttribute('data-opened', 'fragment');
        // After layout settles (a headless screenshot resizes the window after load).
        window.requestAnimationFrame(function () { d.scrollIntoView({block: 'start'}); });
      }
      return;
    }
    state = {filter: params.get('filter') || 'all', family: params.get('family') || '',
             clause: params.get('clause') || '', search: params.get('search') || ''};
    apply();
  }
  for (var k = 0; k < buttons.length; k++) {
    buttons[k].addEventListener('click', function (e) {
      location.hash = 'filter=' + encodeURIComponent(e.currentTarget.getAttribute('data-filter'));
    });
  }
  search.addEventListener('input', function () {
    state.search = search.value;
    apply();
  });
  window.addEventListener('hashchange', fromHash);
  fromHash();
  var actions = document.querySelectorAll('.filters button[data-action]');
  for (var a = 0; a < actions.length; a++) {
    actions[a].addEventListener('click', function (e) {
      var expand = e.currentTarget.getAttribute('data-action') === 'expand';
      for (var i = 0; i < items.length; i++)
        items[i].open = expand && !items[i].hidden;
    });
  }
  // Printing: the failures open with their evidence (and close again afterwards).
  var reopened = [];
  window.addEventListener('beforeprint', function () {
    reopened = [];
    for (var i = 0; i < items.length; i++) {
      if (items[i].getAttribute('data-print') === 'expand' && !items[i].open) {
        items[i].open = true;
        reopened.push(items[i]);
      }
    }
  });
  window.addEventListener('afterprint', function () {
    for (var i = 0; i < reopened.length; i++) reopened[i].open = false;
    reopened = [];
  });
  document.body.setAttribute('data-js', 'ready');
})();
)js";

// ---- timing diagram ---------------------------------------------------------------------

struct BitName {
  std::uint16_t mask;
  std::string_view name;
};

namespace cw = cia402::controlword;
namespace sw = cia402::statusword;

constexpr std::array<BitName, 9> kControlwordBits{{
    {cw::kSwitchOn, "switch on"},
    {cw::kEnableVoltage, "enable voltage"},
    {cw::kQuickStop, "quick stop (0=QS)"},
    {cw::kEnableOperation, "enable operation"},
    {cw::kNewSetPoint, "bit 4 (new set-point/start)"},
    {cw::kChangeSetImmediately, "bit 5 (change immediately)"},
    {cw::kRelative, "bit 6 (relative)"},
    {cw::kFaultReset, "fault reset"},
    {cw::kHalt, "halt"},
}};

constexpr std::array<BitName, 14> kStatuswordBits{{
    {sw::kReadyToSwitchOn, "ready to switch on"},
    {sw::kSwitchedOn, "switched on"},
    {sw::kOperationEnabled, "operation enabled"},
    {sw::kFault, "fault"},
    {sw::kVoltageEnabled, "voltage enabled"},
    {sw::kQuickStop, "quick stop (0=QS)"},
    {sw::kSwitchOnDisabled, "switch on disabled"},
    {sw::kWarning, "warning"},
    {sw::kManufacturer8, "bit 8 (manufacturer)"},
    {sw::kRemote, "remote"},
    {sw::kTargetReached, "target reached"},
    {sw::kInternalLimitActive, "internal limit"},
    {sw::kSetPointAcknowledge, "bit 12 (ack/attained)"},
    {sw::kFollowingError, "bit 13 (error)"},
}};

// Colours and shapes of the sample marks by origin (SDO dot, TPDO square, RPDO bar); the
// class names are hooks for tests and scripts. The marks of one row and origin are one <path>
// of zero-length strokes ("M x y h0", the line cap draws the dot), so thousands of samples stay
// a few bytes each.
struct OriginStyle {
  conformance::SampleOrigin origin;
  std::string_view css_class;
  std::string_view label;
  std::string_view colour;
};
constexpr std::array<OriginStyle, 3> kOriginStyles{{
    {conformance::SampleOrigin::sdo, "sample-sdo", "SDO", "#8250df"},
    {conformance::SampleOrigin::tpdo, "sample-tpdo", "TPDO", "#1a7f37"},
    {conformance::SampleOrigin::rpdo, "sample-rpdo", "RPDO", "#bf3989"},
}};
const OriginStyle& style_of(conformance::SampleOrigin origin) {
  return kOriginStyles[static_cast<std::size_t>(origin)];
}

struct SignalSample {
  std::int64_t t = 0;  // ns from the first sample
  std::int64_t value = 0;
  conformance::SampleOrigin origin = conformance::SampleOrigin::sdo;
};

// A row of the diagram: a bit of the controlword/statusword (digital), a value (analog, with
// its sample marks on the line), or the sample marks of a controlword/statusword (one row for
// all its bits).
enum class RowKind : std::uint8_t { digital, analog, marks };

struct Trace {
  std::string label;
  RowKind kind = RowKind::digital;
  std::vector<std::pair<std::int64_t, std::int64_t>> points;  // (t ns from t0, value)
  std::vector<SignalSample> marks;                            // where it was sampled

  // Sample-and-hold: a sample equal to the value held adds nothing to draw (this keeps a
  // 1000-vector page small: a bit that toggles twice is three points, not one per sample).
  void add(const SignalSample& sample) {
    if (points.empty() || points.back().second != sample.value)
      points.emplace_back(sample.t, sample.value);
  }
};

// An analog trace with more points than the plot has pixels keeps, per column of `columns`,
// its first, lowest, highest and last point (in time order): the line looks the same.
void thin_to_columns(Trace& trace, std::int64_t span, int columns) {
  if (trace.kind != RowKind::analog || trace.points.size() <= static_cast<std::size_t>(columns) * 2)
    return;
  std::vector<std::pair<std::int64_t, std::int64_t>> kept;
  std::size_t i = 0;
  const auto& points = trace.points;
  const auto column_of = [&](std::int64_t t) {
    return static_cast<long long>(static_cast<double>(t) * columns / static_cast<double>(span));
  };
  while (i < points.size()) {
    const auto column = column_of(points[i].first);
    std::size_t end = i;
    std::size_t low = i;
    std::size_t high = i;
    while (end < points.size() && column_of(points[end].first) == column) {
      if (points[end].second < points[low].second) low = end;
      if (points[end].second > points[high].second) high = end;
      ++end;
    }
    std::array<std::size_t, 4> picks{i, low, high, end - 1};
    std::sort(picks.begin(), picks.end());
    for (std::size_t k = 0; k < picks.size(); ++k)
      if (k == 0 || picks[k] != picks[k - 1]) kept.push_back(points[picks[k]]);
    i = end;
  }
  trace.points = std::move(kept);
}

void render_timing_svg(std::string& out, const VectorResult& vector) {
  // Signals in first-appearance order, samples sorted by time within each.
  std::vector<std::string> order;
  std::map<std::string, std::vector<SignalSample>> signals;
  std::array<std::size_t, 3> by_origin{};
  std::int64_t t_min = INT64_MAX;
  std::int64_t t_max = INT64_MIN;
  for (const auto& sample : vector.samples) {
    const std::int64_t t = sample.at.time_since_epoch().count();
    t_min = std::min(t_min, t);
    t_max = std::max(t_max, t);
  }
  // The failed checks with their time (the frame judged or the deadline that passed) are
  // marked on the diagram, which spans them too.
  std::vector<const conformance::Check*> failed;
  for (const auto& check : vector.checks) {
    if (check.ok || !check.at || vector.samples.empty()) continue;
    failed.push_back(&check);
    const std::int64_t t = check.at->time_since_epoch().count();
    t_min = std::min(t_min, t);
    t_max = std::max(t_max, t);
  }
  for (const auto& sample : vector.samples) {
    auto& list = signals[sample.signal];
    if (list.empty()) order.push_back(sample.signal);
    // Unsigned difference: any two int64 times (a report read from JSON may hold extremes).
    const auto offset = static_cast<std::uint64_t>(sample.at.time_since_epoch().count()) -
                        static_cast<std::uint64_t>(t_min);
    list.push_back({static_cast<std::int64_t>(std::min<std::uint64_t>(offset, INT64_MAX)),
                    sample.value, sample.origin});
    ++by_origin[static_cast<std::size_t>(sample.origin)];
  }
  if (order.empty()) return;
  const std::int64_t span = std::max<std::int64_t>(
      static_cast<std::int64_t>(std::min<std::uint64_t>(
          static_cast<std::uint64_t>(t_max) - static_cast<std::uint64_t>(t_min), INT64_MAX)),
      1'000'000);  // ≥ 1 ms

  constexpr int kLeft = 236;
  constexpr int kWidth = 1000;
  constexpr int kPlot = kWidth - kLeft - 20;

  std::vector<Trace> traces;
  for (const auto& name : order) {
    auto& list = signals[name];
    std::stable_sort(list.begin(), list.end(),
                     [](const auto& a, const auto& b) { return a.t < b.t; });
    const bool is_cw = name == "controlword";
    const bool is_sw = name == "statusword";
    if (is_cw || is_sw) {
      const auto bits = is_cw ? std::span<const BitName>(kControlwordBits)
                              : std::span<const BitName>(kStatuswordBits);
      for (const BitName& bit : bits) {
        bool ever_set = false;
        for (const auto& sample : list)
          if ((static_cast<std::uint64_t>(sample.value) & bit.mask) != 0) ever_set = true;
        if (!ever_set) continue;
        Trace trace{fmt::format("{} {}", is_cw ? "CW" : "SW", bit.name), RowKind::digital, {}, {}};
        for (const auto& sample : list) {
          trace.add({sample.t, (static_cast<std::uint64_t>(sample.value) & bit.mask) != 0 ? 1 : 0,
                     sample.origin});
        }
        traces.push_back(std::move(trace));
      }
      traces.push_back(
          Trace{fmt::format("{} sampled", is_cw ? "CW" : "SW"), RowKind::marks, {}, list});
    } else {
      Trace trace{name, RowKind::analog, {}, list};
      for (const auto& sample : list)
        trace.add(sample);
      thin_to_columns(trace, span, kPlot);
      traces.push_back(std::move(trace));
    }
  }
  if (traces.empty()) return;

  constexpr int kLegendHeight = 16;
  constexpr int kDigitalHeight = 18;
  constexpr int kAnalogHeight = 64;
  constexpr int kMarksHeight = 10;
  const auto row_height = [&](const Trace& trace) {
    switch (trace.kind) {
      case RowKind::digital:
        return kDigitalHeight;
      case RowKind::analog:
        return kAnalogHeight;
      case RowKind::marks:
        return kMarksHeight;
    }
    return kDigitalHeight;
  };
  int height = 8 + kLegendHeight;
  for (const auto& trace : traces)
    height += row_height(trace) + 4;
  const int axis_y = height;
  height += 24;

  const auto x_of = [&](std::int64_t t) {
    return kLeft + static_cast<double>(t) * kPlot / static_cast<double>(span);
  };
  fmt::format_to(std::back_inserter(out),
                 "<svg class=\"timing\" viewBox=\"0 0 {} {}\" role=\"img\" "
                 "xmlns=\"http://www.w3.org/2000/svg\"><title>Timing diagram of {}</title>\n",
                 kWidth, height, esc(vector.id));
  // Legend: where the samples came from, and how many a long vector left out.
  // One zero-length stroke per mark; path_of() wraps the strokes of one origin.
  const auto stroke = [](std::string& to, conformance::SampleOrigin origin, double x, double y) {
    if (origin == conformance::SampleOrigin::rpdo)
      fmt::format_to(std::back_inserter(to), "M{:.1f} {:.1f}v6", x, y - 3);
    else
      fmt::format_to(std::back_inserter(to), "M{:.1f} {:.1f}h0", x, y);
  };
  const auto path_of = [](std::string& to, conformance::SampleOrigin origin,
                          std::string_view strokes) {
    const OriginStyle& style = style_of(origin);
    const bool bar = origin == conformance::SampleOrigin::rpdo;
    fmt::format_to(std::back_inserter(to),
                   "<path class=\"{}\" d=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"{}\" "
                   "stroke-linecap=\"{}\"/>",
                   style.css_class, strokes, style.colour, bar ? "1.5" : "4",
                   origin == conformance::SampleOrigin::sdo    ? "round"
                   : origin == conformance::SampleOrigin::tpdo ? "square"
                                                               : "butt");
  };
  {
    double x = kLeft;
    const int y = 8 + 8;
    fmt::format_to(std::back_inserter(out), "<text x=\"4\" y=\"{}\">samples</text>", y + 4);
    for (const OriginStyle& style : kOriginStyles) {
      const std::size_t count = by_origin[static_cast<std::size_t>(style.origin)];
      if (count == 0) continue;
      std::string strokes;
      stroke(strokes, style.origin, x + 3, y);
      path_of(out, style.origin, strokes);
      const std::string text = fmt::format("{} ({})", style.label, count);
      fmt::format_to(std::back_inserter(out), "<text x=\"{:.1f}\" y=\"{}\">{}</text>", x + 10,
                     y + 4, text);
      x += 24 + 7.0 * static_cast<double>(text.size());
    }
    if (vector.samples_elided != 0) {
      fmt::format_to(std::back_inserter(out),
                     "<text x=\"{:.1f}\" y=\"{}\" fill=\"#59636e\">{} more thinned out (every bit "
                     "edge kept)</text>",
                     x, y + 4, vector.samples_elided);
    }
  }
  int y = 8 + kLegendHeight;
  for (const auto& trace : traces) {
    const int row = row_height(trace);
    std::int64_t lo = 0;
    std::int64_t hi = 1;
    if (trace.kind == RowKind::analog) {
      lo = INT64_MAX;
      hi = INT64_MIN;
      for (const auto& [t, value] : trace.points) {
        lo = std::min(lo, value);
        hi = std::max(hi, value);
      }
    }
    // In double: a constant signal gets a range of 2 around its value, without overflow.
    const double bottom = static_cast<double>(lo) - (lo == hi ? 1.0 : 0.0);
    const double range = static_cast<double>(hi) + (lo == hi ? 1.0 : 0.0) - bottom;
    const auto y_of = [&](std::int64_t value) {
      return y + row - 3 - (static_cast<double>(value) - bottom) * (row - 6) / range;
    };
    fmt::format_to(std::back_inserter(out),
                   "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"#eaeef2\"/>", kLeft,
                   y + row, kLeft + kPlot, y + row);
    if (trace.kind == RowKind::marks) {
      fmt::format_to(std::back_inserter(out), "<text x=\"4\" y=\"{}\" fill=\"#59636e\">{}</text>",
                     y + row - 1, esc(trace.label));
    } else if (trace.kind == RowKind::digital) {
      fmt::format_to(std::back_inserter(out), "<text x=\"4\" y=\"{}\">{}</text>", y + row - 4,
                     esc(trace.label));
    } else {
      fmt::format_to(std::back_inserter(out),
                     "<text x=\"4\" y=\"{}\">{}</text><text x=\"4\" y=\"{}\" "
                     "fill=\"#59636e\">{} … {}</text>",
                     y + 14, esc(trace.label), y + 30, lo, hi);
    }
    // Sample-and-hold step line: each value holds until the next sample, the last one to the end.
    if (trace.kind != RowKind::marks) {
      std::string points;
      double last_y = 0;
      for (std::size_t i = 0; i < trace.points.size(); ++i) {
        const double x = x_of(trace.points[i].first);
        const double value_y = y_of(trace.points[i].second);
        if (i > 0) fmt::format_to(std::back_inserter(points), "{:.1f},{:.1f} ", x, last_y);
        fmt::format_to(std::back_inserter(points), "{:.1f},{:.1f} ", x, value_y);
        last_y = value_y;
      }
      fmt::format_to(std::back_inserter(points), "{:.1f},{:.1f}", x_of(span), last_y);
      fmt::format_to(std::back_inserter(out),
                     "<polyline fill=\"none\" stroke=\"{}\" stroke-width=\"1.5\" points=\"{}\"/>\n",
                     trace.kind == RowKind::digital ? "#0969da" : "#bc4c00", points);
    }
    // Where it was sampled: on an analog line at the value, in a marks row at its middle; one
    // mark per origin, 3-pixel column and height (thousands of samples stay a few hundred).
    std::map<std::tuple<int, int, int>, bool> drawn;
    std::array<std::string, 3> strokes;
    for (const auto& sample : trace.marks) {
      const double x = x_of(sample.t);
      const double value_y = trace.kind == RowKind::marks
                                 ? y + row / 2.0
                                 : std::clamp(y_of(sample.value), static_cast<double>(y + 2),
                                              static_cast<double>(y + row - 2));
      const auto key = std::make_tuple(static_cast<int>(x / 3), static_cast<int>(value_y / 3),
                                       static_cast<int>(sample.origin));
      if (!drawn.emplace(key, true).second) continue;
      stroke(strokes[static_cast<std::size_t>(sample.origin)], sample.origin, x, value_y);
    }
    for (const OriginStyle& style : kOriginStyles) {
      const auto& d = strokes[static_cast<std::size_t>(style.origin)];
      if (!d.empty()) path_of(out, style.origin, d);
    }
    out += '\n';
    y += row + 4;
  }
  // Where it failed: a dashed red line at the failed check's time, labelled with its step.
  for (const conformance::Check* check : failed) {
    const auto offset = static_cast<std::uint64_t>(check->at->time_since_epoch().count()) -
                        static_cast<std::uint64_t>(t_min);
    const double x = x_of(static_cast<std::int64_t>(std::min<std::uint64_t>(offset, INT64_MAX)));
    const std::string what =
        fmt::format("{} failed", conformance::step_label(check->step, check->iterations));
    fmt::format_to(std::back_inserter(out),
                   "<g class=\"failure-mark\" data-step=\"{0}\"><title>{1}: Expected {2}; Actual "
                   "{3}</title><line x1=\"{4:.1f}\" y1=\"{5}\" x2=\"{4:.1f}\" y2=\"{6}\" "
                   "stroke=\"#cf222e\" stroke-width=\"1.5\" stroke-dasharray=\"4 3\"/>"
                   "<text x=\"{7:.1f}\" y=\"{8}\" text-anchor=\"end\" fill=\"#cf222e\">{1} ({9})"
                   "</text></g>\n",
                   check->step, what, esc(check->expected), esc(check->actual), x,
                   8 + kLegendHeight, axis_y, x - 3, 8 + kLegendHeight + 10, esc(check->action));
  }
  // Time axis: 5 ticks, labelled in ms from the first sample.
  fmt::format_to(std::back_inserter(out),
                 "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"#59636e\"/>", kLeft,
                 axis_y, kLeft + kPlot, axis_y);
  for (int tick = 0; tick <= 4; ++tick) {
    const std::int64_t t = span * tick / 4;
    const double x = x_of(t);
    fmt::format_to(std::back_inserter(out),
                   "<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#59636e\"/>"
                   "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\">{4:.3f} ms</text>",
                   x, axis_y, axis_y + 4, axis_y + 16, static_cast<double>(t) / 1e6);
  }
  out += "</svg>\n";
}

// ---- page -----------------------------------------------------------------------------

void render_run_info(std::string& out, const RunResult& result) {
  const auto& info = result.info;
  const auto& dut = info.dut;
  const auto row = [&](std::string_view name, std::string_view value) {
    fmt::format_to(std::back_inserter(out), "<dt>{}</dt><dd>{}</dd>", name, esc(value));
  };
  const auto hex = [](const std::optional<std::uint32_t>& value) {
    return value ? fmt::format("{:08X}h", *value) : std::string("(not readable)");
  };
  out += "<dl class=\"run\" id=\"run\">";
  row("Device (1008h)", dut.device_name.value_or("(not readable)"));
  row("Device type (1000h)", hex(dut.device_type));
  row("Vendor ID (1018h:1)", hex(dut.vendor_id));
  row("Product code (1018h:2)", hex(dut.product_code));
  row("Revision (1018h:3)", hex(dut.revision));
  row("Serial number (1018h:4)", hex(dut.serial));
  if (dut.hardware_version) row("Hardware version (1009h)", *dut.hardware_version);
  if (dut.software_version) row("Software version (100Ah)", *dut.software_version);
  row("Profile", info.profile_title.empty() ? info.profile_name
                                            : info.profile_name + " — " + info.profile_title);
  if (!info.profile_choice.empty()) row("Profile chosen by", info.profile_choice);
  if (!info.capabilities.empty()) {
    // What the device showed it has, probed once at the start (conformance/capabilities.hpp).
    fmt::format_to(std::back_inserter(out), "<dt>Capabilities</dt><dd><ul class=\"capabilities\">");
    for (const auto& line : info.capabilities)
      fmt::format_to(std::back_inserter(out), "<li>{}</li>", esc(line));
    out += "</ul></dd>";
  }
  if (!info.commissioning.empty()) {
    // The SDO writes the engine made after each setup: the drive's units as the vectors assume.
    fmt::format_to(std::back_inserter(out),
                   "<dt>Commissioning</dt><dd><ul class=\"commissioning\">");
    for (const auto& line : info.commissioning)
      fmt::format_to(std::back_inserter(out), "<li>{}</li>", esc(line));
    out += "</ul></dd>";
  }
  if (!info.eds_file.empty()) row("EDS", info.eds_file + "  sha256 " + info.eds_sha256);
  if (!info.eds_findings.empty()) {
    // What the EDS reader and linter found (warnings: an EDS with errors is refused).
    fmt::format_to(std::back_inserter(out), "<dt>EDS findings</dt><dd><ul class=\"eds-findings\">");
    for (const auto& line : info.eds_findings)
      fmt::format_to(std::back_inserter(out), "<li>{}</li>", esc(line));
    out += "</ul></dd>";
  }
  if (!info.esi_file.empty()) row("ESI", info.esi_file + "  sha256 " + info.esi_sha256);
  if (const auto& device = info.esi_device) {
    // The identity the ESI gives the device the slave was matched to (beside 1018h's above).
    row("ESI device", fmt::format("{}: vendor ID {:08X}h, product code {:08X}h, revision {:08X}h",
                                  device->name.empty() ? std::string("(no name)") : device->name,
                                  device->vendor_id, device->product_code, device->revision));
  }
  row("Date", info.started_utc);
  row("Bus", fmt::format("{}, node {}", info.bus, info.node));
  if (!info.personality.empty()) row("Reference drive personality", info.personality);
  if (!info.deviations.empty()) {
    std::string list;
    for (const auto& deviation : info.deviations)
      list += (list.empty() ? "" : ", ") + deviation;
    row("Injected deviations", list);
  }
  row("Options",
      fmt::format("seed {}{}{}{}{}{}", info.seed,
                  info.order == "file" ? "" : ", --order " + info.order,
                  info.strict ? ", --strict" : "", info.allow_motion ? ", --allow-motion" : "",
                  info.allow_factory_restore ? ", --allow-factory-restore" : "",
                  info.filter.empty() ? "" : ", --filter " + info.filter));
  row("Duration",
      fmt::format("{:.3f} s bus time, {:.3f} s wall",
                  static_cast<double>(result.simulated.count()) / 1e9, result.wall_seconds));
  row("drivecheck", info.revision.empty() || info.revision == info.tool_version
                        ? info.tool_version
                        : info.tool_version + " (revision " + info.revision + ")");
  if (!info.vector_digest.empty()) {
    fmt::format_to(
        std::back_inserter(out),
        "<dt>Vector set</dt><dd><span class=\"mono\" data-vector-digest>sha256 {}</span> "
        "({} files: vectors and drive profiles)</dd>",
        esc(info.vector_digest), info.vector_files);
  }
  if (!info.documents.empty()) {
    // The one place that says which document and edition each citation refers to.
    out += "<dt>Cited documents</dt><dd><ul class=\"documents\" id=\"documents\">";
    for (const auto& document : info.documents) {
      fmt::format_to(std::back_inserter(out),
                     "<li data-document=\"{0}\"><span class=\"mono\">{0}</span>: {1}{2}</li>",
                     esc(document.key), esc(document.title),
                     document.edition.empty() ? "" : ", edition " + esc(document.edition));
    }
    out += "</ul></dd>";
  }
  out += "</dl>\n";
  if (result.interrupted)
    out +=
        "<p class=\"banner\" data-interrupted>The run was interrupted: these are the vectors "
        "finished so far.</p>\n";
  if (result.dut_lost)
    out += "<p class=\"banner\" data-dut-lost>The device under test stopped answering.</p>\n";
  if (!result.harness_notes.empty()) {
    out += "<ul class=\"harness-notes\" data-harness-notes>";
    for (const auto& note : result.harness_notes)
      out += "<li>" + esc(note) + "</li>";
    out += "</ul>\n";
  }
}

void render_counts(std::string& out, const RunResult& result) {
  // The counts every output shows (conformance::VerdictCounts): each vector in one tally.
  const auto counts = result.counts();
  out += "<div class=\"counts\" id=\"counts\">";
  fmt::format_to(std::back_inserter(out),
                 "<span class=\"count\"><b data-count-total>{}</b>vectors</span>", counts.total());
  for (std::size_t i = 0; i < conformance::kTallyCount; ++i) {
    const auto tally = static_cast<Tally>(i);
    fmt::format_to(std::back_inserter(out),
                   "<span class=\"count v-{0}\"><b data-count-{0}>{1}</b>{2}</span>",
                   to_string(tally), counts.by_tally[i], label(tally));
  }
  fmt::format_to(std::back_inserter(out),
                 "<span class=\"count\">exit code <b data-exit-code>{}</b></span></div>\n",
                 conformance::exit_code(result));
}

void tally_header(std::string& out) {
  for (std::size_t i = 0; i < conformance::kTallyCount; ++i)
    fmt::format_to(std::back_inserter(out), "<th class=\"v-{}\">{}</th>",
                   to_string(static_cast<Tally>(i)), label(static_cast<Tally>(i)));
}

void render_matrix(std::string& out, const RunResult& result) {
  std::vector<std::string> families;
  std::map<std::string, conformance::VerdictCounts> by_family;
  for (const auto& vector : result.vectors) {
    auto [it, inserted] = by_family.try_emplace(vector.family);
    if (inserted) families.push_back(vector.family);
    it->second.add(vector.verdict, vector.warning);
  }
  out +=
      "<section><h2>Conformance matrix by family</h2>\n<table "
      "id=\"matrix\"><thead><tr><th>Family</th>";
  tally_header(out);
  out += "<th>total</th></tr></thead><tbody>\n";
  const auto cell = [&](std::string_view filter, std::string_view family, std::size_t n) {
    if (n == 0) {
      out += "<td class=\"zero\">0</td>";
      return;
    }
    fmt::format_to(std::back_inserter(out),
                   "<td><a class=\"v-{0}\" href=\"#filter={0}&amp;family={1}\" "
                   "data-matrix-verdict=\"{0}\" data-matrix-family=\"{2}\">{3}</a></td>",
                   filter, esc(url_component(family)), esc(family), n);
  };
  for (const auto& family : families) {
    const auto& counts = by_family[family];
    fmt::format_to(std::back_inserter(out), "<tr data-family=\"{0}\"><th>{0}</th>", esc(family));
    for (std::size_t i = 0; i < conformance::kTallyCount; ++i)
      cell(to_string(static_cast<Tally>(i)), family, counts.by_tally[i]);
    cell("all", family, counts.total());
    out += "</tr>\n";
  }
  out += "</tbody></table></section>\n";
}

// Numeric-aware order of clauses: "§3.2.10" after "§3.2.9".
bool clause_less(const std::string& a, const std::string& b) {
  std::size_t i = 0;
  std::size_t j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = a[i] >= '0' && a[i] <= '9';
    const bool db = b[j] >= '0' && b[j] <= '9';
    if (da && db) {
      std::size_t ei = i;
      std::size_t ej = j;
      while (ei < a.size() && a[ei] >= '0' && a[ei] <= '9')
        ++ei;
      while (ej < b.size() && b[ej] >= '0' && b[ej] <= '9')
        ++ej;
      const std::string na = a.substr(i, ei - i);
      const std::string nb = b.substr(j, ej - j);
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ei;
      j = ej;
      continue;
    }
    if (a[i] != b[j]) return a[i] < b[j];
    ++i;
    ++j;
  }
  return a.size() - i < b.size() - j;
}

// The matrix by clause: each CiA 301 / CiA 402 clause or manual section the vectors cite, the
// vectors that cite it and their verdicts. A cell filters the list to that clause.
void render_clause_matrix(std::string& out, const RunResult& result) {
  std::map<std::string, std::vector<const VectorResult*>> by_clause;
  for (const auto& vector : result.vectors) {
    std::vector<std::string> seen;
    for (const auto& source : vector.sources) {
      std::string clause = clause_of(source);
      if (std::find(seen.begin(), seen.end(), clause) != seen.end()) continue;
      seen.push_back(clause);
      by_clause[std::move(clause)].push_back(&vector);
    }
  }
  std::vector<std::string> clauses;
  for (const auto& [clause, list] : by_clause)
    clauses.push_back(clause);
  std::sort(clauses.begin(), clauses.end(), clause_less);
  fmt::format_to(std::back_inserter(out),
                 "<section><details id=\"clause-box\"><summary><h2 style=\"display:inline\">"
                 "Conformance matrix by clause</h2> ({} clauses and manual sections)</summary>\n"
                 "<table id=\"clause-matrix\"><thead><tr><th>Clause</th>",
                 clauses.size());
  tally_header(out);
  out += "<th>vectors</th></tr></thead><tbody>\n";
  for (const auto& clause : clauses) {
    const auto& list = by_clause[clause];
    conformance::VerdictCounts counts;
    for (const VectorResult* vector : list)
      counts.add(vector->verdict, vector->warning);
    const conformance::CitedDocument* document = cited_document(result.info, clause);
    fmt::format_to(std::back_inserter(out),
                   "<tr data-clause=\"{0}\"><th><a href=\"#clause={1}\" data-clause-link=\"{0}\">"
                   "{0}</a>{2}</th>",
                   esc(clause), esc(url_component(clause)),
                   document == nullptr
                       ? std::string()
                       : "<br><span class=\"doc\">" + esc(document->title) +
                             (document->edition.empty() ? "" : ", " + esc(document->edition)) +
                             "</span>");
    for (std::size_t i = 0; i < conformance::kTallyCount; ++i) {
      if (counts.by_tally[i] == 0)
        out += "<td class=\"zero\">0</td>";
      else
        fmt::format_to(std::back_inserter(out), "<td class=\"v-{}\">{}</td>",
                       to_string(static_cast<Tally>(i)), counts.by_tally[i]);
    }
    out += "<td class=\"vectors\">";
    for (const VectorResult* vector : list) {
      fmt::format_to(std::back_inserter(out),
                     "<a class=\"v-{0}\" href=\"#open={1}\" title=\"{0}\">{2}</a>",
                     to_string(tally_of(*vector)), esc(url_component(vector->id)), esc(vector->id));
    }
    out += "</td></tr>\n";
  }
  out += "</tbody></table></details></section>\n";
}

// The transcript lines of `frames`, with a marker line before the first frame after each
// failed check's time (where the vector failed).
void render_transcript(std::string& out, const VectorResult& vector) {
  std::vector<const conformance::Check*> marks;
  for (const auto& check : vector.checks)
    if (!check.ok && check.at) marks.push_back(&check);
  std::size_t next = 0;
  const auto mark_until = [&](std::optional<can::TimePoint> before) {
    while (next < marks.size() && (!before || *marks[next]->at < *before)) {
      const auto* check = marks[next++];
      fmt::format_to(std::back_inserter(out),
                     "<span class=\"failmark\" data-failure-step=\"{}\">{} ✗ {} failed here: "
                     "Expected {}; Actual {}</span>\n",
                     check->step,
                     fmt::format("({:11.6f})",
                                 static_cast<double>((*check->at - vector.started).count()) / 1e9),
                     conformance::step_label(check->step, check->iterations), esc(check->expected),
                     esc(check->actual));
    }
  };
  RepeatLines repeats;
  for (std::size_t i = 0; i < vector.frames.size(); ++i) {
    if (vector.frames_elided != 0 && i == vector.frames_elided_at) {
      out += esc(elided_line(vector.frames_elided));
      out += '\n';
    }
    if (const auto* repeat = repeats.before(i)) {
      mark_until(repeat->until);
      out += esc(repeat_line(*repeat, vector.started, "frame(s)"));
      out += '\n';
    }
    mark_until(vector.frames[i].at);
    out += esc(transcript_line(vector.frames[i], vector.started));
    out += '\n';
    repeats.after(i, vector.frames[i].repeat);
  }
  mark_until(std::nullopt);
}

// The frames a vector's summarised patterns left out.
std::size_t repeated_frames(const VectorResult& vector) {
  std::size_t n = 0;
  for (const auto& frame : vector.frames)
    n += frame.repeat.times * frame.repeat.length;
  return n;
}

void render_vector(std::string& out, const VectorResult& vector, const RunResult& result) {
  const std::string verdict(to_string(vector.verdict));
  const Tally tally = tally_of(vector);
  std::string clauses;
  for (const auto& source : vector.sources)
    clauses += (clauses.empty() ? "" : "\n") + clause_of(source);
  const bool expand_in_print =
      tally == Tally::fail || tally == Tally::error || tally == Tally::warning;
  fmt::format_to(std::back_inserter(out),
                 "<details class=\"vector\" id=\"v:{0}\" data-verdict=\"{1}\" data-tally=\"{8}\" "
                 "data-family=\"{2}\" data-warning=\"{3}\" data-clauses=\"{9}\"{10}><summary><span "
                 "class=\"badge v-{4}\">{5}</span> <code>{0}</code> {6}<a class=\"permalink\" "
                 "href=\"#open={7}\" title=\"link to this vector\">#</a></summary>\n<div "
                 "class=\"vbody\">",
                 esc(vector.id), verdict, esc(vector.family), vector.warning ? "true" : "false",
                 to_string(tally), label(tally), esc(vector.title), esc(url_component(vector.id)),
                 to_string(tally), esc(clauses), expand_in_print ? " data-print=\"expand\"" : "");
  fmt::format_to(std::back_inserter(out), "<p class=\"requirement\"><b>{}</b> · level <b>{}</b>",
                 esc(vector.title), to_string(vector.level));
  for (const auto& source : vector.sources) {
    const conformance::CitedDocument* document = cited_document(result.info, source);
    fmt::format_to(
        std::back_inserter(out), " · source <span class=\"mono\">{}</span>{}", esc(source),
        document == nullptr
            ? std::string()
            : " <span class=\"doc\">(" + esc(document->title) +
                  (document->edition.empty() ? "" : ", " + esc(document->edition)) + ")</span>");
  }
  if (!vector.file.empty())
    fmt::format_to(std::back_inserter(out), " · vector <span class=\"mono\">{}:{}</span>",
                   esc(vector.file), vector.line);
  out += "</p>\n";
  fmt::format_to(std::back_inserter(out), "<p>Verdict: <b class=\"v-{}\">{}</b>{}</p>\n", verdict,
                 verdict,
                 vector.warning ? " (warning: a " + std::string(to_string(vector.level)) +
                                      " requirement; fails only with --strict)"
                                : "");
  if (vector.verdict == Verdict::deviation) {
    fmt::format_to(std::back_inserter(out),
                   "<p class=\"deviation\">Documented deviation <code>{}</code>, source "
                   "<span class=\"mono\">{}</span></p>\n",
                   esc(vector.deviation_id),
                   esc(citation_text(result.info, vector.deviation_source)));
  }
  if (!vector.message.empty())
    fmt::format_to(std::back_inserter(out), "<div class=\"message\">{}</div>\n",
                   esc(vector.message));
  if (!vector.checks.empty()) {
    // Steps numbered from 1 as in the vector file and the message; "setup" for the setup.
    out +=
        "<table class=\"checks\"><thead><tr><th>step</th><th>action</th><th>Expected</th>"
        "<th>Actual</th><th></th></tr></thead><tbody>";
    for (const auto& check : vector.checks) {
      fmt::format_to(
          std::back_inserter(out),
          "<tr><td>{}</td><td>{}</td><td class=\"mono\">{}</td><td "
          "class=\"mono\">{}</td><td class=\"{}\">{}</td></tr>",
          check.step == 0 ? std::string("setup")
          : check.iterations.empty()
              ? std::to_string(check.step)
              : fmt::format("{} ({})", check.step, conformance::iteration_text(check.iterations)),
          esc(check.action), esc(check.expected), esc(check.actual), check.ok ? "ok" : "bad",
          check.ok ? "ok" : "FAILED");
    }
    out += "</tbody></table>\n";
  }
  if (!vector.timings.empty()) {
    out +=
        "<table class=\"timings\"><thead><tr><th>timing</th><th>measured</th><th>min</th>"
        "<th>max</th><th></th></tr></thead><tbody>";
    for (const auto& timing : vector.timings) {
      fmt::format_to(std::back_inserter(out),
                     "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td class=\"{}\">{}</td>"
                     "</tr>",
                     esc(timing.name), ms_text(timing.measured),
                     timing.min ? ms_text(*timing.min) : "", timing.max ? ms_text(*timing.max) : "",
                     timing.ok ? "ok" : "bad", timing.ok ? "ok" : "FAILED");
    }
    out += "</tbody></table>\n";
  }
  render_timing_svg(out, vector);
  if (!vector.between_vectors.empty()) {
    fmt::format_to(std::back_inserter(out),
                   "<div class=\"between\" data-between-vectors=\"{}\"><p>Between vectors: {} "
                   "frame(s) arrived after the vector before ended and before this vector's setup "
                   "(e.g. a late answer to the vector before). They are not this vector's "
                   "evidence.</p><pre class=\"transcript between-vectors\">",
                   vector.between_vectors.size(), vector.between_vectors.size());
    for (const auto& frame : vector.between_vectors) {
      out += esc(transcript_line(frame, vector.started));
      out += '\n';
    }
    out += "</pre></div>\n";
  }
  if (!vector.datagrams.empty()) {
    // EtherCAT: the master's datagrams, decoded; runs of identical frames counted.
    std::size_t frames = vector.datagrams_elided;
    for (const auto& d : vector.datagrams)
      frames += d.count;
    for (std::size_t i = 0; i < vector.datagrams.size(); ++i) {
      const auto& repeat = vector.datagrams[i].repeat;
      for (std::size_t k = 0; k < repeat.length && repeat.times != 0; ++k)
        frames += repeat.times * vector.datagrams[i + k].count;  // about: a shown pattern's counts
    }
    fmt::format_to(std::back_inserter(out),
                   "<p class=\"mono\">{} EtherCAT datagrams, {} bus time</p><pre "
                   "class=\"transcript datagrams\">{}</pre></div></details>\n",
                   frames, ms_text(vector.finished - vector.started),
                   esc(datagram_transcript(vector)));
    return;
  }
  fmt::format_to(std::back_inserter(out),
                 "<p class=\"mono\">{} frames, {} bus time</p><pre class=\"transcript\">",
                 vector.frames.size() + vector.frames_elided + repeated_frames(vector),
                 ms_text(vector.finished - vector.started));
  render_transcript(out, vector);
  out += "</pre></div></details>\n";
}

}  // namespace

std::string render_html(const RunResult& result) {
  std::string out;
  out.reserve(4096 + result.vectors.size() * 4096);
  const auto counts = result.counts();
  const std::string name = result.info.dut.device_name.value_or(result.info.profile_name);
  fmt::format_to(std::back_inserter(out),
                 "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n"
                 "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
                 "<meta name=\"generator\" content=\"drivecheck {}\">\n"
                 "<title>drivecheck report — {}</title>\n<style>{}</style></head>\n"
                 "<body data-js=\"off\">\n<header><h1>CANopen conformance report — {}</h1>\n",
                 esc(result.info.tool_version), esc(name), kStyle, esc(name));
  render_run_info(out, result);
  render_counts(out, result);
  out += "</header>\n<div class=\"matrices\">";
  render_matrix(out, result);
  render_clause_matrix(out, result);
  out += "</div>\n";

  out +=
      "<p class=\"legend\"><b>pass</b>: the device did what the requirement says. "
      "<b>fail</b>: it did not (the Expected/Actual block and the frames show how). "
      "<b>deviation</b>: it did not, exactly where its manual documents that it deviates "
      "(with the manual's section): specified behaviour, not a failure. <b>n/a</b>: the "
      "device does not have the feature (per its profile or EDS). <b>error</b>: the test "
      "could not be carried out. <b>warning</b>: a SHOULD/MAY requirement not met (fails "
      "only with --strict; counted as a warning, not a failure). <b>interrupted</b>: the run "
      "was stopped while the vector ran: no verdict, neither passed nor failed.</p>\n";
  out += "<h2>Vectors</h2>\n<div class=\"filters\" id=\"filters\">";
  out +=
      "<input type=\"search\" id=\"search\" placeholder=\"search id, title, source, "
      "message\" aria-label=\"search the vectors\">";
  fmt::format_to(std::back_inserter(out),
                 "<button type=\"button\" data-filter=\"all\" class=\"on\">all ({})</button>",
                 counts.total());
  for (std::size_t i = 0; i < conformance::kTallyCount; ++i) {
    const auto tally = static_cast<Tally>(i);
    fmt::format_to(std::back_inserter(out),
                   "<button type=\"button\" data-filter=\"{0}\" class=\"v-{0}\">{1} ({2})</button>",
                   to_string(tally), label(tally), counts.by_tally[i]);
  }
  out +=
      "<button type=\"button\" data-action=\"expand\">expand shown</button>"
      "<button type=\"button\" data-action=\"collapse\">collapse all</button>"
      "<span id=\"shown\"></span></div>\n<div id=\"vectors\">\n";
  for (const auto& vector : result.vectors)
    render_vector(out, vector, result);
  fmt::format_to(std::back_inserter(out),
                 "</div>\n<footer>Generated by drivecheck {} · times are bus time from each "
                 "vector's start · tx = sent by drivecheck, rx = sent by the device</footer>\n"
                 "<script>{}</script>\n</body></html>\n",
                 esc(result.info.tool_version), kScript);
  return out;
}

Expected<void, std::string> write_html_report(const std::filesystem::path& path,
                                              const RunResult& result) {
  return write_file_atomically(path, render_html(result));
}

}  // namespace drivecheck::reports
