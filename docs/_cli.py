"""The command line's parser for sphinx-argparse, its help made safe for reStructuredText."""

from __future__ import annotations

import argparse

from scara_robust.cli import build_parser


def _escape(text: str | None) -> str | None:
    # `|e|` and `*` in help strings are plain text, not reST substitutions or emphasis
    return None if text is None else text.replace("|", r"\|").replace("*", r"\*")


def parser() -> argparse.ArgumentParser:
    """`build_parser()` with every help and description escaped for reST."""
    root = build_parser()
    stack = [root]
    while stack:
        p = stack.pop()
        p.description = _escape(p.description)
        p.epilog = _escape(p.epilog)
        for action in p._actions:
            action.help = _escape(action.help) if action.help is not argparse.SUPPRESS else action.help
            if isinstance(action, argparse._SubParsersAction):
                for choice in action._choices_actions:
                    choice.help = _escape(choice.help)
                stack.extend(action.choices.values())
    return root
