"""The base of every configuration schema (pydantic): a campaign file's sections, each
sensor's and each method's spec. A leaf module, so that truth, sensors and analysis can
declare their specs without importing the campaign loader."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict


class Section(BaseModel):
    """Base of every schema block: unknown keys are errors, values are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)
