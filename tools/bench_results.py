"""The benchmark results files: ``bench/results/latest.json`` and ``latest.md``.

Both benchmarks (navigation, control loop) write into the same pair of files, each under its
own top-level key (``navigation``, ``control_loop``): a benchmark replaces its own section and
keeps the others, then the Markdown is rendered again from the whole JSON. The merge and the
rendering are pure; :func:`write_section` is the only function touching files.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
RESULTS_DIR = ROOT / "bench" / "results"
SECTIONS = ("navigation", "control_loop", "planning", "amphibious", "survey", "ground", "soak")


def merge_section(existing: object, key: str, section: Mapping[str, Any]) -> dict[str, Any]:
    """``existing`` (any JSON value; a non-mapping counts as empty) with ``key`` replaced."""
    if key not in SECTIONS:
        raise ValueError(f"unknown results section {key!r}; expected one of {SECTIONS}")
    merged = dict(existing) if isinstance(existing, dict) else {}
    merged[key] = dict(section)
    return merged


def jsonable(value: Any) -> Any:
    """Non-finite floats → None (JSON has no NaN), tuples → lists, recursively."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    return value


def fmt(value: object, spec: str = ".2f") -> str:
    """A table cell: numbers formatted, None as ``-``."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return format(value, spec)
    return str(value)


def md_table(headers: list[str], rows: list[list[str]]) -> list[str]:
    out = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    out += ["| " + " | ".join(cell.replace("|", "/") for cell in row) + " |" for row in rows]
    return out


def _stat(cell: Mapping[str, Any], name: str, spec: str = ".2f") -> str:
    figure = cell.get(name)
    if not isinstance(figure, Mapping):
        return "-"
    return f"{fmt(figure.get('mean'), spec)} / {fmt(figure.get('worst'), spec)}"


def navigation_markdown(nav: Mapping[str, Any]) -> list[str]:
    lines = ["## Navigation", ""]
    meta = nav.get("meta", {})
    if isinstance(meta, Mapping):
        lines += [f"- {k}: {fmt(v)}" for k, v in meta.items()]
        lines.append("")
    for note in nav.get("notes", []) or []:
        lines.append(f"> {note}")
    cells = nav.get("cells", [])
    if isinstance(cells, list) and cells:
        lines += [
            "",
            "Per cell over seeds, **mean / worst**, measured on the simulator's TRUE pose "
            "(est = on the pose the daemon saw, from summary.json). Time on the autopilot "
            "clock; effort = ∫ Σ|scroll fraction| dt.",
            "",
        ]
        rows = [
            [
                str(c.get("mission")), str(c.get("mode")), str(c.get("terrain")),
                str(c.get("noise", "-")), str(c.get("guidance")), str(c.get("completed")),
                _stat(c, "xt_rms_m"), _stat(c, "xt_max_m"), _stat(c, "final_error_m"),
                _stat(c, "time_s", ".1f"), _stat(c, "effort", ".1f"), _stat(c, "est_xt_rms_m"),
            ]
            for c in cells
            if isinstance(c, Mapping)
        ]  # fmt: skip
        lines += md_table(
            ["mission", "mode", "terrain", "noise", "guidance", "completed", "RMS m", "max m",
             "final m", "time s", "effort", "est RMS m"],
            rows,
        )  # fmt: skip
    ratios = nav.get("ratios", [])
    if isinstance(ratios, list) and ratios:
        target = nav.get("target", "")
        lines += ["", f"Ratio new / baseline in the same run. Target (not asserted): {target}", ""]
        rows = [
            [
                str(r.get("mission")), str(r.get("mode")), str(r.get("terrain")),
                str(r.get("noise", "-")),
                f"{r.get('new')} / {r.get('baseline')}, {r.get('time_baseline', '-')}",
                fmt(r.get("rms_ratio")), fmt(r.get("est_rms_ratio")), fmt(r.get("time_ratio")),
                fmt(r.get("worst_time_ratio")), str(r.get("verdict")),
            ]
            for r in ratios
            if isinstance(r, Mapping)
        ]  # fmt: skip
        lines += md_table(
            ["mission", "mode", "terrain", "noise", "new / RMS, time baseline", "RMS ratio (true)",
             "est RMS ratio", "time ratio", "worst seed time ratio", "target"],
            rows,
        )  # fmt: skip
    whys = nav.get("explanations", [])
    if isinstance(whys, list) and whys:
        lines += ["", "Where a target is missed, by how much and why:", ""]
        lines += [f"- {why}" for why in whys]
    survey = nav.get("survey")
    if isinstance(survey, Mapping):
        lines += ["", *survey_markdown(survey)]
    failures = nav.get("failures", [])
    if isinstance(failures, list) and failures:
        lines += ["", "Failed runs:", ""] + [f"- {f}" for f in failures]
    return lines


def survey_markdown(survey: Mapping[str, Any]) -> list[str]:
    """The survey block's line-law runs against ArduPilot AUTO's real-SITL figures."""
    helixd = survey.get("helixd", {}) or {}
    auto = survey.get("auto", {}) or {}
    lines = [
        f"### Survey block against ArduPilot AUTO ({survey.get('plant')} plant, "
        f"{survey.get('completed')} completed)",
        "",
    ]
    lines += md_table(
        ["pilot", "time s", "RMS m", "max m", "final m"],
        [
            [
                "helixd (line law, corner arcs), mean / worst",
                _stat(helixd, "time_s", ".1f"), _stat(helixd, "xt_rms_m", ".3f"),
                _stat(helixd, "xt_max_m", ".3f"), _stat(helixd, "final_error_m", ".3f"),
            ],
            [
                "ArduPilot AUTO, real SITL", fmt(auto.get("time_s"), ".1f"),
                fmt(auto.get("xt_rms_m"), ".3f"), fmt(auto.get("xt_max_m"), ".3f"),
                fmt(auto.get("final_error_m"), ".3f"),
            ],
        ],
    )  # fmt: skip
    lines += [
        "",
        f"Target: {survey.get('target')} — {survey.get('verdict')}. AUTO: {auto.get('source')}.",
    ]
    return lines


def control_loop_markdown(loop: Mapping[str, Any]) -> list[str]:
    lines = ["## Control loop", ""]
    per_rate = loop.get("per_rate", {})
    if isinstance(per_rate, Mapping) and per_rate:
        rows = []
        for rate, fig in per_rate.items():
            if not isinstance(fig, Mapping):
                continue
            lat = fig.get("latency_ms", {}) or {}
            jit = fig.get("jitter_ms", {}) or {}
            rows.append(
                [
                    f"{rate} Hz",
                    fmt(lat.get("p50")), fmt(lat.get("p99")), fmt(lat.get("max")),
                    fmt(jit.get("p99")), fmt(fig.get("cpu_percent")),
                    fmt(fig.get("poses_not_stepped"), "d"),
                    fmt(fig.get("floor_cpu_percent")), fmt(fig.get("ratio_to_floor")),
                    fmt(fig.get("asyncio_floor_cpu_percent")),
                    fmt(fig.get("ratio_to_asyncio_floor")),
                ]
            )  # fmt: skip
        lines += md_table(
            ["rate", "latency p50 ms", "latency p99 ms", "latency max ms", "jitter p99 ms",
             "CPU %", "poses not stepped", "floor CPU %", "CPU / floor",
             "asyncio echo CPU %", "CPU / asyncio echo"],
            rows,
        )  # fmt: skip
        lines += [
            "",
            "floor: a bare pymavlink echo loop (blocking reads); asyncio echo: the same echo as "
            "the least asyncio program (add_reader, override sent from the reader callback); "
            "both against the same fake autopilot in the same run.",
        ]
        loop_rows = []
        for rate, fig in per_rate.items():
            if not isinstance(fig, Mapping):
                continue
            loops = fig.get("event_loops") or {}
            for name, c in loops.items() if isinstance(loops, Mapping) else ():
                if isinstance(c, Mapping):
                    headline = " (headline)" if name == fig.get("event_loop") else ""
                    loop_rows.append(
                        [
                            f"{rate} Hz", f"{name}{headline}", fmt(c.get("cpu_percent")),
                            fmt(c.get("cpu_us_per_step"), ".0f"),
                            fmt(c.get("autopilot_rtt_p99_ms")), fmt(c.get("poses_not_stepped")),
                        ]
                    )  # fmt: skip
        if len(loop_rows) > len(per_rate):
            lines += ["", "Event loops of the daemon side, measured in the same run:", ""]
            lines += md_table(
                ["rate", "event loop", "CPU %", "CPU µs / step", "autopilot rtt p99 ms",
                 "poses not stepped"],
                loop_rows,
            )  # fmt: skip
        lines += floor_target_lines(per_rate)
    targets = loop.get("targets", {})
    if isinstance(targets, Mapping) and targets:
        lines += ["", "Targets: " + ", ".join(f"{k} {fmt(v, 'g')}" for k, v in targets.items())]
    meta = loop.get("meta", {})
    if isinstance(meta, Mapping) and meta:
        lines += [""] + [f"- {k}: {fmt(v)}" for k, v in meta.items()]
    return lines


CPU_PER_ECHO_TARGET = 2.0  # daemon CPU at most 2x the asyncio echo's
RTT_PER_ECHO_TARGET = 1.5  # and the autopilot's round trip p99 at most 1.5x the echo's
CPU_MISS_WHY = (
    "Why the CPU target is missed: per step the daemon does what the echo does (read, decode, "
    "encode, sendto, and since 2026-11-26 in the same place: the step runs in the link's "
    "reader callback, as the echo's does) plus the vehicle state, the safety supervisor, the "
    "navigator (~200 small pure-function calls, ~70 finiteness checks), the slip fit, the "
    "kinematics, the row journal and the display. Timed warm in a tight loop that was ~70 µs "
    "a step; timed in this benchmark at 200 Hz with the thread's CPU clock (2026-11-26) it is "
    "~400 µs: navigator 88, RC override sink 103 (of which encode + sendto 41), supervisor "
    "43, slip fit 32, the rest of the step 44, report 36, bookkeeping 23, feeds 8, and ~73 µs "
    "for each of the ~2 messages read per step — more than the echo's whole step (~180 µs). "
    "Each step runs on a process just woken from sleep, with cold caches, which multiplies "
    "every line touched; no single frame is more than a few percent of the profile. The "
    "round trip misses for the same reason: that work sits between the pose and the override "
    "(the row batches, flushes and feeds no longer do: they run after the send)."
)


def floor_target_lines(per_rate: Mapping[str, Any]) -> list[str]:
    """The loop-cost targets against the asyncio echo measured in the same run, with the miss."""
    rows, misses = [], []
    for rate, fig in per_rate.items():
        if not isinstance(fig, Mapping):
            continue
        cpu_ratio = fig.get("ratio_to_asyncio_floor")
        rtt = fig.get("autopilot_rtt_ms") or {}
        echo = fig.get("asyncio_floor_rtt_ms") or {}
        rtt_p99, echo_p99 = rtt.get("p99"), echo.get("p99")
        rtt_ratio = rtt_p99 / echo_p99 if rtt_p99 and echo_p99 else None
        unstepped = fig.get("poses_not_stepped")
        rows.append(
            [
                f"{rate} Hz", fmt(cpu_ratio), fmt(rtt_p99), fmt(echo_p99), fmt(rtt_ratio),
                fmt(unstepped, "d"),
            ]
        )  # fmt: skip
        if isinstance(cpu_ratio, (int, float)) and cpu_ratio > CPU_PER_ECHO_TARGET:
            over = cpu_ratio - CPU_PER_ECHO_TARGET
            misses.append(f"{rate} Hz CPU {cpu_ratio:.2f}x the echo (by {over:.2f})")
        if rtt_ratio is not None and rtt_ratio > RTT_PER_ECHO_TARGET:
            over = rtt_ratio - RTT_PER_ECHO_TARGET
            misses.append(f"{rate} Hz rtt p99 {rtt_ratio:.2f}x the echo's (by {over:.2f})")
        if rate == "200" and isinstance(unstepped, int) and unstepped > 0:
            misses.append(f"200 Hz: {unstepped} poses not stepped")
    if not rows:
        return []
    lines = ["", "Against the asyncio echo of the same run:", ""]
    lines += md_table(
        ["rate", "CPU / echo (target <= 2.0)", "autopilot rtt p99 ms", "echo rtt p99 ms",
         "rtt p99 / echo (target <= 1.5)", "poses not stepped (target 0 at 200 Hz)"],
        rows,
    )  # fmt: skip
    if misses:
        lines += ["", "Missed: " + "; ".join(misses) + ".", "", CPU_MISS_WHY]
    else:
        lines += ["", "Met."]
    return lines


def planning_markdown(plan: Mapping[str, Any]) -> list[str]:
    lines = ["## Planning", ""]
    cases = plan.get("cases", {})
    if isinstance(cases, Mapping) and cases:
        rows = []
        for name, c in cases.items():
            if not isinstance(c, Mapping):
                continue
            total = c.get("total_ms", {}) or {}
            rows.append(
                [
                    str(name), fmt(total.get("median"), ".0f"), fmt(total.get("worst"), ".0f"),
                    fmt(c.get("inflate_ms"), ".0f"), fmt(c.get("search_ms"), ".0f"),
                    fmt(c.get("shortcut_ms"), ".0f"), fmt(c.get("legs")),
                    fmt(c.get("path_m"), ".1f"), fmt(c.get("blocked_percent"), ".0f"),
                ]
            )  # fmt: skip
        lines += md_table(
            ["map", "total median ms", "total worst ms", "inflate ms", "search ms",
             "shortcut ms", "legs", "path m", "blocked %"],
            rows,
        )  # fmt: skip
    target = plan.get("target")
    if target:
        lines += ["", f"Target: {target} — {'met' if plan.get('target_met') else 'NOT met'}"]
    meta = plan.get("meta", {})
    if isinstance(meta, Mapping) and meta:
        lines += [""] + [f"- {k}: {fmt(v)}" for k, v in meta.items()]
    return lines


def amphibious_markdown(amph: Mapping[str, Any]) -> list[str]:
    """The amphibious courses: one row per course and policy, then the verdicts."""
    lines = ["## Amphibious missions (tools/bench_amphibious.py)", ""]
    rows: list[list[str]] = []
    for course, cell in amph.items():
        if not isinstance(cell, Mapping):
            continue
        for policy, fig in cell.items():
            if not isinstance(fig, Mapping):
                continue
            rms = fig.get("rms_m") or {}
            rows.append(
                [
                    course,
                    policy,
                    fmt(fig.get("completed")),
                    fmt(fig.get("time_s"), ".1f"),
                    fmt(fig.get("energy_j"), ".0f"),
                    ", ".join(f"{m} {fmt(v)}" for m, v in rms.items()) or "-",
                    fmt(fig.get("detect_distance_m")),
                    fmt(fig.get("fault")),
                ]
            )
    headers = ["course", "policy", "completed", "time_s", "energy_j", "rms_m", "detect_m"]
    lines += md_table([*headers, "fault"], rows)
    verdict_lines = amph.get("verdicts")
    if isinstance(verdict_lines, list):
        lines += ["", *(f"- {v}" for v in verdict_lines)]
    return lines


def depth_survey_markdown(survey: Mapping[str, Any]) -> list[str]:
    """The pond's depth survey (tools/bench_survey.py): its figures, then the verdicts."""
    lines = ["## Depth survey (tools/bench_survey.py)", ""]
    keys = ("samples", "coverage", "rms_m", "max_abs_m", "holes", "holes_mission_items")
    lines += md_table(
        ["bathymetry", *keys],
        [[fmt(survey.get("bathymetry")), *(fmt(survey.get(k), ".4f") for k in keys)]],
    )
    verdict_lines = survey.get("verdicts")
    if isinstance(verdict_lines, list):
        lines += ["", *(f"- {v}" for v in verdict_lines)]
    return lines


def ground_markdown(ground: Mapping[str, Any]) -> list[str]:
    """The ground bench: per truth its three runs, the learning error and the policy."""
    lines = ["## Ground (tools/bench_ground.py)", ""]
    rows = []
    for name, cell in ground.items():
        if not isinstance(cell, Mapping) or not isinstance(cell.get("runs"), list):
            continue
        for k, run in enumerate(cell["runs"], 1):
            rows.append(
                [
                    name,
                    str(k),
                    fmt(run.get("completed")),
                    fmt(run.get("time_s"), ".1f"),
                    fmt(run.get("estimate_s"), ".0f"),
                    fmt(run.get("energy_j"), ".0f"),
                ]
            )
    lines += md_table(["truth", "run", "completed", "time_s", "estimate_s", "energy_j"], rows)
    lines.append("")
    lines += [f"- {v}" for v in ground.get("verdicts", []) or []]
    return lines


def soak_markdown(soak: Mapping[str, Any]) -> list[str]:
    """The soak (tools/soak.py): its totals, its violations, the presses and faults it made."""
    lines = ["## Soak (tools/soak.py)", ""]
    for key in ("days", "day_hours", "simulated_hours", "wall_s", "cpu_s",
                "simulated_hours_per_wall_minute"):  # fmt: skip
        lines.append(f"- {key}: {fmt(soak.get(key))}")
    violations = soak.get("violations") or []
    lines += ["", f"Violations: {len(violations) if isinstance(violations, list) else '-'}"]
    if isinstance(violations, list):
        lines += [
            f"- seed {v.get('seed')}: {v.get('rule')}" for v in violations if isinstance(v, Mapping)
        ]
    for title, key in (("crew action", "actions"), ("fault", "faults")):
        counts = soak.get(key)
        if isinstance(counts, Mapping) and counts:
            lines += [
                "",
                *md_table([title, "count"], [[str(k), fmt(v)] for k, v in counts.items()]),
            ]
    return lines


def render_markdown(results: Mapping[str, Any]) -> str:
    """The whole results file as Markdown (sections in a fixed order, missing ones skipped)."""
    lines = ["# helixd benchmark results", "", "Written by `make bench` (tools/bench_*.py)."]
    nav = results.get("navigation")
    if isinstance(nav, Mapping):
        lines += ["", *navigation_markdown(nav)]
    loop = results.get("control_loop")
    if isinstance(loop, Mapping):
        lines += ["", *control_loop_markdown(loop)]
    plan = results.get("planning")
    if isinstance(plan, Mapping):
        lines += ["", *planning_markdown(plan)]
    amphibious = results.get("amphibious")
    if isinstance(amphibious, Mapping):
        lines += ["", *amphibious_markdown(amphibious)]
    depth = results.get("survey")
    if isinstance(depth, Mapping):
        lines += ["", *depth_survey_markdown(depth)]
    ground = results.get("ground")
    if isinstance(ground, Mapping):
        lines += ["", *ground_markdown(ground)]
    soak = results.get("soak")
    if isinstance(soak, Mapping):
        lines += ["", *soak_markdown(soak)]
    return "\n".join(lines) + "\n"


def write_section(key: str, section: Mapping[str, Any], out_dir: Path = RESULTS_DIR) -> Path:
    """Merge ``section`` into ``out_dir/latest.json`` and re-render ``latest.md``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    json_path = out_dir / "latest.json"
    try:
        existing: object = json.loads(json_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        existing = None
    merged = merge_section(existing, key, jsonable(section))
    for path, text in (
        (json_path, json.dumps(merged, indent=2, allow_nan=False) + "\n"),
        (out_dir / "latest.md", render_markdown(merged)),
    ):
        tmp = path.with_suffix(path.suffix + ".tmp")
        tmp.write_text(text, encoding="utf-8")
        os.replace(tmp, path)
    return json_path
