"""Shell completion of ``bench`` and ``catpose`` (``bench run -sc install=bash``).

Hydra's own completion script completes one program whose arguments are all Hydra's; ``bench``
has a command first, so ``bench run -sc install=bash`` prints a script of its own instead: the
first word completes to a command name, the words after ``bench run`` to what Hydra's completion
offers (config groups, their names, keys; ``bench run -sc query=bash``, answered by Hydra with
the line as if ``run`` were not there), and the words of the other commands to file names::

    eval "$(bench run -sc install=bash)"     # in ~/.bashrc; zsh: install=zsh (bashcompinit)
    eval "$(bench run -sc uninstall=bash)"

Fish is not offered: Hydra's fish script completes one program only.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

from catpose.errors import ConfigError

SHELLS = ("bash", "zsh")
PROGRAMS = ("bench", "catpose")

_FUNCTION = "_catpose_bench_completion"

_BASH = r"""{function}()
{{
    local words=($COMP_LINE)
    local word=${{words[$COMP_CWORD]}}
    if (( COMP_CWORD <= 1 )); then
        local commands=$(${{words[0]}} --help 2> /dev/null | awk '/^commands:/{{f=1; next}} /^$/{{f=0}} f{{print $1}}')
        compopt +o nospace 2> /dev/null
        COMPREPLY=($(compgen -W "$commands" -- "$word"))
        return
    fi
    if [ "${{words[1]}}" != "run" ]; then
        compopt +o nospace 2> /dev/null
        COMPREPLY=($(compgen -f -- "$word"))
        return
    fi
    local choices=$(COMP_POINT=$COMP_POINT COMP_LINE="$COMP_LINE" ${{words[0]}} run -sc query=bash 2> /dev/null)
    COMPREPLY=($(compgen -o nospace -o default -W "$choices" -- "$word"))
}}
COMP_WORDBREAKS=${{COMP_WORDBREAKS//=}}
complete -o nospace -o default -F {function} {programs}
"""


def install_script(shell: str) -> str:
    """The completion script for ``shell`` (bash; zsh through its bash compatibility). The
    command names come from ``bench --help`` when a user presses Tab (the CLI's own list)."""
    script = _BASH.format(function=_FUNCTION, programs=" ".join(PROGRAMS))
    if shell == "zsh":
        script = "autoload -U +X bashcompinit && bashcompinit\n" + script
    return script


def uninstall_script(shell: str) -> str:
    """Shell lines that remove what :func:`install_script` set up."""
    return f"complete -r {' '.join(PROGRAMS)} 2> /dev/null\nunset -f {_FUNCTION}\n"


def query_line(line: str) -> str:
    """The completion line as Hydra's query reads it: ``bench run met`` -> ``bench met`` (Hydra
    drops the first word, the program, and completes the rest)."""
    words = line.split(" ")
    if len(words) >= 2 and words[1] == "run":
        return " ".join(words[:1] + words[2:])
    return line


def shell_completion(overrides: Sequence[str]) -> str | None:
    """``bench run -sc ACTION=SHELL``: the script to print for ``install`` / ``uninstall``; for
    ``query`` (the script's call while a user presses Tab), ``None`` after rewriting
    ``COMP_LINE`` (:func:`query_line`), so that Hydra answers it. A :class:`ConfigError` names
    the accepted forms otherwise."""
    action, _, shell = (overrides[0] if len(overrides) == 1 else "").partition("=")
    if action not in ("install", "uninstall", "query") or shell not in SHELLS:
        raise ConfigError(
            f"-sc takes install=SHELL, uninstall=SHELL or query=SHELL with SHELL one of {', '.join(SHELLS)}; "
            f'got {" ".join(overrides) or "nothing"} (eval "$(bench run -sc install=bash)" sets it up)'
        )
    if action == "install":
        return install_script(shell)
    if action == "uninstall":
        return uninstall_script(shell)
    os.environ["COMP_LINE"] = query_line(os.environ.get("COMP_LINE", "bench run "))
    return None
