"""Mutated specs, dicts and arrays: every outcome is a result or a lincal.Error (or the
TypeError of a wrong argument type), never a crash or another exception."""

from __future__ import annotations

import copy
import random

import numpy as np
import pytest

import lincal
from conftest import MODELS, SPECS
from test_errors import TWO_LINK, TWO_LINK_DICT

ODD_VALUES = [None, True, 0, -1, 2**70, 1e308, -1e-320, float("nan"), float("inf"), "", "pi/0",
              "a1", "((((1))))", "x" * 300, [], {}, [1, [2, [3]]], {"nominal": "pi"}, (1, 2),
              np.float64(0.5), np.int32(3), np.array([1.0, 2.0]), b"bytes", 1 + 2j]


def paths(obj, prefix=()):
    """Every (container, key) inside a nested dict/list."""
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield obj, k
            yield from paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield obj, i
            yield from paths(v, prefix + (i,))


def test_mutated_dicts():
    rng = random.Random(2024)
    outcomes = {"ok": 0, "error": 0}
    for _ in range(300):
        d = copy.deepcopy(TWO_LINK_DICT)
        for _ in range(rng.randint(1, 3)):
            places = list(paths(d))
            container, key = rng.choice(places)
            action = rng.random()
            if action < 0.6:
                container[key] = copy.deepcopy(rng.choice(ODD_VALUES))
            elif action < 0.8 and isinstance(container, dict):
                container.pop(key)
            elif isinstance(container, dict):
                container[rng.choice(["extra", "a1", "home", "b", "1"])] = rng.choice(ODD_VALUES)
        try:
            spec = lincal.Spec.from_dict(d)
            spec.basis()
            outcomes["ok"] += 1
        except lincal.Error as e:
            assert isinstance(e, ValueError), e
            assert str(e)
            outcomes["error"] += 1
    assert outcomes["error"] > 100


def test_mutated_yaml_text():
    rng = random.Random(7)
    texts = [TWO_LINK] + [p.read_text() for p in sorted(SPECS.glob("*.yaml"))[:4]]
    alphabet = "{}[]:,-'\"#&*!|>%@` \n\t0123456789.eE+-piabxyz"
    for _ in range(300):
        t = list(rng.choice(texts))
        for _ in range(rng.randint(1, 4)):
            i = rng.randrange(len(t))
            op = rng.random()
            if op < 0.4:
                t[i] = rng.choice(alphabet)
            elif op < 0.7:
                del t[i]
            else:
                t.insert(i, rng.choice(alphabet))
        try:
            lincal.Spec.from_str("".join(t), max_terms=20_000)
        except lincal.Error as e:
            assert str(e)


def test_random_arrays():
    spec = lincal.Spec.from_yaml(MODELS / "adept_one.yaml")
    good = lincal.simulate(spec, 40, seed=1).q
    rng = np.random.default_rng(5)
    shapes = [(0, 2), (1, 2), (5, 2), (40, 2), (40, 1), (40, 3), (2,), (2, 2, 2), ()]
    for _ in range(200):
        choice = rng.integers(5)
        if choice == 0:
            q = rng.normal(size=shapes[rng.integers(len(shapes))])
        elif choice == 1:
            q = good.copy()
            q.flat[rng.integers(q.size)] = rng.choice([np.nan, np.inf, 1e12, -0.0, 1e-300])
        elif choice == 2:
            q = good.astype(rng.choice([np.float32, np.int64, np.uint8, np.float16]))
        elif choice == 3:
            q = good[:: rng.integers(1, 4)]
        else:
            q = np.full((40, 2), rng.normal())
        kwargs = {}
        if rng.random() < 0.2:
            kwargs["lines"] = rng.integers(-2, 50, size=len(q) if q.ndim else 1)
        try:
            lincal.calibrate(spec, q, refine=bool(rng.integers(2)), **kwargs)
        except lincal.Error as e:
            assert str(e)


@pytest.mark.parametrize("bad", [None, "q", 3.0, object(), [[None, 1.0]], {"a": 1}])
def test_not_arrays(bad):
    spec = lincal.Spec.from_str(TWO_LINK)
    with pytest.raises(lincal.DataError):
        lincal.calibrate(spec, bad)
