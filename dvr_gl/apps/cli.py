"""The ``dvr`` command: one entry point, a subcommand per job.

User errors (:class:`~dvr_gl.errors.DvrError`) and command-line mistakes print one line and exit 1;
``--debug`` adds the traceback.  Anything else is a bug: one line naming it
(exit 3), or the traceback with ``--debug``.
"""

from __future__ import annotations

import argparse
import os
import re
import sys
import traceback
import warnings

from dvr_gl import __version__
from dvr_gl.errors import DvrError
from dvr_gl.gl.context import BACKEND_VARIABLE, HEADLESS_BACKENDS

from . import bench as bench_cmd
from . import completion as completion_cmd
from . import info as info_cmd
from . import progress as feedback
from . import pyramid as pyramid_cmd
from . import render as render_cmd
from . import view as view_cmd

SUBCOMMANDS = {"render": render_cmd, "view": view_cmd, "info": info_cmd, "bench": bench_cmd,
               "completion": completion_cmd, "pyramid": pyramid_cmd}


class OneLineParser(argparse.ArgumentParser):
    """Command-line mistakes as every other bad input: one line naming the problem and where the flags
    are listed, exit status 1 (argparse prints its whole usage and exits 2)."""

    def error(self, message):
        self.exit(1, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="dvr", description="dvr-gl: direct volume rendering on OpenGL")
    parser.add_argument("--version", action="version", version=f"dvr-gl {__version__}")
    feedback.add_arguments(parser)
    add_gl_backend(parser)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, module in SUBCOMMANDS.items():
        # descriptions keep their line breaks: bench's list of benches, render's list of renderers
        p = sub.add_parser(name, help=module.HELP, description=module.__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        p.add_argument("--debug", action="store_true", help="show tracebacks of errors")
        feedback.add_arguments(p)
        add_gl_backend(p)
        module.add_arguments(p)
        p.set_defaults(run=module.run)
    return parser


def add_gl_backend(p: argparse.ArgumentParser):
    """``--gl-backend``, before or after the subcommand; it sets ``DVR_GL_BACKEND`` (dvr_gl/gl/context.py) for this
    process and the workers it starts."""
    p.add_argument("--gl-backend", choices=HEADLESS_BACKENDS, default=argparse.SUPPRESS,
                   help="the headless OpenGL backend (default: $DVR_GL_BACKEND, else auto: EGL, and OSMesa where EGL "
                        "gives no context)")


# Negative numbers argparse takes for flags (it knows -1 and -.5 only): -1e3, -2.5E-4, -inf, -nan.
_NEGATIVE_NUMBER = re.compile(r"-(?:(?:\d+\.?\d*|\.\d+)e[+-]?\d+|inf(?:inity)?|nan)", re.IGNORECASE)


def joined_negative_axes(argv) -> list[str]:
    """``--up -z`` as ``--up=-z``, and ``--rescale-intercept -1e3`` as ``--rescale-intercept=-1e3``: argparse
    takes a value that starts with ``-`` for a flag (unless it looks like -1 or -.5)."""
    args, out = [str(a) for a in argv], []
    i = 0
    while i < len(args):
        if args[i] == "--up" and i + 1 < len(args) and args[i + 1].lower() in ("-x", "-y", "-z"):
            out.append(f"--up={args[i + 1]}")
            i += 2
        elif args[i].startswith("--") and "=" not in args[i] and i + 1 < len(args) and \
                _NEGATIVE_NUMBER.fullmatch(args[i + 1]):
            out.append(f"{args[i]}={args[i + 1]}")
            i += 2
        else:
            out.append(args[i])
            i += 1
    return out


#: The exit status of a command whose reader went away (``dvr info FILE | head -1``): 128 + SIGPIPE, as a
#: command the signal ended would report.
BROKEN_PIPE = 141


def closed_stdout() -> int:
    """The reader of stdout closed it: no more output and no message, the standard way (Python's docs, "Note on
    SIGPIPE"): stdout goes to devnull, so that flushing it at exit does not fail again."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # a stdout without a file descriptor (captured, in tests)
        pass
    return BROKEN_PIPE


def main(argv: list[str] | None = None) -> int:
    try:
        return _main(argv)
    except BrokenPipeError:  # also from --help or --version, printed before any command runs
        return closed_stdout()


def _main(argv: list[str] | None) -> int:
    # the printed time is what the user waits for: from the process's start when run from the shell
    started = feedback.started(whole_process=argv is None)
    parser = build_parser()
    args = parser.parse_args(joined_negative_axes(sys.argv[1:] if argv is None else argv))
    args.command_line = "dvr " + " ".join(sys.argv[1:] if argv is None else argv)
    args.parser = parser  # what dvr completion describes
    args.started = started
    args.quiet = getattr(args, "quiet", False)
    args.verbose = getattr(args, "verbose", 0)
    if args.quiet and args.verbose:
        parser.error("give -q or -v, not both")
    if getattr(args, "gl_backend", None):
        os.environ[BACKEND_VARIABLE] = args.gl_backend
    verbosity = feedback.QUIET if args.quiet else min(args.verbose, feedback.VERBOSE)
    try:
        with warnings.catch_warnings(), feedback.feedback(args.command, verbosity):
            if not args.debug:
                # The last guard: a library warning (numpy's RuntimeWarning) is no line for the user; their
                # sources are fixed where found (the scene's checks), and --debug shows any that remain.
                warnings.simplefilter("ignore")
            return args.run(args) or 0
    except DvrError as exc:
        if args.debug:
            traceback.print_exc()
        print(f"dvr {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"dvr {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # stdout's reader went away: main's quiet exit, not a bug
        raise
    except Exception as exc:  # a bug: say so in one line unless debugging
        if args.debug:
            traceback.print_exc()
        else:
            print(f"dvr {args.command}: internal error: {type(exc).__name__}: {exc} "
                  f"(run with --debug for the traceback, and please report it)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
