// The vector-set digest and the cited documents (provenance.hpp).
#include "conformance/provenance.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <system_error>
#include <utility>

#include "conformance/sha256.hpp"
#include "conformance/vector_lint.hpp"

namespace drivecheck::conformance {

namespace {

Expected<void, std::string> list_yaml_files(
    const std::filesystem::path& dir, const std::string& prefix,
    std::vector<std::pair<std::string, std::filesystem::path>>& files) {
  std::error_code error;
  std::filesystem::recursive_directory_iterator it(dir, error);
  if (error) return Unexpected("cannot read " + dir.string() + ": " + error.message());
  for (const auto end = std::filesystem::recursive_directory_iterator(); it != end;
       it.increment(error)) {
    if (error) return Unexpected("cannot read " + dir.string() + ": " + error.message());
    if (!it->is_regular_file(error) || it->path().extension() != ".yaml") continue;
    files.emplace_back(prefix + it->path().lexically_relative(dir).generic_string(), it->path());
  }
  if (error) return Unexpected("cannot read " + dir.string() + ": " + error.message());
  return {};
}

}  // namespace

Expected<VectorSetDigest, std::string> vector_set_digest(const std::filesystem::path& dir) {
  return vector_set_digest(std::vector<std::filesystem::path>{dir});
}

Expected<VectorSetDigest, std::string> vector_set_digest(
    const std::vector<std::filesystem::path>& dirs) {
  std::vector<std::pair<std::string, std::filesystem::path>> files;
  for (std::size_t k = 0; k < dirs.size(); ++k) {
    auto listed = list_yaml_files(dirs[k], k == 0 ? std::string() : fmt::format("+{}/", k), files);
    if (!listed) return Unexpected(listed.error());
  }
  std::sort(files.begin(), files.end());
  std::string listing;
  for (const auto& [name, path] : files) {
    auto digest = sha256_file(path);
    if (!digest) return Unexpected(digest.error());
    listing += *digest + "  " + name + "\n";
  }
  return VectorSetDigest{sha256_hex(listing), files.size()};
}

std::vector<CitedDocument> cited_documents(const std::filesystem::path& manuals_yaml) {
  return cited_documents(std::vector<std::filesystem::path>{manuals_yaml});
}

std::vector<CitedDocument> cited_documents(const std::vector<std::filesystem::path>& manual_lists) {
  std::vector<CitedDocument> documents;
  for (const auto& [key, title, edition] : kCitedStandards)
    documents.push_back({std::string(key), std::string(title), std::string(edition)});
  for (const auto& list : manual_lists) {
    const auto manuals = load_manuals(list);
    if (!manuals) continue;
    for (const auto& manual : *manuals) {
      documents.push_back(
          {manual.file, manual.title.empty() ? manual.device : manual.title, manual.edition});
    }
  }
  return documents;
}

}  // namespace drivecheck::conformance
