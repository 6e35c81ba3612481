"""Per-case summary metrics of a sweep: a few numbers per case instead of whole histories.

A summary is written ``METRIC:CHANNEL`` or ``METRIC:CHANNEL:OPTION=VALUE``:

| metric | value | options |
|---|---|---|
| ``peak`` | max abs x(t) | ``after`` (s): only t >= after |
| ``rms`` | root mean square of x(t) over the samples | ``after`` |
| ``max``, ``min``, ``mean`` | of x(t) | ``after`` |
| ``final`` | x at the last output time | |
| ``residual`` | max abs x(t) for t >= after: the vibration left after a manoeuvre | ``after`` (required) |
| ``settling`` | first time after which abs(x(t) - x_final) stays <= band (s); NaN if the last sample but one is outside the band (not settled by the end of the run) | ``band`` (required, the channel's unit) |

The summary's variable in the sweep's Dataset is named after the text, e.g.
``peak_link2_tip_deflection``, ``residual_link2_tip_deflection_after_3s``; its unit is the
channel's (``s`` for ``settling``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..channels import Channel
from .errors import SweepError

METRICS = ("peak", "rms", "max", "min", "mean", "final", "residual", "settling")
OPTIONS = {"peak": ("after",), "rms": ("after",), "max": ("after",), "min": ("after",),
           "mean": ("after",), "final": (), "residual": ("after",), "settling": ("band",)}
REQUIRED = {"residual": "after", "settling": "band"}
DESCRIPTIONS = {
    "peak": "peak absolute value", "rms": "root mean square", "max": "maximum",
    "min": "minimum", "mean": "mean", "final": "value at the last output time",
    "residual": "peak absolute value after the manoeuvre",
    "settling": "settling time to within the band of the final value (NaN: not settled "
                "by the end of the run)",
}
EXAMPLE = "peak:link2_tip_deflection, residual:link2_tip_deflection:after=3"


@dataclass(frozen=True)
class Summary:
    """One per-case metric of one channel; ``after`` in s, ``band`` in the channel's unit."""

    metric: str
    channel: str
    after: float | None = None
    band: float | None = None

    @property
    def name(self) -> str:
        """The Dataset variable's name."""
        name = f"{self.metric}_{self.channel}"
        if self.after is not None:
            name += f"_after_{_number(self.after)}s"
        if self.band is not None:
            name += f"_band_{_number(self.band)}"
        return name

    def unit(self, channel: Channel) -> str:
        return "s" if self.metric == "settling" else channel.unit

    def long_name(self, channel: Channel) -> str:
        text = f"{DESCRIPTIONS[self.metric]} of {channel.name}"
        if self.after is not None:
            text += f" from t = {self.after:g} s"
        if self.band is not None:
            text += f" (band {self.band:g} {channel.unit})"
        return text

    def evaluate(self, t: np.ndarray, x: np.ndarray) -> float:
        """The metric of one history ``x`` at the output times ``t`` (s); NaN if no sample
        lies at or after ``after``."""
        if self.metric == "final":
            return float(x[-1])
        if self.metric == "settling":
            outside = np.flatnonzero(np.abs(x - x[-1]) > self.band)
            if outside.size and outside[-1] >= t.size - 2:
                return math.nan  # inside only at the last sample, trivially: not settled
            return float(t[0] if outside.size == 0 else t[outside[-1] + 1])
        if self.after is not None:
            x = x[t >= self.after - 1e-12 * max(1.0, abs(self.after))]
            if x.size == 0:
                return math.nan
        if self.metric in ("peak", "residual"):
            return float(np.max(np.abs(x)))
        if self.metric == "rms":
            return float(np.sqrt(np.mean(np.square(x))))
        return float(getattr(np, self.metric)(x))


def parse_summary(text: str) -> Summary:
    """``METRIC:CHANNEL[:OPTION=VALUE …]`` → Summary (SweepError naming the problem)."""
    def refuse(problem: str) -> SweepError:
        return SweepError([f"summary {text!r}: {problem}"])

    parts = [p.strip() for p in str(text).split(":")]
    if len(parts) < 2 or not parts[0] or not parts[1]:
        raise refuse(f"write METRIC:CHANNEL[:OPTION=VALUE], e.g. {EXAMPLE}")
    metric, channel, options = parts[0].lower(), parts[1], parts[2:]
    if metric not in METRICS:
        raise refuse(f"unknown metric {metric!r}; choose one of {', '.join(METRICS)}")
    values: dict[str, float] = {}
    for option in options:
        key, _, value = (part.strip() for part in option.partition("="))
        if key not in OPTIONS[metric]:
            allowed = ", ".join(OPTIONS[metric]) or "none"
            raise refuse(f"{metric} takes no option {key!r} (options: {allowed})")
        try:
            number = float(value)
        except ValueError:
            raise refuse(f"{key} must be a number, got {value!r}") from None
        if not math.isfinite(number) or number < 0 or (key == "band" and number == 0):
            raise refuse(f"{key} must be a finite number {'> 0' if key == 'band' else '>= 0'}, "
                         f"got {value}")
        values[key] = number
    need = REQUIRED.get(metric)
    if need is not None and need not in values:
        example = "3" if need == "after" else "1e-3"
        raise refuse(f"{metric} needs {need}=…, e.g. {metric}:{channel}:{need}={example}")
    return Summary(metric, channel, values.get("after"), values.get("band"))


def parse_summaries(items: Sequence[str | Summary]) -> list[Summary]:
    """Every summary parsed, all problems at once; a name given twice is refused."""
    parsed, problems = [], []
    for item in items:
        try:
            parsed.append(item if isinstance(item, Summary) else parse_summary(item))
        except SweepError as exc:
            problems += exc.problems
    names = [s.name for s in parsed]
    problems += [f"summary {name} is given twice" for name in sorted(set(names))
                 if names.count(name) > 1]
    if problems:
        raise SweepError(problems)
    return parsed


def check_channels(summaries: Sequence[Summary], known: Sequence[str], t_end: float) -> None:
    """Every summary names a channel the scenario produces and a time inside the run."""
    problems = [f"summary {s.name}: unknown channel {s.channel!r}; available: "
                f"{', '.join(known)}" for s in summaries if s.channel not in known]
    problems += [f"summary {s.name}: after = {s.after:g} s is past the end of the run "
                 f"(t_end = {t_end:g} s)" for s in summaries
                 if s.after is not None and s.after > t_end]
    if problems:
        raise SweepError(problems)


def _number(value: float) -> str:
    """A number as a variable-name fragment: 3 → '3', 0.25 → '0p25', 1e-3 → '0p001'."""
    text = f"{value:g}".replace("-", "m").replace("+", "")
    return re.sub(r"\.", "p", text)
