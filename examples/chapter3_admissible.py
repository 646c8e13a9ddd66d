"""Safe switching conditions from maximal output admissible sets (chapter 3, §3.3.3).

HDD benchmark plant with a 500 Hz lead-lag; |u| <= 0.02 A after the switch; J-min IVC
with J = sum u^2 against a zero reset of the controller; Table 3.1's conditions.
Run: ``PYTHONPATH=src python examples/chapter3_admissible.py``
"""

import numpy as np

from servokit.models import HDD_BENCHMARK_TS, hdd_benchmark
from servokit.switching import ivc_jmin, max_output_admissible_set, switched_loop
from servokit.switching.design import lead_lag

plant = hdd_benchmark().discretize(HDD_BENCHMARK_TS)  # position in tracks, input in A
loop = switched_loop(plant, lead_lag(plant, 500.0))
K = ivc_jmin(loop, None, output_weight=loop.Cu)  # (3.91): minimise the input energy
O_inf = max_output_admissible_set(loop.A, loop.Cu, -0.02, 0.02)
print(f"O_inf finitely determined at t* = {O_inf.t_star} ({len(O_inf.h)} inequalities)")

E = np.zeros((loop.n, 2))  # slice: position [track], velocity [mm/s]; the rest at rest
E[0, 0], E[1, 1] = 1.0, 1e-3 / 2.54e-7
ivc, zero = O_inf.restrict(loop.stack(K) @ E), O_inf.restrict(loop.stack(0 * K) @ E)
for i, (pos, vel) in enumerate([(-1, 1), (-16, 10), (-36, 18), (-46, 25)], start=1):
    x = np.array([pos, vel], dtype=float)
    print(
        f"condition {i}: IVC {'safe' if ivc.contains(x) else 'violates'} "
        f"(needs {0.02 * ivc.gauge(x)[0]:.4f} A), zero reset "
        f"{'safe' if zero.contains(x) else 'violates'} (needs {0.02 * zero.gauge(x)[0]:.4f} A)"
    )
