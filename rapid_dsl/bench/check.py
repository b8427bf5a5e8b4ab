"""`rapidc bench check`: how fast the front end is.

Measures, on generated programs that check clean (builtins and the standard library only):
- checking a ~2,000-line program (lines per second, warm),
- checking every file of the standard library,
- checking a ~200-line strategy file in a running process (target < 50 ms),
- `rapidc check` of that file as a new process, start-up included (target < 100 ms; the sources
  compile anew each time when PYTHONDONTWRITEBYTECODE is set, which costs about 40 ms more),
- how checking scales with operator chains and runs of prefixes: n and 4n terms (default 10,000
  and 40,000) as one expression, which the parser refuses (E0409) as it reads past the
  depth limit, and as many expressions within the limit, which check clean.
"""

from __future__ import annotations

import gc
import json
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from importlib import resources
from pathlib import Path

WARM_TARGET_MS = 50.0
STARTUP_TARGET_MS = 100.0
WITHIN = 200        # terms of one expression in the shapes that check clean (the limit is 400)


def _unit(i: int) -> str:
    """One def, relation, primitive and strategy (about 45 lines) that check clean."""
    return f"""\
def lift_{i}(o: Body, s: Body) -> Length = height(o) - top(s)
relation near_{i}(a: Body, b: Body) = distance(a, b) < {i % 9 + 1}cm

primitive nudge_{i} {{
  goal "Nudge the object toward the fixture, variant {i}"
  roles {{ target: Object, support: Surface, wall: Fixture, hand: Manipulator }}
  requires {{
    on(target, support)
    reachable(hand, target)
  }}
  params {{ gap: Length in [1cm, 5cm] = 2cm, turn: Angle = 0deg }}
  resolve {{
    d = distance(target, wall)
    h = lift_{i}(target, support)
    turned = rotation(target, about=up)
  }}
  success {{
    d < gap
    abs(turned - turn) < 10deg
    settled(target)
  }}
  cost final = ((d - gap) / 1cm)^2 + abs(h) / 1cm + ((turned - turn) / 10deg)^2
  cost progress weight 0.1 = distance(hand, target) / 1cm
  motion {{
    keypoint reach = pos(target) - 4cm * direction(target, wall) + 3cm * up gripper closed
    keypoint push = reach + (d - gap + 4cm) * direction(target, wall)
    spread 1cm
    duration 2s
  }}
  optimize {{ samples 32; elites 4; iterations 3 }}
  filter {{ extents(target).z < 10cm }}
}}

strategy approach_{i} {{
  goal "Bring the object close to the wall, variant {i}"
  roles {{ box: Object, table: Surface, wall: Fixture, hand: Manipulator }}
  requires {{ on(box, table); reachable(hand, box) }}
  let margin = {i % 5 + 1}cm
  phase first: nudge_{i}(target=box, support=table, wall=wall, hand=hand) {{
    gap = margin + 1cm
  }}
  phase second: nudge_{i}(target=box, support=table, wall=wall, hand=hand)
  success {{ near_{i}(box, wall) or distance(box, wall) < margin }}
}}

"""


def generate_program(lines: int) -> str:
    """A clean program of at least `lines` lines."""
    parts: list[str] = []
    count = 0
    while count < lines:
        parts.append(_unit(len(parts)))
        count += parts[-1].count("\n")
    return "".join(parts)


def generate_strategy_file(lines: int = 200) -> str:
    """A strategy file of about `lines` lines: local primitives plus one long strategy."""
    head = "use stdlib.{push, flip}\n\n"
    units = ""
    while len(units) == 0 or (units + _unit(0)).count("\n") <= lines - 45:
        units += _unit(units.count("strategy approach_"))
    phases = "".join(
        f"  phase p{k}: nudge_0(target=box, support=table, wall=wall, hand=hand) {{\n"
        f"    gap = {k % 4 + 1}cm\n  }}\n"
        for k in range(max(1, (lines - units.count("\n") - 17) // 3)))
    strategy = ("strategy long_run {\n"
                '  goal "Push, nudge and flip the box against the wall"\n'
                "  roles { box: Object, table: Surface, wall: Fixture, hand: Manipulator }\n"
                "  requires { on(box, table); faces(wall, box); reachable(hand, box) }\n"
                "  phase shove: push(target=box, support=table, hand=hand) {\n"
                "    displacement = (distance(box, wall) - 1cm) * direction(box, wall)\n  }\n"
                f"{phases}"
                "  phase tip: flip(target=box, support=table, fixture=wall, hand=hand) {\n"
                "    angle = 90deg - tilt(box)\n  }\n"
                "  success { tilt(box) > 60deg }\n}\n")
    return head + units + strategy


def _one(head: str, terms: list[str] | str, join: str = "") -> str:
    return head + (terms if isinstance(terms, str) else join.join(terms)) + "\n"


def _split(n: int, make: Callable[[int, int], str]) -> str:
    """n terms in all, as declarations `make(i, terms)` of at most WITHIN terms each."""
    return "".join(make(i, min(WITHIN, n - i * WITHIN)) for i in range(-(-n // WITHIN)))


# name -> (what it is, its program of n terms, the one error it must give or None: clean)
SHAPES: dict[str, tuple[str, Callable[[int], str], str | None]] = {
    "sum": ("one sum `1 + 1 + ...`",
            lambda n: _one("def f() -> Real = ", ["1"] * n, " + "), "E0409"),
    "product": ("one product `x * x * ...`",
                lambda n: _one("def f(x: Real) -> Real = ", ["x"] * n, " * "), "E0409"),
    "and": ("one `1 < 2 and 1 < 2 and ...`",
            lambda n: _one("relation r() = ", ["1 < 2"] * n, " and "), "E0409"),
    "comparisons": ("one `1 < 1 < 1 ...`",
                    lambda n: _one("relation r() = ", ["1"] * n, " < "), "E0409"),
    "minus": ("one run `- - - ... 1`",
              lambda n: _one("def f() -> Real = ", "- " * n + "1"), "E0409"),
    "not": ("one run `not not ... 1 < 2`",
            lambda n: _one("relation r() = ", "not " * n + "1 < 2"), "E0409"),
    "sums": (f"sums of {WITHIN} terms", lambda n: _split(n, lambda i, k: _one(
        f"def f{i}() -> Real = ", ["1"] * k, " + ")), None),
    "minus_runs": (f"runs of {WITHIN} `-`", lambda n: _split(n, lambda i, k: _one(
        f"def f{i}() -> Real = ", "- " * k + "1")), None),
}


@dataclass
class Scaling:
    shape: str
    terms: int
    ms: float            # CPU time of checking n terms, best of the runs
    ms_4n: float         # the same for 4n terms

    @property
    def ratio(self) -> float:
        return self.ms_4n / max(self.ms, 1e-3)


@dataclass
class Numbers:
    program_lines: int
    program_ms: float
    stdlib_files: int
    stdlib_lines: int
    stdlib_ms: float
    strategy_lines: int
    strategy_ms: float
    startup_ms: float
    python_ms: float
    errors: int
    scaling: list[Scaling]

    @property
    def lines_per_second(self) -> float:
        return self.program_lines / (self.program_ms / 1000.0)


def _median_ms(action: Callable[[], object], runs: int,
               setup: Callable[[], object] = lambda: None) -> float:
    times = []
    for _ in range(runs):
        setup()
        start = time.perf_counter()
        action()
        times.append((time.perf_counter() - start) * 1000.0)
    return statistics.median(times)




def cpu_ms(text: str, runs: int) -> tuple[float, list[str]]:
    """CPU time of checking `text` anew (best of `runs`: a busy machine adds, never takes away)
    and the codes of its errors."""
    from rapid_dsl.frontend.driver import check_text
    from rapid_dsl.frontend.parser import forget_parsed

    best, codes = float("inf"), []
    for _ in range(runs):
        forget_parsed()
        gc.collect()
        start = time.process_time()
        result = check_text(text, "scaling.rapid")
        best = min(best, time.process_time() - start)
        codes = [d.code for d in result.diagnostics if d.is_error]
    return best * 1000.0, codes


def scaling(terms: int, runs: int) -> tuple[list[Scaling], int]:
    """Each shape at `terms` and 4x `terms`; and how many results were not the expected one."""
    out, wrong = [], 0
    for name, (_, make, expected) in SHAPES.items():
        (small, codes), (large, codes_4n) = cpu_ms(make(terms), runs), \
            cpu_ms(make(4 * terms), runs)
        wanted = [expected] if expected else []
        wrong += (codes != wanted) + (codes_4n != wanted)
        out.append(Scaling(name, terms, small, large))
    return out, wrong


def measure(lines: int = 2000, runs: int = 5, terms: int = 10_000) -> Numbers:
    from rapid_dsl.frontend.driver import check_file
    from rapid_dsl.frontend.parser import forget_parsed
    from rapid_dsl.language.files import write_atomic

    errors = 0
    with tempfile.TemporaryDirectory(prefix="rapidc-bench-") as folder:
        program_text, strategy_text = generate_program(lines), generate_strategy_file(200)
        big = write_atomic(Path(folder, "big.rapid"), program_text)
        strategy = write_atomic(Path(folder, "strategy.rapid"), strategy_text)
        small = write_atomic(Path(folder, "small.rapid"), _unit(0))

        def check(path: Path) -> int:
            nonlocal errors
            forget_parsed()  # every measured check parses its file and the stdlib it uses anew
            errors += sum(d.is_error for d in check_file(str(path)).diagnostics)
            return errors

        check(small)  # warm up: grammar, imports, standard library
        # the garbage of one run is collected before the next, not during it
        program_ms = _median_ms(lambda: check(big), runs, gc.collect)
        strategy_ms = _median_ms(lambda: check(strategy), max(runs, 10), gc.collect)
        stdlib = sorted((f for f in resources.files("rapid_dsl.stdlib_primitives").iterdir()
                         if f.name.endswith(".rapid")), key=lambda f: f.name)
        stdlib_lines = sum(f.read_text(encoding="utf-8").count("\n") for f in stdlib)
        stdlib_ms = _median_ms(lambda: [check(Path(str(f))) for f in stdlib], runs, gc.collect)
        startup_ms = _median_ms(lambda: subprocess.run(
            [sys.executable, "-m", "rapid_dsl", "check", "--quiet", str(strategy)], check=False,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL), runs)
        python_ms = _median_ms(lambda: subprocess.run([sys.executable, "-c", "pass"],
                                                      check=False), runs)
    rows, wrong = scaling(terms, runs)
    return Numbers(program_text.count("\n"), program_ms, len(stdlib), stdlib_lines, stdlib_ms,
                   strategy_text.count("\n"), strategy_ms, startup_ms, python_ms,
                   errors + wrong, rows)


def report(n: Numbers) -> str:
    def verdict(value: float, target: float) -> str:
        return f"(target < {target:.0f} ms: {'ok' if value < target else 'MISSED'})"

    return "\n".join([
        (f"check {n.program_lines}-line program:    {n.program_ms:8.1f} ms  "
         f"= {n.lines_per_second:,.0f} lines/s"),
        f"check stdlib ({n.stdlib_files} files, {n.stdlib_lines} lines): {n.stdlib_ms:8.1f} ms",
        f"check {n.strategy_lines}-line strategy file: {n.strategy_ms:8.1f} ms  "
        + verdict(n.strategy_ms, WARM_TARGET_MS),
        f"`rapidc check` process, that file: {n.startup_ms:8.1f} ms  "
        + verdict(n.startup_ms, STARTUP_TARGET_MS)
        + f"  [`python -c pass`: {n.python_ms:.1f} ms]",
        "",
        *scaling_report(n.scaling),
    ])


def scaling_report(rows: list[Scaling]) -> list[str]:
    if not rows:
        return []
    n = rows[0].terms
    head = f"{'scaling (CPU ms, best of the runs)':40} {f'n = {n:,}':>12} {f'4n = {4 * n:,}':>14}"
    lines = [head + "   4n / n"]
    for row in rows:
        label, _, expected = SHAPES[row.shape]
        label += f" ({expected})" if expected else " (clean)"
        lines.append(f"{label:40} {row.ms:12.1f} {row.ms_4n:14.1f} {row.ratio:8.1f}x")
    return lines


def main(*, lines: int = 2000, runs: int = 5, terms: int = 10_000, as_json: bool = False) -> int:
    numbers = measure(lines, runs, terms)
    if as_json:
        document = asdict(numbers)
        for row, plain in zip(numbers.scaling, document["scaling"], strict=True):
            plain["ratio"] = row.ratio
        print(json.dumps({**document, "lines_per_second": numbers.lines_per_second}, indent=2))
    else:
        print(report(numbers))
    if numbers.errors:
        print(f"rapidc: error: the generated programs have {numbers.errors} unexpected errors; "
              "the numbers above do not measure what they name", file=sys.stderr)
        return 1
    return 0
