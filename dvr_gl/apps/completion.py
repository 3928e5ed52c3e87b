"""Print a shell completion script for dvr (bash, zsh or tcsh), generated from its own flags by shtab.

  bash:  dvr completion bash > ~/.local/share/bash-completion/completions/dvr
  zsh:   dvr completion zsh > "${fpath[1]}/_dvr"
  tcsh:  dvr completion tcsh > ~/.dvr.completion.csh   (then: source ~/.dvr.completion.csh)

The script is static: regenerate it after upgrading dvr-gl.  It needs the completion extra
(pip install 'dvr-gl[completion]')."""

from __future__ import annotations

from dvr_gl.errors import DvrError

HELP = "print a shell completion script (bash, zsh, tcsh)"
SHELLS = ("bash", "zsh", "tcsh")  # shtab's shells


def add_arguments(p):
    p.add_argument("shell", choices=SHELLS, help="the shell to complete in")


def script(shell: str) -> str:
    """The completion script for ``shell``, generated from :func:`dvr_gl.apps.cli.build_parser`."""
    try:
        import shtab
    except ImportError:
        raise DvrError("shell completion needs shtab: pip install 'dvr-gl[completion]'") from None
    from .cli import build_parser

    return shtab.complete(build_parser(), shell=shell)


def run(args) -> int:
    print(script(args.shell))
    return 0
