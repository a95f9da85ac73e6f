"""python3 -m vdbscatter COMMAND [options]: the vdbscatter CLI, run through the library.
Output goes to stdout and messages to stderr as they come; the exit status is the CLI's
(130 after Ctrl-C, which cancels the command: it leaves no partial output)."""
import os
import signal
import sys

from . import _lib, __version__, _run

# The CLI's own usage text (cli/main.c); tests/test_python.py checks that the two agree.
USAGE = """\
usage: vdbscatter COMMAND [options]

commands:
  bake IN.vdb -o OUT.vdb     light a density VDB and write a lit VDB
  render IN.vdb -o IMG.exr   ray-march or path-trace a picture of a volume
  compare A B                error metrics of image A against reference B
  info FILE.vdb              list grids, sizes, value ranges, optical thickness
  sample NAME -o OUT.vdb     write a procedural sample volume
  tradeoff IN.vdb -o DIR     every method's error against time on your scene
  phase-svd --g G --directions D   the phase matrix's factorisation error per term

Run 'vdbscatter COMMAND --help' for the options of a command.
Exit status: 0 success, 1 failure while working, 2 bad input or usage.
"""


def _write(kind, text):
    stream = sys.stdout if kind == _lib.MESSAGE_OUTPUT else sys.stderr
    stream.buffer.write(text)
    stream.buffer.flush()


def main(argv):
    if not argv:
        sys.stderr.write(USAGE)
        return 2
    if argv[0] in ("--help", "-h", "help"):
        sys.stdout.write(USAGE)
        return 0
    if argv[0] == "--version":
        print(f"vdbscatter {__version__}")
        return 0
    # Progress lines, as the CLI: only to a terminal, and not with -q.
    progress = sys.stderr.isatty() and "-q" not in argv[1:]
    try:
        return _run(argv, _write, progress=progress).exit_status
    except KeyboardInterrupt:
        return 128 + signal.SIGINT
    except BrokenPipeError:
        # A reader that stopped early (| head): exit as the CLI would after SIGPIPE, without
        # a second error when Python flushes stdout at exit.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 128 + signal.SIGPIPE


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
