#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""How long tools/fuzz.sh runs each fuzz target: longer for those whose code changed.

    tools/fuzz_plan.py BUILD_DIR SHORT_SECONDS CHANGED_SECONDS BUDGET_SECONDS JOBS

Prints one line per target in BUILD_DIR/bin (built), longest first:
    SECONDS TARGET WHY
Each target runs SHORT_SECONDS, or CHANGED_SECONDS when its code changed; when that would take
longer than BUDGET_SECONDS on JOBS cores, the changed targets share what is left (never less
than SHORT_SECONDS each).
A target "changed" when a file it is built from (the sources of the objects linked into it, and
the headers they include, as ninja recorded them) differs between the base and the working tree.
The base is FUZZ_BASE when set; otherwise the merge base with `main` when HEAD is not on it (a
branch); otherwise the newest commit at least FUZZ_RECENT_HOURS (default 24) older than HEAD, so
that a clean clone of a landing counts what was committed in the last day. Without a base (a
shallow clone, no git), every target counts as changed.
"""
import os
import subprocess
import sys


def run(args, cwd=None):
    return subprocess.run(args, cwd=cwd, capture_output=True, text=True, check=True).stdout


def git(root, *args):
    try:
        return run(["git", "-C", root, *args]).strip()
    except (subprocess.CalledProcessError, FileNotFoundError):
        return None


def find_base(root):
    """(revision, how it was chosen) or (None, why there is none)."""
    if os.environ.get("FUZZ_BASE"):
        rev = git(root, "rev-parse", "--verify", os.environ["FUZZ_BASE"] + "^{commit}")
        return (rev, "FUZZ_BASE") if rev else (None, "FUZZ_BASE is not a commit")
    head = git(root, "rev-parse", "HEAD")
    if not head:
        return None, "no git history"
    main = git(root, "rev-parse", "--verify", "--quiet", "refs/heads/main")
    if main and main != head:
        base = git(root, "merge-base", "HEAD", main)
        if base and base != head:
            return base, "the merge base with main"
    hours = float(os.environ.get("FUZZ_RECENT_HOURS", "24"))
    head_time = int(git(root, "log", "-1", "--format=%ct", "HEAD"))
    base = git(root, "rev-list", "-1", f"--before={head_time - int(hours * 3600)}", "HEAD")
    if not base:
        return None, f"no commit {hours:g} h older than HEAD"
    return base, f"the newest commit {hours:g} h older than HEAD"


def object_deps(build):
    """Object file -> the files it was compiled from (its source first, then headers)."""
    deps, current = {}, None
    for line in run(["ninja", "-C", build, "-t", "deps"]).splitlines():
        if not line.strip():
            current = None
        elif not line.startswith(" "):
            current = line.split(":", 1)[0]
            deps[current] = []
        elif current:
            deps[current].append(line.strip())
    return deps


def strong_symbols(path):
    """Symbols a file defines that only one object may define (functions and data)."""
    try:
        out = run(["nm", "-g", "--defined-only", "--format=posix", path])
    except subprocess.CalledProcessError:
        return set()  # not there: counted as linked
    return {f.split()[0] for f in out.splitlines() if len(f.split()) > 1 and f.split()[1] in "TDBR"}


def main():
    build, short, changed_seconds = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
    budget, jobs = int(sys.argv[4]), int(sys.argv[5])
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    targets = sorted(f for f in os.listdir(os.path.join(build, "bin")) if f.endswith("_fuzz"))
    base, how = find_base(root)
    changed = None
    if base:
        diff = git(root, "diff", "--name-only", base)
        changed = {os.path.join(root, f) for f in diff.splitlines()} if diff is not None else None
    print(f"    fuzz base: {base[:12] + ' (' + how + ')' if base else 'none (' + how + ')'}",
          file=sys.stderr)
    deps = object_deps(build) if changed is not None else {}
    symbols = {}
    plan = []
    for name in targets:
        if changed is None:
            plan.append((changed_seconds, name, "no base"))
            continue
        try:
            inputs = run(["ninja", "-C", build, "-t", "inputs", "bin/" + name]).splitlines()
        except subprocess.CalledProcessError:
            plan.append((changed_seconds, name, "not built by ninja"))
            continue
        binary = strong_symbols(os.path.join(build, "bin", name))
        files = set()
        for obj in (i for i in inputs if i.endswith(".o")):
            if obj not in symbols:
                symbols[obj] = strong_symbols(os.path.join(build, obj))
            # An archive member is linked only when the program uses something it defines.
            if symbols[obj] and not symbols[obj] & binary:
                continue
            files.update(os.path.normpath(os.path.join(build, f)) for f in deps.get(obj, []))
        hit = sorted(os.path.relpath(f, root) for f in files & changed)
        if hit:
            more = f" and {len(hit) - 1} more" if len(hit) > 1 else ""
            plan.append((changed_seconds, name, f"changed: {hit[0]}{more}"))
        else:
            plan.append((short, name, "unchanged"))
    # Within the budget: what the unchanged targets leave, shared by the changed ones.
    n_changed = sum(1 for p in plan if p[0] == changed_seconds and changed_seconds > short)
    if n_changed:
        left = budget * jobs - short * (len(plan) - n_changed)
        share = max(short, min(changed_seconds, left // n_changed))
        plan = [(share if p[0] == changed_seconds else p[0], p[1], p[2]) for p in plan]
    for seconds, name, why in sorted(plan, key=lambda p: (-p[0], p[1])):
        print(seconds, name, why)


if __name__ == "__main__":
    main()
