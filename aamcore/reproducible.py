"""Training that gives the same model on every run of the same machine: one BLAS thread.

OpenBLAS splits some products over its threads, and their sums then depend on how many
threads there are: the small test model trained with one and with two BLAS threads differed
in its combined modes (by 1e-14) and its descent stages (by 1e-7), which tracking then
amplified. One thread is also the faster choice on two cores, where training's own worker
threads keep both busy (the small model: 51 s against 96 s).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

from threadpoolctl import threadpool_limits

P = ParamSpec("P")
R = TypeVar("R")


def one_blas_thread(train: Callable[P, R]) -> Callable[P, R]:
    """``train`` run with one BLAS thread, whatever the caller's settings."""

    @functools.wraps(train)
    def wrapped(*args: P.args, **kwargs: P.kwargs) -> R:
        with threadpool_limits(limits=1, user_api="blas"):
            return train(*args, **kwargs)

    return wrapped
