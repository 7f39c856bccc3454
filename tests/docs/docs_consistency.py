#!/usr/bin/env python3
"""Facts the documentation states in more than one place say the same thing everywhere.

    docs_consistency.py SOURCE_DIR

Each check names a fact, the files that state it, and a pattern that finds its statement; the
statements must exist and be equal (whitespace and line breaks aside)."""
import re
import sys

# (what, files, pattern): the pattern's first group is the statement.
FACTS = [
    ("who takes part in physical mode", ["README.md", "docs/physical-mode.md"],
     r"(Owners that offer paths:.*?relayed\.)"),
]


def main(src):
    failed = 0
    for what, files, pattern in FACTS:
        found = {}
        for f in files:
            with open(src + "/" + f, encoding="utf-8") as text:
                flat = " ".join(text.read().split())
            m = re.search(pattern, flat)
            if m is None:
                print("FAIL: %s: %s does not state it" % (what, f))
                failed += 1
            else:
                found[f] = m.group(1)
        if len(set(found.values())) > 1:
            print("FAIL: %s differs:" % what)
            for f, statement in found.items():
                print("  %s: %s" % (f, statement))
            failed += 1
        elif len(found) == len(files):
            print("ok: %s (%s)" % (what, ", ".join(files)))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
