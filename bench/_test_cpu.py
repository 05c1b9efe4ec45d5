"""A pytest plugin for bench/bench_tests.py: each test's CPU seconds (this process's and its
waited-for children's) and wall seconds, written as tab-separated lines to the file named by
``MJLINK_TEST_CPU`` at the end of the session."""

from __future__ import annotations

import os
import resource
import time
from collections.abc import Iterator
from typing import Any

import pytest

_rows: list[tuple[float, float, str]] = []


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item: pytest.Item, nextitem: Any) -> Iterator[None]:
    cpu, wall = _cpu(), time.perf_counter()
    yield
    _rows.append((_cpu() - cpu, time.perf_counter() - wall, item.nodeid))


def pytest_sessionfinish(session: pytest.Session) -> None:
    path = os.environ.get("MJLINK_TEST_CPU")
    if path:
        with open(path, "w") as f:
            f.writelines(f"{c:.3f}\t{w:.3f}\t{n}\n" for c, w, n in _rows)
