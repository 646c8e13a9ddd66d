"""The HDD benchmark's parameter variations (book Table 2.3) as a variation set and as
its fixed 18 plants.

Kept out of :mod:`servokit.models.catalogue` so that the catalogue does not depend on
the variation-file reader (which resolves a file's ``plant`` through the catalogue).
"""

from __future__ import annotations

from servokit.models.catalogue import hdd_benchmark
from servokit.models.modal import ModalPlant
from servokit.models.variation_file import HDD_BENCHMARK_VARIATIONS, read_variations
from servokit.models.variations import VariationSet

__all__ = ["hdd_benchmark_variants", "hdd_benchmark_variation_set"]


def hdd_benchmark_variation_set() -> VariationSet:
    """Parameter ranges of the HDD benchmark (book Table 2.3), read from the shipped file.

    Ranges (index: meaning): 0 f2 -2/+1 %, 1 f3 -5/+2.5 %, 2 f4..7 -2/+0.5 %,
    3 A2,4 -200/+0 %, 4 A3 -0/+20 %, 5 zeta5..7 -50/+100 %.  Gain range +-10 %
    (§2.4.1 "the change in loop gain of +-10 % is also assumed"; §2.4.1 also mentions
    +-5 % for the benchmark; feedforward-only studies ignore the gain).  The box is the
    variation file :data:`~servokit.models.variation_file.HDD_BENCHMARK_VARIATIONS`
    (the modes of one table row move together).

    Returns
    -------
    VariationSet
        The nominal :func:`hdd_benchmark` with the six relative ranges above (mode numbers
        counted from the rigid body, 1) and the loop-gain range ``(-0.1, 0.1)``.
    """
    return read_variations(HDD_BENCHMARK_VARIATIONS, hdd_benchmark())


def hdd_benchmark_variants() -> list[ModalPlant]:
    """The fixed set of 18 HDD benchmark plants (book Table 2.3), nominal first.

    Every combination of 3 frequency rows (nominal; all up; all down), 3 damping rows
    (nominal; -50 %; +100 % on zeta5..7) and 2 residue rows (nominal; A2 -200 %,
    A3 +20 %, A4 -200 %).

    Returns
    -------
    list of ModalPlant
        18 plants (gain nominal), the nominal benchmark first, named
        ``"hdd-benchmark #0"`` .. ``"#17"``.
    """
    vs = hdd_benchmark_variation_set()
    freq_row = [((0, "high"), (1, "high"), (2, "high")), ((0, "low"), (1, "low"), (2, "low"))]
    damp_row = [((5, "low"),), ((5, "high"),)]
    res_row = [((3, "low"), (4, "high"))]
    plants = vs.rows([freq_row, damp_row, res_row])
    return [p.replace(name=f"hdd-benchmark #{i}") for i, p in enumerate(plants)]
