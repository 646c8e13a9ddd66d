"""Simulator benchmarks: open loop vs python-control and the arithmetic bound, 10^5
variants in bounded memory, closed loops vs python-control's feedback + forced_response."""

from __future__ import annotations

import control
import numpy as np
import scipy.signal
from _timing import best_time, dgemm_peak_flops, interleaved_best, peak_memory

import servokit as sk
from servokit.models import HDD_BENCHMARK_TS, HDD_SAMPLED_DATA_TS
from servokit.simulate import _bank, simulate, simulate_metrics, stability

#: flops of one modal mode per fine step: x <- Phi x (4 multiply-adds), + Gnew u and
#: + Gold u_old (2 + 2 multiply-adds), y += q (1 add); a multiply-add counts 2 flops
FLOPS_PER_MODE_STEP = 17


def seek_input(n: int) -> np.ndarray:
    """A smooth acceleration pulse pair: moves the rigid body and stops (integral zero)."""
    k = np.arange(n)
    return 2e-6 * np.sin(2 * np.pi * k / n) * np.sin(np.pi * k / n) ** 2


def _open_loop_case(n_variants: int):
    Ts, S = HDD_BENCHMARK_TS, 40
    K = int(round(2e-3 / Ts))  # a 2 ms record on a Ts/40 grid
    u = seek_input(26)
    plants = sk.models.hdd_benchmark_variation_set().monte_carlo(n_variants, seed=2026)
    kw = dict(dt=Ts, n_samples=K, substeps=S, feedforward=u)
    ufine = np.zeros(K * S)
    ufine[: u.size * S] = np.repeat(u, S)
    return plants, kw, ufine, Ts / S


def open_loop(n_variants: int, n_baseline: int) -> dict:
    plants, kw, ufine, h = _open_loop_case(n_variants)
    steps = kw["n_samples"] * kw["substeps"]
    res = simulate(plants, **kw)
    t_sk = best_time(lambda: simulate(plants, **kw), 10)
    _, peak = peak_memory(lambda: simulate(plants, **kw))
    sub = plants[:n_baseline]
    worst = 0.0

    def pc_loop() -> None:
        nonlocal worst
        for i, p in enumerate(sub):
            y = control.forced_response(p.discretize(h), U=ufine).outputs
            worst = max(worst, float(np.max(np.abs(y - res.yc[i]))))

    def scipy_loop() -> None:
        for p in sub:
            d = p.discretize(h)
            scipy.signal.dlsim((d.A, d.B, d.C, d.D, h), ufine)

    t_pc = best_time(pc_loop, 2) * n_variants / n_baseline
    t_sp = best_time(scipy_loop, 2) * n_variants / n_baseline
    t_sk = min(t_sk, best_time(lambda: simulate(plants, **kw), 10))  # same load as baselines
    n_modes = float(np.mean([len(p.modes) for p in plants]))
    peak_flops = dgemm_peak_flops()
    bound_ns = FLOPS_PER_MODE_STEP * n_modes / peak_flops * 1e9
    ns = t_sk / (n_variants * steps) * 1e9
    return {
        "variants": n_variants,
        "fine_steps": steps,
        "servokit_s": t_sk,
        "python_control_s": t_pc,
        "scipy_dlsim_s": t_sp,
        "baseline_variants_run": n_baseline,
        "speedup_vs_python_control": t_pc / t_sk,
        "speedup_vs_scipy_dlsim": t_sp / t_sk,
        "ns_per_variant_step": ns,
        "flops_per_variant_step": FLOPS_PER_MODE_STEP * n_modes,
        "dgemm_peak_gflops": peak_flops / 1e9,
        "bound_ns_per_variant_step": bound_ns,
        "ratio_to_bound": ns / bound_ns,
        "peak_memory_mb": peak / 1e6,
        "max_abs_difference_track": worst,
    }


def many_variants(n_variants: int) -> dict:
    """Seek metrics of ``n_variants`` without keeping their trajectories.

    The time per variant-step is compared with the same work done as repeated
    1000-variant simulations, the two timed in turn (both runs are long, so load
    bursts on the shared machine hit them alike).
    """
    plants, kw, _, _ = _open_loop_case(n_variants)
    small = plants[:1000]
    reps = max(1, n_variants // len(small))
    steps = kw["n_samples"] * kw["substeps"]

    def metric(res):  # peak excursion and final position of each variant
        return np.c_[np.abs(res.yc).max(axis=1), res.yc[:, -1]]

    def thousands() -> None:
        for _ in range(reps):
            simulate(small, **kw)

    best = interleaved_best(
        {"many": lambda: simulate_metrics(plants, metric, **kw), "thousands": thousands}, 2
    )
    out, peak = peak_memory(lambda: simulate_metrics(plants, metric, **kw))
    ns = best["many"] / (n_variants * steps) * 1e9
    ns_1000 = best["thousands"] / (reps * len(small) * steps) * 1e9
    return {
        "variants": n_variants,
        "servokit_s": best["many"],
        "ns_per_variant_step": ns,
        "ns_per_variant_step_1000_variants": ns_1000,
        "ratio_to_1000_variant_figure": ns / ns_1000,
        "peak_memory_mb": peak / 1e6,
        "trajectories_would_need_mb": 8.0 * n_variants * steps / 1e6,
        "metrics_shape": list(out.shape),
    }


def _forget() -> None:
    """Drop the discretisations and eigenvalues kept for re-running a few plants."""
    _bank._reused_bank.cache_clear()
    stability.clear_radii_cache()


def closed_loop(n_variants: int, n_baseline: int) -> dict:
    """hdd-sampled-data with C(z) of eq. (4.69), 300 samples of a unit reference step."""
    Ts, K = HDD_SAMPLED_DATA_TS, 300
    C = sk.models.controller_eq_4_69()
    nominal = sk.models.hdd_sampled_data()
    rng = np.random.default_rng(7)
    plants = [
        nominal.replace(
            gain=nominal.gain * rng.uniform(0.8, 1.2),
            modes=tuple(m.__class__(m.freq_hz * rng.uniform(0.95, 1.05), m.damping, m.residue)
                        for m in nominal.modes),
        )
        for _ in range(n_variants)
    ]  # fmt: skip
    r = np.ones(K)
    kw = dict(dt=Ts, n_samples=K, substeps=1, controller=C, reference=r)

    def pc(ps) -> list[np.ndarray]:
        out = []
        for p in ps:
            cl = control.feedback(p.discretize(Ts) * C, 1)
            out.append(control.forced_response(cl, U=r).outputs)
        return out

    res = simulate(plants, **kw)
    ref = pc(plants[:n_baseline])
    diff = max(float(np.max(np.abs(a - b))) for a, b in zip(ref, res.yd, strict=False))
    t_sk = best_time(lambda: simulate(plants, **kw), 3)
    t_pc = best_time(lambda: pc(plants[:n_baseline]), 1) * n_variants / n_baseline
    one = plants[:1]
    # re-running one loop (its discretisation and eigenvalues reused, issue 24)
    t1_sk = best_time(lambda: simulate(one, **kw), 20)
    t1_pc = best_time(lambda: pc(one), 20)
    # the first call on a plant (nothing reused: discretisation and eigenvalues afresh)
    t1_cold = best_time(lambda: (_forget(), simulate(one, **kw)), 20)
    # the same loop with 4 sub-steps (output between the samples too; issue 24)
    kw4 = {**kw, "substeps": 4}
    t4_sk = best_time(lambda: simulate(one, **kw4), 20)
    return {
        "variants": n_variants,
        "samples": K,
        "servokit_s": t_sk,
        "python_control_s": t_pc,
        "baseline_variants_run": n_baseline,
        "speedup": t_pc / t_sk,
        "single_plant_servokit_s": t1_sk,
        "single_plant_python_control_s": t1_pc,
        "single_plant_speedup": t1_pc / t1_sk,
        "single_plant_first_call_servokit_s": t1_cold,
        "single_plant_first_call_speedup": t1_pc / t1_cold,
        "single_plant_4_substeps_servokit_s": t4_sk,
        "single_plant_4_substeps_speedup": t1_pc / t4_sk,
        "max_abs_difference": diff,
    }
