"""Initial value compensation on the book's delayed HDD loop (chapter 3, §3.3.1-§3.3.2).

Rebuilds the loop from its printed closed-loop poles, loads the controller state by
pole-zero IVC and by an additional input r', and prints the zeros the book lists.
Run: ``PYTHONPATH=src python examples/chapter3_ivc.py``
"""

import numpy as np

from servokit.switching import (
    additional_input_response,
    fit_delay_ratio,
    free_response,
    ivc_additional_input,
    ivc_pole_zero,
    ivc_zeros,
    pade_double_integrator,
    place_controller,
    switched_loop,
)

dt = 150e-6  # assumed sampling period [s]
ratio = fit_delay_ratio([-56.79, -0.235])  # Td/dt from the plant zeros printed in §3.3.2
plant = pade_double_integrator(dt, ratio * dt)  # states [position, velocity, Padé]
poles = [-0.335, 0.555 + 0.416j, 0.555 - 0.416j, 0.905, 0.954]  # §3.3.1
loop = switched_loop(plant, place_controller(plant, poles))
print(f"Td/dt = {ratio:.4f}; closed-loop poles {np.round(np.sort_complex(loop.poles()), 4)}")

K = ivc_pole_zero(loop, None, [0.905, 0.954])
print("pole-zero IVC, zeros of xpos[0] -> y:", np.round(np.sort(ivc_zeros(loop, K, 0).real), 4))
print("                zeros of xvel[0] -> y:", np.round(np.sort(ivc_zeros(loop, K, 1).real), 4))

xp0 = np.array([5.0, -10e3, 0.0])  # 5 um, -10 mm/s (in um and um/s)
y_ivc = free_response(loop.A, loop.C, loop.stack(K) @ xp0, 40)[:, 0]
y_off = free_response(loop.A, loop.C, loop.stack(0 * K) @ xp0, 40)[:, 0]
print("largest undershoot with / without IVC [um]:", -y_ivc.min().round(3), -y_off.min().round(3))

design = ivc_additional_input(loop, 0.6)  # r' = n_k/d xp_k[0], one assigned pole at 0.6
y, u, rp = additional_input_response(loop, design, xp0, 40)
print("r' IVC: y[k+1]/y[k] for k >= 1:", np.round(y[2:8] / y[1:7], 12))
