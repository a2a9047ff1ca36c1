#!/usr/bin/python3
"""Every file includes only what its target links, and docs/architecture.md says so.

Three checks, each printing what it finds and making the script exit 1:

1. Includes. Reads the CMake build from the top CMakeLists.txt down its add_subdirectory calls
   (tests/, bench/ and fuzz/ left out): every target of add_library, add_executable,
   pybind11_add_module and python_add_library, its sources (with target_sources, set/list
   variables and configure_file templates followed) and its target_link_libraries. A header
   belongs to the target that lists it, else to its .cpp's, else to the targets with the most
   sources in its folder; a generated header (configure_file into a build folder) to its
   `.in` template's. Every `#include "dir/file.h"` of every source, header and template must
   reach the file's own target or one it links, directly or through another.
2. Every source folder. Every .cpp/.h/.in file outside tests/, bench/, fuzz/, build*/ and hidden
   folders must have a target: a .cpp (or .cpp.in) must be listed by one, a header must be
   listed or sit beside a target's sources. A new folder cannot escape check 1 unnoticed.
3. The document. The table of docs/architecture.md (`| library | folder | uses | used by |`)
   must have one row per target of ours (a target with a source outside tests/, bench/, fuzz/),
   its `uses` must name exactly the target's direct links of ours and its `used by` exactly the
   targets that link it; the picture above the table must show every target once, each below
   every target that links it. The table's conventions are written above it in the document.

    check-arrows.py [REPO]
"""
import collections
import os
import posixpath
import re
import sys

root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1
                       else os.path.join(os.path.dirname(__file__), ".."))
DOC = "docs/architecture.md"
EXCLUDED = ("tests", "bench", "fuzz")  # top folders of test programs, not of the architecture
KINDS = {"add_library": "library", "add_executable": "program",
         "pybind11_add_module": "Python module", "python_add_library": "Python module"}
CREATORS = tuple(KINDS)
CREATOR_KEYWORDS = {"STATIC", "SHARED", "MODULE", "OBJECT", "INTERFACE", "EXCLUDE_FROM_ALL",
                    "WIN32", "MACOSX_BUNDLE", "NO_EXTRAS", "THIN_LTO", "OPT_SIZE", "WITHOUT_SOABI",
                    "WITH_SOABI", "SYSTEM", "USE_SABI"}
SCOPES = {"PUBLIC", "PRIVATE", "INTERFACE", "LINK_PUBLIC", "LINK_PRIVATE",
          "LINK_INTERFACE_LIBRARIES", "debug", "optimized", "general"}
SRC, BIN = "\x01src", "\x01bin"  # the source and build trees in expanded CMake paths


def excluded(rel):
    top = rel.split("/")[0]
    return top in EXCLUDED or top.startswith(("build", "."))


# ---------------------------------------------------------------------------------------------
# CMake: a reader of the commands, not an interpreter. Every branch of if() is read; function and
# macro bodies are skipped; ${VAR} is expanded from set()/list(APPEND), unknown ones to nothing.

def skip_comment(text, i):
    """The index after the comment at text[i] ('#'): a line comment or a #[[bracket comment]]."""
    m = re.compile(r"#\[(=*)\[").match(text, i)
    end = text.find("]" + m.group(1) + "]", m.end()) if m else text.find("\n", i)
    return len(text) if end < 0 else end + (len(m.group(1)) + 2 if m else 0)


def cmake_commands(text):
    """(name, [arguments]) of every command call, comments and bracket arguments handled."""
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
        elif c == "#":
            i = skip_comment(text, i)
        else:
            m = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)\s*\(").match(text, i)
            if not m:  # not a command: skip the line
                end = text.find("\n", i)
                i = n if end < 0 else end + 1
                continue
            i, args, depth = m.end(), [], 1
            while i < n and depth:
                c = text[i]
                if c.isspace():
                    i += 1
                elif c == "(":
                    depth, i = depth + 1, i + 1
                elif c == ")":
                    depth, i = depth - 1, i + 1
                elif c == "#":
                    i = skip_comment(text, i)
                elif c == '"':
                    j = i + 1
                    while j < n and text[j] != '"':
                        j += 2 if text[j] == "\\" else 1
                    args.append(text[i + 1:j])
                    i = j + 1
                elif text.startswith("[", i) and re.match(r"\[=*\[", text[i:]):
                    b = re.match(r"\[(=*)\[", text[i:])
                    end = text.find("]" + b.group(1) + "]", i)
                    end = n if end < 0 else end
                    args.append(text[i + len(b.group(0)):end])
                    i = end + len(b.group(0))
                else:
                    m2 = re.compile(r'(?:[^\s()#"\\]|\\.|"[^"]*")+').match(text, i)
                    if not m2:
                        i += 1
                        continue
                    args.append(m2.group(0))
                    i = m2.end()
            yield m.group(1).lower(), args


def expand(arg, variables):
    """${VAR} replaced, innermost first, unknown variables by nothing (as CMake does)."""
    pattern = re.compile(r"\$\{([^${}]*)\}")
    while pattern.search(arg):
        arg = pattern.sub(lambda m: variables.get(m.group(1), ""), arg)
    return arg


def expand_all(args, variables):
    """Arguments expanded and split into list items (CMake lists are ;-separated)."""
    return [item for arg in args for item in expand(arg, variables).split(";") if item]


def repo_path(item, here):
    """An expanded path argument as a repository path, BIN + path for the build tree, or None."""
    if item.startswith(SRC):
        return posixpath.normpath(item[len(SRC):].lstrip("/")) if item != SRC else "."
    if item.startswith(BIN) or "$<" in item:
        return item
    if item.startswith("/"):
        return None
    return posixpath.normpath(posixpath.join(here, item))


targets = {}                                  # target -> kind (the creating command)
sources = collections.defaultdict(set)        # target -> repository files it lists
links = collections.defaultdict(set)          # target -> every name it links
configured = {}                               # configure_file output (BIN path) -> template
binary_include_dirs = set()                   # include folders in the build tree


def read_cmake(here, variables):
    """Reads here/CMakeLists.txt (here: repository folder, "." for the top) and its subfolders."""
    variables = dict(variables, CMAKE_CURRENT_SOURCE_DIR=f"{SRC}/{here}".rstrip("/."),
                     CMAKE_CURRENT_LIST_DIR=f"{SRC}/{here}".rstrip("/."),
                     CMAKE_CURRENT_BINARY_DIR=f"{BIN}/{here}".rstrip("/."))
    with open(os.path.join(root, here, "CMakeLists.txt"), encoding="utf-8") as f:
        text = f.read()
    in_body = 0
    for command, raw in cmake_commands(text):
        if command in ("function", "macro"):
            in_body += 1
        elif command in ("endfunction", "endmacro"):
            in_body -= 1
        if in_body:
            continue
        args = expand_all(raw, variables)
        if not args:
            continue
        if command == "set":
            values = [a for a in args[1:] if a != "PARENT_SCOPE"]
            if "CACHE" in values:
                values = values[:values.index("CACHE")]
                if args[0] in variables:  # a cache entry does not replace a normal variable
                    continue
            variables[args[0]] = ";".join(values)
        elif command == "list" and len(args) > 1 and args[0] == "APPEND":
            variables[args[1]] = ";".join([v for v in [variables.get(args[1], "")] if v] + args[2:])
        elif command == "add_subdirectory":
            sub = repo_path(args[0], here)
            if sub and not sub.startswith(BIN) and not excluded(sub) and \
                    os.path.isfile(os.path.join(root, sub, "CMakeLists.txt")):
                read_cmake(sub, variables)
        elif command in CREATORS:
            if {"IMPORTED", "ALIAS"} & set(args[1:]):
                continue
            targets.setdefault(args[0], command)
            sources[args[0]].update(repo_path(a, here) for a in args[1:]
                                    if a not in CREATOR_KEYWORDS)
        elif command == "target_sources":
            sources[args[0]].update(repo_path(a, here) for a in args[1:] if a not in SCOPES)
        elif command == "target_link_libraries":
            links[args[0]].update(a for a in args[1:] if a not in SCOPES)
        elif command == "target_include_directories":
            binary_include_dirs.update(a for a in args[1:] if a.startswith(BIN))
        elif command == "configure_file" and len(args) > 1:
            configured[repo_path(args[1], here)] = repo_path(args[0], here)


read_cmake(".", {"PROJECT_SOURCE_DIR": SRC, "CMAKE_SOURCE_DIR": SRC, "PROJECT_BINARY_DIR": BIN,
                 "CMAKE_BINARY_DIR": BIN})

# What each target builds from the repository: listed files, and the templates of configured ones.
owners = collections.defaultdict(set)         # repository file -> targets listing it
for target in targets:
    for path in sources[target]:
        path = configured.get(path, path)
        if path and not path.startswith((BIN, "$<")) and os.path.isfile(os.path.join(root, path)):
            owners[path].add(target)
# Ours: the targets with a source outside the test folders (not the interface library of
# warnings, not the programs under tests/reference that build committed references).
ours = sorted(t for t in targets if any(t in owners[p] and not excluded(p) for p in owners))
arrows = {t: {d for d in links[t] if d in ours and d != t} for t in ours}
generated = {}                                # include name of a configured header -> template
for output, template in configured.items():
    for folder in binary_include_dirs:
        if output.startswith(folder + "/"):
            generated[output[len(folder) + 1:]] = template
folder_votes = collections.defaultdict(collections.Counter)
for path, ts in owners.items():
    for t in ts:
        folder_votes[posixpath.dirname(path)][t] += 1


def owners_of(path):
    """The targets a repository file (or include name) belongs to; empty if none."""
    path = generated.get(path, path)
    if owners.get(path):
        return owners[path]
    base = path[:-3] if path.endswith(".in") else path
    cpp = posixpath.splitext(base)[0] + ".cpp"
    if owners.get(cpp):
        return owners[cpp]
    votes = folder_votes.get(posixpath.dirname(path))
    if not votes:
        return set()
    most = max(votes.values())
    return {t for t, count in votes.items() if count == most}


def reachable(target):
    seen, pending = {target}, [target]
    while pending:
        for dep in arrows.get(pending.pop(), ()):
            if dep not in seen:
                seen.add(dep)
                pending.append(dep)
    return seen


problems = collections.Counter()

# 1 and 2: every C++ file of the source folders has a target, and includes only what it links.
files = []
for folder, subfolders, names in os.walk(root):
    rel = posixpath.relpath(folder.replace(os.sep, "/"), root.replace(os.sep, "/"))
    subfolders[:] = sorted(d for d in subfolders if not d.startswith(".")
                           and not excluded(d if rel == "." else f"{rel}/{d}"))
    for name in sorted(names):
        if name.endswith((".cpp", ".h", ".hpp", ".cc", ".cpp.in", ".h.in")):
            files.append(name if rel == "." else f"{rel}/{name}")
include = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
checked = 0
for path in files:
    own = owners_of(path)
    is_cpp = path.endswith((".cpp", ".cc", ".cpp.in"))
    if not own or (is_cpp and not owners.get(path)):
        print(f"{path}: belongs to no target: " + (
            "no add_library/add_executable/pybind11_add_module/target_sources lists it" if is_cpp
            else "no target lists it or has a source in its folder")
            + " (its includes cannot be checked; list it in its folder's CMakeLists.txt)")
        problems["unclaimed"] += 1
        continue
    checked += 1
    with open(os.path.join(root, path), encoding="utf-8") as f:
        lines = f.read().splitlines()
    for number, line in enumerate(lines, 1):
        m = include.match(line)
        if not m:
            continue
        name = m.group(1)
        if "/" not in name:  # a neighbour, if there is one by that name
            name = posixpath.join(posixpath.dirname(path), name)
            if not os.path.isfile(os.path.join(root, name)):
                continue
        theirs = owners_of(name)
        for target in sorted(own):
            allowed = reachable(target)
            if theirs and not theirs & allowed:
                print(f"{path}:{number}: includes {m.group(1)} ({', '.join(sorted(theirs))}), "
                      f"but {target} links only "
                      f"{', '.join(sorted(allowed - {target})) or 'nothing of ours'}")
                problems["include"] += 1


# 3: the table and the picture of docs/architecture.md.
def short(target):
    return target[len("plumage_"):] if target.startswith("plumage_") else target


def braces(names):
    return "{" + ", ".join(sorted(names)) + "}"


def complain(message):
    print(f"{DOC}: {message}")
    problems["document"] += 1


by_short = {short(t): t for t in ours}


def names_in(cell, column, row):
    """The targets of ours a `uses`/`used by` cell names: the comma-separated short names before
    its first semicolon, remarks in parentheses dropped; "—" (or nothing) for none."""
    while re.search(r"\([^()]*\)", cell):
        cell = re.sub(r"\([^()]*\)", "", cell)
    names = set()
    for item in cell.split(";")[0].split(","):
        item = item.strip().strip("`").strip()
        if item in ("", "—", "-"):
            continue
        if item not in by_short:
            complain(f"{row}: '{item}' in `{column}` is not the short name of a target of ours "
                     "(outside libraries and other users go after the ';')")
            continue
        names.add(item)
    return names


doc_path = os.path.join(root, DOC)
doc = open(doc_path, encoding="utf-8").read().splitlines() if os.path.isfile(doc_path) else []
COLUMNS = ["library", "folder", "uses", "used by"]
header = next((i for i, line in enumerate(doc)
               if [c.strip() for c in line.strip().strip("|").split("|")] == COLUMNS), None)
if header is None:
    complain("no table with the header | library | folder | uses | used by |")
else:
    table = {}
    for line in doc[header + 2:]:
        if not line.startswith("|"):
            break
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        m = re.match(r"`([A-Za-z0-9_]+)`", cells[0])
        if len(cells) != 4 or not m:
            complain(f"a table row that is not | `target` | folder | uses | used by |: {line}")
            continue
        if m.group(1) in table:
            complain(f"{m.group(1)}: two rows")
        table[m.group(1)] = cells
    linked_by = {t: {u for u in ours if t in arrows[u]} for t in ours}
    for target in sorted(set(table) - set(ours)):
        complain(f"{target}: a row in the table, but CMake has no such target of ours")
    for target in ours:
        if target not in table:
            complain(f"{target}: no row in the table (CMake links "
                     f"{braces(map(short, arrows[target]))})")
            continue
        uses = names_in(table[target][2], "uses", target)
        if uses != set(map(short, arrows[target])):
            complain(f"{target}: table says uses {braces(uses)}, CMake links "
                     f"{braces(map(short, arrows[target]))}")
        used_by = names_in(table[target][3], "used by", target)
        if used_by != set(map(short, linked_by[target])):
            complain(f"{target}: table says used by {braces(used_by)}, CMake: linked by "
                     f"{braces(map(short, linked_by[target]))}")
    # The picture: the fenced block before the table shows every target once, each on a line
    # below every target that links it (a floor uses only the floors below it).
    fences = [i for i in range(header) if doc[i].startswith("```")]
    picture = range(fences[-2] + 1, fences[-1]) if len(fences) >= 2 else range(0)
    floor = {}
    for target in ours:
        name = re.compile(r"(?<![\w.`/])" + re.escape(target) + r"(?![\w.])")
        where = [i for i in picture if name.search(doc[i])]
        if len(where) != 1:
            complain(f"the picture shows {target} {len(where)} times, not once")
        elif where:
            floor[target] = where[0]
    for target in ours:
        for dep in sorted(arrows[target]):
            if target in floor and dep in floor and floor[dep] <= floor[target]:
                complain(f"the picture draws {dep} (line {floor[dep] + 1}) on a floor not below "
                         f"{target} (line {floor[target] + 1}), which links it")

kinds = collections.Counter(KINDS[targets[t]] for t in ours)
others = [f"{KINDS[targets[t]]} {t}" for t in ours if KINDS[targets[t]] != "library"]
print(f"check-arrows: {checked} files of {len(ours)} targets "
      f"({', '.join([str(kinds['library']) + ' libraries'] + others)}), "
      f"{sum(map(len, arrows.values()))} arrows; "
      f"{problems['include']} include(s) against the arrows, {problems['unclaimed']} file(s) of no "
      f"target, {problems['document']} disagreement(s) of {DOC} with CMake")
sys.exit(1 if problems else 0)
