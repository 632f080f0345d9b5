"""--auto's threads: results in order, errors raised, at most MAX_WORKERS threads."""

from __future__ import annotations

import threading
import time

import pytest

from sonarproc.auto.threads import MAX_WORKERS, available_workers, in_threads


def test_results_come_back_in_the_items_order_whatever_finishes_first() -> None:
    def slow_first(i: int) -> tuple[int, str]:
        time.sleep(0.02 * (5 - i))  # the first item finishes last
        return i, threading.current_thread().name

    out = in_threads(slow_first, range(5), workers=3)
    assert [i for i, _ in out] == [0, 1, 2, 3, 4]
    assert len({name for _, name in out}) > 1  # it did run on several threads


def test_one_worker_runs_in_the_calling_thread() -> None:
    here = threading.current_thread().name
    assert in_threads(lambda _: threading.current_thread().name, range(3), workers=1) == [here] * 3


def test_an_error_in_a_piece_is_raised_to_the_caller() -> None:
    def piece(i: int) -> int:
        if i == 2:
            raise ValueError("piece 2 failed")
        return i

    with pytest.raises(ValueError, match="piece 2 failed"):
        in_threads(piece, range(4), workers=2)


def test_available_workers_is_between_one_and_the_cap() -> None:
    assert 1 <= available_workers() <= MAX_WORKERS
