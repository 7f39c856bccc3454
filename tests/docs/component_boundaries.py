#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""No target compiles another component's sources or includes its private headers.

    component_boundaries.py SOURCE_DIR

Reads every CMakeLists.txt and *.cmake file of the tree and resolves the paths it names (with
${PROJECT_SOURCE_DIR}, ${CMAKE_SOURCE_DIR}, ${CMAKE_CURRENT_SOURCE_DIR}, ${CMAKE_CURRENT_LIST_DIR}
and the file's own set(VAR path) variables). A path into another component's src/ or internal/
folder fails the check: a source file there belongs to a library target that the other component
links; a header there is reached through that target (runtime/internal: skrobot_runtime_internal).
A component is plugins/<name>, satellite/<name>, tools/<name>, or a top-level folder (runtime,
core, plugin-api, tests, bench, ...). The one exception, ALLOWED below (an include folder, never a
source file), is written down with its reason."""
import os
import re
import sys

# (component, folder it may include from, why)
ALLOWED = [
    ("tests", "core/src/flow",
     "tests of the hub's parts include its private headers as the hub does"),
]

SKIP_DIRS = {".git", "build", "node_modules", "third_party", "__pycache__"}
NESTED = ("plugins", "satellite", "tools", "examples")
PATH_TOKEN = re.compile(r"(?:\$\{\w+\}|\.\.?/)[^\s()\"';]*")
SET_PATH = re.compile(r"^\s*set\(\s*(\w+)\s+\"?([^\s()\"]+)\"?\s*\)", re.M)
PRIVATE_PARTS = ("src", "internal")
SOURCE_SUFFIXES = (".c", ".cc", ".cpp")


def component(rel):
    parts = rel.split("/")
    if parts[0] in NESTED and len(parts) > 2:
        return "/".join(parts[:2])
    return parts[0] if len(parts) > 1 else ""


def strip_comments(text):
    out = []
    for line in text.splitlines():
        quoted = False
        for i, c in enumerate(line):
            if c == '"':
                quoted = not quoted
            elif c == "#" and not quoted:
                line = line[:i]
                break
        out.append(line)
    return "\n".join(out)


def resolve(token, variables):
    def var(m):
        name = m.group(1)
        return variables.get(name, m.group(0))
    for _ in range(3):  # variables defined from variables
        token = re.sub(r"\$\{(\w+)\}", var, token)
    return token


def check_file(src, path):
    rel_file = os.path.relpath(path, src)
    here = os.path.dirname(path)
    own = component(rel_file)
    text = strip_comments(open(path, encoding="utf-8").read())
    variables = {"PROJECT_SOURCE_DIR": src, "CMAKE_SOURCE_DIR": src,
                 "CMAKE_CURRENT_SOURCE_DIR": here, "CMAKE_CURRENT_LIST_DIR": here}
    for name, value in SET_PATH.findall(text):
        variables[name] = resolve(value, variables)
    problems = []
    for token in PATH_TOKEN.findall(text):
        resolved = resolve(token, variables)
        if "${" in resolved:
            continue  # a variable this check cannot know (a loop's, a function's)
        if not os.path.isabs(resolved):
            resolved = os.path.join(here, resolved)
        target = os.path.relpath(os.path.normpath(resolved), src)
        if target.startswith(".."):
            continue  # outside the tree (the build folder, the system)
        other = component(target + "/")
        if other in ("", own):
            continue
        inside = target[len(other):].lstrip("/").split("/")
        if inside[0] not in PRIVATE_PARTS:
            continue
        source = target.endswith(SOURCE_SUFFIXES)
        if not source and any(own == c and (target + "/").startswith(folder + "/")
                              for c, folder, _ in ALLOWED):
            continue
        problems.append("%s: %s reaches into %s's %s/ (%s)" %
                        (rel_file, token, other, inside[0], target))
    return problems


def main(src):
    src = os.path.realpath(src)
    problems = []
    files = 0
    for root, dirs, names in os.walk(src):
        dirs[:] = sorted(d for d in dirs if d not in SKIP_DIRS and not d.startswith("build"))
        for name in sorted(names):
            if name == "CMakeLists.txt" or name.endswith(".cmake"):
                files += 1
                problems += check_file(src, os.path.join(root, name))
    for p in problems:
        print("FAIL: " + p)
    if problems:
        print("%d path(s) into another component's private folders: link its library target "
              "instead (docs/internals.md, \"Where things live, and how they are named\")"
              % len(problems))
        return 1
    print("ok: %d CMake files, no target compiles another component's sources or includes its "
          "private headers" % files)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
