"""Attack bench (issue 42): every attack of the test suite on a real run, repeated.

Run: ``OMP_NUM_THREADS=1 python -m bench attacks [--runs 3] [-k EXPR]``

Each attack is a test of the suite (a real stack and a real attacker process: a thief
without capabilities, an intruder on the run's bus), run ``--runs`` times, each time in a
fresh ``pytest`` process, so that one run's state never helps the next:

- keys: the start-up race with a debugger attached, a key request of the thief's own, every
  route at start, at a restart and while the run lasts (``test_key_theft.py``); keys found
  must be 0, and a traced or impersonated service must stop the run with exit 2;
- forged, replayed and malformed messages, forged poses beside ``aamtrack record`` and
  ``echo``, a forged launcher, a rogue detector holding every query, frames replayed to a
  restarted fitter (``test_hostile.py``): no forged message in a result, a recording or
  its export; 0 frames lost to the detector; a run that lost frames exits 1 with every
  lost frame counted.

Target: every attack passes every run. The table gives each attack's passes and the
seconds of its slowest run; the last failure's reason is printed under it.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

from aamcore.config import REPO_ROOT
from bench import options
from bench.targets import Target

ATTACKS = {
    "traced before hardening": "tests/services/stack/test_key_theft.py::"
    "test_a_service_traced_before_it_hardens_is_refused_its_key_and_the_run_stops",
    "forged key request": "tests/services/stack/test_key_theft.py::"
    "test_a_key_request_of_another_process_is_refused_and_the_run_stops",
    "every route, restart race": "tests/services/stack/test_key_theft.py::"
    "test_no_route_gives_a_key_at_start_at_a_restart_or_while_the_run_lasts",
    "forged messages": "tests/services/stack/test_hostile.py::"
    "test_every_attack_without_the_keys_is_ignored_counted_and_the_run_exits_0",
    "readers, rogue detector": "tests/services/stack/test_hostile.py::"
    "test_readers_keep_only_the_run_s_messages_and_the_detector_s_answer_is_the_detector_s",
    "replay after restart": "tests/services/stack/test_hostile.py::"
    "test_frames_a_dead_fitter_missed_stay_unanswered_whatever_is_replayed",
}
"""Attack name -> the test that carries it out and checks it."""
EVERY_RUN = Target("every attack passes every run", "==", True)
TARGETS = (EVERY_RUN,)


def attack(node: str) -> tuple[bool, float, str]:
    """One run of one attack: whether it passed, its seconds, and why not."""
    env = os.environ | {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO_ROOT)}
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider",
                           node], cwd=REPO_ROOT, env=env, capture_output=True, text=True)
    took = time.monotonic() - started
    lines = [x for x in done.stdout.splitlines() if x.startswith(("E ", "FAILED", "ERROR"))]
    return done.returncode == 0, took, (lines[0] if lines else done.stdout[-300:]).strip()


def main(argv: list[str] | None = None) -> int:
    parser = options.parser(__doc__, __name__)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("-k", default="", help="only the attacks whose name holds this")
    args = options.parse(parser, argv)
    load = os.getloadavg()[0]
    print(f"load average {load:.1f} on {os.cpu_count()} cores; {args.runs} runs per attack")
    print(f"{'attack':<28}{'passed':>10}{'slowest s':>11}")
    ok = True
    for name, node in ATTACKS.items():
        if args.k not in name:
            continue
        results = [attack(node) for _ in range(args.runs)]
        passed = sum(good for good, _, _ in results)
        ok &= passed == args.runs
        print(f"{name:<28}{passed:>5} of {args.runs}{max(t for _, t, _ in results):>11.0f}",
              flush=True)
        for good, _, why in results:
            if not good:
                print(f"    {why[:200]}")
    return 0 if EVERY_RUN.check(ok) else 1

