#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""Facts the documentation states in more than one place say the same thing everywhere.

    docs_consistency.py SOURCE_DIR

Each check names a fact, the files that state it, and a pattern that finds its statement; the
statements must exist and be equal (whitespace and line breaks aside). The licence is LICENSE's:
the package metadata, the SPDX tool and the Debian copyright file must name the same one."""
import glob
import json
import os
import re
import sys
import tomllib

# (what, files, pattern): the pattern's first group is the statement.
FACTS = [
    ("who takes part in physical mode", ["README.md", "docs/physical-mode.md"],
     r"(Owners that offer paths:.*?relayed\.)"),
    ("the modules that are combined works under the GPL",
     ["README.md", "docs/audio.md", "NOTICE"],
     r"(fft-audio \(it links FFTW.*?does not load them\.)"),
]
GPL_STATEMENT = FACTS[-1]

# The licences LICENSE may hold, by their first words.
LICENCE_TEXTS = {"Apache-2.0": r"^\s*Apache License\s+Version 2\.0, January 2004"}
DEP5_FORMAT = "https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/"


def read(src, name):
    with open(os.path.join(src, name), encoding="utf-8") as f:
        return f.read()


def dep5(text):
    """The paragraphs of a DEP-5 file as lists of (field, value) (continuations joined)."""
    paragraphs = []
    for block in re.split(r"\n\s*\n", text.strip("\n")):
        fields = []
        for line in block.split("\n"):
            if line.startswith((" ", "\t")) and fields:
                fields[-1] = (fields[-1][0], fields[-1][1] + "\n" + line.strip())
            else:
                m = re.match(r"^([A-Za-z-]+):\s?(.*)$", line)
                if m is None:
                    raise ValueError("not a field or a continuation: %r" % line)
                fields.append((m.group(1), m.group(2)))
        paragraphs.append(fields)
    return paragraphs


def licence_problems(src):
    """What disagrees with LICENSE."""
    problems = []
    text = read(src, "LICENSE")
    ids = [i for i, first in LICENCE_TEXTS.items() if re.match(first, text)]
    if len(ids) != 1:
        return ["LICENSE is none of " + ", ".join(LICENCE_TEXTS)]
    lic = ids[0]

    def want(where, found):
        if found != lic:
            problems.append("%s says %r, LICENSE is %s" % (where, found, lic))

    want("web/package.json", json.loads(read(src, "web/package.json")).get("license"))
    lock = json.loads(read(src, "web/package-lock.json"))
    want("web/package-lock.json (its root)", lock["packages"][""].get("license"))
    project = tomllib.loads(read(src, "satellite/python/pyproject.toml"))["project"]
    want("satellite/python/pyproject.toml", project.get("license", {}).get("text"))
    if lic == "Apache-2.0" and \
            "License :: OSI Approved :: Apache Software License" not in project["classifiers"]:
        problems.append("satellite/python/pyproject.toml: no Apache classifier")
    m = re.search(r'^LICENCE = "([^"]*)"', read(src, "tools/spdx.py"), re.M)
    want("tools/spdx.py", m.group(1) if m else None)
    readme = " ".join(read(src, "README.md").split("\n## Licence\n", 1)[-1].split())
    if "\n## Licence\n" not in read(src, "README.md") or "(`LICENSE`)" not in readme:
        problems.append("README.md has no section Licence naming LICENSE")

    # The Debian copyright file: DEP-5, Files: * under LICENSE's licence, every licence named
    # has its text, every path exists, and its GPL modules are those the docs name.
    name = "packaging/debian/copyright"
    try:
        paragraphs = [dict(p) for p in dep5(read(src, name))]
    except ValueError as e:
        return problems + ["%s: %s" % (name, e)]
    if paragraphs[0].get("Format") != DEP5_FORMAT:
        problems.append("%s: the first paragraph has no Format: %s" % (name, DEP5_FORMAT))
    files = [p for p in paragraphs if "Files" in p]
    texts = {p["License"].split("\n")[0] for p in paragraphs if "Files" not in p and "License" in p}
    star = [p for p in files if p["Files"].split() == ["*"]]
    want(name + " (Files: *)", star[0]["License"] if star else None)
    gpl = set()
    for p in files:
        for short in re.split(r"\s+(?:and|or)\s+", p["License"].split("\n")[0]):
            if short not in texts:
                problems.append("%s: License %s has no paragraph with its text" % (name, short))
        for pattern in p["Files"].split():
            if pattern != "*" and not glob.glob(os.path.join(src, pattern)) and \
                    not pattern.startswith("web/node_modules/"):
                problems.append("%s: Files %s matches nothing" % (name, pattern))
            m = re.match(r"^plugins/([^/]+)/\*$", pattern)
            if m and "GPL" in p["License"]:
                gpl.add(m.group(1))
    flat = " ".join(read(src, "README.md").split())
    statement = re.search(GPL_STATEMENT[2], flat)
    named = set(re.findall(r"([a-z-]+) \((?:it links )?[^)]*GPL", statement.group(1))) \
        if statement else set()
    if gpl != named:
        problems.append("%s puts %s under the GPL, README.md names %s" %
                        (name, sorted(gpl), sorted(named)))
    return problems


def main(src):
    failed = 0
    for what, files, pattern in FACTS:
        found = {}
        for f in files:
            try:
                with open(src + "/" + f, encoding="utf-8") as text:
                    flat = " ".join(text.read().split())
            except OSError as e:
                print("FAIL: %s: %s" % (what, e))
                failed += 1
                continue
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
    try:
        problems = licence_problems(src)
    except (OSError, KeyError, ValueError) as e:
        problems = ["%s: %s" % (type(e).__name__, e)]
    for p in problems:
        print("FAIL: licence: " + p)
    if not problems:
        print("ok: the licence (LICENSE, web/package.json, package-lock.json, pyproject.toml, "
              "tools/spdx.py, README.md, packaging/debian/copyright)")
    return 1 if failed or problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
