#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The sketch executor: runs a PySketch sketch.

    pysketch-executor SKETCH.py [the sketch's own options...]
    python3 -m PySketch.executor SKETCH.py [...]
    ./SKETCH.py [...]      with a first line #!/usr/bin/env pysketch-executor,
                           #!/usr/local/bin/pysketch-executor, #!PySketch/executor.py or
                           #!PySketch/sketch-executor.py (the last two relative to the current
                           directory: run the sketch from its own directory, PySketch next to it)

The sketch is a Python file that defines setup() (called once; a false result stops), loop()
(called again and again until it returns a false value) and optionally close() (called at the
end after a successful setup(): when loop() stops, on an exception, on Ctrl-C and on SIGTERM).
It runs as a module named "__sketch__" with the sketch's directory first on sys.path (so a
PySketch directory next to it is found first) and sys.argv = [executor, SKETCH.py, options...]:
a sketch's argparse sees SKETCH.py as its positional `sketchfile`, then its own options.

Exit status: 0 when loop() ended or the sketch was stopped by SIGINT/SIGTERM, 1 when setup()
failed or the sketch raised, 2 for a usage error.
"""
from __future__ import print_function, division, absolute_import

import os
import sys

if __name__ == "__main__" and not __package__:
    # Run as a file (#!PySketch/executor.py): import the package by its name, not our directory.
    _here = os.path.dirname(os.path.realpath(__file__))
    sys.path = [p for p in sys.path if os.path.realpath(p or ".") != _here]
    sys.path.insert(0, os.path.dirname(_here))

import signal  # noqa: E402
import traceback  # noqa: E402
import types  # noqa: E402

USAGE = "usage: pysketch-executor SKETCH.py [sketch options...]"


class _Stopped(KeyboardInterrupt):
    pass


def _onSigterm(signum, frame):
    raise _Stopped()


def _lineBuffered():
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        reconf = getattr(stream, "reconfigure", None)
        if reconf is not None:
            try:
                reconf(line_buffering=True)
            except (ValueError, OSError):
                pass
        elif sys.version_info[0] == 2:  # pragma: no cover
            try:
                setattr(sys, name, os.fdopen(stream.fileno(), "w", 1))
            except (OSError, IOError, ValueError, AttributeError):
                pass


def loadSketch(path):
    """Executes the sketch file as the module "__sketch__" and returns it."""
    mod = types.ModuleType("__sketch__")
    mod.__file__ = os.path.abspath(path)
    sys.modules["__sketch__"] = mod
    with open(path, "rb") as f:
        source = f.read()
    # dont_inherit: the sketch gets its own __future__ flags, not the executor's.
    code = compile(source, path, "exec", 0, True)
    exec(code, mod.__dict__)
    return mod


def run(module):
    """Runs setup() / loop() / close() of a loaded sketch; returns the exit status."""
    setup = getattr(module, "setup", None)
    loop = getattr(module, "loop", None)
    close = getattr(module, "close", None)
    if not callable(setup) or not callable(loop):
        print("pysketch-executor: the sketch must define setup() and loop()", file=sys.stderr)
        return 2
    status = 0
    ready = False
    try:
        ok = setup()
        if not ok:
            print("pysketch-executor: setup() returned %r: stopping" % (ok,), file=sys.stderr)
            return 1
        ready = True
        while loop():
            pass
    except KeyboardInterrupt as e:
        print("pysketch-executor: stopped by %s" % ("SIGTERM" if isinstance(e, _Stopped)
                                                   else "SIGINT"), file=sys.stderr)
    except SystemExit as e:
        status = e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    except Exception:
        traceback.print_exc()
        status = 1
    finally:
        if ready and callable(close):
            try:
                close()
            except KeyboardInterrupt:
                pass
            except Exception:
                traceback.print_exc()
                status = status or 1
    return status


def main(argv=None):
    argv = list(sys.argv if argv is None else argv)
    if len(argv) < 2:
        print(USAGE, file=sys.stderr)
        return 2
    if argv[1] in ("-h", "--help"):
        print(USAGE)
        print(__doc__.split("\n\n", 1)[1])
        return 0
    sketch = argv[1]
    if not os.path.isfile(sketch):
        print("pysketch-executor: no sketch file %s" % sketch, file=sys.stderr)
        return 2
    _lineBuffered()
    sys.path.insert(0, os.path.dirname(os.path.abspath(sketch)))
    sys.argv = argv
    from PySketch import abstractflow
    abstractflow.defaultClientName = os.path.splitext(os.path.basename(sketch))[0]
    try:
        signal.signal(signal.SIGTERM, _onSigterm)
    except (ValueError, AttributeError):  # not the main thread
        pass
    try:
        module = loadSketch(sketch)
    except KeyboardInterrupt:
        return 0
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else (0 if e.code is None else 1)
    except Exception:
        traceback.print_exc()
        return 1
    return run(module)


if __name__ == "__main__":
    from PySketch.executor import main as _main  # the package's copy, not this __main__
    sys.exit(_main())
