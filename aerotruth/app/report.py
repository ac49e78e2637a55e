"""RUN_DIR/report.md: the campaign, its metric tables and its figures (PNG embedded, PDF
linked), ready to paste into a paper or a pull request."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from aerotruth.app.figures import make_figures
from aerotruth.files import atomic_write_text
from aerotruth.markdown import to_markdown
from aerotruth.sim.store import RunStore
from aerotruth.sim.studies import campaign_registry


def write_report(run_dir: str | Path) -> Path:
    """Draw the figures and write RUN_DIR/report.md; returns its path."""
    store = RunStore(run_dir)
    campaign = store.campaign()
    manifest = store.read_manifest()
    doc = store.read_metrics()
    figures = make_figures(store.root)
    reg = campaign_registry(campaign)

    lines = [f"# Campaign `{campaign.name}`", ""]
    if campaign.description:
        lines += [campaign.description.strip(), ""]
    lines += [
        f"* seed: {campaign.seed}",
        f"* config hash: `{doc['config_hash'][:16]}`",
        "* tasks: " + ", ".join(f"{k} {v}" for k, v in doc["tasks"].items()),
        "* versions: " + ", ".join(f"{k} {v}" for k, v in manifest.get("versions", {}).items()),
        "",
        "Metrics are in `metrics.json`; tables as CSV in `tables/`; figures as PNG and PDF in `figures/`.",
        "",
    ]
    for name in campaign.studies:
        study = reg.get(name)
        prefix = f"{name}."
        mine = {k[len(prefix) :]: v for k, v in doc["metrics"].items() if k.startswith(prefix)}
        lines += [f"## {study.title}", ""]
        for tname, table in store.read_tables(name).items():
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
    atomic_write_text(store.report_path, "\n".join(lines))
    return store.report_path
