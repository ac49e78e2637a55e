"""Throughput of reading raw Mode-S / ADS-B frames on one core (aerotruth.measured.frames):
hex messages with their times -> pyModeS 3 decoding (PipeDecoder: CPR pairs, Comm-B
inference, address checks) -> the per-aircraft state table -> the canonical traffic frame.

Data: the frames of ../shared/real-data/full_flight_short.jsonl.gz (57,793 messages of one
flight), in memory; when fewer than --min-frames, copies of it follow each other in time
(each shifted by the capture's span and an hour, so no copy's frame repeats another's).
Without the file: the traffic generator's flights (tests/traffic_generator.py) encoded as
frames by tests/test_frames.py.

Prints `label: value` lines: `frames` (input rows), `frames_per_s` (input rows per second,
end to end), the stage times, and the same run's references on the same frames:
`pymodes_decode_per_s` (bare `pyModeS.decode(msg)`, one message at a time, no state) and
`pymodes_df_per_s` (`pyModeS.Message(msg).df`, the header alone), with `ratio_to_decode` and
`ratio_to_df` (frames_per_s over each).

    python benchmarks/frames_speed.py [--min-frames 100000] [--repeat 3]
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"  # per core

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from aerotruth.measured import frames  # noqa: E402
from aerotruth.measured.kinds import real_data_dir  # noqa: E402
from aerotruth.measured.traffic import canonical_traffic  # noqa: E402


def load(min_frames: int) -> tuple[pd.DataFrame, str]:
    path = real_data_dir() / "full_flight_short.jsonl.gz"
    if path.is_file():
        one = pd.read_json(path, lines=True, dtype=False)[["timestamp", "frame"]]
        source = path.name
    else:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
        import traffic_generator as gen
        from test_frames import encode_traffic

        one = encode_traffic(gen.make_traffic(20, seed=11)[0]).rename(columns={"rawmsg": "frame"})
        source = "generated traffic (real capture not found)"
    span = float(one["timestamp"].max() - one["timestamp"].min()) + 3600.0
    copies = max(1, -(-min_frames // len(one)))
    df = pd.concat([one.assign(timestamp=one["timestamp"] + k * span) for k in range(copies)], ignore_index=True)
    return df, f"{source} x {copies}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--min-frames", type=int, default=100_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    import pyModeS

    df, source = load(args.min_frames)
    msgs = df["frame"].tolist()
    best = None
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        dec = frames.decode_frames(df, "bench")
        t1 = time.perf_counter()
        states = frames.states_from_frames(dec)
        t2 = time.perf_counter()
        tr = canonical_traffic(states, "bench")
        t3 = time.perf_counter()
        stages = (t1 - t0, t2 - t1, t3 - t2)
        if best is None or sum(stages) < sum(best):
            best = stages
    assert best is not None
    ref_decode = ref_df = np.inf
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        for m in msgs:
            pyModeS.decode(m)
        t1 = time.perf_counter()
        for m in msgs:
            _ = pyModeS.Message(m).df
        t2 = time.perf_counter()
        ref_decode, ref_df = min(ref_decode, t1 - t0), min(ref_df, t2 - t1)
    total = sum(best)
    rate = len(df) / total
    print(f"source: {source}")
    print(f"pymodes_version: {pyModeS.__version__}")
    print(f"frames: {len(df)}")
    print(f"frames_decoded: {len(dec)}")
    print(f"samples: {len(tr)}")
    print(f"decode_s: {best[0]:.3f}")
    print(f"assemble_s: {best[1]:.3f}")
    print(f"canonical_s: {best[2]:.3f}")
    print(f"frames_per_s: {rate:.0f}")
    print(f"pymodes_decode_per_s: {len(df) / ref_decode:.0f}")
    print(f"pymodes_df_per_s: {len(df) / ref_df:.0f}")
    print(f"ratio_to_decode: {rate / (len(df) / ref_decode):.2f}")
    print(f"ratio_to_df: {rate / (len(df) / ref_df):.3f}")


if __name__ == "__main__":
    main()
