"""An argparse parser that suggests the closest flag or subcommand to a mistyped one (difflib), as Python 3.14's
suggest_on_error does and the Python 3.11 argparse does not."""

from __future__ import annotations

import argparse
import re
from typing import NoReturn

from sim.suggest import closest, did_you_mean, similarity

_INVALID_CHOICE = re.compile(r"invalid choice: '?(?P<name>[^' ]*)'? \(choose from (?P<choices>.*)\)")


class SuggestingParser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors add the closest allowed name: "unrecognized arguments: --pos-thres (did
    you mean '--pos-threshold'?)", "invalid choice: 'genrate' (did you mean 'generate'?)". Subparsers are of the
    same class; an unrecognised flag is compared with the flags of the parsers that took part in the parse (the
    command and its subcommands). Abbreviated flags are refused (allow_abbrev=False): `--output` is not taken for
    `--outputs`."""

    def __init__(self, *args: object, **kwargs: object):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def parse_known_args(self, args: list[str] | None = None, namespace: argparse.Namespace | None = None
                         ) -> tuple[argparse.Namespace, list[str]]:
        """argparse's, noting that this parser took part in the parse (its flags are then compared).

        Parameters
        ----------
        args : list of str, optional
            The arguments (default sys.argv[1:]).
        namespace : argparse.Namespace, optional
            The namespace to fill.

        Returns
        -------
        tuple of (argparse.Namespace, list of str)
            The namespace and the arguments not recognised.
        """
        self._took_part = True
        return super().parse_known_args(args, namespace)

    def error(self, message: str) -> NoReturn:
        """argparse's usage error (exit 2), with the closest allowed name added.

        Parameters
        ----------
        message : str
            argparse's message.

        Returns
        -------
        NoReturn
            Never returns: exits with status 2.
        """
        match = _INVALID_CHOICE.search(message)
        if match:
            choices = [c.strip().strip("'") for c in match["choices"].split(",")]
            message += did_you_mean(match["name"], choices)
        elif message.startswith("unrecognized arguments:"):
            flags = self._flags_in_use()
            words = [w.split("=")[0] for w in message.split(":", 1)[1].split() if w.startswith("--")]
            hints = [f"{w!r}: did you mean {hint}?" for w in words if (hint := self._hints(w, flags))]
            if hints:
                message += f" ({'; '.join(hints)})"
            # argparse reports unrecognised flags from the top-level parser: show the usage of the subcommand typed
            argparse.ArgumentParser.error(self._deepest_in_use(), message)
        super().error(message)

    def _hints(self, word: str, flags: list[str]) -> str | None:
        """What to suggest for `word`: a flag it extends and one that extends it when both exist ('--out' or
        '--outputs' for --output: abbreviations are refused, so either may be meant), else the closest flag."""
        shorter = max((f for f in flags if word.startswith(f) and len(f) > 2), key=len, default=None)
        longer = min((f for f in flags if f.startswith(word) and f != word), key=len, default=None)
        if shorter and longer:
            return f"{shorter!r} or {longer!r}"
        hint = self._hint(word, flags)
        return None if hint is None else repr(hint)

    def _hint(self, word: str, flags: list[str]) -> str | None:
        """The closer of the closest flag and flag_hint's suggestion (by similarity), or None."""
        match = closest(word, flags)
        candidates = [(similarity(word, match), match)] if match else []
        other = self.flag_hint(word)
        if other is not None:
            candidates.append(other[::-1])
        return max(candidates)[1] if candidates else None

    @staticmethod
    def flag_hint(flag: str) -> tuple[str, float] | None:
        """What to type instead of an unknown flag; set on the top-level parser (e.g.
        evsim_app.model_flags.flag_hint: a model field -> --dvs FIELD=VALUE).

        Parameters
        ----------
        flag : str
            The unknown flag.

        Returns
        -------
        tuple of (str, float) or None
            (what to type, how close: 0..1), or None (this default: no hint).
        """
        return None

    def _deepest_in_use(self) -> argparse.ArgumentParser:
        """The innermost subparser that took part in the parse (this parser when none did)."""
        parser = self
        while True:
            inner = [p for action in parser._actions if isinstance(action, argparse._SubParsersAction)
                     for p in action.choices.values() if getattr(p, "_took_part", False)]
            if not inner:
                return parser
            parser = inner[0]

    def _flags_in_use(self) -> list[str]:
        """The option strings of this parser and of the subparsers that took part in the parse."""
        flags, todo = [], [self]
        while todo:
            parser = todo.pop()
            for action in parser._actions:
                flags += [s for s in action.option_strings if s.startswith("--")]
                if isinstance(action, argparse._SubParsersAction):
                    todo += [p for p in action.choices.values() if getattr(p, "_took_part", False)]
        return flags
