"""Data-driven settling judgement (book §6.2): SVM judge, seek data, validation."""

from servokit.learn.evaluate import (
    JudgementStats,
    conventional_judgement,
    evaluate_judgements,
    judgement_plot,
)
from servokit.learn.judge import TRUSTED_TYPES, SettlingJudge
from servokit.learn.seeks import (
    SETTLE_BOUND,
    SVM_TS,
    SeekResponse,
    TrainingSet,
    iter_seeks,
    seek_grid,
    settled_index,
    simulate_seeks,
    training_seeks,
    training_set,
    validation_seeks,
)

__all__ = [
    "SETTLE_BOUND",
    "SVM_TS",
    "TRUSTED_TYPES",
    "JudgementStats",
    "SeekResponse",
    "SettlingJudge",
    "TrainingSet",
    "conventional_judgement",
    "evaluate_judgements",
    "iter_seeks",
    "judgement_plot",
    "seek_grid",
    "settled_index",
    "simulate_seeks",
    "training_seeks",
    "training_set",
    "validation_seeks",
]
