#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The docs' lists of flowctl's commands are what `flowctl help --markdown` prints.

    commands_markdown.py FLOWCTL SOURCE_DIR [--write]

Each document below holds the list between the lines `<!-- flowctl-commands:begin ... -->` and
`<!-- flowctl-commands:end -->`. A list that differs fails with its diff; --write puts flowctl's
list there instead (after a change to tools/flowctl/commands.cpp)."""
import difflib
import subprocess
import sys

DOCUMENTS = ["README.md", "docs/cpp-satellites.md"]
BEGIN = "<!-- flowctl-commands:begin"
END = "<!-- flowctl-commands:end -->"


def block(lines, path):
    """The indices of the begin and end marker lines."""
    begins = [i for i, line in enumerate(lines) if line.startswith(BEGIN)]
    ends = [i for i, line in enumerate(lines) if line.rstrip("\n") == END]
    if len(begins) != 1 or len(ends) != 1 or ends[0] < begins[0]:
        raise ValueError("%s: expected one %s ... %s block" % (path, BEGIN, END))
    return begins[0], ends[0]


def main(flowctl, src, write):
    run = subprocess.run([flowctl, "help", "--markdown"], capture_output=True, text=True,
                         check=False)
    if run.returncode != 0 or not run.stdout:
        print("FAIL: flowctl help --markdown exited %d: %s" % (run.returncode, run.stderr))
        return 1
    wanted = run.stdout.splitlines(keepends=True)
    failed = 0
    for doc in DOCUMENTS:
        path = src + "/" + doc
        with open(path, encoding="utf-8") as f:
            lines = f.readlines()
        try:
            begin, end = block(lines, doc)
        except ValueError as e:
            print("FAIL: %s" % e)
            failed += 1
            continue
        listed = lines[begin + 1:end]
        if listed == wanted:
            print("ok: %s lists flowctl's %d commands" % (doc, len(wanted)))
            continue
        if write:
            with open(path, "w", encoding="utf-8") as f:
                f.writelines(lines[:begin + 1] + wanted + lines[end:])
            print("written: %s" % doc)
            continue
        print("FAIL: %s's list of commands is not `flowctl help --markdown` (rewrite it with "
              "tools/flowctl/tests/commands_markdown.py FLOWCTL SOURCE_DIR --write):" % doc)
        sys.stdout.writelines(difflib.unified_diff(listed, wanted, doc, "flowctl help --markdown"))
        failed += 1
    return 1 if failed else 0


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4) or (len(sys.argv) == 4 and sys.argv[3] != "--write"):
        print(__doc__)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2], len(sys.argv) == 4))
