"""The server's own defences, below the routes: request size and time limits, and the access
token of a server that listens beyond this machine.

- :class:`BodyLimit` (ASGI middleware) reads a request's body itself before the app sees it:
  a ``Content-Length`` over the limit is refused with 413 before one byte of the body is read,
  a body that grows past the limit while it streams (chunked) is refused as soon as it does,
  and a body that has not arrived :attr:`~morphogen.web.limits.Limits.body_timeout_s` after its
  headers is refused with 408. Either way the connection is closed. The limit is
  :attr:`~morphogen.web.limits.Limits.max_body_bytes` (an image, a pasted model), or
  :attr:`~morphogen.web.limits.Limits.max_upload_bytes` for the one route that takes a whole
  checkpoint (``POST /api/live/{sid}/state``).
- :func:`header_timeout_protocol`: uvicorn's h11 protocol with a deadline on a request's
  headers (:attr:`~morphogen.web.limits.Limits.header_timeout_s` from the connection's first
  byte, or from the first byte of the next request on a kept-alive connection): a client that
  sends half a request line and waits is disconnected. :func:`server_options` gathers these and
  the other bounds of ``morphogen serve`` (keep-alive, header size, WebSocket message size).
- :class:`AccessToken` (ASGI middleware): every HTTP request and WebSocket must carry the token,
  as ``?token=...`` (which also sets a cookie, so the page's own requests carry it), the
  cookie, or an ``Authorization: Bearer ...`` header; anything else gets 403 (a WebSocket is
  refused before it opens). ``morphogen serve --allow-remote`` uses it, like Jupyter's token.
"""

from __future__ import annotations

import json
import re
import secrets
from http.cookies import SimpleCookie
from typing import Any
from urllib.parse import parse_qsl, urlencode

import anyio

from morphogen.web.limits import Limits

Scope = dict[str, Any]

UPLOAD_PATHS = (re.compile(r"^/api/live/[^/]+/state$"),)
"""Routes whose body may reach ``Limits.max_upload_bytes`` (a checkpoint, base64)."""

async def _refuse(send, status: int, message: str) -> None:
    body = json.dumps({"error": message}).encode()
    await send({"type": "http.response.start", "status": status, "headers": [
        (b"content-type", b"application/json"), (b"content-length", str(len(body)).encode()),
        (b"connection", b"close"), (b"cache-control", b"no-store"),
        (b"x-content-type-options", b"nosniff")]})
    await send({"type": "http.response.body", "body": body})


class BodyLimit:
    """Read each request's body under a size and a time limit before the app runs (see the
    module docstring); the app then reads the buffered body."""

    def __init__(self, app, limits: Limits):
        self.app = app
        self.limits = limits

    def cap(self, path: str) -> int:
        """The largest body accepted on ``path``."""
        if any(p.match(path) for p in UPLOAD_PATHS):
            return self.limits.max_upload_bytes
        return self.limits.max_body_bytes

    async def __call__(self, scope: Scope, receive, send) -> None:
        if scope["type"] != "http":  # every method: a GET may carry a body too
            return await self.app(scope, receive, send)
        cap = self.cap(scope.get("path", ""))
        declared = dict(scope.get("headers") or []).get(b"content-length")
        if declared is not None:
            try:
                length = int(declared)
            except ValueError:
                return await _refuse(send, 400, "Content-Length is not a number")
            if length > cap:
                return await _refuse(send, 413, _too_large(cap))
        parts: list[bytes] = []
        size = 0
        with anyio.move_on_after(self.limits.body_timeout_s) as deadline:
            while True:
                message = await receive()
                if message["type"] == "http.disconnect":
                    return
                chunk = message.get("body", b"")
                size += len(chunk)
                if size > cap:
                    return await _refuse(send, 413, _too_large(cap))
                parts.append(chunk)
                if not message.get("more_body", False):
                    break
        if deadline.cancelled_caught:
            return await _refuse(send, 408, f"the request body did not arrive within "
                                 f"{self.limits.body_timeout_s:g} s")
        body = b"".join(parts)
        sent = False

        async def replay():
            nonlocal sent
            if not sent:
                sent = True
                return {"type": "http.request", "body": body, "more_body": False}
            return await receive()

        await self.app(scope, replay, send)


def _too_large(cap: int) -> str:
    return f"the request is larger than the server accepts ({cap / 2**20:.3g} MiB)"


def header_timeout_protocol(timeout_s: float) -> type:
    """uvicorn's h11 protocol whose connections are closed when a request's headers are not
    complete ``timeout_s`` seconds after its first byte (or after the connection opened)."""
    import h11
    from uvicorn.protocols.http.h11_impl import H11Protocol

    class HeaderDeadline(H11Protocol):
        header_timeout_s = timeout_s
        _deadline = None

        def connection_made(self, transport) -> None:
            super().connection_made(transport)
            self._arm()

        def _arm(self) -> None:
            if self._deadline is None:
                self._deadline = self.loop.call_later(self.header_timeout_s, self._late)

        def _disarm(self) -> None:
            if self._deadline is not None:
                self._deadline.cancel()
                self._deadline = None

        def _late(self) -> None:
            self._deadline = None
            if self.conn.their_state is h11.IDLE and not self.transport.is_closing():
                self.transport.close()

        def data_received(self, data: bytes) -> None:
            if self.conn.their_state is h11.IDLE:
                self._arm()  # a new request begins: its headers must arrive in time
            super().data_received(data)
            if self.conn.their_state is not h11.IDLE:
                self._disarm()

        def connection_lost(self, exc) -> None:
            self._disarm()
            super().connection_lost(exc)

    return HeaderDeadline


def server_options(limits: Limits) -> dict[str, Any]:
    """uvicorn settings that bound what one connection can hold (see the module docstring)."""
    return {
        "http": header_timeout_protocol(limits.header_timeout_s),
        "timeout_keep_alive": limits.keep_alive_s,
        "h11_max_incomplete_event_size": 16 * 1024,
        "ws_max_size": limits.max_ws_message_bytes,
    }


COOKIE = "morphogen-token"


def new_token() -> str:
    """A fresh random access token (32 URL-safe characters)."""
    return secrets.token_urlsafe(24)


class AccessToken:
    """Refuse every request and WebSocket that does not carry ``token`` (module docstring)."""

    def __init__(self, app, token: str):
        self.app = app
        self.token = token

    def _cookie_name(self, scope: Scope) -> str:
        server = scope.get("server")
        return f"{COOKIE}-{server[1]}" if server and server[1] else COOKIE

    def _matches(self, value: str | None) -> bool:
        return bool(value) and secrets.compare_digest(value.encode(), self.token.encode())

    async def __call__(self, scope: Scope, receive, send) -> None:
        if scope["type"] not in ("http", "websocket"):
            return await self.app(scope, receive, send)
        name = self._cookie_name(scope)
        query = parse_qsl(scope.get("query_string", b"").decode("latin-1"),
                          keep_blank_values=True)
        from_query = next((v for k, v in query if k == "token"), None)
        headers = dict(scope.get("headers") or [])
        cookie = SimpleCookie()
        try:
            cookie.load(headers.get(b"cookie", b"").decode("latin-1"))
        except Exception:  # a malformed cookie header counts as none
            cookie = SimpleCookie()
        from_cookie = cookie[name].value if name in cookie else None
        auth = headers.get(b"authorization", b"").decode("latin-1")
        from_header = auth[7:].strip() if auth[:7].lower() == "bearer " else None
        if not any(self._matches(v) for v in (from_query, from_cookie, from_header)):
            if scope["type"] == "websocket":
                await send({"type": "websocket.close", "code": 1008})
                return
            return await _refuse(send, 403, "this server needs its access token: open the "
                                 "address it printed at start (with ?token=...)")
        if scope["type"] == "websocket" or not self._matches(from_query):
            return await self.app(scope, receive, send)
        set_cookie = (b"set-cookie", f"{name}={self.token}; Path=/; HttpOnly; "
                      "SameSite=Strict".encode())
        if scope.get("method") in ("GET", "HEAD") and scope.get("path") == "/":
            # the page: drop the token from the address bar (the cookie carries it from now on)
            rest = urlencode([(k, v) for k, v in query if k != "token"])
            where = "/" + (f"?{rest}" if rest else "")
            await send({"type": "http.response.start", "status": 303, "headers": [
                (b"location", where.encode()), (b"content-length", b"0"),
                (b"cache-control", b"no-store"), set_cookie]})
            await send({"type": "http.response.body", "body": b""})
            return

        async def send_with_cookie(message):
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message.get("headers", []), set_cookie]}
            await send(message)

        await self.app(scope, receive, send_with_cookie)


def install(app, limits: Limits, token: str | None) -> None:
    """Add the body limit and, with ``token``, the access token around ``app`` (outermost:
    a request without the token is refused before its body is read)."""
    app.add_middleware(BodyLimit, limits=limits)
    if token:
        app.add_middleware(AccessToken, token=token)
