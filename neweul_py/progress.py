"""Progress of long work on stderr, one helper for every layer (tqdm bars with a remaining-time
estimate).

Two kinds of hooks reach this module, and a :class:`Tracker` serves as both:

- a *message* hook ``progress(message: str)`` — the ``Progress`` type of ``elastic/`` and
  ``fem/`` (``"factorizing K − σM …"``);
- a *counted* hook ``progress(done: float, total: float)`` — ``simulate(progress=...)`` passes
  the simulated time reached and the time span, sweeps the number of finished cases.

- a *staged* hook ``progress(stage: str, done: int, total: int)`` — work in several steps
  of different kinds, such as the derivation of a model (``"kinematics"``, ``"equations"``,
  ``"code generation"``: frames, bodies, blocks); call sites use :class:`Steps`.

Call sites in counted loops use :func:`report`, which advances a tracker's bar (with an
estimate of the remaining time) and hands plain message hooks their message, so a user's
``print`` still works as a hook. Bars are drawn only when stderr is a terminal; elsewhere (a
log file, a pipe, CI) a tracker prints one line at most every :data:`LOG_INTERVAL` seconds
with the stage, how far it is and an estimate of the time left (linear in the stage's
progress), so long work is never silent in a log and short work prints nothing. Messages are
printed (one line each) and all of it is silenced when the tracker is ``quiet``. Library code
never creates a tracker itself: the CLI (or the user) passes one in, so the Python API stays
silent by default.

Examples
--------
>>> from neweul_py.progress import Tracker
>>> with Tracker("simulate", unit="s") as track:            # doctest: +SKIP
...     simulate(mod, 100.0, progress=track)
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import IO, Any

__all__ = ["LOG_INTERVAL", "QUIET_HELP", "CountedProgress", "MessageProgress", "StagedProgress",
           "Steps", "Tracker", "interactive", "report"]

#: A hook receiving short messages of long steps (``elastic.projection.Progress``).
MessageProgress = Callable[[str], None] | None
#: A hook receiving ``(done, total)`` of a counted loop.
CountedProgress = Callable[[float, float], None] | None
#: A hook receiving ``(stage, done, total)`` of work in stages (the derivation of a model);
#: ``done`` counts finished steps, with fractions inside long steps.
StagedProgress = Callable[[str, float, int], None] | None

#: Help text of the ``--quiet`` option of the commands that report progress.
QUIET_HELP = "no progress bars, progress lines or progress messages on stderr"

#: Seconds between two progress lines when stderr is not a terminal.
LOG_INTERVAL = 5.0


def _clock_text(seconds: float) -> str:
    """``m:ss`` (``h:mm:ss`` from an hour on)."""
    s = round(max(seconds, 0.0))
    h, m = divmod(s, 3600)
    m, s = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


def interactive(stream: IO[str] | None = None) -> bool:
    """Whether ``stream`` (default: stderr) is a terminal, where progress bars are drawn."""
    stream = sys.stderr if stream is None else stream
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):  # closed or not a real stream
        return False


class Tracker:
    """A tqdm progress bar on stderr with messages above it.

    Parameters
    ----------
    desc
        Label of the bar (``"simulate"``, ``"sweep"``).
    unit
        Unit of the counted quantity (``"s"`` simulated time, ``"case"``).
    quiet
        Neither bars nor messages.
    stream
        Where to write (default: ``sys.stderr``); bars only when it is a terminal.
    bar
        Draw a bar (``None``: when ``stream`` is a terminal and not ``quiet``).
    interval
        Seconds between progress lines without a bar (default :data:`LOG_INTERVAL`).
    clock
        The clock of those lines (:func:`time.monotonic`).

    Notes
    -----
    Called with a string it prints the message (``tqdm.write`` while a bar is shown, so the bar
    stays intact); called with two numbers it advances the bar to ``done`` of ``total``. tqdm
    throttles redraws itself (``mininterval``), so a hook called often costs little.
    """

    def __init__(
        self,
        desc: str = "",
        *,
        unit: str = "it",
        quiet: bool = False,
        stream: IO[str] | None = None,
        bar: bool | None = None,
        interval: float | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.desc = desc
        self.unit = unit
        self.quiet = quiet
        self._stream = stream
        self._bar_enabled = (not quiet and interactive(stream)) if bar is None else bool(bar)
        self._bar: Any = None
        self._interval = LOG_INTERVAL if interval is None else float(interval)
        self._clock = clock
        self._last_line = clock()          # nothing in the first interval: short work is quiet
        self._stage_start: float | None = None

    @property
    def stream(self) -> IO[str]:
        """The stream written to (stderr unless given)."""
        return sys.stderr if self._stream is None else self._stream

    # ------------------------------------------------------------------ hooks
    def __call__(self, what: str | float, done: float | None = None,
                 total: float | None = None) -> None:
        """A message hook (``what`` a string), a counted hook (``what`` done of ``done``,
        the total) or a staged hook (stage ``what``, ``done`` of ``total``)."""
        if isinstance(what, str):
            if done is None:
                self.say(what)
            else:
                self.stage(what, done, total if total is not None else done)
        else:
            self.advance(float(what), float(done if done is not None else what))

    def stage(self, name: str, done: float, total: float) -> None:
        """Move the bar of stage ``name`` to ``done`` of ``total`` (a new bar, labelled
        ``name``, when the stage changes)."""
        if name != self.desc:
            self.close()
            self.desc = name
            self._stage_start = None
        self.advance(float(done), float(total))

    def say(self, message: str) -> None:
        """Print one message line (unless quiet)."""
        if self.quiet or not message:
            return
        if self._bar is not None:
            from tqdm import tqdm

            tqdm.write(f"  {message}", file=self.stream)
        else:
            print(f"  {message}", file=self.stream, flush=True)

    def advance(self, done: float, total: float, message: str = "") -> None:
        """Move the bar to ``done`` of ``total`` (with ``message`` beside it); without a bar
        (not a terminal) the message is printed, and a progress line every
        :data:`LOG_INTERVAL` seconds (:meth:`log_line`)."""
        if not self._bar_enabled:
            self.say(message)
            self.log_line(done, total)
            return
        if self._bar is None:
            from tqdm import tqdm

            self._bar = tqdm(total=total, desc=self.desc, unit=self.unit, file=self.stream,
                             dynamic_ncols=True, leave=False, unit_scale=self.unit != "case")
        bar = self._bar
        if bar.total != total:
            bar.total = total
        if message:
            bar.set_postfix_str(message, refresh=False)
        step = min(done, total) - bar.n
        if step > 0:
            bar.update(step)

    def log_line(self, done: float, total: float) -> None:
        """Print ``stage: done/total unit (p %), m:ss elapsed, about m:ss left`` when the
        interval since the last line has passed (unless quiet); the estimate assumes the rest
        of the stage goes at the pace of its part done."""
        now = self._clock()
        if self._stage_start is None:
            self._stage_start = now
        if self.quiet or now - self._last_line < self._interval:
            return
        self._last_line = now
        frac = min(max(done / total, 0.0), 1.0) if total > 0 else 0.0
        elapsed = now - self._stage_start
        unit = f" {self.unit}" if self.unit not in ("", "it") else ""
        line = (f"{self.desc or 'progress'}: {done:.4g}/{total:.4g}{unit} ({100 * frac:.0f} %), "
                f"{_clock_text(elapsed)} elapsed")
        if 0 < frac < 1:
            line += f", about {_clock_text(elapsed * (1 - frac) / frac)} left"
        print(line, file=self.stream, flush=True)

    def close(self) -> None:
        """Remove the bar (if one was drawn)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> Tracker:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def report(
    progress: Callable[..., Any] | None,
    message: str = "",
    done: float | None = None,
    total: float | None = None,
) -> None:
    """Report one step of a counted loop to a hook of either kind.

    A :class:`Tracker` advances its bar to ``done`` of ``total`` (with the message beside it;
    printed as a line where no bar is drawn); any other hook is a message hook and gets
    ``message``; ``None`` does nothing.
    """
    if progress is None:
        return
    if isinstance(progress, Tracker) and done is not None and total is not None:
        progress.advance(done, total, message)
    elif message:
        progress(message)


class Steps:
    """The steps of one stage of staged work, each reported to a staged hook.

    Parameters
    ----------
    progress
        ``progress(stage, done, total)`` (a :class:`Tracker` or any callable), or ``None``.
    stage
        Name of the stage (``"kinematics"``).
    total
        Number of steps.

    Examples
    --------
    >>> calls = []
    >>> step = Steps(lambda *a: calls.append(a), "frames", 2)
    >>> step(); step()
    >>> calls
    [('frames', 1, 2), ('frames', 2, 2)]
    """

    def __init__(self, progress: StagedProgress, stage: str, total: int) -> None:
        self.progress = progress
        self.stage = stage
        self.total = max(int(total), 1)
        self.done = 0
        self._last = 0.0

    def __call__(self) -> None:
        """One step done (never past ``total``)."""
        if self.progress is None or self.done >= self.total:
            return
        self.done += 1
        self._last = float(self.done)
        self.progress(self.stage, self.done, self.total)

    def part(self, lo: float = 0.0, hi: float = 1.0) -> Callable[[float], None] | None:
        """A hook ``tick(f)`` for the inside of the current step: ``f`` in [0, 1] of a long
        loop is reported as ``done + lo + f (hi − lo)`` (a fraction of the step, only when it
        increases); ``None`` without a hook, so loops can skip the calls."""
        if self.progress is None:
            return None

        def tick(f: float) -> None:
            value = self.done + lo + (hi - lo) * min(max(float(f), 0.0), 1.0)
            if self._last < value < min(self.done + 1, self.total):  # inside the step
                self._last = value
                self.progress(self.stage, value, self.total)  # type: ignore[misc, arg-type]

        return tick
