#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Every source file of the project names its licence (LICENSE: Apache-2.0) in an SPDX line.

    tools/spdx.py [--check | --write | --list] [SOURCE_DIR]

--check (the default; CTest licence.spdx) names each file without the line, or with no rule for
its kind, and exits 1. --write adds the line where it is missing. --list prints each file with
its comment syntax, or why it has none. The files are git's (tracked, and new ones git does not
ignore), so a new file cannot forget the line. Third-party files keep their own licence: they
are listed here and in NOTICE (checked).

The line is the file's first, after what must come first: a shebang, Python's coding line (the
first two lines), HTML's doctype. In C and C++ it is `// SPDX-...`, or `/* SPDX-... */` in a file
written in C's block comments (the C ABI header, the C test modules)."""
import fnmatch
import os
import re
import subprocess
import sys

LICENCE = "Apache-2.0"
TAG = "SPDX-License-Identifier: "
SKIP = 77  # CTest's SKIP_RETURN_CODE: not a git checkout

# Comment syntaxes: the line as --write writes it; C and C++ accept either form.
LINE = {
    "c++": ["// " + TAG + LICENCE, "/* " + TAG + LICENCE + " */"],
    "hash": ["# " + TAG + LICENCE],
    "css": ["/* " + TAG + LICENCE + " */"],
    "html": ["<!-- " + TAG + LICENCE + " -->"],
}

# By file name (fnmatch on the path's last component), first match wins. A template (NAME.in)
# takes the syntax of NAME.
BY_NAME = [
    ("*.c", "c++"), ("*.h", "c++"), ("*.cpp", "c++"), ("*.hpp", "c++"), ("*.inc", "c++"),
    ("*.ino", "c++"),  # Arduino sketches (C++)
    ("*.idl", "c++"),  # OMG IDL (C++ comments)
    ("*.js", "c++"), ("*.mjs", "c++"), ("*.ts", "c++"),
    ("CMakeLists.txt", "hash"), ("*.cmake", "hash"), ("*.py", "hash"), ("*.sh", "hash"),
    ("*.toml", "hash"), ("*.pc", "hash"), ("*.service", "hash"), ("*.properties", "hash"),
    ("*.css", "css"), ("*.html", "html"),
]

# No line, and why (fnmatch on the whole path).
NOT_SOURCE = [
    ("*.md", "documentation"),
    ("*.json", "data (JSON has no comments)"),
    ("*.jpg", "image"), ("*.png", "image"), ("*.mcap", "recording"),
    ("LICENSE", "the licence"), ("NOTICE", "the notice"),
    ("*/.gitignore", "git's list"), (".gitignore", "git's list"),
    (".clang-format", "formatter settings"), ("*/.clang-format", "formatter settings"),
    (".clang-tidy", "linter settings"),
    ("packaging/debian/conffiles", "dpkg's list of paths (no comments)"),
    ("packaging/debian/copyright", "states every licence itself (DEP-5)"),
    ("tests/fuzz/seeds/*", "fuzzer input"),
    ("satellite/js/types/*.d.ts", "tsc's declarations of satellite/js/src, whose files carry the line"),
    ("tests/modules/garbage.so.in", "test data: a file that must not load"),
    ("plugin-api/ros2/msgs/*", "ROS 2 interface definitions, read as MCAP schema text (NOTICE)"),
    ("tests/modules/abi/[0-9]*/*", "a frozen ABI header: never edited (tests/modules/abi/README.md)"),
]

# Third-party files in the repository: they keep their licence and are named in NOTICE.
THIRD_PARTY = [
    ("satellite/python/tests/py27_grammar.txt", "PSF-2.0"),
    ("tests/ros2/peers/fastdds_gen/*", "Apache-2.0"),
]


def git_files(src):
    """The tracked files and the new ones git does not ignore, or None outside a checkout."""
    try:
        out = subprocess.run(["git", "-C", src, "ls-files", "-z", "--cached", "--others",
                              "--exclude-standard"], capture_output=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    names = sorted(set(n.decode("utf-8") for n in out.split(b"\0") if n))
    return [n for n in names if os.path.isfile(os.path.join(src, n))]


def head_line(path):
    with open(path, "rb") as f:
        return f.readline().decode("utf-8", "replace")


def syntax(src, name):
    """(syntax, None) for a source file, (None, why) for a file without the line."""
    for pattern, licence in THIRD_PARTY:
        if fnmatch.fnmatchcase(name, pattern):
            return None, "third party (%s, NOTICE)" % licence
    for pattern, why in NOT_SOURCE:
        if fnmatch.fnmatchcase(name, pattern):
            return None, why
    base = os.path.basename(name)
    if base.endswith(".in"):
        base = base[:-3]
    for pattern, kind in BY_NAME:
        if fnmatch.fnmatchcase(base, pattern):
            return kind, None
    if "." not in base and head_line(os.path.join(src, name)).startswith("#!"):
        return "hash", None  # a script
    return None, None  # no rule: --check names it


def insert_at(lines, kind, name):
    """The index where the line belongs: after a shebang, a coding line, a doctype."""
    i = 0
    if lines and lines[0].startswith("#!"):
        i = 1
    if kind == "hash" and (name.endswith((".py", ".py.in")) or i == 1):
        # PEP 263: the coding line must stay on line 1 or 2.
        if len(lines) > i and i < 2 and re.match(r"^[ \t\f]*#.*?coding[:=]", lines[i]):
            i += 1
    if kind == "html" and lines and lines[0].lower().startswith("<!doctype"):
        i = 1
    return i


def write_form(kind, lines, at):
    """C files written in block comments get the block form."""
    if kind == "c++" and len(lines) > at and lines[at].startswith("/*"):
        return LINE[kind][1]
    return LINE[kind][0]


def read_lines(path):
    with open(path, encoding="utf-8", newline="") as f:
        return f.read().splitlines(keepends=True)


def state(src, name, kind):
    """None when the file has its line where it belongs, else what is wrong."""
    lines = read_lines(os.path.join(src, name))
    at = insert_at(lines, kind, name)
    if len(lines) > at and lines[at].rstrip("\r\n") in LINE[kind]:
        return None
    if any(line.strip() in LINE[kind] for line in lines):
        return "its SPDX line is not %r at line %d" % (LINE[kind][0], at + 1)
    return "no SPDX line"


def write(src, name, kind):
    path = os.path.join(src, name)
    lines = read_lines(path)
    at = insert_at(lines, kind, name)
    if at > 0 and not lines[at - 1].endswith("\n"):
        lines[at - 1] += "\n"
    lines.insert(at, write_form(kind, lines, at) + "\n")
    mode = os.stat(path).st_mode
    with open(path, "w", encoding="utf-8", newline="") as f:
        f.write("".join(lines))
    os.chmod(path, mode)


def notice_misses(src):
    """Third-party files that NOTICE does not name."""
    try:
        with open(os.path.join(src, "NOTICE"), encoding="utf-8") as f:
            notice = f.read()
    except OSError:
        return ["NOTICE is missing"]
    return ["NOTICE does not name %s" % p for p, _ in THIRD_PARTY if p not in notice]


def main(argv):
    mode = "--check"
    args = []
    for a in argv:
        if a in ("--check", "--write", "--list"):
            mode = a
        elif a.startswith("-"):
            print(__doc__)
            return 2
        else:
            args.append(a)
    src = os.path.abspath(args[0] if args else ".")
    names = git_files(src)
    if names is None:
        print("skipped: %s is not a git checkout (the files are git's)" % src)
        return SKIP
    problems = notice_misses(src)
    written = checked = 0
    for name in names:
        kind, why = syntax(src, name)
        if mode == "--list":
            print("%-6s %s%s" % (kind or "-", name, "" if kind else "  (%s)" % (why or "NO RULE")))
            continue
        if kind is None:
            if why is None:
                problems.append("%s: no rule for this kind of file: add one to tools/spdx.py "
                                "(BY_NAME, or NOT_SOURCE with why)" % name)
            continue
        checked += 1
        wrong = state(src, name, kind)
        if wrong is None:
            continue
        if mode == "--write" and wrong == "no SPDX line":
            write(src, name, kind)
            written += 1
        else:
            problems.append("%s: %s" % (name, wrong))
    if mode == "--list":
        return 0
    for p in problems:
        print("FAIL: " + p)
    if mode == "--write":
        print("%d files given the SPDX line (%s), %d checked" % (written, LICENCE, checked))
    elif not problems:
        print("ok: %d source files carry the SPDX line (%s)" % (checked, LICENCE))
    if problems and mode == "--check":
        print("%d files: run tools/spdx.py --write (or add a rule)" % len(problems))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
