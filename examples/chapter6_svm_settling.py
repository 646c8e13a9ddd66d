"""Chapter 6 (§6.2): judge the end of a track seek with a support vector machine.

Read top to bottom; run with ``python examples/chapter6_svm_settling.py [OUTDIR]``.

1. Simulate FSC seeks of the plant (6.7) (rigid body + 4.1 kHz + 7 kHz, Ts = 37.879 us),
   collect the states whose output is inside +-0.03 track, label them class 1 (the output
   leaves the bound again) or class 2 (it never does).
2. Fit the judge: StandardScaler + SVC with a 4th-order polynomial kernel.
3. Validate on random seeks against the conventional rule (5 samples in a row) and the
   safety level -0.8; save the judge with skops and load it back.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

from servokit.learn import (  # noqa: E402
    SettlingJudge,
    evaluate_judgements,
    judgement_plot,
    simulate_seeks,
    training_seeks,
    training_set,
    validation_seeks,
)

SMALL = os.environ.get("SERVOKIT_EXAMPLE_SMALL") == "1"
outdir = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("out")
outdir.mkdir(parents=True, exist_ok=True)

# 1. training data (the book's ranges: 10-900 tracks, 24-130 samples)
grid = training_seeks(3, 4) if SMALL else training_seeks()
data = training_set(simulate_seeks(grid))
print(f"{len(grid)} training seeks -> {len(data.X)} states (class 1, class 2) = {data.counts}")

# 2. the judge (C and the kernel offset: see SettlingJudge.tune for cross-validation)
judge = SettlingJudge(C=10.0, coef0=0.5).fit(data.X, data.labels)

# 3. validation, persistence
responses = simulate_seeks(validation_seeks(10 if SMALL else 100, seed=1))
stats = evaluate_judgements(responses, judge, levels=(0.0, -0.8))
for s in stats:
    print(f"{s.method:>28}: failures {s.failures}, mean N_judge - N0 {s.mean_delay:.2f} samples")
path = judge.save(outdir / "settling_judge.skops")
print(f"wrote {path}")
same = SettlingJudge.load(path).judge(responses[0].states, responses[0].output)
print(f"reloaded judge decides seek 0 at sample {same} (N0 = {responses[0].n0()})")
fig = judgement_plot(
    [stats[1], stats[0], stats[2]],
    outdir / "svm_histograms.png",
    figures=["Fig. 6.10", "Fig. 6.11", "Fig. 6.12"],
)
print(f"wrote {fig}")
