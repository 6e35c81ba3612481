"""report.html: one self-contained page per run, compare, fit or sweep.

Everything is inline, nothing is fetched when the page is viewed: PNG figures and the GIF
animation as base64 data URIs, traces as JSON drawn by a small inline script (drag across a
trace to zoom in on time, double-click to zoom out) into SVG. The page adds to the folder; it
replaces none of its files.
"""

from __future__ import annotations

import base64
import html
import json
import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..channels import ChannelKind, ChannelTable, kind_summary
from .atomic import atomic_file
from .folder import REPORT_NAME
from .plotting import display_scale
from .variables import Layout

MAX_POINTS = 3000  # per trace: min/max per bucket keeps every peak, the page stays small


@dataclass
class Trace:
    """One zoomable panel: ``t`` (s) and named series in display units."""

    title: str
    unit: str
    t: np.ndarray
    series: dict[str, np.ndarray]


@dataclass
class ReportPage:
    """The parts of a page, in order; `html()` renders it."""

    title: str
    summary: dict[str, Any] = field(default_factory=dict)
    # HTML, or a function giving it when the page is rendered (figures drawn meanwhile)
    sections: list[str | Callable[[], str]] = field(default_factory=list)

    def add_table(self, heading: str, rows: Sequence[Mapping[str, Any]],
                  note: str = "") -> None:
        """A table of dicts (their keys are the columns)."""
        if not rows:
            return
        columns = list(dict.fromkeys(k for row in rows for k in row))
        head = "".join(f"<th>{html.escape(str(c))}</th>" for c in columns)
        body = "".join("<tr>" + "".join(f"<td>{_cell(row.get(c))}</td>" for c in columns)
                       + "</tr>" for row in rows)
        extra = f"<p class='note'>{html.escape(note)}</p>" if note else ""
        self.sections.append(f"<h2>{html.escape(heading)}</h2><table><thead><tr>{head}</tr>"
                             f"</thead><tbody>{body}</tbody></table>{extra}")

    def add_traces(self, heading: str, traces: Sequence[Trace]) -> None:
        """Zoomable time traces (drag to zoom on time, double-click to reset)."""
        if not traces:
            return
        panels = "".join(
            f"<div class='trace' data-trace='{html.escape(_trace_text(tr))}'>"
            "</div>" for tr in traces)
        self.sections.append(f"<h2>{html.escape(heading)}</h2><p class='note'>Drag across a "
                             "trace to zoom in on time; double-click to zoom out.</p>" + panels)

    def add_images(self, heading: str, paths: Sequence[Path]) -> None:
        """PNG or GIF files, inlined."""
        section = _images_html(heading, paths)
        if section:
            self.sections.append(section)

    def add_images_later(self, heading: str, find: Callable[[], Sequence[Path]]) -> None:
        """PNG or GIF files, found (``find()``) and inlined when the page is rendered: the
        rest of a run's page is built while its figures are drawn."""
        self.sections.append(lambda: _images_html(heading, find()))

    def add_text(self, heading: str, text: str) -> None:
        """Preformatted text (the scenario)."""
        self.sections.append(f"<h2>{html.escape(heading)}</h2><details open><summary>show"
                             f"</summary><pre>{html.escape(text)}</pre></details>")

    def html(self) -> str:
        rows = "".join(f"<tr><th>{html.escape(str(k))}</th><td>{_cell(v)}</td></tr>"
                       for k, v in self.summary.items())
        return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>"
                f"<meta name='viewport' content='width=device-width, initial-scale=1'>"
                f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>"
                f"<h1>{html.escape(self.title)}</h1><table class='summary'>{rows}</table>"
                + "".join(s() if callable(s) else s for s in self.sections)
                + f"<script>{_SCRIPT}</script></body></html>")

    def write(self, path: Path) -> Path:
        """Write the page atomically; return its path."""
        with atomic_file(path) as partial:
            partial.write_text(self.html(), encoding="utf-8")
        return Path(path)


def _images_html(heading: str, paths: Sequence[Path]) -> str:
    """A section of the files among ``paths`` that exist, inlined ("" if none)."""
    images = [p for p in paths if p.is_file()]
    if not images:
        return ""
    tags = "".join(f"<figure><img alt='{html.escape(p.stem)}' src='{data_uri(p)}'>"
                   f"<figcaption>{html.escape(p.name)}</figcaption></figure>"
                   for p in images)
    return f"<h2>{html.escape(heading)}</h2>{tags}"


def data_uri(path: Path) -> str:
    """The file as a base64 data URI (PNG or GIF)."""
    kind = "gif" if path.suffix.lower() == ".gif" else "png"
    return f"data:image/{kind};base64,{base64.b64encode(path.read_bytes()).decode('ascii')}"


def channel_traces(results: ChannelTable, kinds: Sequence[ChannelKind]) -> list[Trace]:
    """One trace per channel of the given kinds, in display units."""
    out = []
    for name in results.names_of(*kinds):
        channel = results.channels[name]
        factor, unit = display_scale(channel.unit)
        out.append(Trace(f"{name}: {channel.description}", unit, results.time,
                         {name: results[name] * factor}))
    return out


def run_page(folder: Path, results: ChannelTable, resolved_text: str,
             name: str | None = None) -> ReportPage:
    """The page of a run folder: summary, zoomable sensor and joint traces, the figures, the
    animation if the folder has one, the resolved scenario. ``name``: the folder's name when
    ``folder`` is where it is being written (an atomic write's hidden partial folder). The
    figures and the animation are read when the page is rendered (`ReportPage.html`), so the
    page may be built while they are still being drawn."""
    meta = results.metadata
    t = results.time
    name = name or folder.name
    page = ReportPage(f"flexlink run: {meta.get('scenario', name)}")
    page.summary = {"folder": name, "time": f"{t[0]:g} … {t[-1]:g} s, {t.size} samples",
                    **run_summary(meta), "channels": kind_summary(results.channels.values())}
    page.add_traces("Signals", channel_traces(results, (ChannelKind.SENSOR, ChannelKind.JOINT,
                                                        ChannelKind.BASE)))
    page.add_images_later("Animation", lambda: [folder / "animation.gif"])
    page.add_images_later("Figures", lambda: sorted((folder / "figures").glob("*.png")))
    page.add_table("Peaks", [{"channel": n, "kind": c.kind.value, "unit": c.unit,
                              "peak |value|": float(np.abs(results[n]).max()),
                              "description": c.description}
                             for n, c in results.channels.items()])
    page.add_text("Scenario (scenario.resolved.toml)", resolved_text)
    return page


# The run metadata the summary shows, under readable names, with how each value is shown.
SUMMARY_FIELDS: dict[str, tuple[str, Callable[[Any], str]]] = {
    "model": ("model", lambda v: str(v).replace("_", "-")),
    "path": ("joints", lambda v: {"prescribed": "prescribed", "nonlinear": "prescribed",
                                  "closed_loop": "prescribed, in closed loop",
                                  "forward": "forward dynamics (driven joints or moving base)",
                                  "nonlinear_forward": "forward dynamics (driven joints or "
                                                       "moving base)"}.get(str(v), str(v))),
    "method": ("integrator", str),
    "geometric_stiffening": ("geometric stiffening", lambda v: "yes" if v else
                             "no (the paper's model)"),
    "elastic_coordinates": ("elastic coordinates", str),
    "wall_time_s": ("simulation time (wall clock)", lambda v: f"{float(v):.3g} s"),
    "peak_tip_deflection_per_length": ("largest tip deflection",
                                       lambda v: f"{100 * float(v):.1f}% of its link's length"),
    "accuracy": ("accuracy against the nonlinear model", str),
    "rtol": ("integration tolerance asked for (rtol)", lambda v: f"{float(v):g}"),
    "error_estimate": ("integration error estimate reached",
                       lambda v: f"{float(v):.2g} of the peak"),
    "error_estimate_measure": ("the estimate measures", str),
    "validity_warning": ("warning", str),
    "control_warning": ("closed-loop warning", str),
    "mode_bases": ("mode shapes", str),
    "mode_convergence_warning": ("mode-convergence warning", str),
    "flexlink_version": ("flexlink version", str),
}


def run_summary(meta: Mapping[str, Any]) -> dict[str, str]:
    """The summary rows of a run's metadata: readable names and values (SUMMARY_FIELDS)."""
    return {label: show(meta[key]) for key, (label, show) in SUMMARY_FIELDS.items()
            if key in meta}


def write_run_report(folder: Path, results: ChannelTable | None = None,
                     name: str | None = None) -> Path:
    """Write report.html into a run folder (reads the folder's results if not given);
    ``name``: the folder's final name if ``folder`` is a partial one."""
    from .folder import RESOLVED_NAME

    if results is None:
        from .reading import read_run

        results = read_run(folder)
    resolved = folder / RESOLVED_NAME
    text = resolved.read_text(encoding="utf-8") if resolved.is_file() else ""
    return run_page(folder, results, text, name).write(folder / REPORT_NAME)


def decimate(t: np.ndarray, ys: Sequence[np.ndarray], points: int = MAX_POINTS
             ) -> tuple[np.ndarray, list[np.ndarray]]:
    """At most ~``points`` samples: each bucket keeps the samples where any series has its
    minimum or maximum (the first such sample, NaN ignored), so no peak is lost."""
    n = t.size
    if n <= points:
        return t, list(ys)
    buckets = np.linspace(0, n, points // 2 + 1).astype(int)
    starts = buckets[:-1][buckets[1:] > buckets[:-1]]  # non-empty buckets
    bucket = np.repeat(np.arange(starts.size), np.diff(np.append(starts, n)))
    keep = [np.array([0, n - 1])]
    for y in ys:
        y = np.asarray(y, float)
        for reduce in (np.fmin, np.fmax):  # NaN-ignoring, like nanargmin / nanargmax
            extreme = reduce.reduceat(y, starts)
            hit = np.flatnonzero(y == extreme[bucket])
            first = np.unique(bucket[hit], return_index=True)[1]
            keep.append(hit[first])
    index = np.unique(np.concatenate(keep))
    return t[index], [y[index] for y in ys]


def _trace_text(trace: Trace) -> str:
    """The trace as JSON text: title, unit, the decimated times ``t`` and each series' ``y``,
    every number rounded to 6 significant digits (non-finite: null), the text json.dumps
    gives for them (a test), formatted all at once (`_numbers_text`)."""
    t, ys = decimate(np.asarray(trace.t, float), [np.asarray(v, float)
                                                   for v in trace.series.values()])
    series = ", ".join(f'{{"name": {json.dumps(n)}, "y": {_numbers_text(y)}}}'
                       for n, y in zip(trace.series, ys, strict=True))
    return (f'{{"title": {json.dumps(trace.title)}, "unit": {json.dumps(trace.unit)}, '
            f'"t": {_numbers_text(t)}, "series": [{series}]}}')


# Where the text of %.6g is not repr's (json's) of the value it rounds to: exponent form for
# 1e6 ≤ |x| < 1e16 (repr: positional), and subnormal numbers (fewer digits than 6 tell them
# apart, repr writes fewer)
_NOT_REPR = re.compile(r"e(?:\+(?:0[6-9]|1[0-5])|-3(?:0[89]|[1-9]\d))$")


def _numbers_text(values: np.ndarray) -> str:
    """The JSON list of ``values``, each rounded to 6 significant digits (non-finite: null),
    as json.dumps writes the rounded floats. One ``%`` formatting for all values instead of a format, a parse and a
    repr per value; the text of %.6g is repr's but for integral values (repr adds ".0"), the
    exponent form between 1e6 and 1e16 (repr writes those positional), subnormal values and
    non-finite ones."""
    if values.size == 0:
        return "[]"
    tokens = (("%.6g," * values.size) % tuple(values.tolist()))[:-1].split(",")
    for i, token in enumerate(tokens):
        if "e" in token:
            if _NOT_REPR.search(token):
                tokens[i] = repr(float(token))
        elif "n" in token:  # nan, inf, -inf
            tokens[i] = "null"
        elif "." not in token:  # integral: 12 → 12.0
            tokens[i] = token + ".0"
    return "[" + ", ".join(tokens) + "]"


def _cell(value: Any) -> str:
    if isinstance(value, float | np.floating):
        return "—" if not math.isfinite(value) else f"{value:.5g}"
    if value is None:
        return "—"
    return html.escape(str(value))


_CSS = """
body{font-family:system-ui,sans-serif;max-width:1000px;margin:1em auto;padding:0 1em;
color:#222}
h1{font-size:1.4em}h2{font-size:1.15em;margin-top:1.6em;border-bottom:1px solid #ccc}
table{border-collapse:collapse;font-size:.85em;margin:.5em 0}
td,th{border:1px solid #ddd;padding:.2em .5em;text-align:left;vertical-align:top}
table.summary th{background:#f4f4f4}
figure{display:inline-block;margin:.5em}img{max-width:100%}
figcaption{font-size:.8em;color:#555}pre{background:#f8f8f8;padding:.5em;overflow:auto;
font-size:.8em}
.note{font-size:.8em;color:#555}.trace{margin:.3em 0}
.trace svg{width:100%;height:auto;user-select:none;cursor:crosshair}
"""

# Zoomable traces without a library: SVG redrawn for the time range shown.
_SCRIPT = r"""
(function(){
var W=900,H=210,L=70,R=10,T=22,B=30,COL=['#c0392b','#1f77b4','#2ca02c','#9467bd','#8c564b',
'#e377c2','#7f7f7f','#bcbd22','#17becf','#ff7f0e'];
var NS='http://www.w3.org/2000/svg';
function el(n,a,p){var e=document.createElementNS(NS,n);for(var k in a)e.setAttribute(k,a[k]);
if(p)p.appendChild(e);return e;}
function ticks(a,b,n){var s=(b-a)/n,m=Math.pow(10,Math.floor(Math.log10(s||1))),r=s/m;
var st=(r<1.5?1:r<3.5?2:r<7.5?5:10)*m,out=[];for(var v=Math.ceil(a/st)*st;v<=b+st*1e-9;
v+=st)out.push(Math.abs(v)<st*1e-9?0:v);return out;}
function fmt(v){return Math.abs(v)>=1e4||(Math.abs(v)<1e-3&&v!==0)?v.toExponential(1):
+v.toPrecision(4)+'';}
function plot(div){var d=JSON.parse(div.getAttribute('data-trace'));var t=d.t;
var full=[t[0],t[t.length-1]];var svg=el('svg',{viewBox:'0 0 '+W+' '+H,role:'img'},div);
function draw(x0,x1){while(svg.firstChild)svg.removeChild(svg.firstChild);
var lo=Infinity,hi=-Infinity;d.series.forEach(function(s){for(var i=0;i<t.length;i++){
if(t[i]<x0||t[i]>x1||s.y[i]===null)continue;lo=Math.min(lo,s.y[i]);hi=Math.max(hi,s.y[i]);}});
if(!isFinite(lo)){lo=-1;hi=1;}if(hi-lo<1e-12){lo-=1;hi+=1;}var pad=(hi-lo)*0.06;lo-=pad;
hi+=pad;function X(v){return L+(v-x0)/(x1-x0)*(W-L-R);}function Y(v){return H-B-(v-lo)/
(hi-lo)*(H-T-B);}el('text',{x:L,y:14,'font-size':12},svg).textContent=d.title;
ticks(x0,x1,8).forEach(function(v){el('line',{x1:X(v),x2:X(v),y1:T,y2:H-B,stroke:'#eee'},svg);
el('text',{x:X(v),y:H-B+14,'font-size':10,'text-anchor':'middle'},svg).textContent=fmt(v);});
ticks(lo,hi,4).forEach(function(v){el('line',{x1:L,x2:W-R,y1:Y(v),y2:Y(v),stroke:'#eee'},svg);
el('text',{x:L-4,y:Y(v)+3,'font-size':10,'text-anchor':'end'},svg).textContent=fmt(v);});
el('rect',{x:L,y:T,width:W-L-R,height:H-T-B,fill:'none',stroke:'#999'},svg);
el('text',{x:W-R,y:H-4,'font-size':10,'text-anchor':'end'},svg).textContent='time t [s]';
el('text',{x:4,y:T+8,'font-size':10},svg).textContent='['+(d.unit||'-')+']';
d.series.forEach(function(s,k){var pts=[];for(var i=0;i<t.length;i++){if(t[i]<x0||t[i]>x1||
s.y[i]===null)continue;pts.push(X(t[i]).toFixed(1)+','+Y(s.y[i]).toFixed(1));}
el('polyline',{points:pts.join(' '),fill:'none',stroke:COL[k%COL.length],
'stroke-width':1.2,'class':'series'},svg);});if(d.series.length>1)d.series.forEach(function(s,k){
el('text',{x:W-R-4,y:T+12+12*k,'font-size':10,'text-anchor':'end',fill:COL[k%COL.length]},svg)
.textContent=s.name;});var sel=el('rect',{x:0,y:T,width:0,height:H-T-B,fill:'rgba(0,90,200,.15)'},
svg);var start=null;function tx(ev){var r=svg.getBoundingClientRect();var px=(ev.clientX-r.left)/
r.width*W;return x0+(Math.min(Math.max(px,L),W-R)-L)/(W-L-R)*(x1-x0);}
svg.onmousedown=function(ev){start=tx(ev);};svg.onmousemove=function(ev){if(start===null)return;
var a=X(Math.min(start,tx(ev))),b=X(Math.max(start,tx(ev)));sel.setAttribute('x',a);
sel.setAttribute('width',b-a);};svg.onmouseup=function(ev){if(start===null)return;var a=start,
b=tx(ev);start=null;if(Math.abs(b-a)>(x1-x0)*0.005)draw(Math.min(a,b),Math.max(a,b));
else sel.setAttribute('width',0);};svg.ondblclick=function(){draw(full[0],full[1]);};}
draw(full[0],full[1]);div.zoom=draw;}
Array.prototype.forEach.call(document.querySelectorAll('.trace'),plot);})();
"""


MAX_SWEEP_TRACES = 10  # cases overlaid in a sweep's traces
MAX_SWEEP_CHANNELS = 8
MAX_SWEEP_ROWS = 1000  # rows of the page's case table; the file holds every case


def sweep_report_path(sweep_file: Path) -> Path:
    """Where a sweep file's page goes: beside it, ``<stem>.html``."""
    return Path(sweep_file).with_suffix(".html")


def write_sweep_report(sweep_file: Path, animation: bool = False,
                       layout: Layout | None = None) -> Path:
    """Write the page of a sweep file: what was swept, every case's parameters and status,
    the channels of up to `MAX_SWEEP_TRACES` finished cases overlaid (zoomable), the base
    scenario; with ``animation`` also ``<stem>_animation.gif`` (cases overlaid; netCDF only).
    ``layout``: the file's content if at hand (read from the netCDF file otherwise)."""
    from .file_checks import read_sweep_layout

    sweep_file = Path(sweep_file)
    layout = layout or read_sweep_layout(sweep_file)
    attrs = layout.attrs
    status = np.asarray(layout.data["status"].values).astype(str)
    params = [n for n, v in layout.coords.items() if v.dims == ("case",) and n != "case"]
    page = ReportPage(str(attrs.get("title", "flexlink sweep")))
    page.summary = {"file": sweep_file.name, **{k: attrs[k] for k in (
        "parameters", "sampler", "seed", "sweep_state", "flexlink_version", "date_created")
        if k in attrs}, "cases": ", ".join(f"{s} {int((status == s).sum())}"
                                          for s in dict.fromkeys(status))}
    ok = np.flatnonzero(status == "ok")
    if "time" in layout.coords:  # a sweep that kept histories
        _add_sweep_traces(page, layout, ok, params)
    if animation:
        from .animation import animate_sweep, page_speed

        gif = sweep_file.with_name(f"{sweep_file.stem}_animation.gif")
        animate_sweep(sweep_file, gif,
                      speed=page_speed(np.asarray(layout.coords["time"].values, float)))
        page.add_images("Animation", [gif])
    summaries = [(n, v) for n, v in layout.data.items() if "metric" in v.attrs]
    rows = []
    for c in range(min(status.size, MAX_SWEEP_ROWS)):
        row: dict[str, Any] = {"case": c}
        row.update({p: layout.coords[p].values[c] for p in params})
        row["status"] = status[c]
        row.update({f"{n} [{v.attrs.get('units', '')}]": float(v.values[c])
                    for n, v in summaries})
        if "wall_time" in layout.data:
            row["wall time [s]"] = float(layout.data["wall_time"].values[c])
        if "error" in layout.data:
            row["error"] = str(layout.data["error"].values[c])
        rows.append(row)
    shown_rows = "" if status.size <= MAX_SWEEP_ROWS else \
        f" (the first {MAX_SWEEP_ROWS} of {status.size}; every case is in {sweep_file.name})"
    page.add_table(f"Cases{shown_rows}", rows)
    page.add_text("Base scenario", str(attrs.get("base_scenario", "")))
    return page.write(sweep_report_path(sweep_file))


def _add_sweep_traces(page: ReportPage, layout: Layout, ok: np.ndarray,
                      params: list[str]) -> None:
    """The channels of up to `MAX_SWEEP_TRACES` finished cases overlaid."""
    time = np.asarray(layout.coords["time"].values, float)
    shown = ok[:MAX_SWEEP_TRACES]
    label = {c: ", ".join(f"{p} = {layout.coords[p].values[c]:.4g}" for p in params)
             or f"case {c}" for c in shown}
    channels = [(n, v) for n, v in layout.data.items()
                if v.dims == ("case", "time") and "kind" in v.attrs]
    channels.sort(key=lambda nv: nv[1].attrs["kind"] != ChannelKind.SENSOR.value)
    traces = []
    for name, variable in channels[:MAX_SWEEP_CHANNELS]:
        factor, unit = display_scale(str(variable.attrs.get("units", "")))
        traces.append(Trace(f"{name}: {variable.attrs.get('long_name', '')}", unit, time,
                            {label[c]: np.asarray(variable.values[c], float) * factor
                             for c in shown}))
    page.add_traces(f"Channels of {shown.size} of {ok.size} finished cases", traces)
