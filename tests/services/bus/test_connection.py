"""services.bus.connection: the bus options of every service, from the command line and the
environment, and the Zenoh configuration they give."""

from __future__ import annotations

import argparse

import pytest

from services.bus.connection import BusOptions
from services.bus.options import OptionError, add_options, options_argv, options_from


def parse(argv: list[str]) -> BusOptions:
    parser = argparse.ArgumentParser()
    add_options(parser, BusOptions)
    return options_from(BusOptions, parser.parse_args(argv))


def test_bus_options_from_environment_and_back_to_argv(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("AAMTRACK_STREAM", "camA")
    monkeypatch.setenv("AAMTRACK_ZENOH_CONNECT", "tcp/127.0.0.1:7000, tcp/127.0.0.1:7001")
    opts = parse(["--listen", "tcp/127.0.0.1:0", "--run-id", "run-1"])
    assert opts == BusOptions("camA", "peer", ("tcp/127.0.0.1:0",),
                              ("tcp/127.0.0.1:7000", "tcp/127.0.0.1:7001"), run_id="run-1")
    monkeypatch.delenv("AAMTRACK_STREAM")
    monkeypatch.delenv("AAMTRACK_ZENOH_CONNECT")
    assert parse(options_argv(opts)) == opts


def test_bus_options_reject_bad_names_modes_and_configs(tmp_path) -> None:
    with pytest.raises(OptionError, match="--stream 'a/b'"):
        BusOptions("a/b")
    with pytest.raises(OptionError, match="--mode 'hub'"):
        BusOptions("cam0", mode="hub")
    with pytest.raises(OptionError, match="--run-id"):
        BusOptions("cam0", run_id="no spaces")
    with pytest.raises(ValueError, match="endpoint"):
        BusOptions("cam0", connect=("localhost",)).config()
    with pytest.raises(OptionError, match="--zenoh-config"):
        BusOptions("cam0", zenoh_config=str(tmp_path / "missing.json5")).config()
