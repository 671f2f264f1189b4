"""Fixtures of the OpenGL tests: one real EGL context (Mesa llvmpipe headless, or a GPU)."""

from __future__ import annotations

from collections.abc import Iterator

import moderngl
import pytest


@pytest.fixture(scope="module")
def gl_ctx() -> Iterator[moderngl.Context]:
    """A standalone EGL context, current in the main thread where the tests run.

    Module-scoped so that no context outlives the GL tests: a process holding
    one must not fork (see STACK_NOTES), and other tests may start processes.
    """
    ctx = moderngl.create_standalone_context(backend="egl")
    yield ctx
    ctx.release()
