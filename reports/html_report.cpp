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
#include <string>
#include <vector>

#include "protocol/cia402/controlword.hpp"
#include "protocol/cia402/statusword.hpp"
#include "reports/report_writers.hpp"

namespace drivecheck::reports {
namespace {

using conformance::RunResult;
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

constexpr std::array<std::string_view, conformance::kVerdictCount> kVerdictLabels{
    "pass", "fail", "deviation", "n/a", "error"};

std::string_view label(Verdict verdict) {
  return kVerdictLabels[static_cast<std::size_t>(verdict)];
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
@media print{.filters{display:none}details.vector>summary{list-style:none}}
details.vector{border:1px solid var(--line);border-left:4px solid var(--line);border-radius:4px;margin:4px 0}
details.vector[data-verdict=pass]{border-left-color:var(--pass)}
details.vector[data-verdict=fail]{border-left-color:var(--fail)}
details.vector[data-verdict=deviation]{border-left-color:var(--deviation)}
details.vector[data-verdict=not-applicable]{border-left-color:var(--na)}
details.vector[data-verdict=error]{border-left-color:var(--error)}
details.vector[data-warning=true]{border-left-color:var(--warn)}
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
  function apply(filter, family) {
    var n = 0;
    for (var i = 0; i < items.length; i++) {
      var d = items[i];
      var ok = filter === 'all' ||
               (filter === 'warning' ? d.getAttribute('data-warning') === 'true'
                                     : d.getAttribute('data-verdict') === filter);
      if (family && d.getAttribute('data-family') !== family) ok = false;
      d.hidden = !ok;
      if (ok) n++;
    }
    for (var j = 0; j < buttons.length; j++)
      buttons[j].classList.toggle('on', buttons[j].getAttribute('data-filter') === filter);
    list.setAttribute('data-filter', filter);
    list.setAttribute('data-family', family || '');
    shown.textContent = n + ' shown' + (family ? ' in ' + family : '');
    shown.setAttribute('data-shown', String(n));
  }
  function fromHash() {
    var params = new URLSearchParams(location.hash.replace(/^#/, ''));
    var open = params.get('open');
    if (open !== null) {
      apply('all', '');
      var d = document.getElementById('v:' + open);
      if (d) {
        d.open = true;
        d.setAttribute('data-opened', 'fragment');
        // After layout settles (a headless screenshot resizes the window after load).
        window.requestAnimationFrame(function () { d.scrollIntoView({block: 'start'}); });
      }
      return;
    }
    apply(params.get('filter') || 'all', params.get('family') || '');
  }
  for (var k = 0; k < buttons.length; k++) {
    buttons[k].addEventListener('click', function (e) {
      location.hash = 'filter=' + encodeURIComponent(e.currentTarget.getAttribute('data-filter'));
    });
  }
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

struct Trace {
  std::string label;
  bool digital = false;
  std::vector<std::pair<std::int64_t, std::int64_t>> points;  // (t ns from t0, value)

  // Sample-and-hold: a sample equal to the value held adds nothing to draw (this keeps a
  // 1000-vector page small: a bit that toggles twice is three points, not one per sample).
  void add(std::int64_t t, std::int64_t value) {
    if (points.empty() || points.back().second != value) points.emplace_back(t, value);
  }
};

void render_timing_svg(std::string& out, const VectorResult& vector) {
  // Signals in first-appearance order, samples sorted by time within each.
  std::vector<std::string> order;
  std::map<std::string, std::vector<std::pair<std::int64_t, std::int64_t>>> signals;
  std::int64_t t_min = INT64_MAX;
  std::int64_t t_max = INT64_MIN;
  for (const auto& sample : vector.samples) {
    auto& list = signals[sample.signal];
    if (list.empty()) order.push_back(sample.signal);
    const std::int64_t t = sample.at.time_since_epoch().count();
    list.emplace_back(t, sample.value);
    t_min = std::min(t_min, t);
    t_max = std::max(t_max, t);
  }
  if (order.empty()) return;
  const std::int64_t span = std::max<std::int64_t>(t_max - t_min, 1'000'000);  // ≥ 1 ms

  std::vector<Trace> traces;
  for (const auto& name : order) {
    auto& list = signals[name];
    std::stable_sort(list.begin(), list.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    const bool is_cw = name == "controlword";
    const bool is_sw = name == "statusword";
    if (is_cw || is_sw) {
      const auto bits = is_cw ? std::span<const BitName>(kControlwordBits)
                              : std::span<const BitName>(kStatuswordBits);
      for (const BitName& bit : bits) {
        bool ever_set = false;
        for (const auto& [t, value] : list)
          if ((static_cast<std::uint64_t>(value) & bit.mask) != 0) ever_set = true;
        if (!ever_set) continue;
        Trace trace{fmt::format("{} {}", is_cw ? "CW" : "SW", bit.name), true, {}};
        for (const auto& [t, value] : list)
          trace.add(t - t_min, (static_cast<std::uint64_t>(value) & bit.mask) != 0 ? 1 : 0);
        traces.push_back(std::move(trace));
      }
    } else {
      Trace trace{name, false, {}};
      for (const auto& [t, value] : list)
        trace.add(t - t_min, value);
      traces.push_back(std::move(trace));
    }
  }
  if (traces.empty()) return;

  constexpr int kLeft = 236;
  constexpr int kWidth = 1000;
  constexpr int kPlot = kWidth - kLeft - 20;
  constexpr int kDigitalHeight = 18;
  constexpr int kAnalogHeight = 64;
  int height = 8;
  for (const auto& trace : traces)
    height += (trace.digital ? kDigitalHeight : kAnalogHeight) + 4;
  const int axis_y = height;
  height += 24;

  const auto x_of = [&](std::int64_t t) {
    return kLeft + static_cast<double>(t) * kPlot / static_cast<double>(span);
  };
  fmt::format_to(std::back_inserter(out),
                 "<svg class=\"timing\" viewBox=\"0 0 {} {}\" role=\"img\" "
                 "xmlns=\"http://www.w3.org/2000/svg\"><title>Timing diagram of {}</title>\n",
                 kWidth, height, esc(vector.id));
  int y = 8;
  for (const auto& trace : traces) {
    const int row = trace.digital ? kDigitalHeight : kAnalogHeight;
    std::int64_t lo = 0;
    std::int64_t hi = 1;
    if (!trace.digital) {
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
    if (trace.digital) {
      fmt::format_to(std::back_inserter(out), "<text x=\"4\" y=\"{}\">{}</text>", y + row - 4,
                     esc(trace.label));
    } else {
      fmt::format_to(std::back_inserter(out),
                     "<text x=\"4\" y=\"{}\">{}</text><text x=\"4\" y=\"{}\" "
                     "fill=\"#59636e\">{} … {}</text>",
                     y + 14, esc(trace.label), y + 30, lo, hi);
    }
    // Sample-and-hold: each value holds until the next sample, the last one to the end.
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
                   trace.digital ? "#0969da" : "#bc4c00", points);
    y += row + 4;
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
  if (!info.eds_file.empty()) row("EDS", info.eds_file + "  sha256 " + info.eds_sha256);
  row("Date", info.started_utc);
  row("Bus", fmt::format("{}, node {}", info.bus, info.node));
  if (!info.personality.empty()) row("Reference drive personality", info.personality);
  if (!info.deviations.empty()) {
    std::string list;
    for (const auto& deviation : info.deviations)
      list += (list.empty() ? "" : ", ") + deviation;
    row("Injected deviations", list);
  }
  row("Options", fmt::format("seed {}{}{}{}", info.seed, info.strict ? ", --strict" : "",
                             info.allow_motion ? ", --allow-motion" : "",
                             info.filter.empty() ? "" : ", --filter " + info.filter));
  row("Duration",
      fmt::format("{:.3f} s bus time, {:.3f} s wall",
                  static_cast<double>(result.simulated.count()) / 1e9, result.wall_seconds));
  row("drivecheck", info.tool_version);
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
  const auto counts = result.counts();
  out += "<div class=\"counts\" id=\"counts\">";
  fmt::format_to(std::back_inserter(out),
                 "<span class=\"count\"><b data-count-total>{}</b>vectors</span>", counts.total());
  for (std::size_t i = 0; i < conformance::kVerdictCount; ++i) {
    const auto verdict = static_cast<Verdict>(i);
    fmt::format_to(std::back_inserter(out),
                   "<span class=\"count v-{0}\"><b data-count-{0}>{1}</b>{2}</span>",
                   to_string(verdict), counts.by_verdict[i], label(verdict));
  }
  fmt::format_to(std::back_inserter(out),
                 "<span class=\"count v-warning\"><b data-count-warnings>{}</b>warnings</span>",
                 counts.warnings);
  fmt::format_to(std::back_inserter(out),
                 "<span class=\"count\">exit code <b data-exit-code>{}</b></span></div>\n",
                 conformance::exit_code(result));
}

void render_matrix(std::string& out, const RunResult& result) {
  std::vector<std::string> families;
  std::map<std::string, conformance::VerdictCounts> by_family;
  for (const auto& vector : result.vectors) {
    auto [it, inserted] = by_family.try_emplace(vector.family);
    if (inserted) families.push_back(vector.family);
    ++it->second.by_verdict[static_cast<std::size_t>(vector.verdict)];
    if (vector.warning) ++it->second.warnings;
  }
  out += "<h2>Conformance matrix</h2>\n<table id=\"matrix\"><thead><tr><th>Family</th>";
  for (std::size_t i = 0; i < conformance::kVerdictCount; ++i)
    fmt::format_to(std::back_inserter(out), "<th class=\"v-{}\">{}</th>",
                   to_string(static_cast<Verdict>(i)), label(static_cast<Verdict>(i)));
  out += "<th class=\"v-warning\">warnings</th><th>total</th></tr></thead><tbody>\n";
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
    for (std::size_t i = 0; i < conformance::kVerdictCount; ++i)
      cell(to_string(static_cast<Verdict>(i)), family, counts.by_verdict[i]);
    cell("warning", family, counts.warnings);
    cell("all", family, counts.total());
    out += "</tr>\n";
  }
  out += "</tbody></table>\n";
}

void render_vector(std::string& out, const VectorResult& vector) {
  const std::string verdict(to_string(vector.verdict));
  fmt::format_to(std::back_inserter(out),
                 "<details class=\"vector\" id=\"v:{0}\" data-verdict=\"{1}\" data-family=\"{2}\" "
                 "data-warning=\"{3}\"><summary><span class=\"badge v-{4}\">{5}</span> "
                 "<code>{0}</code> {6}<a class=\"permalink\" href=\"#open={7}\" "
                 "title=\"link to this vector\">#</a></summary>\n<div class=\"vbody\">",
                 esc(vector.id), verdict, esc(vector.family), vector.warning ? "true" : "false",
                 vector.warning ? "warning" : verdict,
                 vector.warning ? "warning" : label(vector.verdict), esc(vector.title),
                 esc(url_component(vector.id)));
  fmt::format_to(std::back_inserter(out), "<p class=\"requirement\"><b>{}</b> · level <b>{}</b>",
                 esc(vector.title), to_string(vector.level));
  for (const auto& source : vector.sources)
    fmt::format_to(std::back_inserter(out), " · source <span class=\"mono\">{}</span>",
                   esc(source));
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
                   esc(vector.deviation_id), esc(vector.deviation_source));
  }
  if (!vector.message.empty())
    fmt::format_to(std::back_inserter(out), "<div class=\"message\">{}</div>\n",
                   esc(vector.message));
  if (!vector.checks.empty()) {
    out +=
        "<table class=\"checks\"><thead><tr><th>step</th><th>action</th><th>Expected</th>"
        "<th>Actual</th><th></th></tr></thead><tbody>";
    for (const auto& check : vector.checks) {
      fmt::format_to(std::back_inserter(out),
                     "<tr><td>{}</td><td>{}</td><td class=\"mono\">{}</td><td "
                     "class=\"mono\">{}</td><td class=\"{}\">{}</td></tr>",
                     check.step, esc(check.action), esc(check.expected), esc(check.actual),
                     check.ok ? "ok" : "bad", check.ok ? "ok" : "FAILED");
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
  fmt::format_to(std::back_inserter(out),
                 "<p class=\"mono\">{} frames, {} bus time</p><pre class=\"transcript\">",
                 vector.frames.size() + vector.frames_elided,
                 ms_text(vector.finished - vector.started));
  for (std::size_t i = 0; i < vector.frames.size(); ++i) {
    if (vector.frames_elided != 0 && i == vector.frames_elided_at) {
      out += esc(elided_line(vector.frames_elided));
      out += '\n';
    }
    out += esc(transcript_line(vector.frames[i], vector.started));
    out += '\n';
  }
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
  out += "</header>\n";
  render_matrix(out, result);

  out +=
      "<p class=\"legend\"><b>pass</b>: the device did what the requirement says. "
      "<b>fail</b>: it did not (the Expected/Actual block and the frames show how). "
      "<b>deviation</b>: it did not, exactly where its manual documents that it deviates "
      "(with the manual's section): specified behaviour, not a failure. <b>n/a</b>: the "
      "device does not have the feature (per its profile or EDS). <b>error</b>: the test "
      "could not be carried out. <b>warning</b>: a SHOULD/MAY requirement not met (fails "
      "only with --strict).</p>\n";
  out += "<h2>Vectors</h2>\n<div class=\"filters\" id=\"filters\">";
  fmt::format_to(std::back_inserter(out),
                 "<button type=\"button\" data-filter=\"all\" class=\"on\">all ({})</button>",
                 counts.total());
  for (std::size_t i = 0; i < conformance::kVerdictCount; ++i) {
    const auto verdict = static_cast<Verdict>(i);
    fmt::format_to(std::back_inserter(out),
                   "<button type=\"button\" data-filter=\"{0}\" class=\"v-{0}\">{1} ({2})</button>",
                   to_string(verdict), label(verdict), counts.by_verdict[i]);
  }
  fmt::format_to(std::back_inserter(out),
                 "<button type=\"button\" data-filter=\"warning\" class=\"v-warning\">warnings "
                 "({})</button><button type=\"button\" data-action=\"expand\">expand shown</button>"
                 "<button type=\"button\" data-action=\"collapse\">collapse all</button>"
                 "<span id=\"shown\"></span></div>\n<div id=\"vectors\">\n",
                 counts.warnings);
  for (const auto& vector : result.vectors)
    render_vector(out, vector);
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
