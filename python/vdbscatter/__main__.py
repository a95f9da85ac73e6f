"""python3 -m vdbscatter COMMAND [options]: the vdbscatter CLI, run through the library.
Output goes to stdout and messages to stderr as they come; the exit status is the CLI's
(130 after Ctrl-C, which cancels the command: it leaves no partial output)."""
import os
import signal
import sys

from . import _lib, _run


def _write(kind, text):
    stream = sys.stdout if kind == _lib.MESSAGE_OUTPUT else sys.stderr
    stream.buffer.write(text)
    stream.buffer.flush()


def main(argv):
    # Every word goes to the library, the usage, --help and --version too. Progress lines, as
    # the CLI: only to a terminal, and not with -q.
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
