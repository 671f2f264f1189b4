"""The benchmarks, one tool: ``python -m bench --list``, ``python -m bench NAME [options]``.

Each ``bench_NAME.py`` holds one benchmark: a ``main(argv)`` that parses its options with
:func:`bench.options.parser` and its ``TARGETS`` (:class:`bench.targets.Target`) declared
beside it; :mod:`bench.tool` names them all and prints every target met or missed.
"""
