"""What a study's `run` gets besides its task: named random streams, the truth store and
the learned states the task needs."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from aerotruth.sim.tasks import IdentityValue, Task

if TYPE_CHECKING:
    import pandas as pd

    from aerotruth.truth.store import TruthStore


@dataclass
class TaskContext:
    """Per-task services (see the module docstring)."""

    task: Task
    campaign_seed: int
    truth_root: str | None = None
    learned: dict[str, pd.DataFrame] = field(default_factory=dict)
    _truth: TruthStore | None = field(default=None, repr=False)

    def rng(self, *name: IdentityValue) -> np.random.Generator:
        """The task's child stream `name` (e.g. "sensor", "flux_valve"): each consumer its
        own, so adding or changing one never moves the numbers another draws."""
        if not name:
            raise ValueError("rng: name the consumer of the stream, e.g. ctx.rng('sensor', 'heading')")
        return self.task.rng(self.campaign_seed, *name)

    @property
    def truth(self) -> TruthStore:
        """The shared truth store (flies only what is missing)."""
        if self._truth is None:
            from aerotruth.truth.store import TruthStore

            self._truth = TruthStore(Path(self.truth_root) if self.truth_root else None)
        return self._truth

    @property
    def legs_flown(self) -> int:
        """Legs and approaches this task flew into the truth store (not found there)."""
        return self._truth.flown_here if self._truth is not None else 0
