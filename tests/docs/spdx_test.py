#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""tools/spdx.py on a scratch git repository: --check names each file without its line (tracked
or new), --write puts the line where each kind of file wants it, once.

    spdx_test.py TOOLS_SPDX_PY"""
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile
import unittest

TOOL = None
LINE = "SPDX-License-Identifier: Apache-2.0"

FILES = {
    # Written from the tool's own THIRD_PARTY list in setUp (NOTICE names each entry).
    "NOTICE": "",
    "a.cpp": "// What a.cpp does.\n#include <x>\n",
    "c/plain.c": "/* A C file in block comments. */\nint x;\n",
    "c/plain.h": "/* A C header. */\n#pragma once\n",
    "web/page.html": "<!doctype html>\n<html></html>\n",
    "web/look.css": ":root { color: red; }\n",
    "web/m.mjs": "export const x = 1;",  # no final newline
    "run.sh": "#!/bin/sh\n# Runs.\necho hi\n",
    "p.py": "#!/usr/bin/env python\n# -*- coding: utf-8 -*-\n\"\"\"Doc.\"\"\"\n",
    "q.py": "\"\"\"Doc.\"\"\"\n",
    "CMakeLists.txt": "add_subdirectory(c)\n",
    "tool": "#!/usr/bin/env python3\nprint(1)\n",
    "unit.service.in": "[Unit]\n",
    "notes.md": "# Notes\n",
    "data.json": "{}\n",
    "odd.xyz": "what is this\n",
    "new.h": "#pragma once\n",  # never git-added: a new file
}

EXPECTED = {
    "a.cpp": "// " + LINE + "\n// What a.cpp does.\n#include <x>\n",
    "c/plain.c": "/* " + LINE + " */\n/* A C file in block comments. */\nint x;\n",
    "c/plain.h": "/* " + LINE + " */\n/* A C header. */\n#pragma once\n",
    "web/page.html": "<!doctype html>\n<!-- " + LINE + " -->\n<html></html>\n",
    "web/look.css": "/* " + LINE + " */\n:root { color: red; }\n",
    "web/m.mjs": "// " + LINE + "\nexport const x = 1;",
    "run.sh": "#!/bin/sh\n# " + LINE + "\n# Runs.\necho hi\n",
    "p.py": "#!/usr/bin/env python\n# -*- coding: utf-8 -*-\n# " + LINE + "\n\"\"\"Doc.\"\"\"\n",
    "q.py": "# " + LINE + "\n\"\"\"Doc.\"\"\"\n",
    "CMakeLists.txt": "# " + LINE + "\nadd_subdirectory(c)\n",
    "tool": "#!/usr/bin/env python3\n# " + LINE + "\nprint(1)\n",
    "unit.service.in": "# " + LINE + "\n[Unit]\n",
    "new.h": "// " + LINE + "\n#pragma once\n",
    "notes.md": "# Notes\n",
    "data.json": "{}\n",
}


def third_party():
    """The tool's THIRD_PARTY list (the one place it is written)."""
    spec = importlib.util.spec_from_file_location("spdx_tool", TOOL)
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    return tool.THIRD_PARTY


class Spdx(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="spdx-test-")
        subprocess.run(["git", "init", "-q", self.dir], check=True)
        for name, text in FILES.items():
            path = os.path.join(self.dir, name)
            os.makedirs(os.path.dirname(path), exist_ok=True)
            with open(path, "w", encoding="utf-8", newline="") as f:
                f.write(text)
        with open(os.path.join(self.dir, "NOTICE"), "w", encoding="utf-8") as f:
            f.write("".join("%s: %s\n" % entry for entry in third_party()))
        os.chmod(os.path.join(self.dir, "run.sh"), 0o755)
        subprocess.run(["git", "-C", self.dir, "add"] + [n for n in FILES if n != "new.h"],
                       check=True)

    def tearDown(self):
        shutil.rmtree(self.dir)

    def tool(self, *args):
        run = subprocess.run([sys.executable, TOOL] + list(args) + [self.dir],
                             capture_output=True, text=True, check=False)
        return run.returncode, run.stdout

    def read(self, name):
        with open(os.path.join(self.dir, name), encoding="utf-8", newline="") as f:
            return f.read()

    def test_check_names_each_file_without_the_line(self):
        rc, out = self.tool("--check")
        self.assertEqual(rc, 1, out)
        for name in EXPECTED:
            if name in ("notes.md", "data.json"):
                self.assertNotIn(name, out)
            else:
                self.assertIn("FAIL: %s: no SPDX line" % name, out)
        self.assertIn("FAIL: odd.xyz: no rule for this kind of file", out)
        self.assertNotIn("NOTICE", out)

    def test_a_third_party_file_must_be_in_notice(self):
        with open(os.path.join(self.dir, "NOTICE"), "w", encoding="utf-8") as f:
            f.write("nothing\n")
        rc, out = self.tool("--check")
        self.assertIn("FAIL: NOTICE does not name satellite/python/tests/py27_grammar.txt", out)

    def test_write_puts_the_line_where_each_kind_wants_it_once(self):
        rc, out = self.tool("--write")
        self.assertEqual(rc, 1, out)  # odd.xyz has no rule
        self.assertIn("13 files given the SPDX line", out)
        for name, text in EXPECTED.items():
            self.assertEqual(self.read(name), text, name)
        self.assertTrue(os.access(os.path.join(self.dir, "run.sh"), os.X_OK))
        os.remove(os.path.join(self.dir, "odd.xyz"))
        subprocess.run(["git", "-C", self.dir, "rm", "-q", "--cached", "odd.xyz"], check=True)
        rc, out = self.tool("--check")
        self.assertEqual(rc, 0, out)
        self.assertIn("ok: 13 source files carry the SPDX line", out)
        rc, out = self.tool("--write")
        self.assertEqual(rc, 0, out)
        self.assertIn("0 files given the SPDX line", out)

    def test_a_line_out_of_place_is_named_and_left(self):
        with open(os.path.join(self.dir, "q.py"), "w", encoding="utf-8") as f:
            f.write("\"\"\"Doc.\"\"\"\n# " + LINE + "\n")
        rc, out = self.tool("--write")
        self.assertIn("FAIL: q.py: its SPDX line is not '# %s' at line 1" % LINE, out)
        self.assertEqual(self.read("q.py"), "\"\"\"Doc.\"\"\"\n# " + LINE + "\n")

    def test_outside_a_checkout_it_skips(self):
        shutil.rmtree(os.path.join(self.dir, ".git"))
        rc, out = self.tool("--check")
        self.assertEqual(rc, 77, out)


if __name__ == "__main__":
    TOOL = os.path.abspath(sys.argv.pop(1))
    unittest.main()
