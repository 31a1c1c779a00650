"""The real ``rmdrake`` parser for sphinx-argparse, its help texts escaped for
reST (sphinx-argparse reads help as reST: a glob such as ``logs/*.csv`` would
start emphasis). Nothing else changes, so the CLI page is the parser's."""

from __future__ import annotations

import argparse

from rmdrake.cli.commands import build_parser


def _escape(parser: argparse.ArgumentParser) -> None:
    for action in parser._actions:
        if action.help:
            action.help = action.help.replace("*", r"\*")
        if isinstance(action.choices, dict):
            for sub in action.choices.values():
                if isinstance(sub, argparse.ArgumentParser):
                    _escape(sub)


def docs_parser() -> argparse.ArgumentParser:
    parser = build_parser()
    _escape(parser)
    return parser
