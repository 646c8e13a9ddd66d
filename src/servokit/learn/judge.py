"""The SVM settling judge of book §6.2 (eqs. 6.1-6.6), built on scikit-learn.

A ``Pipeline(StandardScaler, SVC(kernel="poly", degree=4))`` separates class 1 (the
output leaves the bound again) from class 2 (it never does).  Scaling matters: the modal
positions are in tracks, their rates in tracks/s (five orders of magnitude apart).

Sign convention (the book's ``<w, x> + b = -0.8`` "safe side", Fig. 6.12): servokit's
:meth:`SettlingJudge.decision_function` is ``f(x) = <w, phi(x)> + b`` with class 1
(not settled) on the positive side and class 2 (settled) on the negative side, i.e. minus
scikit-learn's ``decision_function`` for classes ``[1, 2]``.  Settling is declared at the
first in-bound sample with ``f(x) < level``: ``level = 0`` is the separating surface,
``level = -0.8`` demands a margin of 0.8 into class 2 and so judges later but safer.

The book gives neither the SVM's ``C`` nor the polynomial offset; :meth:`SettlingJudge.tune`
chooses them by stratified cross-validation (balanced accuracy) over a small grid.

Persistence uses ``skops`` (no bare pickle): :meth:`save` writes the pipeline and the
settings, :meth:`load` refuses any type that is not on a short list of scikit-learn and
numpy types.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from servokit.errors import ServokitValueError, check_finite, check_positive

__all__ = ["SettlingJudge", "TRUSTED_TYPES"]

#: Types a saved judge may contain (anything else is refused on load).
TRUSTED_TYPES = (
    "sklearn.pipeline.Pipeline",
    "sklearn.preprocessing._data.StandardScaler",
    "sklearn.svm._classes.SVC",
    "numpy.dtype",
    "numpy.ndarray",
    "numpy.float64",
    "numpy.int64",
    "numpy.int32",
    "builtins.float",
    "builtins.int",
    "builtins.str",
)


class SettlingJudge:
    """Decide from the plant state whether a seek has settled (book §6.2.3).

    Parameters
    ----------
    bound : float
        Allowable tracking-error bound [track] (0.03 in the book).
    degree : int
        Polynomial kernel order (4 in the book).
    C : float
        SVM soft-margin weight (the book gives none; see :meth:`tune`).
    coef0 : float
        Polynomial kernel offset ``(gamma <x, x'> + coef0)^degree``.
    level : float
        Decision level: settled when ``f(x) < level`` (0 or the book's -0.8).
    class1_weight : float
        Weight of class-1 errors in the SVM (scikit-learn ``class_weight``); above 1 it
        penalises judging "settled" too early, an alternative to a negative ``level``.

    Attributes
    ----------
    pipeline_ : sklearn.pipeline.Pipeline
        The fitted scaler + SVC.
    cv_scores_ : dict
        Balanced accuracy per (C, coef0) after :meth:`tune`.
    """

    def __init__(
        self,
        *,
        bound: float = 0.03,
        degree: int = 4,
        C: float = 10.0,
        coef0: float = 1.0,
        level: float = 0.0,
        class1_weight: float = 1.0,
    ) -> None:
        self.bound = check_positive("bound", bound, "track")
        self.degree = int(degree)
        self.C = check_positive("C", C)
        self.coef0 = float(check_finite("coef0", coef0))
        self.level = float(check_finite("level", level))
        self.class1_weight = check_positive("class1_weight", class1_weight)
        self.cv_scores_: dict[tuple[float, float], float] = {}

    # ------------------------------------------------------------ training
    def _pipeline(self, C: float, coef0: float):
        from sklearn.pipeline import Pipeline
        from sklearn.preprocessing import StandardScaler
        from sklearn.svm import SVC

        svc = SVC(
            kernel="poly",
            degree=self.degree,
            C=C,
            coef0=coef0,
            gamma="scale",
            class_weight={1: self.class1_weight, 2: 1.0},
        )
        return Pipeline([("scale", StandardScaler()), ("svc", svc)])

    @staticmethod
    def _check_data(X: np.ndarray, labels: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        X = check_finite("X", X)
        y = np.asarray(labels)
        if X.ndim != 2 or len(X) != len(y):
            raise ServokitValueError("X must be (n_samples, n_states) with one label per row")
        if set(np.unique(y)) != {1, 2}:
            raise ServokitValueError("labels must contain both classes 1 and 2")
        return X, y

    def fit(self, X: np.ndarray, labels: np.ndarray) -> SettlingJudge:
        """Fit the pipeline on states ``X`` with labels 1 (leaves again) / 2 (stays)."""
        X, y = self._check_data(X, labels)
        self.pipeline_ = self._pipeline(self.C, self.coef0).fit(X, y)
        return self

    def tune(
        self,
        X: np.ndarray,
        labels: np.ndarray,
        *,
        C_grid: Sequence[float] = (1.0, 10.0, 100.0),
        coef0_grid: Sequence[float] = (0.5, 1.0, 2.0),
        folds: int = 3,
        seed: int = 0,
    ) -> SettlingJudge:
        """Choose ``C`` and ``coef0`` by stratified k-fold CV, then fit on all data."""
        from sklearn.model_selection import StratifiedKFold, cross_val_score

        X, y = self._check_data(X, labels)
        cv = StratifiedKFold(n_splits=folds, shuffle=True, random_state=seed)
        for c in C_grid:
            for r in coef0_grid:
                pipe = self._pipeline(float(c), float(r))
                score = cross_val_score(pipe, X, y, cv=cv, scoring="balanced_accuracy")
                self.cv_scores_[(float(c), float(r))] = float(np.mean(score))
        self.C, self.coef0 = max(self.cv_scores_, key=self.cv_scores_.__getitem__)
        return self.fit(X, y)

    # ------------------------------------------------------------ judging
    def _fitted(self):
        if not hasattr(self, "pipeline_"):
            raise ServokitValueError("the judge is not fitted; call fit() or load() first")
        return self.pipeline_

    def decision_function(self, X: np.ndarray) -> np.ndarray:
        """``f(x)``: positive for class 1 (not settled), negative for class 2 (settled)."""
        X = check_finite("X", np.atleast_2d(X))
        return -self._fitted().decision_function(X)

    def judge(
        self,
        states: np.ndarray,
        output: np.ndarray,
        level: float | None = None,
        *,
        start: int = 0,
    ) -> int:
        """First sample from ``start`` with ``|y| <= bound`` and ``f(x) < level``; -1 if none.

        Parameters
        ----------
        states : ndarray (n_samples, n_states)
            Recorded plant states (target at 0).
        output : ndarray (n_samples,)
            Recorded output [track].
        level : float, optional
            Overrides :attr:`level`.
        start : int
            First sample to judge (the end of the feedforward input, see
            :func:`servokit.learn.training_set`).
        """
        lvl = self.level if level is None else float(level)
        inside = np.flatnonzero(np.abs(np.asarray(output)) <= self.bound)
        inside = inside[inside >= start]
        if inside.size == 0:
            return -1
        hit = inside[self.decision_function(np.asarray(states)[inside]) < lvl]
        return int(hit[0]) if hit.size else -1

    # ------------------------------------------------------------ persistence
    def save(self, path: str | Path) -> Path:
        """Write the fitted judge with ``skops`` (``.skops`` file)."""
        import skops.io as sio

        settings = {
            "bound": self.bound,
            "degree": self.degree,
            "C": self.C,
            "coef0": self.coef0,
            "level": self.level,
            "class1_weight": self.class1_weight,
        }
        sio.dump({"pipeline": self._fitted(), "settings": settings}, Path(path))
        return Path(path)

    @staticmethod
    def _check_loaded(data: object, path: Path) -> None:
        from sklearn.pipeline import Pipeline
        from sklearn.svm import SVC

        keys = ("bound", "degree", "C", "coef0", "level")
        ok = (
            isinstance(data, dict)
            and isinstance(data.get("pipeline"), Pipeline)
            and isinstance(data["pipeline"][-1], SVC)
            and isinstance(data.get("settings"), dict)
            and all(k in data["settings"] for k in keys)
        )
        if not ok:
            raise ServokitValueError(f"{path} is not a servokit settling-judge file")

    @classmethod
    def load(cls, path: str | Path) -> SettlingJudge:
        """Read a judge written by :meth:`save`, refusing untrusted types."""
        import skops.io as sio

        p = Path(path)
        if not p.is_file():
            raise ServokitValueError(f"judge file {p} does not exist; train one first")
        try:
            untrusted = sio.get_untrusted_types(file=p)
        except Exception as exc:  # a corrupt or foreign file: one clear message
            raise ServokitValueError(f"{p} is not a skops judge file ({exc})") from None
        unknown = [t for t in untrusted if t not in TRUSTED_TYPES]
        if unknown:
            raise ServokitValueError(f"{p} holds untrusted types {unknown}; refusing to load")
        data = sio.load(p, trusted=list(untrusted))
        cls._check_loaded(data, p)
        judge = cls(
            **{k: data["settings"][k] for k in ("bound", "C", "coef0", "level")},
            degree=int(data["settings"]["degree"]),
            class1_weight=float(data["settings"].get("class1_weight", 1.0)),
        )
        judge.pipeline_ = data["pipeline"]
        return judge
