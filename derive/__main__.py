import atexit
import os
import sys

INTERRUPTED = 130           # the shell's status for a command stopped by Ctrl-C (128 + SIGINT)


def _leave_interrupted() -> None:
    """Exit with 130 at once after Ctrl-C: the exit handlers run, then the process ends
    without the interpreter's finalisation, which a late KeyboardInterrupt (or one that
    passed through an exec() during the imports) could turn into a death by SIGINT."""
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:             # a closed pipe: nothing more can be said
            pass
    os._exit(INTERRUPTED)


try:                        # Ctrl-C while the imports run (seconds on a busy machine): one line too
    from .cli import main
except KeyboardInterrupt:
    print("derive: interrupted", file=sys.stderr)
    _leave_interrupted()

status = main()
if status == INTERRUPTED:
    _leave_interrupted()
sys.exit(status)
