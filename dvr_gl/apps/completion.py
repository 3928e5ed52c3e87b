"""Print a shell completion script for dvr (bash, zsh or tcsh), generated from its own flags by shtab.

  bash:  dvr completion bash > ~/.local/share/bash-completion/completions/dvr
  zsh:   dvr completion zsh > "${fpath[1]}/_dvr"
  tcsh:  dvr completion tcsh > ~/.dvr.completion.csh   (then: source ~/.dvr.completion.csh)

The script is static: regenerate it after upgrading dvr-gl.  It needs the completion extra
(:func:`dvr_gl.errors.install_hint` says how)."""

from __future__ import annotations

from dvr_gl.errors import DvrError, install_hint

HELP = "print a shell completion script (bash, zsh, tcsh)"
SHELLS = ("bash", "zsh", "tcsh")  # shtab's shells


def add_arguments(p):
    p.add_argument("shell", choices=SHELLS, help="the shell to complete in")


def script(parser, shell: str) -> str:
    """The completion script for ``shell`` of ``parser`` (dvr's, from :func:`dvr_gl.apps.cli.build_parser`, which
    hands itself in: the command line imports its subcommands, never the other way round)."""
    try:
        import shtab
    except ImportError:
        raise DvrError(f"shell completion needs shtab: {install_hint('completion')}") from None
    return shtab.complete(parser, shell=shell)


def run(args) -> int:
    print(script(args.parser, args.shell))
    return 0
