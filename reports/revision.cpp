// The drivecheck revision, generated at build time (reports/revision.cmake).
#include "drivecheck_revision.hpp"
#include "reports/report_writers.hpp"

namespace drivecheck::reports {

std::string_view build_revision() {
  return DRIVECHECK_REVISION;
}

}  // namespace drivecheck::reports
