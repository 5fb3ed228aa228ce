"""SIGTERM while `Campaign.run` runs: stop the campaign between trials, like Ctrl-C.

Python's default for SIGTERM is to die at once (exit status -15), leaving the runs in flight
unstored and saying nothing. While a campaign runs on the main thread, and only if SIGTERM
still has its default action (a handler of the caller's is left alone), `install` makes it
raise `Terminated` there; `Campaign.run` then stops the campaign between trials and raises
`SystemExit(143)` with the resume call on stderr. `restore` puts the default back."""

import signal
import threading
from typing import Any, Optional


class Terminated(BaseException):
    """SIGTERM arrived while a campaign ran (internal: `Campaign.run` turns it into
    `SystemExit(143)`)."""


def _terminated(signum: int, frame: Any) -> None:
    raise Terminated()


def install() -> Optional[Any]:
    """Makes SIGTERM raise `Terminated` on the main thread; returns the handler to restore,
    or None when nothing was installed (not the main thread, or SIGTERM has a handler)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
        return None
    return signal.signal(signal.SIGTERM, _terminated)


def restore(previous: Optional[Any]) -> None:
    """Puts back the handler `install` replaced."""
    if previous is not None:
        signal.signal(signal.SIGTERM, previous)
