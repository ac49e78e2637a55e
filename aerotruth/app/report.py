"""RUN_DIR/report.md: the campaign, its metric tables and its figures (PNG embedded, PDF
linked), ready to paste into a paper or a pull request.

Every file the report is made of is read and checked first (`figures.read_run`), the
figures are drawn aside and the text is composed before anything is written: a damaged run
folder is one line naming the file, with the report and the figures left as they were."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from aerotruth.app.figures import FinishedRun, check_output, drawn_figures, read_run
from aerotruth.errors import RunDirError
from aerotruth.files import atomic_write_text
from aerotruth.markdown import to_markdown
from aerotruth.sim.studies import Figure


def write_report(run_dir: str | Path) -> Path:
    """Draw the figures and write RUN_DIR/report.md; returns its path."""
    run = read_run(run_dir)
    path = run.store.report_path
    check_output(path, folder=False)
    with drawn_figures(run) as figures:
        text = report_text(run, figures)
    try:
        atomic_write_text(path, text)
    except OSError as e:
        raise RunDirError(f"{path}: cannot be written ({e.strerror or e})") from None
    return path


def report_text(run: FinishedRun, figures: dict[str, list[Figure]]) -> str:
    """The Markdown of report.md."""
    campaign, doc = run.campaign, run.metrics
    lines = [f"# Campaign `{campaign.name}`", ""]
    if campaign.description:
        lines += [campaign.description.strip(), ""]
    lines += [
        f"* seed: {campaign.seed}",
        f"* config hash: `{doc['config_hash'][:16]}`",
        "* tasks: " + ", ".join(f"{k} {v}" for k, v in doc["tasks"].items()),
        "* versions: " + ", ".join(f"{k} {v}" for k, v in run.manifest.get("versions", {}).items()),
        "",
        "Metrics are in `metrics.json`; tables as CSV in `tables/`; figures as PNG and PDF in `figures/`.",
        "",
    ]
    for name in campaign.studies:
        study = run.registry.get(name)
        mine = run.study_metrics(name)
        lines += [f"## {study.title}", ""]
        for tname, table in run.tables[name].items():
            lines += [f"### {tname.replace('_', ' ')}", "", to_markdown(table), ""]
        for fig in figures.get(name, []):
            lines += [
                f"![{fig.caption}](figures/{fig.stem}.png)",
                "",
                f"*{fig.caption}* ([PDF](figures/{fig.stem}.pdf))",
                "",
            ]
        if not mine:
            lines += ["(no metrics)", ""]
        else:
            table = pd.DataFrame({"metric": list(mine), "value": list(mine.values())})
            lines += ["<details><summary>all metrics</summary>", "", to_markdown(table, digits=6), "", "</details>", ""]
    return "\n".join(lines)
