"""Bad input to the web app: HTTP 400 with one line, never 500; odd WebSocket messages."""

from __future__ import annotations

import pytest

MODEL = """species = ["u", "v"]
{head}
[parameters]
a = {a}
b = 0.9
[equations]
u = "a - u + u**2*v + lap(u)"
v = "b - u**2*v + 40*lap(v)"
"""


def _one_line_400(r, fragment):
    assert r.status_code == 400, r.text
    msg = r.json()["error"]
    assert fragment in msg and "\n" not in msg


@pytest.mark.parametrize("value", ["1e308", "-1.7e308", "nan", "inf"])
def test_parse_refuses_absurd_parameters(client, value):
    r = client.post("/api/models/parse", json={"equations": MODEL.format(head="", a=value)})
    _one_line_400(r, "magnitude at most 1e+30")


@pytest.mark.parametrize("path", ["/api/mesh", "/api/evolve"])
def test_pasted_model_with_infinite_t_end(client, path):
    text = MODEL.format(head="t_end = inf", a="0.1")
    _one_line_400(client.post(path, json={"model": {"equations": text}}), "t_end")


def test_binary_websocket_message_gets_an_error_not_a_drop(client):
    sid = client.post("/api/live", json={"model": {"library": "gray-scott"}, "size": 16,
                                         "init": "square"}).json()["id"]
    with client.websocket_connect(f"/api/live/{sid}/ws") as ws:
        ws.send_bytes(b"\x00\xffnext")
        assert "send 'next'" in ws.receive_json()["error"]
        ws.send_text("show")
        assert isinstance(ws.receive_bytes(), bytes)


def test_run_file_download_refuses_absurd_steps(client):
    sid = client.post("/api/live", json={"model": {"library": "gray-scott"}, "size": 16,
                                         "init": "square"}).json()["id"]
    _one_line_400(client.get(f"/api/live/{sid}/config", params={"steps": 10**15}), "steps")
    assert client.get(f"/api/live/{sid}/config", params={"steps": 50}).status_code == 200
