"""Every constant of ``--auto``'s decision is named, has a reason and is in the record."""

from __future__ import annotations

import importlib

from sonarproc.auto.constants import CONSTANTS, constants_record


def test_each_constant_is_its_module_s_own_value_with_a_reason() -> None:
    names = [c.name for c in CONSTANTS]
    assert len(names) == len(set(names))
    for c in CONSTANTS:
        value = getattr(importlib.import_module(c.module), c.name)
        expected = tuple(float(v) for v in value) if isinstance(value, tuple) else value
        assert c.value == expected, c.name
        assert c.unit and len(c.reason) > 20, c.name


def test_the_record_lists_them_by_name() -> None:
    record = constants_record()
    assert list(record) == [c.name for c in CONSTANTS]
    assert record["TRIM"] == 0.75 and record["ROUNDS_M"] == (0.08, 0.03)
