// Why a frame does not decode as the service its identifier says it carries.
//
// Every CiA 301 codec in this folder (NMT, error control, SYNC, TIME, EMCY, PDO) decodes any
// frame totally: a typed value, or a DecodeError whose reason is one readable sentence that
// names the service, the defect and the rule, e.g.
//   "NMT node control with DLC 1: invalid (NMT frames carry 2 bytes)".
// Reports and the dissector print the reason as it is; tests compare it by substring.
#pragma once

#include <string>

namespace drivecheck::cia301 {

struct DecodeError {
  std::string reason;
};

}  // namespace drivecheck::cia301
