"""The web server under abuse: body size and time limits, header time-outs, oversized images,
and the access token of a server that listens beyond this machine."""

from __future__ import annotations

import base64
import io
import socket
import struct
import threading
import zlib

import numpy as np
import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from morphogen.cli.main import main
from morphogen.cli.serve_cmd import access, is_local
from morphogen.errors import MorphogenError
from morphogen.web.app import create_app
from morphogen.web.guards import server_options
from morphogen.web.image_input import MAX_IMAGE_PIXELS, decode_png
from morphogen.web.limits import Limits

SMALL = Limits(max_body_bytes=1024, max_upload_bytes=4096, body_timeout_s=0.5,
               header_timeout_s=0.5)
WAIT_S = 20.0  # a socket's wait for the server's answer; the limits above are far below it


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    """A real uvicorn server on 127.0.0.1 with :data:`SMALL` limits; yields its port."""
    import uvicorn

    app = create_app(limits=SMALL, archive=tmp_path_factory.mktemp("a") / "index.sqlite")
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.bind(("127.0.0.1", 0))
    sock.listen(64)  # connections wait in the backlog until the server accepts them
    srv = uvicorn.Server(uvicorn.Config(app, log_level="critical", lifespan="off",
                                        **server_options(SMALL)))
    thread = threading.Thread(target=srv.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    yield sock.getsockname()[1]
    srv.should_exit = True
    thread.join(WAIT_S)
    sock.close()


def _connect(port: int) -> socket.socket:
    s = socket.create_connection(("127.0.0.1", port), timeout=WAIT_S)
    return s


def _answer(s: socket.socket) -> bytes:
    """Everything the server sends until it closes the connection (bounded by the time-out)."""
    data = b""
    for _ in range(1000):
        part = s.recv(65536)
        if not part:
            return data
        data += part
    return data


def _status(answer: bytes) -> int:
    return int(answer.split(b" ", 2)[1])


HEAD = (b"POST /api/models/parse HTTP/1.1\r\nHost: 127.0.0.1\r\n"
        b"Content-Type: application/json\r\n")


def test_declared_oversized_body_is_refused_before_it_is_read(server):
    with _connect(server) as s:
        s.sendall(HEAD + b"Content-Length: 104857600\r\n\r\n")  # 100 MB announced, none sent
        answer = _answer(s)
    assert _status(answer) == 413
    assert b"larger than the server accepts" in answer


def test_streamed_body_past_the_limit_is_refused(server):
    with _connect(server) as s:
        s.sendall(HEAD + b"Transfer-Encoding: chunked\r\n\r\n")
        chunk = b'{"text": "' + b"x" * 500
        for _ in range(4):  # 2 kB in all, over the 1 kB limit, no length announced
            s.sendall(b"%x\r\n%s\r\n" % (len(chunk), chunk))
        answer = _answer(s)
    assert _status(answer) == 413


def test_body_that_stops_arriving_is_refused_and_closed(server):
    with _connect(server) as s:
        s.sendall(HEAD + b"Content-Length: 100\r\n\r\n" + b'{"text": ')
        answer = _answer(s)
    assert _status(answer) == 408
    with _connect(server) as s:  # a GET route reads no body, but its body is timed too
        s.sendall(b"GET /api/models HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: 50\r\n\r\nab")
        answer = _answer(s)
    assert _status(answer) == 408


def test_twenty_half_sent_requests_are_all_closed(server):
    conns = [_connect(server) for _ in range(20)]
    try:
        for i, s in enumerate(conns):
            s.sendall(b"GET /api/models HTTP/1.1\r\nHost: 127" if i % 2 else b"")
        for s in conns:
            assert _answer(s) == b""  # closed by the server, no answer
    finally:
        for s in conns:
            s.close()


def test_a_kept_alive_connection_gets_a_header_deadline_again(server):
    with _connect(server) as s:
        s.sendall(b"GET /api/models HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        first = b""
        for _ in range(1000):
            first += s.recv(65536)
            if b"\r\n\r\n" in first:
                break
        assert _status(first) == 200
        s.sendall(b"GET /api/models HTTP/1.1\r\nHo")  # the next request, half sent
        _answer(s)  # returns only once the server closes the connection


def test_large_body_with_an_extra_key_is_refused(tmp_path):
    app = create_app(limits=SMALL, archive=tmp_path / "index.sqlite",
                     allowed_hosts=["testserver"])
    with TestClient(app, raise_server_exceptions=False) as c:
        r = c.post("/api/models/parse", json={"text": "x", "padding": "y" * 5000})
        assert r.status_code == 413 and "\n" not in r.json()["error"]
        ok = c.post("/api/models/parse", json={"text": "x"})
        assert ok.status_code == 400  # a small body reaches the route (and its parser)
        # the checkpoint route takes up to max_upload_bytes: this one reaches the route
        r = c.post("/api/live/nosuch/state", json={"npz": "A" * 3000})
        assert r.status_code == 404
        r = c.post("/api/live/nosuch/state", json={"npz": "A" * 5000})
        assert r.status_code == 413


def _png_claiming(width: int, height: int) -> bytes:
    """A 1 x 1 PNG whose header says ``width`` x ``height`` (CRC fixed up)."""
    import imageio.v3 as iio

    data = bytearray(iio.imwrite("<bytes>", np.zeros((1, 1), np.uint8), extension=".png"))
    ihdr = bytes(data[12:16]) + struct.pack(">II", width, height) + bytes(data[24:29])
    data[16:24] = struct.pack(">II", width, height)
    data[29:33] = struct.pack(">I", zlib.crc32(ihdr))
    return bytes(data)


def test_png_announcing_144_megapixels_is_refused_before_decoding():
    text = base64.b64encode(_png_claiming(12000, 12000)).decode()
    with pytest.raises(MorphogenError, match="12000 x 12000 pixels"):
        decode_png(text)
    side = int(MAX_IMAGE_PIXELS**0.5)
    with pytest.raises(MorphogenError, match="pixels"):
        decode_png(base64.b64encode(_png_claiming(side + 1, side)).decode())
    with pytest.raises(MorphogenError, match="complete"):
        decode_png(base64.b64encode(b"\x89PNG\r\n\x1a\n").decode())


def test_png_within_the_limit_still_decodes():
    import imageio.v3 as iio

    buf = io.BytesIO(iio.imwrite("<bytes>", np.full((3, 5), 255, np.uint8), extension=".png"))
    grey = decode_png(base64.b64encode(buf.getvalue()).decode())
    assert grey.shape == (3, 5) and float(grey.min()) == 1.0


TOKEN = "k" * 20 + "-_0123456789"


@pytest.fixture(scope="module")
def guarded(tmp_path_factory):
    app = create_app(archive=tmp_path_factory.mktemp("t") / "index.sqlite",
                     allowed_hosts=["*"], token=TOKEN)
    with TestClient(app, raise_server_exceptions=False) as c:
        yield c


@pytest.mark.parametrize("path", ["/", "/static/app.css", "/api/models", "/api/jobs/x"])
def test_every_route_needs_the_token(guarded, path):
    guarded.cookies.clear()
    r = guarded.get(path)
    assert r.status_code == 403 and "token" in r.json()["error"]
    r = guarded.get(path, headers={"Authorization": "Bearer wrong-" + TOKEN})
    assert r.status_code == 403
    r = guarded.post("/api/models/parse", json={"text": "x"})
    assert r.status_code == 403


def test_token_in_the_address_sets_a_cookie_and_is_dropped_from_it(guarded):
    guarded.cookies.clear()
    r = guarded.get(f"/?token={TOKEN}&model=gray-scott", follow_redirects=False)
    assert r.status_code == 303 and r.headers["location"] == "/?model=gray-scott"
    cookie = r.headers["set-cookie"]
    assert TOKEN in cookie and "HttpOnly" in cookie and "SameSite=Strict" in cookie
    assert guarded.get("/").status_code == 200  # the cookie now carries it
    assert guarded.get("/static/app.css").status_code == 200
    guarded.cookies.clear()
    r = guarded.get("/api/models", headers={"Authorization": f"Bearer {TOKEN}"})
    assert r.status_code == 200
    assert guarded.get(f"/api/models?token={TOKEN}").status_code == 200


def test_websocket_needs_the_token(guarded):
    guarded.cookies.clear()
    with pytest.raises(WebSocketDisconnect) as refused:
        with guarded.websocket_connect("/api/live/nosuch/ws") as ws:
            ws.receive_text()
    assert refused.value.code == 1008
    with guarded.websocket_connect(f"/api/live/nosuch/ws?token={TOKEN}") as ws:
        ws.send_text("next")
        assert "error" in ws.receive_json()


def test_serving_beyond_this_machine_needs_allow_remote(capsys, monkeypatch):
    monkeypatch.delenv("MORPHOGEN_TOKEN", raising=False)
    assert main(["serve", "--host", "0.0.0.0", "--port", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--allow-remote" in err and "\n" not in err
    for host in ("127.0.0.1", "localhost", "::1", "127.0.0.2"):
        assert is_local(host) and access(host, False) == (None, None)
    for host in ("0.0.0.0", "::", "192.168.1.5", "example.org"):
        assert not is_local(host)
        with pytest.raises(MorphogenError, match="--allow-remote"):
            access(host, False)
    hosts, token = access("0.0.0.0", True)
    assert hosts == ["*"] and len(token) >= 16
    assert access("0.0.0.0", True)[1] != token  # a fresh one each start
    monkeypatch.setenv("MORPHOGEN_TOKEN", TOKEN)
    assert access("0.0.0.0", True)[1] == TOKEN
    monkeypatch.setenv("MORPHOGEN_TOKEN", "short")
    with pytest.raises(MorphogenError, match="MORPHOGEN_TOKEN"):
        access("0.0.0.0", True)


def test_a_time_limited_jobs_time_left_counts_down_while_its_progress_stands_still():
    """A job that knows how long it runs (a match's search minutes) counts its time left down
    to that, however its progress moves; other jobs extrapolate their progress."""
    from morphogen.web.jobs import Job

    job = Job("j", "match", status="running", progress=0.1, expected_s=60.0)
    assert [job.eta(t) for t in (10.0, 30.0, 59.0, 61.0)] == [50.0, 30.0, 1.0, None]
    plain = Job("k", "atlas", status="running", progress=0.25)
    assert plain.eta(10.0) == 30.0
    assert Job("d", "match", status="done", expected_s=60.0).eta(10.0) is None
