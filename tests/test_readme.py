"""The README and the guides in docs/ describe only what exists, and their examples run.

* The README opens with the two command lines CI runs itself (install + quick campaign,
  install + tests): checked for presence and for what they name, not re-run here.
* Every other command line of the README's ```bash blocks is run as typed, in a scratch
  folder that sees the repository's `campaigns/` and `tests/` (`python -m aerotruth` is the
  same entry point as the `aerotruth` script); those that fly JSBSim are marked slow.
* Every ```python block of the README and of docs/howto/ is run in a fresh interpreter (a
  guide's block that reads a finished run, `runs/...`, is only compiled).
* Every `aerotruth ...` line of a ```bash block in the README and the guides parses with
  the command line's own parser, every command named anywhere exists, every relative link
  and repository path resolves, every AEROTRUTH_* variable is read by the code, and a
  campaign in a ```yaml block of a guide passes `aerotruth validate`.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

import aerotruth
from aerotruth.app.cli import build_parser

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# the docs written with the README (others are generated or kept by their own tests)
GUIDES = sorted(
    [ROOT / "docs" / n for n in ("architecture.md", "commands.md", "truth.md", "sensors.md", "checks.md")]
    + list((ROOT / "docs" / "howto").glob("*.md"))
)
DOCS = [README, *GUIDES]
CI_LINES = ('pip install -e ".[dev]" && aerotruth run campaigns/quick.yaml', 'pip install -e ".[dev]" && pytest')
FLIES = {"fly", "fly-approach", "run"}  # commands that fly JSBSim (minutes of simulated time)
REPO_DIRS = ("aerotruth/", "campaigns/", "tests/", "validation/", "benchmarks/", "tools/", "docs/")


def text(path: Path) -> str:
    return path.read_text(encoding="utf-8")


def blocks(doc: str, lang: str) -> list[str]:
    """The fenced code blocks of language `lang`, in order."""
    return re.findall(rf"^```{lang}\n(.*?)^```", doc, flags=re.S | re.M)


def command_lines(block: str) -> list[list[str]]:
    """The commands of a bash block as argument lists (comments and blank lines left out)."""
    out = []
    for line in block.splitlines():
        words = shlex.split(line, comments=True)
        if words:
            out.append(words)
    return out


def readme_cli_examples() -> list:
    params = []
    for block in blocks(text(README), "bash")[1:]:
        for words in command_lines(block):
            if words[0] != "aerotruth":
                continue
            marks = [pytest.mark.slow] if words[1] in FLIES else []
            params.append(pytest.param(words, marks=marks, id=" ".join(words[:2])))
    return params


@pytest.fixture
def scratch(tmp_path: Path) -> Path:
    """A working folder where the repository's campaigns/ and tests/ are where the docs say."""
    for name in ("campaigns", "tests"):
        (tmp_path / name).symlink_to(ROOT / name)
    return tmp_path


def run(args: list[str], cwd: Path, timeout: float = 600) -> subprocess.CompletedProcess:
    return subprocess.run(
        args, cwd=cwd, capture_output=True, text=True, timeout=timeout, env={**os.environ, "PYTHONPATH": str(ROOT)}
    )


# ----------------------------------------------------------------------------- the README


def test_the_readme_opens_with_the_two_lines_ci_runs_and_stays_short():
    doc = text(README)
    first = blocks(doc, "bash")[0]
    assert first.splitlines() == list(CI_LINES)
    assert doc.index("```bash") < doc.index("\n## "), "the two command lines come before any section"
    assert len(doc.encode("utf-8")) <= 8 * 1024
    # what the two lines name exists: the quick campaign, the dev extra with pytest
    assert (ROOT / "campaigns" / "quick.yaml").is_file()
    pyproject = text(ROOT / "pyproject.toml")
    assert re.search(r'^dev = \[.*"pytest', pyproject, flags=re.M)
    build_parser().parse_args(["run", "campaigns/quick.yaml"])


def test_the_readme_has_a_command_line_and_a_python_example():
    assert readme_cli_examples() and blocks(text(README), "python")


@pytest.mark.parametrize("words", readme_cli_examples())
def test_readme_command_line_example_runs(words, scratch):
    done = run([sys.executable, "-m", "aerotruth", *words[1:]], cwd=scratch)
    assert done.returncode == 0, f"{shlex.join(words)}\n{done.stdout}\n{done.stderr}"
    for i, w in enumerate(words[:-1]):
        if w == "--out":
            assert (scratch / words[i + 1]).exists(), f"{shlex.join(words)} wrote no {words[i + 1]}"


@pytest.mark.parametrize("doc", [README, *(p for p in GUIDES if blocks(text(p), "python"))], ids=lambda p: p.name)
def test_python_examples_run(doc, tmp_path):
    """Each example runs; one that reads a finished run (`runs/...`, which the guide says how to
    make) is only compiled, and the README's examples never need one."""
    for code in blocks(text(doc), "python"):
        compile(code, f"{doc.name} example", "exec")
        if "runs/" in code:
            assert doc != README, "the README's Python examples run on their own"
            continue
        done = run([sys.executable, "-c", code], cwd=tmp_path, timeout=300)
        assert done.returncode == 0, f"{doc.name} example failed:\n{code}\n{done.stderr}"
        assert done.stdout.strip(), f"{doc.name} example printed nothing:\n{code}"


# ----------------------------------------------------------------------------- README and guides


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_command_line_shown_parses(doc):
    parser = build_parser()
    for block in blocks(text(doc), "bash"):
        for words in command_lines(block):
            for cmd in " ".join(words).split(" && "):
                args = shlex.split(cmd)
                if args[0] != "aerotruth":
                    continue
                try:
                    parser.parse_args(args[1:])
                except SystemExit as e:
                    assert e.code == 0, f"{doc.name}: `{cmd}` is not a valid command line"


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_command_named_exists(doc):
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    named = set(re.findall(r"(?:`|&& |\$ )aerotruth ([a-z][a-z-]+)", text(doc)))
    assert named <= set(sub.choices), named - set(sub.choices)
    heading = next(a for a in sub.choices["heading"]._actions if a.dest == "heading_command")
    assert set(re.findall(r"aerotruth heading ([a-z]+)", text(doc))) <= set(heading.choices)


def _anchors(doc: str) -> set[str]:
    """GitHub's heading anchors of a Markdown text, plus explicit <a id=...>."""
    out = set(re.findall(r'<a id="([^"]+)"', doc))
    for title in re.findall(r"^#+ (.+)$", doc, flags=re.M):
        out.add(re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-"))
    return out


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_links_and_paths_resolve(doc):
    body = text(doc)
    for target in re.findall(r"\]\(([^)\s]+)\)", body):
        if re.match(r"[a-z]+:", target):
            continue
        file, _, anchor = target.partition("#")
        path = (doc.parent / file).resolve() if file else doc
        assert path.exists(), f"{doc.name} links to {target}, which does not exist"
        if anchor and path.suffix == ".md":
            assert anchor in _anchors(text(path)), f"{doc.name} links to {target}: no such heading"
    for name in re.findall(r"`([^`\s]+)`", body):
        if name.startswith(REPO_DIRS) and not set(name) & set("<>*|"):
            assert (ROOT / name.split(":")[0]).exists(), f"{doc.name} names {name}, which does not exist"


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: p.name)
def test_every_environment_variable_named_is_read_by_the_code(doc):
    source = "\n".join(p.read_text(encoding="utf-8") for p in Path(aerotruth.__file__).parent.rglob("*.py"))
    for var in set(re.findall(r"AEROTRUTH_[A-Z_]+", text(doc))):
        read = re.search(rf"environ(?:\.get)?[\[(]\s*[\"']{var}[\"']", source)
        assert read, f"{doc.name} names {var}, which no code reads"


@pytest.mark.parametrize("doc", GUIDES, ids=lambda p: p.name)
def test_guides_keep_lines_readable(doc):
    long = [i + 1 for i, line in enumerate(text(doc).splitlines()) if len(line) > 400]
    assert long == [], f"{doc.name}: lines over 400 characters: {long}"


@pytest.mark.parametrize(
    "doc", [p for p in GUIDES if any("studies:" in b for b in blocks(text(p), "yaml"))], ids=lambda p: p.name
)
def test_campaigns_in_the_guides_validate(doc, scratch):
    for i, block in enumerate(b for b in blocks(text(doc), "yaml") if "studies:" in b):
        path = scratch / f"example{i}.yaml"
        path.write_text(block, encoding="utf-8")
        done = run([sys.executable, "-m", "aerotruth", "validate", path.name], cwd=scratch)
        assert done.returncode == 0, f"{doc.name}: campaign example {i} does not validate:\n{done.stderr}"
