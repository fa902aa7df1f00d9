"""Progress display for long work: a tqdm bar with rate and ETA on standard error."""

from __future__ import annotations

import sys

from tqdm import tqdm


class ProgressBar:
    """A progress bar that can be switched off; ``update(n)`` after each compiled chunk."""

    def __init__(self, total: int, *, enabled: bool, unit: str = "it", desc: str = ""):
        self._bar = (
            tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, dynamic_ncols=True,
                 leave=False)
            if enabled
            else None
        )

    def update(self, n: int) -> None:
        if self._bar is not None:
            self._bar.update(n)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
