"""Live simulations by session id: one per browser tab, bounded in number and idle time.

A page asks for a session when it loads and keeps the id in memory only (not in a cookie or
local storage), so every tab gets its own simulation and no tab can see or change another's.
Ids are 128-bit random tokens. When the store is full, the least recently used simulation is
dropped; a page whose session was dropped gets HTTP 404 and starts a new one.
"""

from __future__ import annotations

import secrets
import threading
import time
from collections import OrderedDict

from morphogen.errors import MorphogenError
from morphogen.web.limits import Limits
from morphogen.web.live import LiveSim


class SessionGone(MorphogenError):
    """The session id is unknown or its simulation was dropped."""


class SessionStore:
    """Maps session ids to :class:`LiveSim` instances."""

    def __init__(self, limits: Limits):
        self.limits = limits
        self._sims: OrderedDict[str, LiveSim] = OrderedDict()
        self._lock = threading.Lock()

    def create(self) -> tuple[str, LiveSim]:
        """A new, unconfigured simulation and its id (dropping idle or old ones if needed)."""
        sid = secrets.token_urlsafe(16)
        sim = LiveSim(self.limits)
        with self._lock:
            self._expire()
            while len(self._sims) >= self.limits.max_sessions:
                self._sims.popitem(last=False)
            self._sims[sid] = sim
        return sid, sim

    def get(self, sid: str) -> LiveSim:
        """The simulation of ``sid``, or :class:`SessionGone`."""
        with self._lock:
            sim = self._sims.get(sid)
            if sim is None:
                raise SessionGone(
                    "this live simulation has expired or never existed; reload the page"
                )
            self._sims.move_to_end(sid)
            return sim

    def drop(self, sid: str) -> None:
        """Forget ``sid`` (no error if unknown)."""
        with self._lock:
            self._sims.pop(sid, None)

    def __len__(self) -> int:
        with self._lock:
            return len(self._sims)

    def _expire(self) -> None:
        now = time.monotonic()
        for sid in [s for s, sim in self._sims.items()
                    if now - sim.last_used > self.limits.session_idle_s]:
            del self._sims[sid]
