"""The soak: N seeded crew days of ``helixd serve`` against the built-in simulator on the
simulated clock, every safety rule checked at every step (tests/support/soak_day.py).

```
.venv/bin/python tools/soak.py --days 20 --day-hours 0.25          # 20 short days
.venv/bin/python tools/soak.py --seed 1234 --days 1                 # replay one day exactly
.venv/bin/python tools/soak.py --days 200 --jobs 2 --results-dir bench/results
```

Day ``k`` of a run from ``--seed N`` has seed ``N + k``; everything it does is drawn from that
seed, so ``--seed S --days 1`` replays day S exactly. A broken rule stops the day and prints
the seed, the rule, the last steps and log lines, and (``--shrink``, the default) the shortest
list of steps found that still breaks the same rule. ``--results-dir DIR`` merges a ``soak``
section into ``DIR/latest.json`` (tools/bench_results.py). Exit 1 on any violation.
"""

from __future__ import annotations

import concurrent.futures
import sys
import tempfile
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any

import typer

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run the checkout this tool lives in
    sys.path.insert(0, str(ROOT))
if str(ROOT / "tools") not in sys.path:
    sys.path.insert(0, str(ROOT / "tools"))

from bench_results import write_section  # noqa: E402

from tests.support.soak_day import DayResult, run_day  # noqa: E402
from tests.support.soak_plan import CREW_ACTIONS, FAULT_KINDS, DayPlan, plan_day  # noqa: E402

SHRINK_RUNS = 24  # replays the shrinker may spend on one failing day


def one_day(seed: int, day_hours: float, keep: Path | None = None) -> DayResult:
    plan = plan_day(seed, day_hours * 3600.0)
    return run_plan(plan, keep)


def run_plan(plan: DayPlan, keep: Path | None = None) -> DayResult:
    if keep is not None:
        work = keep / f"day-{plan.seed}"
        work.mkdir(parents=True, exist_ok=True)
        return run_day(plan, work)
    with tempfile.TemporaryDirectory(prefix=f"soak-{plan.seed}-") as tmp:
        return run_day(plan, Path(tmp))


def breaks(plan: DayPlan, rule: str) -> bool:
    got = run_plan(plan)
    return got.violation is not None and got.violation.rule == rule


def shrink(plan: DayPlan, result: DayResult, budget: int = SHRINK_RUNS) -> DayPlan:
    """The plan cut after the failing step, then steps left out in halves, quarters, … (ddmin)
    while the same rule still breaks, within ``budget`` replays."""
    assert result.violation is not None
    rule = result.violation.rule
    done = {s.index for s in result.done}
    last = max((s.at_s for s in result.done), default=0.0)
    cut = replace(plan, steps=tuple(s for s in plan.steps if s.index in done), length_s=last + 60.0)
    runs = 0
    if not breaks(cut, rule):
        return plan
    runs += 1
    chunks = 2
    while runs < budget and len(cut.steps) > 1:
        size = max(1, len(cut.steps) // chunks)
        groups = [cut.steps[i : i + size] for i in range(0, len(cut.steps), size)]
        reduced = False
        for group in groups:
            if runs >= budget:
                break
            trial = cut.without(frozenset(s.index for s in group))
            runs += 1
            if breaks(trial, rule):
                cut, reduced = trial, True
                chunks = max(chunks - 1, 2)
                break
        if not reduced:
            if size == 1:
                break
            chunks = min(chunks * 2, len(cut.steps))
    return cut


def report_failure(result: DayResult, plan: DayPlan, do_shrink: bool, out: Any) -> None:
    v = result.violation
    assert v is not None
    print(f"VIOLATION seed={result.seed} rule={v.rule} at {v.at_s:.2f} s: {v.detail}", file=out)
    print("last events:", file=out)
    for line in result.events:
        print(f"  {line}", file=out)
    if do_shrink:
        small = shrink(plan, result)
        print(f"shrunk to {len(small.steps)} of {len(plan.steps)} steps:", file=out)
        for step in small.steps:
            print(f"  {step.describe()}", file=out)
    print(f"replay: tools/soak.py --seed {result.seed} --days 1 --day-hours "
          f"{plan.length_s / 3600.0:g}", file=out)  # fmt: skip


def section(results: list[DayResult], wall_s: float, day_hours: float) -> dict[str, Any]:
    actions: Counter[str] = Counter({name: 0 for name in CREW_ACTIONS})
    faults: Counter[str] = Counter({name: 0 for name in FAULT_KINDS})
    for r in results:
        actions.update(r.actions)
        faults.update(r.faults)
    simulated_h = sum(r.simulated_s for r in results) / 3600.0
    return {
        "days": len(results),
        "day_hours": day_hours,
        "simulated_hours": round(simulated_h, 3),
        "wall_s": round(wall_s, 1),
        "cpu_s": round(sum(r.cpu_s for r in results), 1),
        "simulated_hours_per_wall_minute": round(simulated_h / max(wall_s / 60.0, 1e-9), 3),
        "violations": [
            {"seed": r.seed, "rule": r.violation.rule, "detail": r.violation.detail[:300]}
            for r in results
            if r.violation is not None
        ],
        # resident memory: the largest growth over a day's second half (rule memory_flat)
        "rss_growth_mb_max": round(
            max((r.rss_mb[1] - r.rss_mb[0] for r in results), default=0.0), 1
        ),
        "actions": dict(sorted(actions.items())),
        "faults": dict(sorted(faults.items())),
    }


def main(
    seed: Annotated[int, typer.Option(help="the first day's seed; day k has seed + k")] = 1,
    days: Annotated[int, typer.Option(min=1, max=100_000, help="days to run")] = 10,
    day_hours: Annotated[
        float, typer.Option(min=0.005, max=24.0, help="simulated hours per day")
    ] = 2.0,
    jobs: Annotated[int, typer.Option(min=1, max=16, help="worker processes")] = 1,
    shrink_failures: Annotated[
        bool, typer.Option("--shrink/--no-shrink", help="shrink a failing day's steps")
    ] = True,
    results_dir: Annotated[
        Path | None, typer.Option(help="merge a soak section into DIR/latest.json")
    ] = None,
    keep: Annotated[Path | None, typer.Option(help="keep each day's files under DIR")] = None,
) -> None:
    """Run seeded crew days; print each violation; exit 1 if any."""
    wall = time.perf_counter()
    seeds = [seed + k for k in range(days)]
    results: list[DayResult] = []
    if jobs == 1:
        for s in seeds:  # each day's line as it ends: a long run shows its progress
            results.append(one_day(s, day_hours, keep))
            day_line(results[-1])
    else:
        with concurrent.futures.ProcessPoolExecutor(jobs) as pool:
            for r in pool.map(one_day, seeds, [day_hours] * days, [keep] * days):
                day_line(r)
                results.append(r)
    wall_s = time.perf_counter() - wall
    for r in results:
        if r.violation is not None:
            report_failure(r, plan_day(r.seed, day_hours * 3600.0), shrink_failures, sys.stdout)
    sec = section(results, wall_s, day_hours)
    print(
        f"soak: {sec['days']} days, {sec['simulated_hours']} simulated h in {sec['wall_s']} s "
        f"wall, {sec['cpu_s']} s CPU "
        f"({sec['simulated_hours_per_wall_minute']} simulated h per wall minute), "
        f"{len(sec['violations'])} violations"
    )
    if results_dir is not None:
        print(f"results: {write_section('soak', sec, results_dir)}")
    raise typer.Exit(1 if sec["violations"] else 0)


def day_line(r: DayResult) -> None:
    verdict = "ok" if r.violation is None else f"VIOLATION {r.violation.rule}"
    steps = sum(r.actions.values()) + sum(r.faults.values())
    print(
        f"day seed={r.seed}: {steps} steps, {r.wall_s:.1f} s wall, {r.cpu_s:.1f} s CPU: {verdict}",
        flush=True,
    )


if __name__ == "__main__":
    typer.run(main)
