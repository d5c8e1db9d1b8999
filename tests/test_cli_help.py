"""``mitsar COMMAND --help``: every option's default shown once, and only when it is a value."""

from __future__ import annotations

import argparse
import re
from pathlib import Path

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


DOCS_CLI = Path(__file__).resolve().parents[1] / "docs" / "cli.md"
GLOBAL_OPTIONS = {"--debug", "--quiet", "--memory-limit"}


def _section(text: str, name: str) -> str:
    """docs/cli.md's section of ``mitsar NAME`` (a heading naming it), up to the next one."""
    found = re.search(rf"^## [^\n]*`mitsar {name}`[^\n]*\n(.*?)(?=^## |\Z)", text,
                      flags=re.MULTILINE | re.DOTALL)
    assert found, f"docs/cli.md has no section for mitsar {name}"
    return found.group(1)


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_docs_cli_lists_every_command_and_its_options(name):
    """Every sub-command has a row in the command table and a section; every option of it (its
    long form) and every choice of an option with choices appears in that section; the global
    options are in the table of options every command accepts."""
    text = DOCS_CLI.read_text()
    table = text[:text.index("Options every command accepts")]
    assert f"`mitsar {name}" in table, f"mitsar {name} is not in docs/cli.md's command table"
    section = _section(text, name)
    missing = []
    for action in COMMANDS[name]._actions:
        if (not action.option_strings or "--help" in action.option_strings
                or action.help == argparse.SUPPRESS):  # hidden: a refusal, not an option
            continue
        option = max(action.option_strings, key=len)
        if option in GLOBAL_OPTIONS:
            if f"`{option}" not in text.split("## Files")[0]:
                missing.append(f"{option} (in the table of options every command accepts)")
            continue
        if not any(re.search(rf"(?<![\w-]){re.escape(form)}(?![\w-])", section)
                   for form in action.option_strings):  # -o or --output
            missing.append(option)
        missing.extend(f"{option} {choice}" for choice in action.choices or ()
                       if str(choice) not in section)
    assert not missing, f"docs/cli.md, mitsar {name}: not documented: {missing}"


def test_docs_cli_says_which_commands_take_overwrite():
    """--overwrite is no global option: sweep and montecarlo refuse it (they resume instead;
    a hidden option that only explains the refusal)."""
    text = DOCS_CLI.read_text()
    options = text[text.index("Options every command accepts"):text.index("## Files")]
    assert "| `--overwrite`" not in options, "docs/cli.md lists --overwrite as a global option"
    for name in ("sweep", "montecarlo"):
        assert all("--overwrite" not in a.option_strings or a.help == argparse.SUPPRESS
                   for a in COMMANDS[name]._actions)
        assert "--overwrite" not in _section(text, name).split("```")[1], (
            f"docs/cli.md shows --overwrite in mitsar {name}'s usage")
