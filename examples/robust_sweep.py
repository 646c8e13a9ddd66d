"""Seek-time distribution of Design 2 over 20 000 Monte-Carlo HDD plants (issue 13).

The plants are drawn from the Table 2.3 ranges and simulated in chunks of bounded
memory; pass ``--dask`` to run the chunks on a local Dask cluster (``servokit[dask]``).
Run: ``PYTHONPATH=src python examples/robust_sweep.py [--dask]``.
"""

from __future__ import annotations

import dataclasses
import sys

import servokit as sk
from servokit.seek import DESIGNS
from servokit.seek.sweep import connect_dask, sweep_seek_times


def main() -> None:
    vset = dataclasses.replace(sk.models.hdd_benchmark_variation_set(), gain=(0.0, 0.0))
    design_2 = DESIGNS[2].design(vset.nominal)
    client = connect_dask(workers=2) if "--dask" in sys.argv else None
    try:
        res = sweep_seek_times(vset, design_2, 1.0, n=20_000, seed=1, client=client)
    finally:
        if client is not None:
            client.close()
    pct = res.percentiles()
    print(f"{res.backend}: chunks of {res.chunk_size} plants (~{res.chunk_mb:.0f} MB each)")
    print("seek time [ms]: " + ", ".join(f"{k} {v * 1e3:.4f}" for k, v in pct.items()))
    print(f"worst plant #{res.worst_index}, {res.n_unsettled} unsettled")


if __name__ == "__main__":
    main()
