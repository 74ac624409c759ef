"""Progress of a sweep on stderr: runs done and failed, the rate and the time left.

On a terminal it is one line redrawn in place (a bar); otherwise (a log file, CI) a log line
through ``logging`` (logger ``playerstage.sweep``) at most every ``interval`` seconds and at
the end. Executors call ``update(result)`` once per finished run.
"""

import logging
import sys
import time
from typing import Any, Dict, Optional, TextIO

log = logging.getLogger("playerstage.sweep")


def _duration(seconds: float) -> str:
    seconds = int(round(seconds))
    h, rest = divmod(seconds, 3600)
    m, s = divmod(rest, 60)
    return f"{h}h{m:02d}m" if h else (f"{m}m{s:02d}s" if m else f"{s}s")


class Progress:
    """``Progress(total, skipped=0)``: ``total`` runs in the plan, ``skipped`` of them already
    stored (resume). ``stream`` defaults to stderr; ``bar`` to whether it is a terminal."""

    def __init__(self, total: int, skipped: int = 0, stream: Optional[TextIO] = None,
                 bar: Optional[bool] = None, interval: float = 2.0):
        self.total = total
        self.skipped = skipped
        self.done = 0
        self.failed = 0
        self.stream = stream if stream is not None else sys.stderr
        self.bar = self.stream.isatty() if bar is None else bar
        self.interval = interval
        self.start = time.monotonic()
        self._last = 0.0
        self._drawn = False

    @property
    def remaining(self) -> int:
        return self.total - self.skipped - self.done

    def eta(self) -> Optional[float]:
        """Seconds left at this sweep's rate so far (None before the first run ends)."""
        if not self.done:
            return None
        return (time.monotonic() - self.start) / self.done * self.remaining

    def line(self) -> str:
        finished = self.skipped + self.done
        eta = self.eta()
        elapsed = time.monotonic() - self.start
        rate = self.done / elapsed * 60 if elapsed > 0 and self.done else 0.0
        text = f"{finished}/{self.total} runs"
        if self.skipped:
            text += f" ({self.skipped} from before)"
        text += f", {self.failed} failed, {rate:.1f} runs/min"
        text += ", " + (f"about {_duration(eta)} left" if eta is not None else "time left unknown")
        return text

    def update(self, result: Dict[str, Any]) -> None:
        """One run finished (its result, as stored)."""
        self.done += 1
        if result.get("error"):
            self.failed += 1
            err = result["error"].strip().splitlines()[-1]
            self._clear()
            log.warning("run %s failed: %s", result.get("run_id"), err)
        now = time.monotonic()
        if self.bar:
            self._draw()
        elif now - self._last >= self.interval or self.remaining == 0:
            self._last = now
            log.info("sweep: %s", self.line())

    def _draw(self) -> None:
        width = 30
        frac = (self.skipped + self.done) / self.total if self.total else 1.0
        filled = int(frac * width)
        self.stream.write(f"\r[{'#' * filled}{'.' * (width - filled)}] {self.line()}\x1b[K")
        self.stream.flush()
        self._drawn = True

    def _clear(self) -> None:
        if self._drawn:
            self.stream.write("\r\x1b[K")
            self.stream.flush()
            self._drawn = False

    def close(self) -> None:
        """Ends the display (a newline after the bar)."""
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
            self._drawn = False
