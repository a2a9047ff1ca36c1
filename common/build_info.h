// What built this binary, for the /provenance of every record (virtual_gonio/RECORD.md): the
// source commit, the compiler and the libraries it was compiled against.
#pragma once

#include <span>
#include <string_view>

namespace plumage {

// `git describe --always` of the source tree when this binary was built, with
// "-dirty-<12 hex digits of the SHA-1 of the tracked files' diff>" when they differed from that
// commit (so different edits give different names); refreshed at every build. "unknown" when
// the sources are not a git checkout of their own (a tarball) or git is missing.
std::string_view git_commit();

// The C++ compiler, e.g. "GNU 12.2.0".
std::string_view compiler();

// A library this build was compiled against and its version ("" when its CMake package does
// not give one).
struct LibraryVersion {
    std::string_view name;
    std::string_view version;
};
// Embree, HDF5, Eigen, OpenVDB and CGAL (in that order): what the plumage binary links.
std::span<const LibraryVersion> library_versions();

}  // namespace plumage
