"""``mitsar COMMAND --help``: every option's default shown once, and only when it is a value."""

from __future__ import annotations

import argparse
import re

import pytest

from mitsar.cli import build_parser


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(sub.choices)


COMMANDS = _commands()


def _option_helps(sub: argparse.ArgumentParser) -> dict[str, str]:
    """Each option's help text as the sub-command's formatter expands it."""
    formatter = sub._get_formatter()
    out = {}
    for action in sub._actions:
        if action.help in (None, argparse.SUPPRESS):
            continue
        text = formatter._get_help_string(action)
        name = action.option_strings[-1] if action.option_strings else action.dest
        out[name] = text % {**vars(action), "prog": sub.prog, "default": action.default}
    return out


def test_every_command_is_checked():
    assert {"simulate", "focus", "metrics", "export", "run", "preview", "sweep",
            "montecarlo", "demo"} <= set(COMMANDS)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_help_shows_each_default_once_and_never_none(name):
    sub = COMMANDS[name]
    page = sub.format_help()
    for empty in ("(default: None)", "(default: False)", "(default: [])", "(default: ==SUPPRESS"):
        assert empty not in page, f"mitsar {name} --help shows {empty}"
    for option, text in _option_helps(sub).items():
        assert len(re.findall(r"default", text, flags=re.IGNORECASE)) <= 1, (
            f"mitsar {name} {option}: the default twice in {text!r}")
    for action in sub._actions:  # a real value as default is shown (from the parser or the text)
        value = action.default
        if (action.option_strings and value not in (None, argparse.SUPPRESS, [], ())
                and not isinstance(value, bool) and action.help):
            assert "default" in _option_helps(sub)[action.option_strings[-1]].lower(), (
                f"mitsar {name} {action.option_strings[-1]} hides its default {value!r}")


def test_help_shows_list_defaults_as_typed():
    help_text = _option_helps(COMMANDS["montecarlo"])["--algorithms"]
    assert "(default: bpa rda wda fsa ffbp)" in help_text
    assert "(default: 10)" in _option_helps(COMMANDS["montecarlo"])["--realisations"]
