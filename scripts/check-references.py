#!/usr/bin/python3
"""No source, script or document points outside the repository (issue 39).

A reader of the repository cannot open the design notes (DESIGN.md, STYLE.md) or the paper folder
(../shared/papers/) the code was first written against: a comment that sends them there tells
them nothing. What the code needs from those notes lives in docs/ (docs/architecture.md,
"Conventions every floor shares": the patch frame, the levels of physics, the seed rule), and a
paper is cited in full where it is used (authors, title, venue, year).

Scans every text file of the repository (C++, Python, shell, CMake, TOML, Markdown, text),
skipping build folders and hidden ones, prints each offending line as file:line: text and exits 1
if there is any.

    check-references.py [REPO]
"""
import os
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).parent.parent).resolve()

# The notes and folders that sit next to the repository, never in it.
OUTSIDE = re.compile(r"\b(?:DESIGN|STYLE)\.md\b|(?:\.\./)+shared\b|\bshared/papers\b")
SUFFIXES = {".h", ".cpp", ".py", ".sh", ".cmake", ".toml", ".md", ".txt", ".in", ".cff", ".yml",
            ".yaml", ".cfg"}
THIS = pathlib.Path(__file__).resolve()


def text_files():
    """The repository's text files, build and hidden folders pruned (never walked)."""
    for folder, subfolders, names in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders if not d.startswith((".", "build")))
        for name in sorted(names):
            path = pathlib.Path(folder) / name
            if path.suffix in SUFFIXES or name == "CMakeLists.txt":
                yield path


violations = []
for path in text_files():
    if path.resolve() == THIS:
        continue
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except UnicodeDecodeError:
        continue
    for number, line in enumerate(lines, 1):
        if OUTSIDE.search(line):
            violations.append(f"{path.relative_to(root)}:{number}: {line.strip()}")

if violations:
    print("These lines point outside the repository (design notes or paper folders a reader "
          "cannot open); state what they need in place, point into docs/, or cite the paper "
          "in full:")
    print("\n".join(violations))
    sys.exit(1)
print(f"check-references: no reference outside the repository in {root}")
