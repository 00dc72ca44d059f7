"""docs/cli.md against the argument parser of `dmoc`: every option of every subcommand is
in its table and no documented option is missing from the parser; the Default column says
what ``--help`` says, and that is the parser's default where it has one; ``--help`` shows
no reST markup; the built-ins, the rules and the table's columns named in the page are the
ones the code has.

Oracle: the page, read as text, and the parser, the registry and a file written by a run."""

import argparse
import pathlib
import re

import pytest

from dmoc.cli import build_parser, main, registry
from dmoc.discrete import RULES

PAGE = (pathlib.Path(__file__).parents[2] / "docs" / "cli.md").read_text()
COMMANDS = ("simulate", "optimize", "demo")


def _subparsers():
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return parser, action.choices


def _documented(command):
    """{option: Default cell} of the table under "## `dmoc COMMAND`"."""
    section = PAGE.split(f"## `dmoc {command}`", 1)[1].split("\n#", 1)[0]
    rows = {}
    for line in section.splitlines():
        if not line.startswith("| `"):
            continue
        name_cell, default = (cell.strip() for cell in line.split("|")[1:3])
        for token in re.findall(r"`([^`]+)`", name_cell):
            rows[token.split()[0]] = default
    return rows


def _options(command):
    """{option or metavar: the action} of the subcommand, --help left out."""
    sub = _subparsers()[1][command]
    return {(a.option_strings[0] if a.option_strings else a.metavar): a
            for a in sub._actions if not isinstance(a, argparse._HelpAction)}


def _help_default(action):
    found = re.search(r"\(default: (.*)\)$", " ".join((action.help or "").split()))
    return found.group(1) if found else "—"


@pytest.mark.parametrize("command", COMMANDS)
def test_every_option_is_documented_and_no_other(command):
    assert set(_documented(command)) == set(_options(command))


@pytest.mark.parametrize("command", COMMANDS)
def test_the_defaults_agree(command):
    documented, options = _documented(command), _options(command)
    for name, action in options.items():
        assert documented[name] == _help_default(action), name
        if action.default not in (None, False):
            shown = _help_default(action).split(",")[0]
            is_number = isinstance(action.default, (int, float))
            assert shown == (f"{action.default:g}" if is_number else action.default), name


def test_help_shows_no_markup_and_every_default():
    parser, subs = _subparsers()
    for text in [parser.format_help(), *(sub.format_help() for sub in subs.values())]:
        assert "``" not in text
    assert "(default: 100)" in " ".join(subs["optimize"].format_help().split())
    assert "(default: 1000, or the rows of --controls)" in " ".join(subs["simulate"].format_help().split())


def test_the_page_names_every_built_in_and_rule():
    intro = PAGE.split("## `dmoc simulate`", 1)[0]
    for name in registry.BUILT_IN:
        assert f"`{name}`" in intro
    for command in ("simulate", "optimize"):
        rule_row = next(line for line in PAGE.split(f"## `dmoc {command}`")[1].splitlines()
                        if line.startswith("| `--rule`"))
        assert re.findall(r"`(\w+)`", rule_row.split("|")[3]) == list(RULES)


def test_the_page_names_the_columns_of_the_table(tmp_path, capsys):
    assert main(["simulate", "knife-edge", "--steps", "2", "--out", str(tmp_path), "--no-plots"]) == 0
    header = (tmp_path / "knife_edge.csv").read_text().splitlines()[0].split(",")
    assert header == ["t", "x", "y", "theta", "p_x", "p_y", "p_theta", "lam_0", "force", "torque"]
    columns = PAGE.split("- `NAME.csv`:", 1)[1].split("\n- ", 1)[0]
    for documented in ("`t`", "`p_NAME`", "`lam_0`"):
        assert documented in columns
    assert "lam_a" not in PAGE
