"""servokit.learn: seek data (6.7), labels, SVM judge, conventional rule, skops I/O."""

from __future__ import annotations

import control
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from servokit.errors import ServokitError
from servokit.learn import (
    SVM_TS,
    SeekResponse,
    SettlingJudge,
    conventional_judgement,
    evaluate_judgements,
    settled_index,
    simulate_seeks,
    training_seeks,
    training_set,
    validation_seeks,
)
from servokit.models import svm_head_plant


def test_seek_matches_python_control_and_ends_on_target():
    from servokit.feedforward import fsc_input

    (r,) = simulate_seeks([(50.0, 40)], horizon=200)
    u = fsc_input(svm_head_plant(), SVM_TS, 40, 50.0, model="rigid-body").u
    sd = svm_head_plant().discretize(SVM_TS)
    x0 = np.zeros(6)
    x0[0] = -50.0
    resp = control.forced_response(sd, U=np.r_[u, np.zeros(200)], X0=x0)
    np.testing.assert_allclose(r.output[:240], resp.outputs[:240], atol=1e-9)
    # FSC on the rigid body: position and velocity of the rigid body exactly on target
    assert abs(r.states[40, 0]) < 1e-9 and abs(r.states[40, 1]) < 1e-6


@settings(max_examples=10, deadline=None)
@given(st.floats(1.0, 1000.0), st.integers(20, 80))
def test_seek_is_linear_in_distance(distance, n):
    (a,), (b,) = simulate_seeks([(distance, n)], horizon=50), simulate_seeks([(1.0, n)], horizon=50)
    np.testing.assert_allclose(a.states, distance * b.states, rtol=1e-9, atol=1e-9 * distance)


def test_settled_index_and_labels():
    y = np.array([1.0, 0.01, 0.05, 0.0, 0.02, -0.01, 0.0])
    assert settled_index(y, 0.03) == 3
    with pytest.raises(ServokitError, match="horizon"):
        settled_index(np.array([0.0, 1.0]), 0.03)
    r = SeekResponse(1.0, 0, np.arange(7.0)[:, None] * np.ones((1, 2)), y)
    ts = training_set([r], bound=0.03, n_after=2)
    np.testing.assert_array_equal(ts.X[:, 0], [1, 3, 4, 5])  # in-bound samples up to N0 + 2
    np.testing.assert_array_equal(ts.labels, [1, 2, 2, 2])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-0.1, 0.1), min_size=1, max_size=40), st.integers(1, 6))
def test_conventional_rule_matches_brute_force(y, n):
    y = np.array(y)
    expect = -1
    for k in range(n - 1, len(y)):
        if np.all(np.abs(y[k - n + 1 : k + 1]) <= 0.03):
            expect = k
            break
    assert conventional_judgement(y, 0.03, n) == expect


def _toy_judge():
    rng = np.random.default_rng(0)
    X = rng.uniform(-1, 1, (400, 2))
    labels = np.where(np.hypot(X[:, 0], X[:, 1]) < 0.6, 2, 1)  # inside the circle: settled
    return SettlingJudge(C=100.0, coef0=1.0).fit(X, labels), X, labels


def test_judge_sign_convention_and_decision():
    judge, X, labels = _toy_judge()
    f = judge.decision_function(np.array([[0.0, 0.0], [0.95, 0.95]]))
    assert f[0] < 0 < f[1]  # settled (class 2) negative, as the book's -0.8 level implies
    assert np.mean((judge.decision_function(X) < 0) == (labels == 2)) > 0.97
    states = np.array([[0.9, 0.9], [0.5, 0.3], [0.1, 0.0], [0.0, 0.0]])
    output = np.array([0.0, 0.5, 0.0, 0.0])  # sample 1 outside the bound
    assert judge.judge(states, output) == 2
    assert judge.judge(states, output, start=3) == 3
    assert judge.judge(states, np.ones(4)) == -1


def test_judge_save_load_roundtrip_and_refusal(tmp_path):
    from fractions import Fraction

    import skops.io as sio
    from sklearn.linear_model import LogisticRegression

    judge, X, _ = _toy_judge()
    path = judge.save(tmp_path / "judge.skops")
    back = SettlingJudge.load(path)
    np.testing.assert_array_equal(back.decision_function(X), judge.decision_function(X))
    assert (back.C, back.coef0, back.bound) == (judge.C, judge.coef0, judge.bound)
    bad = tmp_path / "bad.skops"
    sio.dump({"pipeline": LogisticRegression(), "settings": {}}, bad)
    with pytest.raises(ServokitError, match="not a servokit settling-judge"):
        SettlingJudge.load(bad)
    sio.dump({"pipeline": Fraction(1, 3)}, bad)
    with pytest.raises(ServokitError, match="untrusted"):
        SettlingJudge.load(bad)
    with pytest.raises(ServokitError, match="does not exist"):
        SettlingJudge.load(tmp_path / "none.skops")
    with pytest.raises(ServokitError, match="not fitted"):
        SettlingJudge().decision_function(X)


def test_evaluate_counts_failures():
    judge, _, _ = _toy_judge()
    y = np.array([0.5, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0])  # N0 = 4
    far, near = np.array([0.9, 0.9]), np.zeros(2)
    states = np.array([far, near, far, far, far, near, near, near, near, near])
    r = SeekResponse(1.0, 0, states, y)
    conv, svm = evaluate_judgements([r], judge, levels=(0.0,), n_in_row=2)
    assert conv.delays.tolist() == [5 - 4]  # inside at 4 and 5
    assert svm.delays.tolist() == [1 - 4] and svm.failures == 1  # near state at sample 1


def test_evaluate_matches_judge_per_seek():
    # the batched decision values (one call for every seek and level) judge each seek
    # exactly as SettlingJudge.judge does, from sample 0 and from the end of the input
    data = training_set(simulate_seeks(training_seeks(4, 6)))
    judge = SettlingJudge(C=10.0, coef0=0.5).fit(data.X, data.labels)
    val = simulate_seeks(validation_seeks(15))
    for from_end in (False, True):
        stats = evaluate_judgements(val, judge, levels=(0.0, -0.8), from_input_end=from_end)
        for lvl, stat in zip((0.0, -0.8), stats[1:], strict=True):
            ref = [
                judge.judge(r.states, r.output, lvl, start=r.n_input if from_end else 0)
                for r in val
            ]
            n0 = [r.n0(judge.bound) for r in val]
            expect = [j - n for j, n in zip(ref, n0, strict=True) if j >= 0]
            assert stat.delays.tolist() == expect


def test_svm_scores_stop_early_are_a_prefix_of_the_full_scores():
    # scoring stops at the first f < stop_below of each seek (rounds of 3, 6, 12 ...
    # samples): the scores are bit-identical to one call on every in-bound sample, and
    # the first f < level for every level >= stop_below lies inside the prefix
    from servokit.learn.evaluate import _svm_scores

    data = training_set(simulate_seeks(training_seeks(4, 6)))
    judge = SettlingJudge(C=10.0, coef0=0.5).fit(data.X, data.labels)
    val = simulate_seeks(validation_seeks(12))
    start = [0] * len(val)
    full = _svm_scores(val, judge, start)
    part = _svm_scores(val, judge, start, stop_below=-0.8, chunk=3)
    assert sum(len(f) for _, f in part) < sum(len(f) for _, f in full) / 10
    for (i_full, f_full), (i, f) in zip(full, part, strict=True):
        assert np.array_equal(i, i_full[: len(i)]) and np.array_equal(f, f_full[: len(f)])
        for lvl in (0.0, -0.8):
            assert np.array_equal(i[f < lvl][:1], i_full[f_full < lvl][:1])


def test_grids():
    assert len(training_seeks()) == 180
    seeks = validation_seeks()
    d = np.array([s[0] for s in seeks])
    n = np.array([s[1] for s in seeks])
    assert len(seeks) == 100 and d.min() >= 5 and d.max() <= 1000
    assert n.min() >= 20 and n.max() <= 135
    # the seeded draw, recomputed independently: uniform distances, then integer lengths
    rng = np.random.default_rng(3)
    dist, lengths = rng.uniform(5.0, 1000.0, 100), rng.integers(20, 136, 100)
    assert validation_seeks(seed=3) == [
        (float(a), int(b)) for a, b in zip(dist, lengths, strict=True)
    ]
    assert validation_seeks(seed=3) != validation_seeks(seed=4)  # the seed is used


@pytest.mark.slow
def test_svm_beats_conventional_rule():
    data = training_set(simulate_seeks(training_seeks()))
    judge = SettlingJudge(C=10.0, coef0=0.5).fit(data.X, data.labels)
    conv, svm0, svm8 = evaluate_judgements(simulate_seeks(validation_seeks()), judge)
    assert svm0.failures <= conv.failures and svm0.mean_delay < conv.mean_delay
    assert svm8.failures < svm0.failures


def test_svm_beats_conventional_rule_reduced():
    # the slow test's outcome on a 5 x 9 training grid and 40 validation seeks
    data = training_set(simulate_seeks(training_seeks(5, 9)))
    judge = SettlingJudge(C=10.0, coef0=0.5).fit(data.X, data.labels)
    conv, svm0, svm8 = evaluate_judgements(simulate_seeks(validation_seeks(40)), judge)
    assert conv.failures > 0 and conv.mean_delay > 0
    assert svm0.failures <= conv.failures and svm0.mean_delay < conv.mean_delay
    assert svm8.failures < svm0.failures


def test_class1_weight_makes_the_judge_more_cautious(tmp_path):
    rng = np.random.default_rng(1)
    X = rng.uniform(-1, 1, (400, 2))
    labels = np.where(np.hypot(X[:, 0], X[:, 1]) < 0.6, 2, 1)
    plain = SettlingJudge(C=1.0, coef0=1.0).fit(X, labels)
    cautious = SettlingJudge(C=1.0, coef0=1.0, class1_weight=10.0).fit(X, labels)
    settled_plain = np.sum(plain.decision_function(X) < 0)
    settled_cautious = np.sum(cautious.decision_function(X) < 0)
    assert settled_cautious <= settled_plain
    back = SettlingJudge.load(cautious.save(tmp_path / "c.skops"))
    assert back.class1_weight == 10.0
