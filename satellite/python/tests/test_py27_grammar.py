# SPDX-License-Identifier: Apache-2.0
"""Every file of PySketch, the executors and the example sketches parses as Python 2.7.

Debian 12 has no Python 2 interpreter, and lib2to3's own grammar accepts Python 3 syntax too, so
this builds a real Python 2.7 parser: tests/py27_grammar.txt (pgen format, written from the
Python 2.7 language reference) compiled by lib2to3's pgen, driven by lib2to3's tokenizer, plus
token checks the grammar cannot express (string prefixes: no f-strings; no '_' in numbers;
ASCII names) and keyword arguments named by a plain name. The test proves the parser refuses
each Python-3-only construct and accepts typical Python 2.7 code.

Needs Debian's python3-lib2to3.
"""
import glob
import io
import os
import re
import unittest
import warnings

from tests.hubtest import EXAMPLES, PYROOT, SCRIPTS

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    try:
        from lib2to3 import pytree
        from lib2to3.pgen2 import driver, parse, pgen, token, tokenize
    except ImportError as e:  # pragma: no cover
        raise ImportError("the Python 2.7 grammar check needs lib2to3 "
                          "(Debian: apt-get install python3-lib2to3): %s" % e)

GRAMMAR_FILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "py27_grammar.txt")
PY27_STRING_PREFIXES = {"", "r", "u", "ur", "b", "br"}
_FUTURE = re.compile(r"^from\s+__future__\s+import\s+\(?([\w\s,\\]*)\)?", re.M)

_grammars = {}


def grammar(print_statement):
    """The 2.7 grammar; with print_function in effect 'print' is a name, as in CPython 2.7."""
    if not _grammars:
        full = pgen.generate_grammar(GRAMMAR_FILE)
        no_print = full.copy()
        del no_print.keywords["print"]
        _grammars[True] = full
        _grammars[False] = no_print
    return _grammars[print_statement]


def check27(source, name="<snippet>"):
    """Raises SyntaxError unless `source` is valid Python 2.7."""
    if not source.endswith("\n"):
        source += "\n"
    try:
        for tok in tokenize.generate_tokens(io.StringIO(source).readline):
            kind, text, (line, col) = tok[0], tok[1], tok[2]
            where = "%s:%d:%d" % (name, line, col + 1)
            if kind == token.STRING:
                prefix = text[:min(i for i in (text.find("'"), text.find('"')) if i >= 0)]
                if prefix.lower() not in PY27_STRING_PREFIXES:
                    raise SyntaxError("%s: string prefix %r is not Python 2.7%s" % (
                        where, prefix, " (f-string)" if "f" in prefix.lower() else ""))
            elif kind == token.NUMBER and "_" in text:
                raise SyntaxError("%s: '_' in the number %s is not Python 2.7" % (where, text))
            elif kind == token.NAME and not all(ord(c) < 128 for c in text):
                raise SyntaxError("%s: non-ASCII name %r is not Python 2.7" % (where, text))
    except tokenize.TokenError as e:
        raise SyntaxError("%s: %s" % (name, e))
    futures = " ".join(_FUTURE.findall(source))
    g = grammar(print_statement="print_function" not in futures)
    try:
        tree = driver.Driver(g, convert=pytree.convert).parse_string(source)
    except parse.ParseError as e:
        raise SyntaxError("%s:%d:%d: not Python 2.7: %s %r" % (
            name, e.context[1][0], e.context[1][1] + 1, e.msg, e.value))
    except (tokenize.TokenError, IndentationError, KeyError) as e:
        raise SyntaxError("%s: not Python 2.7: %r" % (name, e))
    argument = g.symbol2number["argument"]
    for node in tree.pre_order():
        if node.type == argument and len(node.children) == 3 and \
                node.children[1].type == token.EQUAL and node.children[0].type != token.NAME:
            raise SyntaxError("%s:%d: keyword can't be an expression" % (name, node.get_lineno()))
    return tree


def filesToCheck():
    files = sorted(glob.glob(os.path.join(PYROOT, "PySketch", "*.py")))
    files.append(os.path.join(SCRIPTS, "pysketch-executor"))
    files += sorted(glob.glob(os.path.join(EXAMPLES, "*.py")))
    return files


class Python27Grammar(unittest.TestCase):
    def assertRejected(self, source, why):
        with self.assertRaises(SyntaxError, msg="accepted (%s): %s" % (why, source)):
            check27(source)

    def test_every_package_executor_and_example_file_is_python_27(self):
        files = filesToCheck()
        names = [os.path.basename(f) for f in files]
        for expected in ("flowsat.py", "executor.py", "sketch-executor.py", "pysketch-executor",
                         "publisher.py", "subscriber.py", "service_provider.py",
                         "service_caller.py", "nao_sketch.py"):
            self.assertIn(expected, names)
        for path in files:
            with io.open(path, encoding="utf-8") as f:
                source = f.read()
            with self.subTest(path=path):
                check27(source, path)

    def test_package_files_use_the_future_imports(self):
        for path in glob.glob(os.path.join(PYROOT, "PySketch", "*.py")):
            with io.open(path, encoding="utf-8") as f:
                self.assertIn("from __future__ import print_function, division, absolute_import",
                              f.read(), path)

    def test_python3_only_constructs_are_rejected(self):
        cases = [
            ('x = f"{y}"', "f-string"),
            ("x = F'{y!r}'", "f-string"),
            ('x = rf"{y}"', "raw f-string"),
            ('x = rb"bytes"', "rb prefix"),
            ("def f(x: int): pass", "parameter annotation"),
            ("def f(x) -> int: pass", "return annotation"),
            ("x: int = 1", "variable annotation"),
            ("def f(a, *, b): pass", "keyword-only parameter"),
            ("def f(*args, b=1): pass", "keyword-only parameter after *args"),
            ("lambda *, a: a", "keyword-only lambda parameter"),
            ("async def f(): pass", "async def"),
            ("def f():\n    await g()\n", "await"),
            ("async def f():\n    async with a as b: pass\n", "async with"),
            ("def f():\n    nonlocal x\n", "nonlocal"),
            ("def g():\n    yield from range(3)\n", "yield from"),
            ("a, *b = [1, 2, 3]", "starred assignment target"),
            ("*a, b = [1, 2, 3]", "starred assignment target"),
            ("x = [*a, 1]", "starred display"),
            ("x = {**a}", "dict unpacking"),
            ("f(*a, *b)", "several * arguments"),
            ("c = a @ b", "@ operator"),
            ("a @= b", "@= operator"),
            ('print("x", end="")', "print function without the future import"),
            ("raise ValueError('x') from None", "raise from"),
            ("if (n := 10) > 5: pass", "assignment expression"),
            ("x = 1_000", "underscore in a number"),
            ("\u00e9t\u00e9 = 1", "non-ASCII name"),
            ("x = ...", "Ellipsis literal"),
            ("f(a.b=1)", "keyword that is not a name"),
        ]
        for source, why in cases:
            with self.subTest(why=why):
                self.assertRejected(source, why)

    def test_typical_python27_code_is_accepted(self):
        check27(
            "import sys\n"
            "print 'hello', 1\n"
            "print >>sys.stderr, 'to stderr'\n"
            "print\n"
            "exec 'x = 1' in globals()\n"
            "exec code in g, l\n"
            "try:\n"
            "    pass\n"
            "except ValueError, e:\n"
            "    raise TypeError, 'msg'\n"
            "except (IOError, OSError) as e:\n"
            "    pass\n"
            "finally:\n"
            "    pass\n"
            "s = `42`\n"
            "if 1 <> 2: pass\n"
            "n = 0777L + 0xFFL + 0o17 + 0b101 + 1e-3j\n"
            "t = ur'raw unicode' + u'u' + b'bytes' + br'raw bytes' + r'raw'\n"
            "def f((a, b), c=1, *args, **kw):\n"
            "    return [x for x in 1, 2]\n"
            "class Old:\n"
            "    __metaclass__ = type\n"
            "@decorator(1)\n"
            "def g():\n"
            "    yield\n"
            "    x = yield 1\n"
            "d = {k: v for k, v in []}\n"
            "st = {1, 2}\n"
            "with open('a') as a, open('b') as b:\n"
            "    pass\n"
            "y = lambda (a, b): a\n"
            "z = x[1:2, ..., ::3]\n"
            "f(*args, **kw)\n"
            "f(a, b=1, *args, **kw)\n"
            "v = a if b else c\n"
            "global q\n"
            "assert x, 'message'\n"
            "del x[0], y\n")

    def test_print_is_a_function_only_with_the_future_import(self):
        check27("from __future__ import print_function\nimport sys\n"
                "print('x', file=sys.stderr, end='')\n")
        check27("from __future__ import (absolute_import,\n    print_function)\nprint('x', end='')\n")
        check27("print('x')\n")              # valid 2.7: a print statement of a parenthesized value
        with self.assertRaises(SyntaxError):
            check27("from __future__ import print_function\nprint 'x'\n")


if __name__ == "__main__":
    unittest.main()
