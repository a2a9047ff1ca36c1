#!/usr/bin/python3
"""Every library includes only what it links (docs/architecture.md).

Reads each library's sources and links from the CMakeLists.txt files (add_library,
target_link_libraries), gives each header the library that lists it or the library of its .cpp (or,
for a header with neither, of its folder's sources), and checks every `#include "dir/file.h"` of every library source and
header: the included file's library must be the file's own or one it links, directly or through
another. Prints each violation as file:line and exits 1 if there is any.

    check-arrows.py [REPO]
"""
import collections
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent).resolve()


def cmake_calls(text, command):
    """Argument lists of every `command(...)` call, comments removed, split on whitespace."""
    text = re.sub(r"#[^\n]*", "", text)
    for m in re.finditer(command + r"\s*\(([^)]*)\)", text):
        yield m.group(1).split()


library_of = {}                       # source path (relative) -> library
links = collections.defaultdict(set)  # library -> plumage libraries it links
folder_votes = collections.defaultdict(collections.Counter)
for cmake in sorted(root.rglob("CMakeLists.txt")):
    rel = cmake.parent.relative_to(root)
    if rel.parts and rel.parts[0] in ("tests", "bench", "fuzz") or "build" in rel.parts[0:1] or \
            (rel.parts and rel.parts[0].startswith("build")):
        continue
    text = cmake.read_text()
    for args in cmake_calls(text, "add_library"):
        # Sources, and headers listed with them (an internal header without a .cpp of its own).
        name, sources = args[0], [a for a in args[1:] if a.endswith((".cpp", ".h"))]
        for s in sources:
            path = (rel / s).as_posix()
            library_of[path] = name
            folder_votes[pathlib.PurePosixPath(path).parent.as_posix()][name] += 1
    for args in cmake_calls(text, "target_link_libraries"):
        links[args[0]].update(a for a in args[1:] if a.startswith("plumage_") and a != "plumage_warnings")


def library(path):
    """The library a repository file belongs to, or None (tests, programs, generated files)."""
    p = pathlib.PurePosixPath(path)
    if path in library_of:
        return library_of[path]
    cpp = p.with_suffix(".cpp").as_posix()
    if cpp in library_of:
        return library_of[cpp]
    votes = folder_votes.get(p.parent.as_posix())
    return votes.most_common(1)[0][0] if votes else None


def reachable(lib):
    seen, pending = {lib}, [lib]
    while pending:
        for dep in links.get(pending.pop(), ()):
            if dep not in seen:
                seen.add(dep)
                pending.append(dep)
    return seen


violations = 0
include = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
for path in sorted(set(library_of) | {p.relative_to(root).as_posix() for p in root.rglob("*.h")}):
    if path.split("/")[0] in ("tests", "bench", "fuzz") or path.startswith("build"):
        continue
    own = library(path)
    if own is None or not (root / path).is_file():
        continue
    allowed = reachable(own)
    for number, line in enumerate((root / path).read_text().splitlines(), 1):
        m = include.match(line)
        if not m or "/" not in m.group(1):
            continue
        target = library(m.group(1))
        if target is not None and target not in allowed:
            print(f"{path}:{number}: includes {m.group(1)} ({target}), but {own} links only "
                  f"{', '.join(sorted(allowed - {own})) or 'nothing of ours'}")
            violations += 1
print(f"check-arrows: {len(library_of)} sources in {len(links)} libraries, {violations} include(s) "
      "against the arrows")
sys.exit(1 if violations else 0)
