"""``aamtrack run`` offers the Rerun outputs as users expect them: ``--rrd``/``--save``,
``--serve PORT`` (serving after the end of stream until Ctrl-C) and ``--connect [URL]``
(a running viewer, checked before anything starts)."""

from __future__ import annotations

import argparse

import pytest

from services.bus.args import service_argv
from services.bus.connection import BusOptions
from services.bus.options import OptionError
from services.rerun_logger.options import RerunOptions
from services.rerun_logger.viewer import DEFAULT_URL
from services.stack import preflight
from services.stack.launcher import serve_until_stopped
from services.stack.options import add_run_options, parse_run_args
from tests.services.rerun_logger.conftest import free_port

VIDEO = ["--video", "some.mp4"]


def test_connect_without_a_value_streams_to_the_default_viewer():
    opts = parse_run_args([*VIDEO, "--connect"])
    assert opts.services["rerun"] == RerunOptions(viewer=DEFAULT_URL)
    assert DEFAULT_URL == "rerun+http://127.0.0.1:9876/proxy"
    # The service gets it under its own flag: its --connect is its Zenoh endpoint.
    argv = service_argv(BusOptions("cam0", connect=("tcp/127.0.0.1:7447",)),
                        opts.services["rerun"])
    assert argv[:2] == ["--viewer", DEFAULT_URL] and "tcp/127.0.0.1:7447" in argv


def test_connect_takes_a_url_or_a_port_and_save_is_an_alias_of_rrd():
    opts = parse_run_args([*VIDEO, "--connect", "rerun+http://10.0.0.2:9000/proxy",
                           "--save", "out.rrd", "--serve", "9877"])
    assert opts.services["rerun"] == RerunOptions(
        rrd="out.rrd", serve=9877, viewer="rerun+http://10.0.0.2:9000/proxy")
    assert parse_run_args([*VIDEO, "--connect", "9000"]).services["rerun"].viewer == "9000"
    assert parse_run_args([*VIDEO, "--save", "a.rrd"]).services["rerun"] == RerunOptions(
        rrd="a.rrd")
    assert parse_run_args([*VIDEO, "--rrd", "a.rrd"]).services["rerun"] == RerunOptions(
        rrd="a.rrd")
    assert "rerun" not in parse_run_args(VIDEO).services


def test_the_run_help_shows_the_rerun_flags_as_users_know_them():
    parser = argparse.ArgumentParser(prog="aamtrack run")
    add_run_options(parser)
    text = " ".join(parser.format_help().split())
    assert "--rrd PATH, --save PATH" in text
    assert "--connect [URL]" in text and f"(without a value: {DEFAULT_URL})" in text
    assert "--viewer" not in text


def test_a_malformed_viewer_url_is_named_by_the_flag_it_was_given_with():
    with pytest.raises(OptionError, match=r"^--connect 'http://x:1/proxy': expected rerun\+http"):
        parse_run_args([*VIDEO, "--connect", "http://x:1/proxy"])


def test_the_service_arguments_of_a_run_with_a_viewer_pass_the_services_own_parser():
    opts = parse_run_args([*VIDEO, "--connect", "--save", "x.rrd"])
    preflight.check_service_args(opts, BusOptions("cam0", connect=("tcp/127.0.0.1:7447",)))


def test_preflight_finds_a_viewer_that_is_not_running(rerun_server):
    viewer = rerun_server()
    preflight.check_viewer(parse_run_args([*VIDEO, "--connect", viewer.url]))
    preflight.check_viewer(parse_run_args(VIDEO))  # no viewer asked for: nothing to check
    port = free_port()
    with pytest.raises(preflight.PreflightError) as err:
        preflight.check_viewer(parse_run_args([*VIDEO, "--connect", str(port)]))
    assert str(err.value).startswith(
        f"--connect: no Rerun viewer at rerun+http://127.0.0.1:{port}/proxy (connection refused)")


def test_aamtrack_run_connecting_to_no_viewer_exits_2_with_one_line(run_cli, single_face):
    port = free_port()
    done = run_cli("run", "--video", str(single_face), "--connect",
                   f"rerun+http://127.0.0.1:{port}/proxy", timeout=120)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert done.stderr.strip().splitlines() == [
        f"aamtrack run: error: --connect: no Rerun viewer at rerun+http://127.0.0.1:{port}/proxy"
        f" (connection refused): start one with `rerun --port {port}`, or give the URL of one "
        "that runs"]


class _FakeService:
    """The launcher's session: ``wait`` answers True (stopped) from the ``stop_at``-th call."""

    def __init__(self, stop_at: int | None) -> None:
        self.calls = 0
        self.stop_at = stop_at

    def wait(self, seconds: float) -> bool:
        self.calls += 1
        return self.stop_at is not None and self.calls >= self.stop_at


class _FakeSupervisor:
    """The rerun service exits with ``code`` after ``exit_after`` checks (never if None)."""

    def __init__(self, exit_after: int | None = None, code: int = 0) -> None:
        self.checks = 0
        self.exit_after = exit_after
        self.code = code

    def check(self) -> None:
        self.checks += 1

    def exitcode(self, name: str) -> int | None:
        assert name == "rerun"
        done = self.exit_after is not None and self.checks >= self.exit_after
        return self.code if done else None

    def failed(self) -> list[str]:
        return ["rerun"] if self.exitcode("rerun") not in (None, 0) else []


def test_the_launcher_waits_for_ctrl_c_while_the_recording_is_served(capsys):
    svc, sup = _FakeService(stop_at=5), _FakeSupervisor()
    assert serve_until_stopped(svc, sup, 9877) == "done"  # type: ignore[arg-type]
    assert svc.calls == 5 and sup.checks == 4  # it watched the services until stopped
    out = capsys.readouterr().out
    assert "the recording is served at rerun+http://127.0.0.1:9877/proxy" in out
    assert "Ctrl-C to stop" in out


@pytest.mark.parametrize("code", [0, 1])
def test_the_launcher_stops_waiting_when_the_serving_service_ends(capsys, code):
    svc, sup = _FakeService(stop_at=None), _FakeSupervisor(exit_after=3, code=code)
    assert serve_until_stopped(svc, sup, 9877) == "done"  # type: ignore[arg-type]
    assert sup.checks == 3
