"""Progress bars for the long steps (training, detection over a dataset), on a terminal only.

Bars go to standard error when it is a terminal (or ``AAMTRACK_PROGRESS=1``),
so that logs and CI output stay free of them.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")


def enabled() -> bool:
    """Whether progress bars are shown."""
    flag = os.environ.get("AAMTRACK_PROGRESS", "")
    if flag:
        return flag not in ("0", "false", "no")
    return sys.stderr.isatty()


def progress(items: Iterable[T], desc: str, total: int | None = None) -> Iterator[T]:
    """``items`` with a bar labelled ``desc`` while they are consumed (when :func:`enabled`)."""
    if not enabled():
        yield from items
        return
    from tqdm import tqdm

    yield from tqdm(items, desc=desc, total=total, unit="img", file=sys.stderr, leave=False)


def bar(desc: str) -> Callable[[Iterable[T]], Iterator[T]]:
    """A wrapper that shows a bar labelled ``desc``: the ``progress`` argument of the trainers."""
    return lambda items: progress(items, desc)


def note(text: str) -> None:
    """A line for the user about a long step (standard error)."""
    print(f"aamtrack: {text}", file=sys.stderr, flush=True)
