"""The verification report as one self-contained HTML page (`rapidc verify --html`, docs/verify.md).

The page is made from the JSON report alone, plus the program's text and the `--media` key-frame
strips: inline CSS, inline SVG plots, images as data: URIs, no script and nothing fetched. Every
string from the program, the scene or the report is escaped by jinja2's autoescape: program text
is untrusted. Key frames are read only from the media folder the caller gives, by the names
verify writes (runtime/verification/runner.py), never from paths the report's records name; `rapidc
report` gives a folder the report names only when it lies in the report's own folder tree.

The page's size is bounded whatever the report holds: at most MAX_PLOTS phases are plotted, each
with the curves of its first MAX_CURVES runs, and a curve of more than MAX_POINTS iterations is
drawn through its first and last point and, for each of (MAX_POINTS - 2) / 2 equal stretches of
the rest, the stretch's lowest and highest cost in their order, so its shape (its range, its
spikes) survives the thinning.
"""

from __future__ import annotations

import base64
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import jinja2

from rapid_dsl.language.files import FileProblem, read_bytes, read_text, write_atomic
from rapid_dsl.runtime.verification.report import ReportProblem
from rapid_dsl.runtime.verification.runner import media_name

Record = dict[str, Any]
TEMPLATES = Path(__file__).resolve().parent   # page.html.jinja lies beside this module
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
MAX_CURVES = 200                  # cost curves drawn per phase: more only blur the plot
MAX_POINTS = 100                  # points drawn per curve (CEM runs at most 100 iterations)
MAX_PLOTS = 16                    # phases plotted; real programs have a few
PLOT = (560, 220, 48, 12, 28)     # width, height, left, right, bottom margins [px]
MAX_STRIPS = 100                  # key-frame strips embedded (about 100 kB each)


def render(report: Mapping[str, Any], *, program: str | None,
           media: str | os.PathLike[str] | None, notes: Mapping[str, str] | None = None) -> str:
    """The page. `program`: the program file (its text is shown, failing lines marked; None or
    unreadable: a note); `media`: the --media folder of the key-frame strips (None: a note);
    `notes`: why the "program" or "media" the report names was not read, said in its place."""
    notes = notes or {}
    env = jinja2.Environment(loader=jinja2.FileSystemLoader(TEMPLATES), autoescape=True,
                             undefined=jinja2.StrictUndefined)
    results: list[Record] = [r for r in report.get("results", []) if isinstance(r, dict)]
    summary = report.get("summary", {})
    name = str(report.get("program", ""))
    plots, more_plots = _plots(results)
    source, source_note = _program_text(program)
    if program is None and notes.get("program"):
        source_note = notes["program"]
    return env.get_template("page.html.jinja").render(
        report=report, summary=summary, rate=_rate(summary.get("success_rate")),
        failures=summary.get("failures", []), rejections=summary.get("rejections", []),
        runs=[_run_view(r, media, notes.get("media")) for r in results[:MAX_STRIPS]],
        more_runs=max(0, len(results) - MAX_STRIPS), media=media,
        plots=plots, more_plots=more_plots, max_points=MAX_POINTS, failing=_failing(results),
        lines=_lines(source, name, results), source_note=source_note, program_name=name)


def write_html(path: str | os.PathLike[str], report: Mapping[str, Any], *, program: str | None,
               media: str | os.PathLike[str] | None,
               inputs: Iterable[str | os.PathLike[str]] = (),
               notes: Mapping[str, str] | None = None) -> None:
    """Render and write the page atomically, never through a symlink, over one of `inputs` or
    over a file the page is made from (the program, the key-frame strips). Raises
    ReportProblem."""
    page = render(report, program=program, media=media, notes=notes)
    strips = sorted(Path(media).glob("*.png")) if media is not None else []
    try:
        write_atomic(path, page, inputs=[*inputs, *([program] if program else []), *strips])
    except FileProblem as exc:
        raise ReportProblem(f"cannot write {path}: {exc}") from None


def run_label(variant: int | None) -> str:
    return "the scene" if variant is None else f"variant {variant}"


def _rate(rate: Any) -> str:
    return "-" if not isinstance(rate, (int, float)) else f"{100 * rate:.1f}%"


def _program_text(program: str | None) -> tuple[list[str], str | None]:
    if program is None:
        return [], "the program's text was not given"
    try:
        return read_text(program).splitlines(), None
    except FileProblem as exc:
        return [], f"{program}: {exc}"


def _strip(media: str | os.PathLike[str] | None, variant: int | None,
           why_not: str | None = None) -> tuple[str | None, str]:
    """(a data: URI of the run's key-frame strip, None) or (None, why there is none)."""
    if media is None:
        return None, f"no key frames: {why_not or 'verify ran without --media DIR'}"
    path = Path(media) / media_name(variant)
    try:
        data = read_bytes(path)
    except FileProblem as exc:
        return None, f"no key frames: {path}: {exc}"
    if not data.startswith(PNG_MAGIC):
        return None, f"no key frames: {path} is not a PNG image"
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii"), ""


def _run_view(record: Record, media: str | os.PathLike[str] | None,
              why_not: str | None = None) -> Record:
    image, note = _strip(media, record.get("variant"), why_not)
    if record.get("media_error"):
        note = str(record["media_error"])
    return {"label": run_label(record.get("variant")), "outcome": str(record.get("outcome")),
            "failure": record.get("failure"), "image": image, "note": note}


def _number(value: Any, unit: Any) -> str:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return "-" if value is None else str(value)
    if unit == "m" and abs(value) < 10:
        return f"{100 * value:.3g} cm"
    if unit == "rad":
        return f"{math.degrees(value):.3g} deg"
    return f"{value:.4g} {unit}".rstrip()


def _failing(results: Sequence[Record]) -> list[Record]:
    """Each failed run's first failing clause, its value against its bound."""
    rows = []
    for record in results:
        failure = record.get("first_failure")
        if not isinstance(failure, dict):
            continue
        clause = _clause(failure)
        unit = clause.get("unit", "")
        value, bound = clause.get("value"), clause.get("bound")
        ratio = None
        if isinstance(value, (int, float)) and isinstance(bound, (int, float)) and bound:
            ratio = min(2.0, max(0.0, abs(value / bound)))
        rows.append({"label": run_label(record.get("variant")), "phase": failure.get("phase"),
                     "stage": failure.get("stage"), "clause": clause.get("text"),
                     "location": failure.get("location"), "value": _number(value, unit),
                     "bound": _number(bound, unit), "ratio": ratio,
                     "message": failure.get("message")})
    return rows


def _clause(failure: Record) -> Record:
    clause = failure.get("clause")
    return clause if isinstance(clause, dict) else {}


def _plots(results: Sequence[Record]) -> tuple[list[Record], int]:
    """Per phase (the first MAX_PLOTS), an SVG line plot of the best CEM cost per iteration of
    every run; and how many more phases had costs."""
    curves: dict[str, list[tuple[str, list[tuple[int, float]]]]] = {}
    for record in results:
        for phase in record.get("phases", []):
            costs = [(i, c) for i, c in enumerate(phase.get("best_cost_per_iteration", []))
                     if isinstance(c, (int, float)) and math.isfinite(c)]
            if costs:
                curves.setdefault(str(phase.get("name")), []).append(
                    (str(record.get("outcome")), costs))
    width, height, left, right, bottom = PLOT
    plots = []
    for name, lines in list(curves.items())[:MAX_PLOTS]:
        shown = lines[:MAX_CURVES]
        top = max(c for _, cs in shown for _, c in cs)
        low = min(c for _, cs in shown for _, c in cs)
        span = (top - low) or 1.0
        steps = max(cs[-1][0] for _, cs in shown) + 1
        inner_w, inner_h = width - left - right, height - bottom - 10

        def x(i: int, steps: int = steps, inner_w: int = inner_w) -> float:
            return left + (inner_w * i / (steps - 1) if steps > 1 else inner_w / 2)

        def y(c: float, low: float = low, span: float = span, inner_h: int = inner_h) -> float:
            return 10 + inner_h * (1 - (c - low) / span)

        drawn = [(outcome, thinned(cs)) for outcome, cs in shown]
        plots.append({
            "phase": name, "width": width, "height": height, "left": left,
            "bottom": height - bottom, "right": width - right, "steps": steps,
            "top_label": f"{top:.3g}", "low_label": f"{low:.3g}", "drawn": len(shown),
            "total": len(lines), "thinned": any(len(p) < len(cs) for (_, p), (_, cs)
                                                in zip(drawn, shown, strict=True)),
            "lines": [{"outcome": outcome,
                       "points": " ".join(f"{x(i):.1f},{y(c):.1f}" for i, c in points),
                       "dots": [(round(x(i), 1), round(y(c), 1)) for i, c in points]}
                      for outcome, points in drawn]})
    return plots, max(0, len(curves) - MAX_PLOTS)


def thinned(points: Sequence[tuple[int, float]],
            limit: int = MAX_POINTS) -> list[tuple[int, float]]:
    """At most `limit` of the (iteration, cost) points: all of them if they fit, else the first,
    the last, and the lowest and highest of each of (limit - 2) // 2 equal stretches between,
    in their order."""
    if len(points) <= limit:
        return list(points)
    inner = points[1:-1]
    buckets = (limit - 2) // 2
    kept = [points[0]]
    for k in range(buckets):
        stretch = inner[k * len(inner) // buckets:(k + 1) * len(inner) // buckets]
        if stretch:
            ends = {min(stretch, key=lambda p: p[1]), max(stretch, key=lambda p: p[1])}
            kept.extend(sorted(ends))
    kept.append(points[-1])
    return kept


def _lines(source: list[str], name: str, results: Sequence[Record]) -> list[Record]:
    """The program's lines, each with the failing clauses (and their phases) found on it."""
    marks: dict[int, set[str]] = {}
    for record in results:
        failure = record.get("first_failure")
        if not isinstance(failure, dict):
            continue
        clause = _clause(failure)
        for where in (failure.get("location"), clause.get("location"), _phase_origin(record)):
            line = _line_in(where, name)
            if line is not None:
                marks.setdefault(line, set()).add(str(failure.get("message") or ""))
    return [{"number": n, "text": text, "marks": sorted(marks.get(n, ()))}
            for n, text in enumerate(source, start=1)]


def _phase_origin(record: Record) -> str | None:
    failure = record.get("first_failure") or {}
    for phase in record.get("phases", []):
        if phase.get("name") == failure.get("phase"):
            origin = phase.get("origin")
            return origin if isinstance(origin, str) else None
    return None


def _line_in(location: Any, name: str) -> int | None:
    """The line of a `FILE:LINE[:COL]` location in the program `name`, else None."""
    if not isinstance(location, str) or not location.startswith(name + ":"):
        return None
    line = location[len(name) + 1:].split(":")[0]
    return int(line) if line.isdigit() else None
