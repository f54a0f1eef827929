// Where a run's vectors come from, for the reports (RunInfo::vector_digest, ::documents):
// a digest of the vector set, and the documents its citations refer to with their editions.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "conformance/result.hpp"
#include "protocol/common/expected.hpp"

namespace drivecheck::conformance {

struct VectorSetDigest {
  std::string sha256;
  std::size_t files = 0;
};

// The digest of a vector directory: every regular `*.yaml` file under `dir` (vector files,
// drives/ profiles, manuals.yaml, coverage.yaml), each as the line
// "<sha256 of its bytes>  <path relative to dir, '/'-separated>\n" (sha256sum's format), the
// lines sorted by path (bytewise), and the sha256 of their concatenation. It depends on the
// files' paths and bytes only: not on the directory's location, the order the files are found
// or read, or time stamps. The same in a shell:
//   cd vectors && find . -type f -name '*.yaml' | sed 's|^\./||' | LC_ALL=C sort |
//     xargs sha256sum | sha256sum
Expected<VectorSetDigest, std::string> vector_set_digest(const std::filesystem::path& dir);
// The digest of a tree and user directories (`--vectors DIR`): the same listing, the first
// directory's paths as above, the k-th user directory's (k from 1) as "+k/<path>", all sorted
// together. With no user directory it is vector_set_digest(dirs.front()).
Expected<VectorSetDigest, std::string> vector_set_digest(
    const std::vector<std::filesystem::path>& dirs);

// The editions of the standards whose clauses the vectors cite ("CiA 301 §7.2.4.3.17",
// "CiA 402-2 §6060h modes of operation"): one table, shown once in every report.
inline constexpr std::array<std::array<std::string_view, 3>, 3> kCitedStandards{{
    // CiA 301 v4.2.0: the edition the clause numbers were taken from; the SDO abort-code table
    // (protocol/cia301/sdo_abort_codes.inc: §7.2.4.3.17 Table 22) was checked against it.
    {"CiA 301", "CANopen application layer and communication profile", "v4.2.0 (2011-02-21)"},
    // CiA 402-2 is cited by object and section name ("6060h modes of operation", "Homing
    // methods 17 to 30"), not by clause number; the edition below is the one the object
    // names and homing methods match, to be confirmed against the text used.
    {"CiA 402-2",
     "CANopen device profile for drives and motion control, part 2: operation modes and "
     "application data (IEC 61800-7-201 profile type 1)",
     "v4.1.0 (to be confirmed: citations name objects and sections, not clause numbers)"},
    // ETG.2000 (the ESI format) is cited by element path, never by section: its text is not
    // public to us. The paths and values are those of the ESI schema published with it
    // (EtherCATInfo.xsd/EtherCATBase.xsd 1.9, which names ETG.2000 1.0.5; public copy in
    // github.com/synapticon/siitool examples/).
    {"ETG.2000", "EtherCAT Slave Information (ESI) Specification",
     "cited by element path of its schema EtherCATInfo.xsd 1.9 (ETG.2000 1.0.5); no section "
     "numbers: the text is not public to us"},
}};

// The documents for RunInfo::documents: the standards above, then each manual of
// `manuals_yaml` (vectors/manuals.yaml: key = its file name, title and edition from its
// `title:`/`edition:`, the `device:` when it has no title). An unreadable manual list gives
// the standards only (the reports then show bare citations for the manuals).
std::vector<CitedDocument> cited_documents(const std::filesystem::path& manuals_yaml);
// The same over several manual lists (the shipped one, then each user directory's; a list that
// does not exist adds nothing).
std::vector<CitedDocument> cited_documents(const std::vector<std::filesystem::path>& manual_lists);

}  // namespace drivecheck::conformance
