"""Figures of a finished run: each study draws its own into RUN_DIR/figures (PNG + PDF)
from its stored rows, summary tables and learned states (nothing is recomputed)."""

from __future__ import annotations

from pathlib import Path

from aerotruth.sim.campaign import expand
from aerotruth.sim.store import RunStore
from aerotruth.sim.studies import Figure, Summary, campaign_registry


def make_figures(run_dir: str | Path) -> dict[str, list[Figure]]:
    """Draw every study's figures of the run in `run_dir`; returns them by study name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    store = RunStore(run_dir)
    campaign = store.campaign()
    store.read_manifest()
    metrics = store.read_metrics()["metrics"]
    reg = campaign_registry(campaign)
    tasks = expand(campaign, reg)
    store.figures_dir.mkdir(parents=True, exist_ok=True)
    out: dict[str, list[Figure]] = {}
    for name in campaign.studies:
        study = reg.get(name)
        rows = store.read_rows([t for t in tasks if t.study == name])
        prefix = f"{name}."
        summary = Summary(
            {k[len(prefix) :]: v for k, v in metrics.items() if k.startswith(prefix)}, store.read_tables(name)
        )
        try:
            out[name] = study.figures(rows, summary, store.learned_of(name), FigureFolder(store.figures_dir))
        finally:
            plt.close("all")
    return out


class FigureFolder:
    """Where a study's figures go: `save(fig, stem)` writes the matplotlib figure as
    <folder>/<stem>.png (150 dpi) and .pdf. A study draws; the application decides where and
    in which formats figures are written. Path-like (`folder / name`, os.fspath) for studies
    that write a file of their own."""

    def __init__(self, path: Path):
        self.path = Path(path)

    def save(self, fig, stem: str) -> None:
        fig.savefig(self.path / f"{stem}.png", dpi=150, bbox_inches="tight")
        fig.savefig(self.path / f"{stem}.pdf", bbox_inches="tight")

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    def __fspath__(self) -> str:
        return str(self.path)
