"""One observation table diagnosed by the `diagnose` code of another checkout of aerotruth
(the confusion plan's sizes are where the code *before* a change names each effect 50-80 %
of the time: validation/diagnose_confusion.py --diagnose-code runs this script with that
checkout first on PYTHONPATH, on datasets the current generators make).

    PYTHONPATH=OTHER_CHECKOUT python validation/diagnose_other_code.py OBS.parquet SPEC.json

SPEC.json: the WindModelSpec fields (those the other code's spec does not know are dropped).
Prints one JSON document: {"findings": [{effect, cause, parameters, evidence, gain}],
"baseline": {"weather_blocks", "not_tested", "rounds"}, "rows", "aerotruth": the aerotruth
package's folder}. Imports only what the diagnosis itself needs
(prepare, diagnose_wind, WindModelSpec), which every checkout since the library/application
split has under aerotruth.analysis.diagnose.wind.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys


def _plain(x):
    """JSON-safe copy: numpy scalars and arrays to Python, non-finite floats to None."""
    import numpy as np

    if isinstance(x, dict):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    if isinstance(x, np.ndarray):
        return _plain(x.tolist())
    if isinstance(x, np.generic):
        return _plain(x.item())
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, str | int | bool) or x is None:
        return x
    return str(x)


def main() -> None:
    if len(sys.argv) != 3:
        sys.exit("usage: diagnose_other_code.py OBS.parquet SPEC.json")
    import pandas as pd

    import aerotruth
    from aerotruth.analysis.diagnose.wind import WindModelSpec, diagnose_wind, prepare

    obs = pd.read_parquet(sys.argv[1])
    fields = json.loads(open(sys.argv[2]).read())
    known = set(WindModelSpec.model_fields)
    spec = WindModelSpec(**{k: v for k, v in fields.items() if k in known})
    d = prepare(obs)
    findings, baseline, _, _ = diagnose_wind(d, spec)
    out = {
        "findings": [_plain(dataclasses.asdict(f)) for f in findings],
        "baseline": _plain({k: baseline.get(k) for k in ("weather_blocks", "not_tested", "rounds") if k in baseline}),
        "rows": int(d.n),
        "aerotruth": str(aerotruth.__file__),
    }
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
