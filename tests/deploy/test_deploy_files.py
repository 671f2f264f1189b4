"""The files under deploy/: Zenoh configurations Zenoh accepts, a stack file that places
every service once with arguments its parser accepts, systemd units that start them."""

from __future__ import annotations

import configparser
import json
import re
import shutil
from pathlib import Path

import pytest
import zenoh

from proto.auth import Keyring
from proto.zenoh_config import config_from_file
from services.bus.args import parse_service_args, service_argv
from services.bus.options import OptionError
from services.bus.trust import write_keys_file
from services.stack.launcher import NAME
from services.stack.registry import SERVICES
from services.stack.stack_file import StackFile, read_stack_file
from tests.deploy.conftest import DEPLOY, ZENOH_DIR

MODES = {"peer.json5": "peer", "client.json5": "client", "router.json5": "router",
         "router-tls.json5": "router", "client-tls.json5": "client",
         "router-acl.json5": "router"}


@pytest.mark.parametrize("name", sorted(MODES))
def test_zenoh_config_files_load_with_their_mode_and_no_multicast(name: str) -> None:
    cfg = config_from_file(ZENOH_DIR / name)
    assert json.loads(cfg.get_json("mode")) == MODES[name]
    assert json.loads(cfg.get_json("scouting/multicast/enabled")) is False


def test_the_deploy_folder_holds_exactly_the_documented_zenoh_files() -> None:
    assert sorted(p.name for p in ZENOH_DIR.glob("*.json5")) == sorted(MODES)


@pytest.mark.parametrize("name", ["router-tls.json5", "client-tls.json5", "router-acl.json5"])
def test_secure_configs_use_tls_endpoints_and_mutual_tls(name: str) -> None:
    cfg = config_from_file(ZENOH_DIR / name)
    tls = json.loads(cfg.get_json("transport/link/tls"))
    assert tls["enable_mtls"] is True and tls["root_ca_certificate"] == "certs/ca.pem"
    key = "listen/endpoints" if MODES[name] == "router" else "connect/endpoints"
    assert all(e.startswith("tls/") for e in json.loads(cfg.get_json(key)))


def test_access_control_denies_by_default_and_lets_only_the_stack_publish() -> None:
    acl = json.loads(config_from_file(ZENOH_DIR / "router-acl.json5").get_json("access_control"))
    assert acl["enabled"] is True and acl["default_permission"] == "deny"
    rules = {r["id"]: r for r in acl["rules"]}
    subjects = {s["id"]: s for s in acl["subjects"]}
    publishers = {s for p in acl["policies"] for s in p["subjects"]
                  if any("put" in rules[r]["messages"] and "ingress" in rules[r]["flows"]
                         for r in p["rules"])}
    assert publishers == {"stack"}
    assert subjects["stack"]["cert_common_names"] == ["aamtrack-stack"]
    assert all(r["permission"] == "allow" and r["key_exprs"] == ["aamtrack/**"]
               for r in rules.values())


def test_a_malformed_config_file_is_reported_by_name(tmp_path: pytest.TempPathFactory) -> None:
    bad = tmp_path / "bad.json5"
    bad.write_text("{ mode: ")
    with pytest.raises(ValueError, match=f"zenoh config {bad}"):
        config_from_file(bad)
    with pytest.raises(ValueError, match="not like"):
        config_from_file(ZENOH_DIR / "peer.json5", connect=["127.0.0.1:7447"])


def test_config_from_file_overrides_mode_and_endpoints() -> None:
    cfg = config_from_file(ZENOH_DIR / "peer.json5", "client", [], ["tcp/10.0.0.2:7447"])
    assert json.loads(cfg.get_json("mode")) == "client"
    assert json.loads(cfg.get_json("connect/endpoints")) == ["tcp/10.0.0.2:7447"]
    assert isinstance(cfg, zenoh.Config)


@pytest.fixture(scope="module")
def stack_file(tmp_path_factory: pytest.TempPathFactory) -> StackFile:
    """deploy/stack.toml, its keys file (made at deployment, never committed) made beside a copy."""
    folder = tmp_path_factory.mktemp("deploy")
    shutil.copy(DEPLOY / "stack.toml", folder / "stack.toml")
    parsed = read_stack_file(folder / "stack.toml")
    write_keys_file(parsed.keys, Keyring.generate([*SERVICES, NAME]))
    return parsed


def test_stack_file_places_every_service_on_exactly_one_host(stack_file: StackFile) -> None:
    placed = [s for host in stack_file.hosts.values() for s in host.services]
    assert sorted(placed) == sorted(SERVICES)
    assert stack_file.hosts["camera"].services == ("source",)
    assert stack_file.hosts["viewer"].services == ("rerun",)
    assert [n for n, h in stack_file.hosts.items() if h.router] == ["compute"]


@pytest.mark.parametrize("name", list(SERVICES))
def test_stack_file_options_are_accepted_by_each_service(stack_file: StackFile, name: str) -> None:
    host = next(h.name for h in stack_file.hosts.values() if name in h.services)
    argv = service_argv(stack_file.bus(host), stack_file.services[name])
    info = SERVICES[name]
    args = parse_service_args(name, info.summary, info.options, argv)
    assert args.options == stack_file.services[name]
    assert args.bus.connect == (stack_file.router,) and args.bus.stream == stack_file.stream


def test_stack_file_errors_name_the_file_and_the_problem(tmp_path: Path) -> None:
    bad = tmp_path / "stack.toml"
    for text, message in [
        ("[services.fitter]\nwarp = \"tpu\"\n", "--warp 'tpu'"),
        ("[services.fitter]\nspeed = 3\n", "unknown option 'speed'"),
        ("[services.blender]\n", "unknown services ['blender']"),
        ("[hosts.a]\nservices = [\"fitter\", \"mixer\"]\n", "unknown services ['mixer']"),
        ("[services.source\n", "not valid TOML"),
    ]:
        bad.write_text(text)
        with pytest.raises(OptionError, match=re.escape(message)) as err:
            read_stack_file(bad)
        assert str(bad) in str(err.value)


def _unit(name: str) -> configparser.ConfigParser:
    unit = configparser.ConfigParser(strict=False, interpolation=None)
    unit.optionxform = str  # systemd keys are case-sensitive
    unit.read_string((DEPLOY / "systemd" / name).read_text())
    return unit


def test_systemd_service_template_runs_one_named_service_connected_to_the_router() -> None:
    unit = _unit("aamtrack@.service")
    exec_start = unit["Service"]["ExecStart"]
    assert " service %i --stack /etc/aamtrack/stack.toml --host ${AAMTRACK_HOST}" in exec_start
    assert unit["Service"]["Restart"] == "on-failure"
    assert "aamtrack-router.service" in unit["Unit"]["After"]


def test_systemd_router_unit_runs_aamtrack_router_on_the_deploy_config() -> None:
    exec_start = _unit("aamtrack-router.service")["Service"]["ExecStart"]
    assert " router --config " in exec_start and exec_start.endswith("router.json5")
