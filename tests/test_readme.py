"""The README describes only what exists: every `aerotruth <command>` it names is a
command of the parser, and every AEROTRUTH_* variable it names is read by the code."""

from __future__ import annotations

import re
from pathlib import Path

import aerotruth
from aerotruth.app.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text(encoding="utf-8")


def test_every_command_the_readme_names_exists():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    named = set(re.findall(r"(?:`|&& |\$ )aerotruth ([a-z][a-z-]+)", README))
    # commands the design plans (DESIGN.md) may be named in passing, as `diagnose`
    planned = {"diagnose", "fits", "heading", "fly-approach"}
    named |= {w for w in re.findall(r"`([a-z][a-z-]+)`", README) if w in planned}
    assert named and named <= set(sub.choices), named - set(sub.choices)


def test_every_environment_variable_the_readme_names_is_read_by_the_code():
    source = "\n".join(p.read_text(encoding="utf-8") for p in Path(aerotruth.__file__).parent.rglob("*.py"))
    for var in set(re.findall(r"AEROTRUTH_[A-Z_]+", README)):
        assert re.search(rf"environ(?:\.get)?[\[(]\s*[\"']{var}[\"']", source), f"README names {var}, which no code reads"
