"""How a tool ends when a run failed or Ctrl-C stopped it: one line saying what to do instead of a traceback, and the
exit status (1; 130 for Ctrl-C)."""
import sys

from child_runs import INTERRUPTED


def failed(prog, error):
    """After a failed run: one line naming it and its log instead of a traceback; returns the exit status, 1."""
    print(f"{prog}: error: {error} (finished runs are kept: run the same command again once it is fixed)", file=sys.stderr)
    return 1


def interrupted(prog, kept):
    """After Ctrl-C: says how to go on (`kept`: what a rerun keeps); returns the exit status, 130."""
    print(f"{prog}: interrupted; run the same command again to resume ({kept})", file=sys.stderr)
    return INTERRUPTED


def run_read_only(main, prog):
    """Runs a tool that only reads its inputs (a report, a plot, a fit): Ctrl-C ends it with one line, not a traceback,
    and status 130; there is nothing to resume."""
    try:
        return main()
    except KeyboardInterrupt:
        print(f"{prog}: interrupted; its inputs are unchanged (an output it was writing may be incomplete)", file=sys.stderr)
        return INTERRUPTED
