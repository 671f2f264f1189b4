"""Viewer URLs are read as Rerun reads them; a recording streams to a real running viewer,
and one that is not running is found before anything is logged."""

from __future__ import annotations

import re

import pytest
import rerun as rr

from services.rerun_logger.recording import open_recording
from services.rerun_logger.viewer import (
    DEFAULT_URL,
    ViewerError,
    check_viewer,
    viewer_address,
    viewer_url_problem,
)
from tests.services.rerun_logger.conftest import free_port


@pytest.mark.parametrize(("text", "host", "port"), [
    (DEFAULT_URL, "127.0.0.1", 9876),
    ("rerun+http://localhost/proxy", "localhost", 9876),
    ("rerun+https://example.com/proxy", "example.com", 443),
    ("rerun://example.com:9000/proxy/", "example.com", 9000),
    ("rerun+http://[::1]:9001/proxy", "::1", 9001),
    ("9877", "127.0.0.1", 9877),
])
def test_viewer_urls_are_read_as_rerun_reads_them(text, host, port):
    address = viewer_address(text)
    assert (address.host, address.port) == (host, port)
    rr.GrpcSink(address.url)  # Rerun takes the URL as it is


@pytest.mark.parametrize(("text", "problem"), [
    ("http://127.0.0.1:9876/proxy", "expected rerun+http://HOST:PORT/proxy"),
    ("rerun+http://127.0.0.1:9876", "the path must be /proxy"),
    ("rerun+http://127.0.0.1:99999/proxy", "the port must be a number from 1 to 65535"),
    ("rerun+http://127.0.0.1:0/proxy", "the port must be a number from 1 to 65535"),
    ("rerun+http:///proxy", "no host"),
    ("viewer", "expected rerun+http://HOST:PORT/proxy"),
])
def test_malformed_viewer_urls_are_refused(text, problem):
    with pytest.raises(ViewerError, match=re.escape(problem)):
        viewer_address(text)
    assert problem in viewer_url_problem(text)
    assert viewer_url_problem(None) == viewer_url_problem(DEFAULT_URL) == ""


def test_a_viewer_that_is_not_running_is_named_in_one_line():
    port = free_port()
    with pytest.raises(ViewerError) as err:
        check_viewer(str(port), timeout=2)
    message = str(err.value)
    assert "\n" not in message
    assert f"no Rerun viewer at rerun+http://127.0.0.1:{port}/proxy" in message
    assert "connection refused" in message and f"rerun --port {port}" in message
    with pytest.raises(ViewerError, match="no Rerun viewer"):
        open_recording(viewer_url=str(port))


def test_a_recording_streams_to_a_running_viewer_and_its_file(tmp_path, rerun_server, rrd_tools):
    read, verify = rrd_tools
    viewer = rerun_server()
    assert check_viewer(viewer.url).port == viewer.port
    rec = open_recording(tmp_path / "also.rrd", viewer_url=viewer.url, recording_id="rec-v")
    assert rec.viewer_url == viewer.url
    for i in range(20):
        rec.stream.set_time("frame", sequence=i)
        rec.stream.log("x", rr.Scalars(float(i)))
    rec.stream.log("events", rr.TextLog("done"))
    rec.close()
    got = viewer.wait_for(lambda c: "/events" in c.entities, "the viewer to get the events")
    assert got.mono("/x", "Scalars:scalars") == [float(i) for i in range(20)]
    verify(rec.rrd_path)
    assert read(rec.rrd_path).mono("/x", "Scalars:scalars") == [float(i) for i in range(20)]


def test_a_viewer_that_goes_away_loses_the_rest_but_the_file_does_not(
    tmp_path, rerun_server, rrd_tools
):
    read, verify = rrd_tools
    viewer = rerun_server()
    rec = open_recording(tmp_path / "kept.rrd", viewer_url=viewer.url)
    rec.stream.set_time("frame", sequence=0)
    rec.stream.log("x", rr.Scalars(0.0))
    assert rec.flush() == ""
    viewer.wait_for(lambda c: "/x" in c.entities, "the viewer to get the first frame")
    viewer.stop()
    for i in range(1, 50):
        rec.stream.set_time("frame", sequence=i)
        rec.stream.log("x", rr.Scalars(float(i)))
    rec.close()  # warns; no exception
    verify(rec.rrd_path)
    assert read(rec.rrd_path).frames("/x", "Scalars:scalars") == list(range(50))
